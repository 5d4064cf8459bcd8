"""The compiled per-tick kernels equal the plain Python they are written in (``HEFT_PURE_PYTHON=1``,
the fallback where numba is missing), run in a process of its own on the same inputs; their cache is
named by their sources."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from heft.hardware_interface.message_checks import REASONS
from heft.systems import compiled
from heft.systems.controller.rx_inverse_kinematics import (JOINT_LIMIT, NON_FINITE, OUT_OF_REACH, SHOULDER_SINGULARITY,
                                                WRIST_SINGULARITY)
from heft.systems.controller.slave_inverse_kinematics import SLEWING

_KERNELS = r"""
import sys
import numpy as np
from heft.diagrams.plants import MakeArmPlant
from heft.systems import compiled
from heft.systems.load_dynamics import GRAVITY_W, regressor_into
from heft.systems.station.sensor_models import (ForceTorqueSensorParams, HeldLowpass, SixAxisMeasurement, lowpass,
                                        lowpass_coefficients)
from heft.systems.serial_chain import SerialChain
from heft.systems.station.setpoint_filter import critically_damped_step_matrices, setpoint_step

rng = np.random.default_rng(11)
plant, S = MakeArmPlant("rx90")
chain = SerialChain(plant, plant.world_frame(), S, GRAVITY_W)
out = {"pure_python": np.array(compiled.PURE_PYTHON), "motion": [], "J": [], "V": []}
for _ in range(10):
    q, qd, qdd = rng.uniform(-2, 2, (3, 6))
    chain.update(q, qd, qdd)
    out["motion"].append(chain.motion.copy())
    out["J"].append(chain.J.copy())
    V = np.empty((6, 10))
    regressor_into(*rng.normal(0, 5, (4, 3)), V)
    out["V"].append(V)
params = ForceTorqueSensorParams()
out["measured"], out["saturated"] = SixAxisMeasurement(params, 0, 1 / 8000).measure(
    rng.normal(0, 1, (64, 6)) * np.array(params.full_scale))
model, coefficients = SixAxisMeasurement(params, 0, 5e-4), lowpass_coefficients(500.0, 5e-4)
draws = np.random.default_rng(12)  # its own stream: the draws below stay those the other checks were written for
walk, filter_state, out["sampled"] = np.zeros(6), draws.normal(0, 1, (2, 6)), []
for k in range(1, 30):  # the simulated sensor's samples: drift, walk, noise, low-pass, saturation, counts
    offsets, measured, saturated = np.empty((3, 1, 6))
    model.sample_into(np.array([5e-4 * k]), model.normals(np.array([k])), walk, True,
                      model.sample_arguments(coefficients if k % 3 else None),
                      filter_state, draws.normal(0, 1, (1, 6)) * np.array(params.full_scale), offsets, measured,
                      saturated)
    out["sampled"].append(np.concatenate((offsets[0], measured[0], saturated[0], walk)))
held, state = HeldLowpass(lowpass_coefficients(500.0, 1 / 8000), 4), rng.normal(0, 1, (2, 6))
out["held"] = np.concatenate([held(state, value) for value in rng.normal(0, 50, (20, 6))])
out["lowpass"] = lowpass(lowpass_coefficients(500.0, 1 / 8000), np.full((2, 6), np.nan), rng.normal(0, 50, (40, 6)))
A, B = critically_damped_step_matrices(10.0, 5e-4)
x = np.zeros((2, 6))
for u in rng.uniform(-1, 1, (50, 6)):
    setpoint_step(A, B, x, u)
out["setpoint"] = x
from heft.diagrams.stations.slave_servo import servo_step, servo_step_matrices

servo_A, servo_C = servo_step_matrices(20.0, [4e4, 4e4, 2e4, 2e3, 2e3, 5e2], [900.0, 1100.0, 400.0, 25.0, 30.0, 3.3],
                                       np.diag([4.8, 7.9, 2.4, 0.08, 0.11, 0.005]) + 0.01, 5e-4)
arm, setpoint, deviation, qdd, out["servo"] = np.zeros((4, 6)), np.zeros(6), np.zeros(24), np.zeros(6), []
for command in rng.uniform(-1, 1, (50, 6)):
    servo_step(servo_A, servo_C, np.full(6, 0.002), command, setpoint, arm, deviation, qdd)
    out["servo"].append(np.concatenate((arm.ravel(), setpoint, qdd)))
