"""MotionScaling: exact reproduction at scale 1, translation and quaternion rotation
scaling through R_RB (checked with scipy's rotations), the clutch and scale changes
without jumps, and the absence of direct feedthrough."""

import numpy as np
import pytest
from pydrake.common.yaml import yaml_load_typed
from pydrake.math import RollPitchYaw, RotationMatrix
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import BasicVector, DiagramBuilder, LeafSystem
from pydrake.systems.primitives import ConstantVectorSource, VectorLogSink
from scipy.spatial.transform import Rotation

from heft.systems.controller.motion_scaling import (IDENTITY_POSE, MEMORY_SIZE, MotionScaling, MotionScalingParams,
                                         motion_scaling_update)

PERIOD = 0.0005
DURATION = 1.0
RPY_RB = [0.3, -0.2, 1.1]
R_RB = Rotation.from_euler("xyz", RPY_RB)  # Drake's roll-pitch-yaw: R = Rz(y)·Ry(p)·Rx(r)
# Off the tick grid, so each tick is unambiguously before or after a switch.
RELEASE, REENGAGE, TRANSLATION_SWITCH, ROTATION_SWITCH = 0.25025, 0.45025, 0.60025, 0.70025
POSE_RT0 = np.concatenate(([0.6, -0.1, 0.9], Rotation.from_rotvec([0.4, -1.0, 0.7]).as_quat(scalar_first=True)))


def stylus_pose(t) -> np.ndarray:
    """A smooth stylus motion in B: [p (m); w, x, y, z]."""
    w = 2 * np.pi * t
    p = [0.2 + 0.03 * np.sin(1.3 * w), 0.02 * np.sin(0.7 * w + 1), -0.15 + 0.025 * (1 - np.cos(w))]
    rotvec = [0.4 * np.sin(0.9 * w), 0.3 * np.sin(1.1 * w), 0.5 * np.sin(0.6 * w)]
    R = Rotation.from_rotvec(rotvec) * Rotation.from_euler("y", np.pi / 2)
    return np.concatenate((p, R.as_quat(scalar_first=True)))


def rotation(pose) -> Rotation:
    """The rotation(s) of a pose vector (7,) or of pose vectors (N, 7)."""
    return Rotation.from_quat(np.asarray(pose)[..., 3:], scalar_first=True)


class ScriptedOperator(LeafSystem):
    """Stylus pose, clutch and scale schedules as functions of time."""

    def __init__(self):
        super().__init__()
        self.DeclareVectorOutputPort("pose_BE", 7, lambda c, o: o.SetFromVector(stylus_pose(c.get_time())),
                                     prerequisites_of_calc={self.time_ticket()})
        self.DeclareVectorOutputPort("clutch", 1, self._clutch, prerequisites_of_calc={self.time_ticket()})
        self.DeclareVectorOutputPort("translation_scale", 1,
                                     lambda c, o: o.SetAtIndex(0, 1.0 if c.get_time() < TRANSLATION_SWITCH else 0.4),
                                     prerequisites_of_calc={self.time_ticket()})
        self.DeclareVectorOutputPort("rotation_scale", 1,
                                     lambda c, o: o.SetAtIndex(0, 1.0 if c.get_time() < ROTATION_SWITCH else 0.5),
                                     prerequisites_of_calc={self.time_ticket()})

    @staticmethod
    def _clutch(context, output: BasicVector):
        output.SetAtIndex(0, 0.0 if RELEASE <= context.get_time() < REENGAGE else 1.0)


@pytest.fixture(scope="module")
def run():
    """Three mappings behind one scripted operator, simulated once:
    identity (k = 1, R_RB = I, slave anchored at the stylus' start pose), scaled
    (k_t = 0.4, k_r = 0.3, R_RB ≠ I, slave at POSE_RT0), and clutched (scales from the
    schedule, R_RB ≠ I, a perfect slave: the measured pose is the desired one). Returns
    the update times and the desired poses there, and the stylus poses as "stylus"."""
    builder = DiagramBuilder()
    operator = builder.AddSystem(ScriptedOperator())
    engaged = builder.AddSystem(ConstantVectorSource([1.0]))
    systems = {
        "identity": (MotionScaling(MotionScalingParams(), PERIOD), stylus_pose(0.0)),
        "scaled": (MotionScaling(MotionScalingParams(0.4, 0.3, RPY_RB), PERIOD), POSE_RT0),
        "clutched": (MotionScaling(MotionScalingParams(R_RB=RPY_RB), PERIOD), None),
    }
    sinks = {}
    for name, (system, measured) in systems.items():
        builder.AddSystem(system)
        builder.Connect(operator.GetOutputPort("pose_BE"), system.GetInputPort("pose_BE"))
        if measured is None:
            builder.Connect(operator.GetOutputPort("clutch"), system.GetInputPort("clutch"))
            for port in ("translation_scale", "rotation_scale"):
                builder.Connect(operator.GetOutputPort(port), system.GetInputPort(port))
            builder.Connect(system.get_output_port(), system.GetInputPort("pose_RT_measured"))
        else:
            builder.Connect(engaged.get_output_port(), system.GetInputPort("clutch"))
            source = builder.AddSystem(ConstantVectorSource(measured))
            builder.Connect(source.get_output_port(), system.GetInputPort("pose_RT_measured"))
        sinks[name] = builder.AddSystem(VectorLogSink(7, publish_period=PERIOD))
        builder.Connect(system.get_output_port(), sinks[name].get_input_port())
    simulator = Simulator(builder.Build())
    simulator.AdvanceTo(DURATION)
    logs = {name: sink.FindLog(simulator.get_context()) for name, sink in sinks.items()}
    times = logs["identity"].sample_times()
    # A log at t_k is published before the update at t_k: it shows the update at t_(k−1).
    update_times = np.concatenate(([0.0], times[:-1]))
    logs = {name: log.data().T for name, log in logs.items()}
    logs["stylus"] = np.array([stylus_pose(t) for t in update_times])
    return update_times, logs


