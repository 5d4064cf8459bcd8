"""A recording whose streams are an LCM log in heft's channels (as `heft … --hardware --record` writes):
the RX90 (or the iiwa, 7 joints) moving its joints with the paper's tool on the JR3, the wrench from Drake's
plant, the joint angles on the arm driver's clock; bad messages left out and counted; `heft compensate` on it."""

import json

import lcm
import numpy as np
import pytest
from drake import lcmt_iiwa_status
from drake_motion import PAPER_TOOL
from pydrake.multibody.math import SpatialAcceleration

from heft.diagrams.arm_params import BUNDLED_ARMS
from heft.diagrams.cli import main
from heft.diagrams.plants import MakeArmPlant
from heft.diagrams.stations.load_on_sensor import LoadOnSensorPlant
from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.lcmtypes import heft_ft_sample
from heft.systems.accelerometer_reading import AccelerometerConvention, reading_from_motion

P_SA = [0.02, 0.01, -0.008]
Q0 = {"rx90": np.array([0.1, -0.4, 1.2, 0.2, 0.8, -0.3]), "iiwa14": np.array(BUNDLED_ARMS["iiwa14"].start)}
"""Where each arm's joints swing about (rad)."""


def _arm_motion(t, robot="rx90"):
    """Joint angles, rates and accelerations: sines about ``Q0`` (rad, rad/s, rad/s²)."""
    n = len(Q0[robot])
    w = 2 * np.pi * np.array([0.6, 0.8, 0.7, 1.1, 0.9, 1.3, 1.0])[:n]
    A = np.array([0.3, 0.2, 0.25, 0.5, 0.4, 0.6, 0.35])[:n]
    return Q0[robot] + A * np.sin(w * t), A * w * np.cos(w * t), -A * w * w * np.sin(w * t)


def _sensor_truth(plant, S, context, q, v, vdot, load_plant):
    """Drake: the JR3 frame S's motion on the arm, then the tool's wrench on a free sensor moving so."""
    plant.SetPositions(context, q)
    plant.SetVelocities(context, v)
    X_WS = plant.CalcRelativeTransform(context, plant.world_frame(), S)
    body = S.body()
    X_WB = plant.EvalBodyPoseInWorld(context, body)
    V_WB = plant.EvalBodySpatialVelocityInWorld(context, body)
    A_WB = plant.CalcSpatialAccelerationsFromVdot(context, vdot)[int(body.index())]
    p_BS_W = X_WB.rotation() @ S.GetFixedPoseInBodyFrame().translation()
    A_WS = SpatialAcceleration(A_WB.rotational(), A_WB.translational()).Shift(p_BS_W, V_WB.rotational())
    V_WS = V_WB.Shift(p_BS_W)
    free_q = np.concatenate((X_WS.rotation().ToQuaternion().wxyz(), X_WS.translation()))
    free_v = np.concatenate((V_WS.rotational(), V_WS.translational()))
    free_vdot = np.concatenate((A_WS.rotational(), A_WS.translational()))
    wrench = load_plant.reaction_wrench(free_q, free_v, free_vdot)
    return wrench, load_plant.motion_in_S(free_q, free_v, free_vdot)


def write_log(path, duration=1.2, ft_rate=1000.0, joint_rate=250.0, robot="rx90"):
    plant, S = MakeArmPlant(robot)
    context = plant.CreateDefaultContext()
    load_plant = LoadOnSensorPlant(PAPER_TOOL)
    channels = LcmChannels()
    log = lcm.EventLog(str(path), "w", overwrite=True)
    events = []
    for k, t in enumerate(np.arange(0, duration, 1 / ft_rate)):
        wrench, (a, alpha, omega, g) = _sensor_truth(plant, S, context, *_arm_motion(t, robot), load_plant)
        msg = heft_ft_sample()
        msg.utime, msg.sample_counter = 5_000_000 + int(round(1e6 * t)), k
        msg.wrench = list(-wrench)  # the sensor's sign
        msg.acceleration = list(reading_from_motion(np.concatenate((a, alpha)), g, omega,
                                                    AccelerometerConvention(True, tuple(P_SA))))
        events.append((t, channels.ft_sample.name, msg))
        if k in (300, 301):  # the same packet twice, then a flagged one
            events.append((t, channels.ft_sample.name, msg))
        if k == 700:
            bad = heft_ft_sample.decode(msg.encode())
            bad.utime += 500
            bad.error = True
            events.append((t, channels.ft_sample.name, bad))
    for k, t in enumerate(np.arange(0, duration, 1 / joint_rate)):
        q = _arm_motion(t, robot)[0]
        if k == 100:  # a status of another arm's joint count between the driver's
            other = q[:6] if len(q) == 7 else np.append(q, 0.0)
            events.append((t, channels.slave_status.name, _status(t, other)))
        events.append((t, channels.slave_status.name, _status(t, q)))
    for t, channel, msg in sorted(events, key=lambda e: e[0]):
        log.write_event(int(1e6 * t), channel, msg.encode())
    for channel in (channels.ft_sample.name, channels.slave_status.name):  # a truncated datagram on each
        log.write_event(int(1e6 * duration), channel, msg.encode()[:20])
    log.close()


def _status(t, q):
    """The arm driver's status at ``t`` (s; its own clock) of the joints at ``q`` (rad)."""
    msg = lcmt_iiwa_status()
    msg.utime, msg.num_joints = 9_000_000 + int(round(1e6 * t)), len(q)
    msg.joint_position_measured = list(q)
    for name in ("joint_position_commanded", "joint_position_ipo", "joint_velocity_estimated",
                 "joint_torque_measured", "joint_torque_commanded", "joint_torque_external"):
        setattr(msg, name, [0.0] * len(q))
    return msg


@pytest.mark.parametrize("robot", ["rx90", "iiwa14"])
def test_compensate_reads_heft_s_own_hardware_log(tmp_path, robot):
    write_log(tmp_path / "run.lcmlog", robot=robot)
    (tmp_path / "rec.yaml").write_text(f"""
lcm_log: run.lcmlog
accelerometer: {{p_SA: {P_SA}}}
orientation: {{robot: {robot}, time: {{offset: 4.0}}}}
""")
    (tmp_path / "est.yaml").write_text(f"phi: {PAPER_TOOL.to_phi().tolist()}\noffsets: [0, 0, 0, 0, 0, 0]\n")
    code = main(["compensate", "--recording", str(tmp_path / "rec.yaml"), "--estimate", str(tmp_path / "est.yaml"),
                 "--out", str(tmp_path / "out")])
    assert code == 0
    metrics = json.loads((tmp_path / "out" / "metrics.json").read_text())
    assert "1200 FT samples, 300 joint states" in metrics["choices"]["lcm_log"]
    assert "'stamped at or before the last': 2" in metrics["choices"]["lcm_log"]
    assert "'error flag': 1" in metrics["choices"]["lcm_log"]
    assert metrics["choices"]["lcm_log"].count("'undecodable': 1") == 2
    assert "'joint count': 1" in metrics["choices"]["lcm_log"]
    assert metrics["intervals"] == []
    rms = metrics["residual_rms_without_contact"]
    # joints at 250 Hz differentiated for ω; the wrench reaches ~40 N and ~2 N·m
    assert max(rms[a] for a in ("fx", "fy", "fz")) < 0.1 and max(rms[a] for a in ("tx", "ty", "tz")) < 0.01