from heft.systems.accelerometer_reading import AccelerometerConvention, motion_from_reading
from heft.systems.controller.force_scaling import (EVALUATION_SIZE, evaluate, initial_memory, next_memory_and_scales,
                                        notch_coefficients)
from heft.systems.pose_vectors import pose_into

displaced = AccelerometerConvention(True, (0.01, -0.02, 0.03))
phi, phi_gripper = rng.normal(0, 1, 10), rng.normal(0, 0.5, 10)
notch, memory, scales = notch_coefficients(30.0, 2.0, 5e-4), initial_memory(), np.array([0.0, 1.0, 0.5])
out["evaluation"], out["memory"], out["motion_S"], out["pose"] = [], [], [], []
for k in range(30):
    evaluation = np.empty(EVALUATION_SIZE)
    wrench = rng.normal(0, 10, 6) if k != 12 else np.full(6, np.nan)  # one fault: decay, notch restarted
    reading, omega, gravity = rng.normal(0, 3, 6), rng.normal(0, 1, 3), rng.normal(0, 5, 3)
    evaluate(evaluation, wrench, reading, omega, gravity, phi, rng.normal(0, 1, 6), scales, memory, 0.9,
             phi_gripper, displaced, notch)
    next_memory_and_scales(memory, scales, evaluation, (1.0, 1.0, 0.3), 0.01, notch)
    out["evaluation"].append(evaluation)
    out["memory"].append(np.nan_to_num(memory, nan=-1.0))
    out["motion_S"].append(motion_from_reading(np.empty(6), reading, gravity, omega, displaced))
    pose = np.empty(7)
    chain.update(rng.uniform(-3, 3, 6))
    pose_into(chain.R, chain.p, pose)
    out["pose"].append(pose)
from heft.systems.controller.motion_scaling import IDENTITY_POSE, motion_scaling_update

memory = np.concatenate(([0.0, 1.0, 1.0], IDENTITY_POSE, IDENTITY_POSE))
desired, R_RB, out["desired"] = IDENTITY_POSE.copy(), chain.R.copy(), []
for k in range(40):  # engaged, released at 10-14, the scales changed at 25
    pose_BE = np.concatenate((rng.normal(0, 0.1, 3), rng.normal(0, 1, 4)))
    scale = 1.0 if k < 25 else 0.5
    memory, desired = motion_scaling_update(memory, desired, pose_BE, not 10 <= k < 15, out["pose"][k % 30],
                                            2.0 * scale, scale, R_RB)
    out["desired"].append(desired)
from heft.systems.controller.feedback_mapping import rendered_wrench
from heft.systems.controller.passivity_controller import master_torque

energy, out["torque"], out["energy"] = np.zeros(2), [], []
for k in range(40):  # the clamps act on about half of the samples
    wrench = rendered_wrench(rng.normal(0, 8, 6), chain.R, 1.0, 1.0, 8.5, 0.188)
    torque, applied, energy, damping, dissipated = master_torque(
        rng.normal(0, 6, 6), rng.normal(0, 2, 6), out["J"][k % 10], energy, 5e-4, (20.0, 0.2), 8.5, 0.188)
    out["torque"].append(np.concatenate((wrench, torque, applied, damping, dissipated)))
    out["energy"].append(energy)

# The slave IK: seeded targets reachable, out of reach, past a limit, near the wrist, elbow and
# shoulder singularities and on the J1 axis; the rich API's kernels and one tick's.
from pydrake.math import RigidTransform, RotationMatrix
from heft.systems.pose_vectors import pose_into
from heft.systems.controller.rx_inverse_kinematics import WORK_ROWS, RxKinematics, all_solutions, nearest_solution
from heft.systems.controller.slave_inverse_kinematics import IkStep

work, q, solutions, pose = np.empty((WORK_ROWS, 6)), np.empty(6), np.empty((8, 6)), np.empty(7)
for name in ("ik_q", "ik_status", "ik_all", "ik_count", "step_command", "step_status"):
    out[name] = []
