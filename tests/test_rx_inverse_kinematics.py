"""Closed-form kinematics of the RX90 / RX60 against Drake's kinematics of our URDFs,
singularity behaviour, and the sampled SlaveInverseKinematics block."""

import dataclasses

import numpy as np
import pytest
from pydrake.common.eigen_geometry import AngleAxis
from pydrake.math import RotationMatrix
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import JacobianWrtVariable
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, TrajectorySource
from pydrake.trajectories import PiecewisePolynomial

from heft.diagrams.models import model_path
from heft.diagrams.scenario import Scenario
from heft.diagrams.plants import AddSlave
from heft.systems.pose_vectors import pose_vector, rigid_transform
from heft.systems.controller.rx_inverse_kinematics import RxKinematics
from heft.systems.controller.slave_inverse_kinematics import SlaveInverseKinematics

ROBOTS = ("rx90", "rx60")
PERIOD = 0.0005  # s


class Arm:
    """Our closed form and Drake's plant of the same URDF, side by side."""

    def __init__(self, robot):
        self.kin = getattr(RxKinematics, robot)()
        self.plant = MultibodyPlant(0.0)
        Parser(self.plant).AddModels(model_path(f"{robot}.urdf"))
        self.plant.WeldFrames(self.plant.world_frame(), self.plant.GetFrameByName(f"{robot}_base"))
        self.plant.Finalize()
        self.context = self.plant.CreateDefaultContext()
        self.flange = self.plant.GetFrameByName("flange")

    def drake_pose(self, q):
        """(R_RF, p_RF) from Drake."""
        self.plant.SetPositions(self.context, q)
        X = self.flange.CalcPoseInWorld(self.context)
        return X.rotation().matrix(), X.translation()

    def random_q(self, rng, count, regular=False):
        """Joint angles uniform within the limits; ``regular``: only where the branches are
        well apart (|sin q3| ≥ 0.1, |sin q5| ≥ the wrist band, wrist centre ≥ 5 cm off J1)."""
        kin, samples = self.kin, []
        while len(samples) < count:
            q = rng.uniform(kin.lower, kin.upper)
            x1 = kin.a2 * np.sin(q[1]) + kin.d4 * np.sin(q[1] + q[2])
            if not regular or (abs(np.sin(q[2])) >= 0.1 and abs(np.sin(q[4])) >= kin.wrist_band and abs(x1) >= 0.05):
                samples.append(q)
        return samples


@pytest.fixture(scope="module", params=ROBOTS)
def arm(request):
    return Arm(request.param)


def angle_difference(a, b):
    return (np.asarray(a) - b + np.pi) % (2 * np.pi) - np.pi


def orientation_error(R_a, R_b):
    """Angle (rad) of the rotation between two rotation matrices."""
    return RotationMatrix(R_a.T @ R_b).ToAngleAxis().angle()


def test_limits_and_speeds_are_the_urdfs(arm):
    np.testing.assert_allclose(arm.kin.lower, arm.plant.GetPositionLowerLimits(), atol=1e-12)
    np.testing.assert_allclose(arm.kin.upper, arm.plant.GetPositionUpperLimits(), atol=1e-12)
    np.testing.assert_allclose(arm.kin.velocity, arm.plant.GetVelocityUpperLimits(), atol=1e-12)


def test_forward_is_drakes_flange_pose(arm):
    for q in arm.random_q(np.random.default_rng(1), 200):
        R, p = arm.kin.forward(q)
        R_drake, p_drake = arm.drake_pose(q)
        np.testing.assert_allclose(R, R_drake, atol=1e-10)
        np.testing.assert_allclose(p, p_drake, atol=1e-10)


def test_manipulability_is_the_jacobian_determinant(arm):
    for q in arm.random_q(np.random.default_rng(2), 50):
        arm.plant.SetPositions(arm.context, q)
        J = arm.plant.CalcJacobianSpatialVelocity(arm.context, JacobianWrtVariable.kV, arm.flange, np.zeros(3),
                                                  arm.plant.world_frame(), arm.plant.world_frame())
        assert arm.kin.manipulability(q) == pytest.approx(abs(np.linalg.det(J)), rel=1e-9, abs=1e-14)