def test_scale_one_reproduces_the_stylus_motion(run):
    update_times, logs = run
    assert update_times.size == round(DURATION / PERIOD) + 1
    stylus = logs["stylus"]
    desired = logs["identity"]
    np.testing.assert_allclose(desired[:, :3], stylus[:, :3], atol=1e-12)
    error = (rotation(desired) * rotation(stylus).inv()).magnitude()
    assert error.max() < 1e-12


def test_scaled_translation_and_rotation_through_R_RB(run):
    update_times, logs = run
    stylus = logs["stylus"]
    desired = logs["scaled"]
    start = stylus[0]
    np.testing.assert_allclose(desired[:, :3], POSE_RT0[:3] + 0.4 * R_RB.apply(stylus[:, :3] - start[:3]),
                               atol=1e-12)
    rotvec_B = (rotation(stylus) * rotation(start).inv()).as_rotvec()
    rotvec_R = (rotation(desired) * rotation(POSE_RT0).inv()).as_rotvec()
    assert np.linalg.norm(rotvec_B, axis=1).max() > 0.5
    np.testing.assert_allclose(rotvec_R, 0.3 * R_RB.apply(rotvec_B), atol=1e-10)


def steps(poses):
    """Per-tick translation (m) and rotation angle (rad) changes of a pose sequence."""
    poses = np.asarray(poses)
    translation = np.linalg.norm(np.diff(poses[:, :3], axis=0), axis=1)
    angle = np.linalg.norm((rotation(poses[1:]) * rotation(poses[:-1]).inv()).as_rotvec(), axis=1)
    return translation, angle


def test_clutch_and_scale_changes_do_not_jump(run):
    update_times, logs = run
    desired = logs["clutched"]
    stylus = logs["stylus"]
    stylus_dp, stylus_dtheta = steps(stylus)
    dp, dtheta = steps(desired)
    # Each output step is bounded by the stylus' own motion in that tick (scales ≤ 1).
    assert np.all(dp <= stylus_dp + 1e-12)
    assert np.all(dtheta <= stylus_dtheta + 1e-9)
    # ... although the stylus moved far while the clutch was out.
    released = (update_times >= RELEASE) & (update_times < REENGAGE)
    moved = np.linalg.norm(stylus_pose(REENGAGE)[:3] - stylus_pose(RELEASE)[:3])
    assert moved > 50 * stylus_dp.max()
    # Released: the output holds.
    held = desired[released]
    np.testing.assert_array_equal(held, np.broadcast_to(held[0], held.shape))


def test_motion_after_reengagement_and_scale_changes(run):
    update_times, logs = run
    desired = logs["clutched"]
    stylus = logs["stylus"]
    engaged = (update_times < RELEASE) | (update_times >= REENGAGE)
    k_t = np.where(update_times < TRANSLATION_SWITCH, 1.0, 0.4)
    # Translation is incremental: each engaged tick moves k_t·R_RB·(stylus step). The tick of
    # the change still moves with the old k_t and re-anchors there, so no motion is lost.
    both = engaged[1:] & engaged[:-1]
    expected = k_t[:-1, None] * R_RB.apply(np.diff(stylus[:, :3], axis=0))
    np.testing.assert_allclose(np.diff(desired[:, :3], axis=0)[both], expected[both], atol=1e-12)
    # Rotation after the k_r change: anchored at the tick of the change, k_r = 0.5 about R_RB·axis.
    j = np.searchsorted(update_times, ROTATION_SWITCH)
    for m in range(j + 1, update_times.size, 25):
        rotvec_B = (rotation(stylus[m]) * rotation(stylus[j]).inv()).as_rotvec()
        rotvec_R = (rotation(desired[m]) * rotation(desired[j]).inv()).as_rotvec()
        np.testing.assert_allclose(rotvec_R, 0.5 * R_RB.apply(rotvec_B), atol=1e-10)