for robot in ("rx90", "rx60"):
    kin = getattr(RxKinematics, robot)()
    step = IkStep(kin, RigidTransform(RotationMatrix.MakeXRotation(0.4), [0.01, -0.02, 0.15]))
    for n in range(300):
        q_target = rng.uniform(kin.lower - 0.2, kin.upper + 0.2)  # some beyond the limits
        q_target[[4, 2][n % 2]] *= 0.02 if n % 3 == 0 else 1.0  # near the wrist or the elbow singularity
        R, p = kin.forward(q_target)
        if n % 5 == 1:  # the wrist centre on (or 1 µm from) the J1 axis
            p_C = p - kin.d6 * R[:, 2]
            p = p - np.array([p_C[0], p_C[1], 0.0]) * (1.0 + 1e-6 * (n % 2))
        if n % 5 == 2:
            p = p + rng.normal(0.0, 0.5, 3)  # often out of reach
        q_reference = np.clip(q_target + rng.normal(0.0, [0.01, 0.3, 2.0][n % 3], 6), kin.lower, kin.upper)
        out["ik_status"].append(nearest_solution(kin.dh, kin.lower, kin.upper, kin.wrist_band, R, p, q_reference,
                                                 q, work))
        out["ik_q"].append(q.copy())
        out["ik_count"].append(all_solutions(kin.dh, kin.lower, kin.upper, R, p, q_reference, solutions, work))
        out["ik_all"].append(solutions[:out["ik_count"][-1]].copy())
        pose_into(R, p, pose)
        pose[4] = np.nan if n % 7 == 6 else pose[4]
        command = np.empty(6)
        out["step_status"].append(step(pose, q_reference, [5e-4, 0.01, 1.0][n % 3], command))
        out["step_command"].append(command)
out["ik_all"] = np.concatenate(out["ik_all"])
# The RLS update with stabilized forgetting (its information update and second moments).
from heft.systems.identification.recursive_estimation import RecursiveLeastSquares

rls, out["rls"] = RecursiveLeastSquares(offsets=False, forgetting=0.999), []
for _ in range(50):
    a, alpha, omega, g = rng.normal(0, 3, (4, 3))
    rls.update(rng.normal(0, 20, 6), a, alpha, omega, g)
    out["rls"].append(rls.state_vector())
# The online estimator's gate (its excitation) and prefilter.
from heft.systems.controller.estimator_gate import excitation
from heft.systems.controller.estimator_prefilter import STATE_SIZE, WIDTH, prefilter_coefficients, prefilter_step

coefficients, state = prefilter_coefficients(20.0, 5e-4), np.full(STATE_SIZE, np.nan)
out["excitation"], out["prefilter"] = [], []
for k in range(40):
    motion = rng.normal(0, 3, 9)
    out["excitation"].append(excitation(motion[:6], motion[6:]))
    prefilter_step(coefficients, state, rng.normal(0, 3, WIDTH) if k != 20 else np.full(WIDTH, np.nan))
    out["prefilter"].append(np.nan_to_num(state, nan=-1.0))
# The controller Diagram's program, its load learned online: the clutch pressed at tick 5, one faulted sensor
# sample at 20, a re-zero asked for at 30, a grasp at 40, stale readings at 45, a new estimate at 50.
from heft.diagrams.load_estimate import LoadEstimate
from heft.diagrams.scenario import layered, overrides_text, resolve_scenario
from heft.diagrams.teleop_controller import TeleopController
from heft.systems.load_dynamics import InertialParameters

scenario = layered(resolve_scenario("fig6"), overrides_text({
    "controller.estimator.mode": "online", "controller.estimator.learning_window": 0.0,
    "controller.estimator.prefilter": 200.0, "controller.estimator.min_excitation": 0.0,
    "controller.contact.force": 1e3, "controller.contact.torque": 1e3}))  # the gate open: RLS learns
load = InertialParameters(0.8, np.array([0.01, -0.02, 0.1]), np.diag([2e-3, 3e-3, 1e-3])).to_phi()
controller = TeleopController(scenario.controller, LoadEstimate(load, rng.normal(0, 0.5, 6)), scenario.robot, 5e-4,
                              accelerometer=scenario.accelerometer.convention())