def test_every_solution_reproduces_the_pose_and_q_is_among_them(arm):
    counts = []
    for q in arm.random_q(np.random.default_rng(3), 200):
        R, p = arm.kin.forward(q)
        solutions = arm.kin.solve_all(R, p)
        counts.append(len(solutions))
        assert 1 <= len(solutions) <= 8
        assert arm.kin.within_limits(solutions).all()
        for solution in solutions:
            R_drake, p_drake = arm.drake_pose(solution)
            np.testing.assert_allclose(R_drake, R, atol=1e-9)
            np.testing.assert_allclose(p_drake, p, atol=1e-9)
        assert np.abs(angle_difference(solutions, q)).max(axis=1).min() < 1e-9
    assert max(counts) == 8  # all branches show up somewhere in the workspace


def test_solve_nearest_from_nearby_returns_the_original(arm):
    rng = np.random.default_rng(4)
    for q in arm.random_q(rng, 200, regular=True):
        R, p = arm.kin.forward(q)
        result = arm.kin.solve_nearest(R, p, q + rng.normal(0.0, 0.02, 6))
        assert result.reachable and result.reason == ""
        np.testing.assert_allclose(result.q, q, atol=1e-9)  # the same turn of joints 4 and 6, too
        assert result.manipulability == pytest.approx(arm.kin.manipulability(q))


def test_multi_turn_joints_take_the_turn_nearest_the_current_one():
    kin = RxKinematics.rx90()
    q = np.array([0.3, 0.5, 1.8, 4.0, 0.8, -4.2])  # q4, q6 beyond ±π
    other_turn = q + [0, 0, 0, -2 * np.pi, 0, 2 * np.pi]
    R, p = kin.forward(q)
    np.testing.assert_allclose(kin.solve_nearest(R, p, q + 0.05).q, q, atol=1e-12)
    np.testing.assert_allclose(kin.solve_nearest(R, p, other_turn + 0.05).q, other_turn, atol=1e-12)


def brute_force_nearest(kin, solutions, q_current):
    """The solution nearest q_current (Euclidean, rad) over every turn of joints 4 and 6 within limits."""
    turns = [-2 * np.pi, 0.0, 2 * np.pi]
    options = [solution + [0, 0, 0, t4, 0, t6] for solution in solutions for t4 in turns for t6 in turns]
    options = [q for q in options if kin.within_limits(q)]
    return min(options, key=lambda q: np.linalg.norm(q - q_current))


def test_solve_nearest_is_the_nearest_of_all_solutions_and_turns(arm):
    rng = np.random.default_rng(5)
    for q, q_current in zip(arm.random_q(rng, 100, regular=True), arm.random_q(rng, 100)):
        R, p = arm.kin.forward(q)
        expected = brute_force_nearest(arm.kin, arm.kin.solve_all(R, p), q_current)
        np.testing.assert_allclose(arm.kin.solve_nearest(R, p, q_current).q, expected, atol=1e-9)


@pytest.mark.parametrize("robot", ROBOTS)
def test_pose_beyond_reach(robot):
    kin = getattr(RxKinematics, robot)()
    q = np.array([0.3, 0.5, 1.0, 0.2, 0.7, 0.1])
    R, p = kin.forward(q)
    result = kin.solve_nearest(R, p + [1.5, 0.0, 0.0], q)
    assert not result.reachable and result.reason == "out of reach"
    np.testing.assert_array_equal(result.q, q)
    assert len(kin.solve_all(R, p + [1.5, 0.0, 0.0])) == 0


def test_rx60_wrist_centre_inside_the_shoulder_offset_is_out_of_reach():
    kin = RxKinematics.rx60()
    R = np.diag([1.0, -1.0, -1.0])  # flange pointing down, wrist centre straight above it
    result = kin.solve_nearest(R, [0.02, 0.0, 0.4], np.zeros(6))  # 2 cm from J1 < d3 = 4.9 cm
    assert not result.reachable and result.reason == "out of reach"


@pytest.mark.parametrize("joint,q", [
    (3, [0.3, 0.4, 2.6, 0.2, 0.7, 0.1]),   # elbow folded past 142.5°: every branch needs |q3| = 2.6
    (5, [0.3, 0.4, 1.0, 0.2, 2.2, 0.1]),   # q5 = 126° > 120°, and its flip −126° < −105°
])
def test_pose_past_a_joint_limit_names_the_joint(joint, q):
    kin = RxKinematics.rx90()
    R, p = kin.forward(q)
    result = kin.solve_nearest(R, p, np.zeros(6))
    assert not result.reachable and result.reason == f"joint limit joint{joint}"
    assert len(kin.solve_all(R, p)) == 0


