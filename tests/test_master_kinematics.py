"""MasterKinematics: pose against Drake on a separately built plant and the URDF's
closed form, Jacobian against finite differences, power consistency, the plant
argument, and the sampled version in a simulated diagram."""

import numpy as np
import pytest
from pydrake.math import RigidTransform
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import SpatialInertia
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import TrajectorySource, VectorLogSink
from pydrake.trajectories import PiecewisePolynomial
from scipy.spatial.transform import Rotation

from heft.diagrams.models import model_path
from heft.diagrams.plants import MakeMasterPlant
from heft.systems.controller.master_kinematics import MasterKinematics
from heft.systems.pose_vectors import rigid_transform

URDF = model_path("phantom_premium_6dof.urdf")
L1, L2 = 0.215, 0.17  # m, from the URDF header
PERIOD = 0.0005


def reference_plant():
    """The Phantom parsed on its own, base welded at the world (as the sim station does)."""
    plant = MultibodyPlant(time_step=0.0)
    (instance,) = Parser(plant).AddModels(URDF)
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("phantom_base", instance))
    plant.Finalize()
    return plant


REFERENCE = reference_plant()
REFERENCE_CONTEXT = REFERENCE.CreateDefaultContext()


def reference_pose(q) -> RigidTransform:
    REFERENCE.SetPositions(REFERENCE_CONTEXT, q)
    return REFERENCE.CalcRelativeTransform(REFERENCE_CONTEXT, REFERENCE.GetFrameByName("phantom_base"),
                                           REFERENCE.GetFrameByName("stylus"))


def random_q(rng, n=None):
    """Joint angles inside the URDF's limits (rad)."""
    lower, upper = REFERENCE.GetPositionLowerLimits(), REFERENCE.GetPositionUpperLimits()
    return rng.uniform(lower, upper, size=None if n is None else (n, 6))


@pytest.fixture(scope="module")
def system():
    mk = MasterKinematics(MakeMasterPlant())
    return mk, mk.CreateDefaultContext()


def evaluate(system, q):
    mk, context = system
    mk.get_input_port().FixValue(context, q)
    return mk.GetOutputPort("pose_BE").Eval(context), mk.GetOutputPort("jacobian").Eval(context).reshape(6, 6)


def log_rotation(R) -> np.ndarray:
    """Rotation vector (axis·angle, rad) of a 3×3 rotation matrix, by scipy."""
    return Rotation.from_matrix(R).as_rotvec()


def test_pose_matches_drake_and_closed_form(system):
    rng = np.random.default_rng(1)
    for q in random_q(rng, 50):
        pose, _ = evaluate(system, q)
        assert rigid_transform(pose).IsNearlyEqualTo(reference_pose(q), 1e-12)
        c1, s1 = np.cos(q[0]), np.sin(q[0])
        reach = L1 * np.cos(q[1]) + L2 * np.sin(q[1] + q[2])
        p_BW = [c1 * reach, s1 * reach, L1 * np.sin(q[1]) - L2 * np.cos(q[1] + q[2])]
        np.testing.assert_allclose(pose[:3], p_BW, atol=1e-12)


def test_zero_pose_axes(system):
    """URDF header: at q = 0, z_E = +x_B, y_E = +y_B, x_E = −z_B, at (l1, 0, −l2)."""
    pose, _ = evaluate(system, np.zeros(6))
    R = rigid_transform(pose).rotation().matrix()
    np.testing.assert_allclose(R, [[0, 0, 1], [0, 1, 0], [-1, 0, 0]], atol=1e-15)
    np.testing.assert_allclose(pose[:3], [L1, 0, -L2], atol=1e-15)


def test_jacobian_matches_finite_differences(system):
    rng = np.random.default_rng(2)
    h = 1e-6
    for q in random_q(rng, 20):
        _, J = evaluate(system, q)
        fd = np.zeros((6, 6))
        for i in range(6):
            dq = np.zeros(6)
            dq[i] = h
            X_plus, X_minus = reference_pose(q + dq), reference_pose(q - dq)
            fd[:3, i] = (X_plus.translation() - X_minus.translation()) / (2 * h)
            fd[3:, i] = log_rotation((X_plus.rotation() @ X_minus.rotation().inverse()).matrix()) / (2 * h)
        np.testing.assert_allclose(J, fd, atol=1e-6)