def test_no_direct_feedthrough():
    assert not MotionScaling().HasAnyDirectFeedthrough()


# --- the pure clutch logic -------------------------------------------------------

R_RB_DRAKE = RotationMatrix(RollPitchYaw(RPY_RB)).matrix()


def fresh_memory(k_t=1.0, k_r=1.0):
    return np.concatenate(([0.0, k_t, k_r], IDENTITY_POSE, IDENTITY_POSE))


def test_rotation_by_theta_about_an_axis_gives_k_theta_about_the_mapped_axis():
    axis_B = np.array([1.0, 2.0, -2.0]) / 3.0
    theta, k_r = 1.2, 0.35
    start = stylus_pose(0.3)
    memory, desired = motion_scaling_update(fresh_memory(1.0, k_r), IDENTITY_POSE, start, True, POSE_RT0,
                                            1.0, k_r, R_RB_DRAKE)
    np.testing.assert_allclose(desired, POSE_RT0, atol=1e-15)
    turned = np.concatenate((start[:3], (Rotation.from_rotvec(theta * axis_B) * rotation(start))
                             .as_quat(scalar_first=True)))
    _, desired = motion_scaling_update(memory, desired, turned, True, POSE_RT0, 1.0, k_r, R_RB_DRAKE)
    rotvec_R = (rotation(desired) * rotation(POSE_RT0).inv()).as_rotvec()
    np.testing.assert_allclose(rotvec_R, k_r * theta * R_RB.apply(axis_B), atol=1e-12)
    np.testing.assert_allclose(desired[:3], POSE_RT0[:3], atol=1e-15)


def test_engagement_anchors_at_the_measured_slave_pose():
    """Released: hold. Re-engaged where the slave is not at the held pose (a tracking
    error): the output continues from the measured pose, as documented."""
    memory, desired = motion_scaling_update(fresh_memory(), IDENTITY_POSE, stylus_pose(0.0), True, POSE_RT0,
                                            1.0, 1.0, R_RB_DRAKE)
    memory, held = motion_scaling_update(memory, desired, stylus_pose(0.1), False, POSE_RT0, 1.0, 1.0, R_RB_DRAKE)
    np.testing.assert_array_equal(held, desired)
    assert memory[0] == 0.0
    measured = POSE_RT0 + np.array([0.001, 0, 0, 0, 0, 0, 0])
    memory, desired = motion_scaling_update(memory, held, stylus_pose(0.2), True, measured, 1.0, 1.0, R_RB_DRAKE)
    np.testing.assert_allclose(desired, measured, atol=1e-15)
    _, desired = motion_scaling_update(memory, desired, stylus_pose(0.21), True, measured, 1.0, 1.0, R_RB_DRAKE)
    np.testing.assert_allclose(desired[:3] - measured[:3],
                               R_RB.apply(stylus_pose(0.21)[:3] - stylus_pose(0.2)[:3]), atol=1e-15)


@pytest.mark.parametrize("bad", ["pose", "scale"])
def test_invalid_input_holds_and_disengages(bad):
    memory, desired = motion_scaling_update(fresh_memory(), IDENTITY_POSE, stylus_pose(0.0), True, POSE_RT0,
                                            1.0, 1.0, R_RB_DRAKE)
    pose = np.full(7, np.nan) if bad == "pose" else stylus_pose(0.1)
    k_t = np.nan if bad == "scale" else 1.0
    memory, held = motion_scaling_update(memory, desired, pose, True, POSE_RT0, k_t, 1.0, R_RB_DRAKE)
    np.testing.assert_array_equal(held, desired)
    assert memory[0] == 0.0 and memory.size == MEMORY_SIZE


def test_start_released_holds_the_measured_pose():
    system = MotionScaling(MotionScalingParams(), PERIOD)
    context = system.CreateDefaultContext()
    system.GetInputPort("pose_BE").FixValue(context, stylus_pose(0.0))
    system.GetInputPort("clutch").FixValue(context, [0.0])
    system.GetInputPort("pose_RT_measured").FixValue(context, POSE_RT0)
    simulator = Simulator(system, context)
    simulator.AdvanceTo(0.01)
    np.testing.assert_allclose(system.get_output_port().Eval(context), POSE_RT0, atol=1e-15)


def test_params_from_yaml_and_validation():
    params = yaml_load_typed(schema=MotionScalingParams,
                             data="{translation_scale: 0.5, rotation_scale: 0.25, R_RB: [0, 0, 1.5]}")
    assert params == MotionScalingParams(0.5, 0.25, [0.0, 0.0, 1.5])
    with pytest.raises(ValueError, match="period"):
        MotionScaling(params, period=0.0)
    with pytest.raises(ValueError, match="translation_scale"):
        MotionScaling(MotionScalingParams(translation_scale=-1.0))
    with pytest.raises(ValueError, match="R_RB"):
        MotionScaling(MotionScalingParams(R_RB=[0.0, 0.0]))