def test_non_finite_pose_is_refused():
    kin = RxKinematics.rx90()
    R, p = kin.forward(np.ones(6))
    result = kin.solve_nearest(R, p + [np.nan, 0.0, 0.0], np.ones(6))
    assert not result.reachable and result.reason == "non-finite pose"


def track(kin, poses, q):
    """solve_nearest along a path of (R, p), each from the last answer: the joint path,
    the largest per-step change (rad), the worst orientation error (rad), the reasons met."""
    path, worst_step, worst_orientation, reasons = [q], 0.0, 0.0, set()
    for R, p in poses:
        result = kin.solve_nearest(R, p, path[-1])
        assert result.reachable, result
        R_q, p_q = kin.forward(result.q)
        error = orientation_error(R_q, R)
        # The wrist centre is always exact; the flange is off by at most d6 × the orientation error.
        np.testing.assert_allclose(p_q - kin.d6 * R_q[:, 2], p - kin.d6 * R[:, 2], atol=1e-9)
        assert np.linalg.norm(p_q - p) <= kin.d6 * error + 1e-9
        worst_step = max(worst_step, np.abs(result.q - path[-1]).max())
        worst_orientation = max(worst_orientation, error)
        reasons.add(result.reason)
        path.append(result.q)
    return np.array(path), worst_step, worst_orientation, reasons


def geodesic_path(kin, q_start, q_end, steps):
    """Flange poses on the straight line and the shortest rotation between two joint poses."""
    (R_a, p_a), (R_b, p_b) = kin.forward(q_start), kin.forward(q_end)
    relative = RotationMatrix(R_a.T @ R_b).ToAngleAxis()
    return [(R_a @ RotationMatrix(AngleAxis(s * relative.angle(), relative.axis())).matrix(), (1 - s) * p_a + s * p_b)
            for s in np.linspace(0.0, 1.0, steps + 1)[1:]]


@pytest.mark.parametrize("miss", [0.0, 0.02])
def test_wrist_singularity_path_stays_continuous(miss):
    """q5 from +0.3 to −0.3 in 200 steps (0.003 rad each), through (miss = 0) or just past
    (miss = 0.02: |sin q5| down to ~1e-4) the singularity. Exactly solved, q4 flips by ~π
    in one step; with the band it moves by less than 0.03 rad per step, the orientation
    error staying under the band."""
    kin = RxKinematics.rx90()
    exact = dataclasses.replace(kin, wrist_band=1e-12)
    q_start = np.array([0.2, 0.4, 1.6, 0.0, 0.3, 0.0])
    q_end = np.array([0.25, 0.45, 1.55, miss, -0.3, -miss])
    poses = geodesic_path(kin, q_start, q_end, 200)
    path, worst_step, worst_orientation, reasons = track(kin, poses, q_start)
    assert worst_step < 0.03 and worst_orientation < kin.wrist_band
    assert "wrist singularity" in reasons
    np.testing.assert_allclose(path[-1], q_end, atol=1e-9)  # exact again beyond the band, no flip
    assert np.abs(np.diff(path[:, 3])).max() < 0.03
    _, exact_worst_step, _, _ = track(exact, poses, q_start)
    assert exact_worst_step > 1.0


def test_shoulder_singularity_path_stays_continuous():
    """The wrist centre crosses the J1 axis (RX90): the shoulder branch switches with q1
    continuous, and every pose is exact."""
    kin = RxKinematics.rx90()
    q_start = np.array([0.3, -0.3, 0.8, 0.2, 0.7, 0.1])
    R, p = kin.forward(q_start)
    p_C = p - kin.d6 * R[:, 2]
    poses = [(R, p - s * 2 * np.array([p_C[0], p_C[1], 0.0])) for s in np.linspace(0, 1, 201)[1:]]
    path, worst_step, worst_orientation, reasons = track(kin, poses, q_start)
    assert worst_step < 0.01 and worst_orientation < 1e-9
    assert "shoulder singularity" in reasons  # the path hits the axis exactly half-way
    assert path[-1][1] < 0 < path[0][1] + 0.6  # leaning the other way, over the top