q_slave = np.array([0.1, -0.4, 1.2, 0.2, 0.6, -0.3])
controller.start(q_slave)
q_master = np.array([0.0, 0.2, 0.3, 0.0, 0.4, 0.0])
out["controller"] = []
for k in range(60):
    q_master += rng.normal(0, 2e-3, 6)
    q_slave += rng.normal(0, 1e-3, 6)
    wrench = rng.normal(0, 5, 6) if k != 20 else np.full(6, np.nan)
    if k == 30:
        controller.request_rezero()
    if k == 40:
        controller.grasp()
    if k == 50:
        controller.set_load(1.1 * load, np.zeros(6))
    controller.step(5e-4, q_master, rng.normal(0, 0.3, 6), q_slave, rng.normal(0, 0.02, 6), wrench,
                    rng.normal(0, 3, 6) + np.array([0, 0, 9.81, 0, 0, 0]), k >= 5, 0.01 if k == 45 else 0.0)
    out["controller"].append(np.concatenate((controller.torque, controller.position, controller.master_wrench,
                                             controller.applied_wrench, controller.energy, controller.offsets,
                                             controller.scales, controller.wrench_contact, controller.phi,
                                             [controller.reachable, controller.rezero_status, controller.holding,
                                              controller.estimator.num_samples, controller.estimator.num_stale])))
# The simulated station's truth: a frame's motion, the load's wrenches at S (with and without a split).
from heft.systems.station.station_truth import frame_motion_into, wrenches_at_S_into

out["truth"], motion, V_scratch = [], np.empty(12), np.empty((6, 10))
for k in range(20):
    chain.update(rng.uniform(-3, 3, 6))
    frame_motion_into(chain.R, *rng.normal(0, 3, (3, 3)), rng.normal(0, 0.1, 3), np.array(GRAVITY_W), motion)
    wrenches = np.empty(12)
    wrenches_at_S_into(motion, phi, phi_gripper if k % 2 else np.zeros(10), chain.R, rng.normal(0, 0.1, 3), V_scratch,
                       wrenches)
    out["truth"].append(np.concatenate((motion, wrenches)))
# The same in one call from Drake's poses and coefficients, with a displaced, mounted accelerometer's reading.
from heft.systems.accelerometer_reading import AccelerometerConvention, convention_record
from heft.systems.compiled import record_views
from heft.systems.station.station_truth import TRUTH, motion_and_wrenches_into

truth, arrays = record_views(TRUTH)
arrays["p_BS"][:], arrays["g_W"][:] = rng.normal(0, 0.1, 3), GRAVITY_W
accelerometer = convention_record(AccelerometerConvention(True, (0.02, 0.01, -0.008), chain.R.copy(), "g",
                                                          (0.01, -0.08, 0.03), 1.02, (0.3, -0.2, 0.25)))
out["truth_one_call"], X = [], np.empty((2, 3, 4))
for k in range(20):
    for pose in X:
        chain.update(rng.uniform(-3, 3, 6))
        pose[:, :3], pose[:, 3] = chain.R, chain.p
    sensor = np.empty(30)
    motion_and_wrenches_into(X[0], *rng.normal(0, 3, (2, 6)), X[1], *rng.normal(0, 3, (2, 6)), phi,
                             phi_gripper if k % 2 else np.zeros(10), truth, accelerometer, sensor)
    out["truth_one_call"].append(sensor)
# The encoders' counts, half-counts included.
from heft.systems.station.encoders import quantize_into

step = 2 * np.pi / 4096
out["counts"] = np.empty(40)
quantize_into(np.concatenate((rng.uniform(-3, 3, 36), step * np.array([0.5, 1.5, -0.5, -2.5]))), step, out["counts"])
# The simulated operator's hand: its reference and impedance.
from heft.systems.station.operator_hand import hand_wrench_into, reference_into

out["hand"], reference, hand = [], [np.empty(n) for n in ((3, 3), 3, 3, 3)], np.empty(6)
for k in range(20):
    chain.update(rng.uniform(-3, 3, 6))
    reference_into(0.05 * k, 0.1, 2.5, np.array([1.0, 0.5]), *rng.normal(0, 0.2, (2, 3)), chain.R, chain.p,
                   *reference)
    chain.update(rng.uniform(-3, 3, 6))
    hand_wrench_into(chain.R, chain.p, *rng.normal(0, 1, (2, 3)), *reference, 800.0, 15.0, 2.0, 0.05,
                     np.empty((3, 3)), np.empty(7), hand)
    out["hand"].append(np.concatenate((reference[0].ravel(), *reference[1:], hand)))
from heft.systems.compiled import record_views
from heft.systems.station.operator_hand import HAND, hand_force_into

out["hand_one_call"], X_WE = [], np.empty((3, 4))
record, fields = record_views(HAND)
for name, value in (("start_time", 0.1), ("frequency", 2.5), ("stiffness", 800.0), ("damping", 15.0),
                    ("rotational_stiffness", 2.0), ("rotational_damping", 0.05)):
    record[name] = value