def test_power_consistency(system):
    """(J q̇)·w = q̇·(Jᵀ w): the twist's power on a wrench equals the joint torques' power,
    with twists [v; ω] and wrenches [f; τ] in the same order."""
    rng = np.random.default_rng(3)
    for q in random_q(rng, 20):
        _, J = evaluate(system, q)
        qdot, w = rng.normal(size=6), rng.normal(size=6)
        twist = J @ qdot
        assert twist[:3] @ w[:3] + twist[3:] @ w[3:] == pytest.approx(qdot @ (J.T @ w), rel=1e-12, abs=1e-14)


def test_takes_the_station_plant(system):
    """A finalized plant with more bodies (the operator's hand welded on the stylus) and
    a discrete time step gives the same kinematics."""
    plant = MultibodyPlant(time_step=0.001)
    (phantom,) = Parser(plant).AddModels(URDF)
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("phantom_base", phantom))
    hand = plant.AddRigidBody("operator_hand", phantom, SpatialInertia.SolidSphereWithMass(0.3, 0.04))
    plant.WeldFrames(plant.GetFrameByName("stylus"), hand.body_frame())
    plant.Finalize()
    mk = MasterKinematics(plant)
    context = mk.CreateDefaultContext()
    q = random_q(np.random.default_rng(4))
    mk.get_input_port().FixValue(context, q)
    pose, J = evaluate(system, q)
    np.testing.assert_array_equal(mk.GetOutputPort("pose_BE").Eval(context), pose)
    np.testing.assert_array_equal(mk.GetOutputPort("jacobian").Eval(context).reshape(6, 6), J)


def test_rejects_bad_arguments():
    with pytest.raises(ValueError, match="finalized"):
        MasterKinematics(MultibodyPlant(time_step=0.0))
    with pytest.raises(ValueError, match="period"):
        MasterKinematics(MakeMasterPlant(), period=0.0)


def test_direct_feedthrough():
    assert MasterKinematics(MakeMasterPlant()).HasDirectFeedthrough(0, 0)
    assert MasterKinematics(MakeMasterPlant()).HasDirectFeedthrough(0, 1)
    sampled = MasterKinematics(MakeMasterPlant(), period=PERIOD)
    assert not sampled.HasAnyDirectFeedthrough()


@pytest.fixture(scope="module")
def sampled_run():
    """Both versions behind one joint trajectory, simulated once for 50 ms."""
    rng = np.random.default_rng(5)
    times = np.linspace(0.0, 0.05, 6)
    knots = random_q(rng, len(times)).T * 0.5
    trajectory = PiecewisePolynomial.CubicShapePreserving(times, knots)
    builder = DiagramBuilder()
    source = builder.AddSystem(TrajectorySource(trajectory))
    continuous = builder.AddSystem(MasterKinematics(MakeMasterPlant()))
    sampled = builder.AddSystem(MasterKinematics(MakeMasterPlant(), period=PERIOD))
    logs = {}
    for name, mk in (("continuous", continuous), ("sampled", sampled)):
        builder.Connect(source.get_output_port(), mk.get_input_port())
        for port in ("pose_BE", "jacobian"):
            sink = builder.AddSystem(VectorLogSink(mk.GetOutputPort(port).size(), publish_period=PERIOD))
            builder.Connect(mk.GetOutputPort(port), sink.get_input_port())
            logs[name, port] = sink
    diagram = builder.Build()
    simulator = Simulator(diagram)
    simulator.AdvanceTo(0.05)
    context = simulator.get_context()
    return trajectory, {key: sink.FindLog(context) for key, sink in logs.items()}


def test_sampled_outputs_hold_the_kinematics_of_the_sample(sampled_run, system):
    """A log at t_k is published before the update at t_k (Drake's event order), so it
    shows the sample taken at t_(k−1): the kinematics of q(t_(k−1)), held for one period."""
    trajectory, logs = sampled_run
    times = logs["sampled", "pose_BE"].sample_times()
    assert times.size >= 100
    np.testing.assert_allclose(np.diff(times), PERIOD, rtol=1e-9)
    for k in range(1, times.size, 10):
        pose, J = evaluate(system, trajectory.value(times[k - 1]).ravel())
        np.testing.assert_allclose(logs["sampled", "pose_BE"].data()[:, k], pose, atol=1e-12)
        np.testing.assert_allclose(logs["sampled", "jacobian"].data()[:, k], J.ravel(), atol=1e-12)
    for port in ("pose_BE", "jacobian"):
        sampled, continuous = logs["sampled", port].data(), logs["continuous", port].data()
        np.testing.assert_allclose(sampled[:, 1:], continuous[:, :-1], atol=1e-12)
        np.testing.assert_allclose(sampled[:, 0], continuous[:, 0], atol=1e-12)