def test_elbow_stretch_and_back_stays_continuous():
    """The wrist centre moves out to full reach (q3 = 0) and back along a ray from the shoulder."""
    kin = RxKinematics.rx90()
    q_start = np.array([0.3, 0.4, 0.5, 0.2, 0.7, 0.1])
    R, p = kin.forward(q_start)
    shoulder = np.array([0.0, 0.0, kin.d1])
    p_C = p - kin.d6 * R[:, 2]
    ray = (p_C - shoulder) / np.linalg.norm(p_C - shoulder)
    radii = np.linalg.norm(p_C - shoulder) + (kin.a2 + kin.d4 - np.linalg.norm(p_C - shoulder)) * np.concatenate(
        (np.linspace(0, 1, 100), np.linspace(1, 0, 100)))
    poses = [(R, shoulder + r * ray + kin.d6 * R[:, 2]) for r in radii]
    path, worst_step, worst_orientation, _ = track(kin, poses, q_start)
    assert worst_step < 0.1 and worst_orientation < 1e-9
    assert np.abs(path[:, 2]).min() < 1e-6  # it did stretch


# --- SlaveInverseKinematics ----------------------------------------------------

def tool_tip_in_flange():
    """X_FT of the paper's tool tip, from the station's plant."""
    plant = MultibodyPlant(0.0)
    AddSlave(plant, Scenario())
    plant.Finalize()
    context = plant.CreateDefaultContext()
    return plant, context, plant.CalcRelativeTransform(context, plant.GetFrameByName("flange"),
                                                       plant.GetFrameByName("tool_tip"))


class Loop:
    """pose source (a ConstantVectorSource whose value the test sets) → SlaveInverseKinematics,
    with position_measured from another constant source."""

    def __init__(self):
        self.kin = RxKinematics.rx90()
        self.plant, self.plant_context, self.X_FT = tool_tip_in_flange()
        self.q_initial = np.array(Scenario().slave_initial_q)
        self.q_measured = self.q_initial + 0.01
        builder = DiagramBuilder()
        self.ik = builder.AddSystem(SlaveInverseKinematics(self.kin, self.X_FT, self.q_initial, PERIOD))
        self.pose = builder.AddSystem(ConstantVectorSource(self.tip_pose(self.q_measured)))
        measured = builder.AddSystem(ConstantVectorSource(self.q_measured))
        builder.Connect(self.pose.get_output_port(), self.ik.GetInputPort("pose_desired"))
        builder.Connect(measured.get_output_port(), self.ik.GetInputPort("position_measured"))
        self.diagram = builder.Build()

    def tip_pose(self, q):
        """X_RT of the tool tip at q, from Drake, as a pose vector."""
        self.plant.SetPositions(self.plant_context, q)
        return pose_vector(self.plant.GetFrameByName("tool_tip").CalcPoseInWorld(self.plant_context))

    def start(self):
        self.context = self.diagram.CreateDefaultContext()
        self.simulator = Simulator(self.diagram, self.context)
        self.simulator.Initialize()
        self.ticks = 0

    def set_pose(self, pose):
        source_context = self.pose.GetMyMutableContextFromRoot(self.context)
        self.pose.get_mutable_source_value(source_context).set_value(pose)

    def advance(self, ticks=1):
        """Runs ``ticks`` periodic updates; returns the commands after each, (ticks, 6)."""
        commands = []
        for _ in range(ticks):
            self.simulator.AdvanceTo((self.ticks + 0.5) * PERIOD)  # half-way between samples
            self.ticks += 1
            commands.append(self.out("position_commanded"))
        return np.array(commands)

    def out(self, name):
        return self.ik.GetOutputPort(name).Eval(self.ik.GetMyContextFromRoot(self.context)).copy()


@pytest.fixture(scope="module")
def loop():
    return Loop()


def test_no_direct_feedthrough(loop):
    assert not loop.ik.HasAnyDirectFeedthrough()


def test_initial_command_must_be_within_the_limits(loop):
    with pytest.raises(ValueError, match="within the limits"):
        SlaveInverseKinematics(loop.kin, loop.X_FT, [0.0, 0.0, 3.0, 0.0, 0.0, 0.0], PERIOD)


def test_starts_at_the_measured_position(loop):
    loop.start()
    np.testing.assert_array_equal(loop.out("position_commanded"), loop.q_measured)
    np.testing.assert_array_equal(loop.out("status"), [1.0, 0.0])


def test_command_follows_the_pose_and_puts_the_tip_there(loop):
    loop.start()
    q_goal = loop.q_measured + np.array([0.002, -0.001, 0.002, 0.003, -0.002, 0.004])
    loop.set_pose(loop.tip_pose(q_goal))
    q = loop.advance()[-1]
    np.testing.assert_allclose(q, q_goal, atol=1e-9)
    np.testing.assert_allclose(loop.tip_pose(q), loop.tip_pose(q_goal), atol=1e-9)
    np.testing.assert_array_equal(loop.out("status"), [1.0, 0.0])
    assert loop.out("slewing")[0] == 0.0