for k in range(20):
    chain.update(rng.uniform(-3, 3, 6))
    X_WE[:, :3], X_WE[:, 3] = chain.R, chain.p
    chain.update(rng.uniform(-3, 3, 6))
    fields["amplitude"][:], fields["rotation_amplitude"][:] = rng.normal(0, 0.2, (2, 3))
    fields["R_WE0"][:], fields["p_WE0"][:] = chain.R, chain.p
    hand_force_into(0.05 * k, X_WE, rng.normal(0, 1, 6), np.array([1.0, 0.5]), record, hand)
    out["hand_one_call"].append(hand.copy())
# The station's readers (every reason a message is refused for), its health and its command gate.
import lcm
from drake import lcmt_iiwa_status
from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.ft_messages import pack_samples
from heft.hardware_interface.hardware_station import HardwareStation
from heft.hardware_interface.lcmtypes import heft_ft_sample, heft_haptic_state
from heft.hardware_interface.message_checks import DeviceLimits

limits = DeviceLimits(*[np.full(6, value) for value in (-3.0, 3.0, 6.0, -3.0, 3.0, 4.0)], np.full(6, 500.0),
                      np.full(6, 100.0))
bus, channels = lcm.LCM("memq://"), LcmChannels()
station = HardwareStation(bus, channels, limits)
out["station"], out["readings"], out["rejected"], sent = [], [], [], [np.zeros(6)]
for k in range(120):
    now = 0.002 * k
    master = heft_haptic_state()
    master.utime, master.num_joints, master.buttons = int(1e6 * now) + 7, 6, k % 4
    master.position = list(np.full(6, 0.3) + 1e-3 * k) if k != 3 else [-1.0] * 6  # a jump: discontinuous
    master.velocity, master.torque_applied = list(rng.normal(0, 1, 6)), [0.0] * 6
    if k == 50:
        master.velocity = [float("nan")] * 6
    if k == 60:
        master.position = [4.0] * 6  # beyond the joints' range
    if k == 70:
        master.error = True
    status = lcmt_iiwa_status()
    status.utime, status.num_joints = int(1e6 * now) + 1000 if k != 80 else 3, 6 if k != 90 else 5
    status.joint_position_measured = list(np.full(status.num_joints, 0.2) + 1e-4 * k)
    status.joint_velocity_estimated = [0.01] * status.num_joints
    for name in ("joint_position_ipo", "joint_torque_measured", "joint_torque_commanded", "joint_torque_external"):
        setattr(status, name, [0.0] * status.num_joints)
    # The command the arm steps on: the last one sent or one to four older, or (every 11th) none of ours.
    echoed = sent[-1 - min(k % 5, len(sent) - 1)] if k % 11 else np.full(6, 9.0)
    status.joint_position_commanded = list(echoed[:status.num_joints])
    samples = [heft_ft_sample() for _ in range(4)]
    for i, sample in enumerate(samples):
        sample.utime, sample.sample_counter = int(1e6 * now) + 50 * i + 1, 4 * k + i
        sample.wrench, sample.acceleration = list(rng.normal(0, 20, 6)), list(rng.normal(0, 5, 6))
        sample.saturated, sample.error = (1 if k == 33 and i == 3 else 0), k == 35 and i == 3
    if k == 37:
        samples[3].wrench = [900.0] * 6
    if k % 2:
        ft = pack_samples([s.utime for s in samples], [s.sample_counter for s in samples],
                          [x for s in samples for x in s.wrench], [x for s in samples for x in s.acceleration],
                          [s.saturated for s in samples], [s.error for s in samples])
    else:
        ft = b"garbage" if k == 10 else samples[-1].encode()
    bus.publish(channels.master_state.name, master.encode() if k != 20 else b"\x00" * 12)
    bus.publish(channels.slave_status.name, status.encode())
    if not 60 <= k < 75:  # the sensor silent for 30 ms: stale, the commands held
        bus.publish(channels.ft_sample.name, ft)
    station.receive(now)
    station.send(now, rng.normal(0, 1, 6) if k != 100 else np.full(6, np.nan),
                 None if k % 9 == 0 else station.slave_position + rng.normal(0, 0.01, 6))
    out["readings"].append(np.concatenate((station.master_position, station.master_velocity, station.slave_position,
                                           station.wrench, station.acceleration, station.ages)))
    out["station"].append([station.healthy, station.gain, station.fault, station.conflicts, station.clutch,
                           station.reanchored, *station.torque_sent, *(station.position_sent
                                                                       if station.position_sent is not None
                                                                       else np.zeros(6)), station.command_echo.lag])
    if station.position_sent is not None:
        sent.append(station.position_sent.copy())
    out["rejected"].append(np.concatenate([reader.rejections.by_code for reader in station._readers]))
np.savez(sys.argv[1], **{name: np.asarray(value) for name, value in out.items()})
"""


def run_kernels(path, pure_python: bool) -> dict:
    env = dict(os.environ, HEFT_PURE_PYTHON="1" if pure_python else "0")
    subprocess.run([sys.executable, "-c", _KERNELS, str(path)], env=env, check=True, timeout=300)
    with np.load(path) as data:
        return dict(data)


def test_the_plain_python_kernels_equal_the_compiled_ones(tmp_path):
    assert not compiled.PURE_PYTHON, "numba is a dependency: the test suite runs the compiled kernels"
    fallback = run_kernels(tmp_path / "python.npz", pure_python=True)
    machine_code = run_kernels(tmp_path / "compiled.npz", pure_python=False)
    assert fallback.pop("pure_python") and not machine_code.pop("pure_python")
    assert fallback.keys() == machine_code.keys()
    ik_status, step_status = fallback["ik_status"], fallback["step_status"]
    assert (ik_status == 0).any() and (ik_status & OUT_OF_REACH).any() and (ik_status & JOINT_LIMIT).any()
    assert (ik_status & SHOULDER_SINGULARITY).any() and (ik_status & WRIST_SINGULARITY).any()
    assert (step_status & NON_FINITE).any() and (step_status & SLEWING).any() and (step_status == 0).any()
    rejected = fallback["rejected"][-1].reshape(-1, len(REASONS))
    refused = {REASONS[code] for per_channel in rejected for code in np.flatnonzero(per_channel)}
    assert refused >= {"undecodable", "joint_count", "non_finite", "out_of_range", "driver_error"}, refused
    assert fallback["station"][:, 0].any() and not fallback["station"][:, 0].all()  # healthy, and not always
    lags = set(fallback["station"][:, -1])  # the arm's echo (its statuses 4 steps apart): lags, and none of ours
    assert -1 in lags and len(lags) >= 4, lags
    ticks = fallback["controller"]
    assert ticks[49, -2] > 0 and ticks[45:50, -1].all() and ticks[45:, -3].all()  # learned, stale ticks, held
    for name, expected in fallback.items():
        assert np.abs(expected).max() > 0, name
        assert machine_code[name].shape == expected.shape, name
        np.testing.assert_allclose(machine_code[name], expected, rtol=1e-13, atol=1e-13, err_msg=name)


def test_the_kernel_cache_is_named_by_every_module_that_defines_kernels(tmp_path, monkeypatch):
    """numba tells a cached kernel stale by its own file only: a kernel calling one from another module kept
    the old callee's machine code after an update of that module alone. The cache's directory is named by
    the text of every module that defines kernels, so such an update compiles them afresh; modules without
    kernels do not count."""
    (tmp_path / "systems").mkdir()
    caller, callee, plain = (tmp_path / "systems" / name for name in ("caller.py", "callee.py", "plain.py"))
    caller.write_text("@compiled('void()')\ndef caller():\n    callee()\n")
    callee.write_text("@compiled('void()')\ndef callee():\n    pass\n")
    plain.write_text("x = 1\n")
    first = compiled.kernel_sources_digest(tmp_path)
    plain.write_text("x = 2\n")
    assert compiled.kernel_sources_digest(tmp_path) == first
    callee.write_text("@compiled('void()')\ndef callee():\n    return\n")
    assert compiled.kernel_sources_digest(tmp_path) != first
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "cache"))
    assert compiled.kernel_cache_dir(tmp_path).parent == tmp_path / "cache"
    if not compiled.PURE_PYTHON:  # this process's kernels are cached by this tree's digest
        root = Path(compiled.__file__).resolve().parent.parent
        assert Path(compiled.numba.config.CACHE_DIR).name == f"heft-kernels-{compiled.kernel_sources_digest(root)}"