def test_unreachable_or_nan_pose_holds_the_last_command_and_counts(loop):
    loop.start()
    q_held = loop.advance()[-1]
    far = loop.tip_pose(q_held)
    far[:3] += [2.0, 0.0, 0.0]
    loop.set_pose(far)
    commands = loop.advance(5)
    np.testing.assert_array_equal(commands, np.tile(q_held, (5, 1)))
    np.testing.assert_array_equal(loop.out("status"), [0.0, 5.0])
    nan_pose = loop.tip_pose(q_held)
    nan_pose[4] = np.nan
    loop.set_pose(nan_pose)
    np.testing.assert_array_equal(loop.advance(3), np.tile(q_held, (3, 1)))
    np.testing.assert_array_equal(loop.out("status"), [0.0, 8.0])
    loop.set_pose(loop.tip_pose(q_held + 0.001))
    np.testing.assert_allclose(loop.advance()[-1], q_held + 0.001, atol=1e-9)
    np.testing.assert_array_equal(loop.out("status"), [1.0, 8.0])  # the count is kept


def test_far_jump_is_slewed_at_the_speed_limits(loop):
    loop.start()
    q_start = loop.advance()[-1]
    q_goal = q_start + np.array([0.3, -0.2, 0.25, 0.6, -0.4, 0.9])
    loop.set_pose(loop.tip_pose(q_goal))
    ticks_needed = int(np.ceil((np.abs(q_goal - q_start) / (loop.kin.velocity * PERIOD)).max()))
    commands = loop.advance(ticks_needed - 1)
    assert loop.out("slewing")[0] == 1.0
    steps = np.abs(np.diff(np.vstack((q_start, commands)), axis=0))
    assert (steps <= loop.kin.velocity * PERIOD + 1e-12).all()
    np.testing.assert_allclose(steps.max(axis=0), loop.kin.velocity * PERIOD, rtol=1e-9)
    np.testing.assert_allclose(loop.advance(1)[-1], q_goal, atol=1e-9)
    assert loop.out("slewing")[0] == 0.0
    np.testing.assert_array_equal(loop.out("status"), [1.0, 0.0])


def test_follows_a_trajectory_source():
    """A smooth 0.2 s tool-tip path from a TrajectorySource; q_measured not connected:
    the command starts at q_initial and, each tick, puts the tip on the path's sample."""
    kin = RxKinematics.rx90()
    plant, plant_context, X_FT = tool_tip_in_flange()
    tip = plant.GetFrameByName("tool_tip")
    q0 = np.array(Scenario().slave_initial_q)
    times = np.linspace(0.0, 0.2, 21)
    path_q = [q0 + 0.3 * np.sin(np.pi * t / 0.2) * np.array([0.2, -0.1, 0.2, 0.3, 0.2, 0.3]) for t in times]
    poses = []
    for q in path_q:
        plant.SetPositions(plant_context, q)
        pose = pose_vector(tip.CalcPoseInWorld(plant_context))
        if poses and pose[3:] @ poses[-1][3:] < 0:  # one quaternion hemisphere, so the hold interpolates
            pose[3:] *= -1
        poses.append(pose)
    trajectory = PiecewisePolynomial.FirstOrderHold(times, np.array(poses).T)
    builder = DiagramBuilder()
    source = builder.AddSystem(TrajectorySource(trajectory))
    ik = builder.AddSystem(SlaveInverseKinematics(kin, X_FT, q0, PERIOD))
    builder.Connect(source.get_output_port(), ik.GetInputPort("pose_desired"))
    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    ik_context = ik.GetMyContextFromRoot(context)
    simulator.Initialize()
    np.testing.assert_array_equal(ik.GetOutputPort("position_commanded").Eval(ik_context), q0)
    worst = 0.0
    for k in range(400):
        simulator.AdvanceTo((k + 0.5) * PERIOD)
        q = ik.GetOutputPort("position_commanded").Eval(ik_context)
        plant.SetPositions(plant_context, q)
        X_RT = tip.CalcPoseInWorld(plant_context).GetAsMatrix4()
        X_RT_desired = rigid_transform(trajectory.value(k * PERIOD).ravel()).GetAsMatrix4()
        worst = max(worst, np.abs(X_RT - X_RT_desired).max())
    assert worst < 1e-9
    np.testing.assert_array_equal(ik.GetOutputPort("status").Eval(ik_context), [1.0, 0.0])
