"""Excitation trajectories (Eqs. 9–10): derivatives, rest, the Drake trajectory,
the sensor frame's motion against Drake, and the optimiser."""

import dataclasses

import numpy as np
import pytest
from pydrake.multibody.math import SpatialAcceleration
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import PrismaticJoint, SpatialInertia
from pydrake.systems.primitives import TrajectorySource

from heft.diagrams.scenario import Scenario
from heft.diagrams.plants import AddSlave
from heft.systems.identification.excitation import (
    ExcitationSettings, FourierTrajectory, JointLimits, SensorFrameMotion, excitation_regressor,
    optimize_excitation, regressor_metrics, rest_basis)

GRAVITY_W = np.array([0.0, 0.0, -9.81])


def random_rest_trajectory(rng, n=6, harmonics=5, base_frequency=0.2, scale=0.3):
    x = rng.normal(scale=scale, size=(n, 2 * harmonics - 3))
    return FourierTrajectory.from_rest_coordinates(base_frequency, x, rng.uniform(-1, 1, n))


# --- FourierTrajectory ---------------------------------------------------------

def test_derivatives_match_central_differences_and_shapes():
    rng = np.random.default_rng(0)
    trajectory = random_rest_trajectory(rng)
    t, h = rng.uniform(0, 20, 50), 1e-5
    for order in (1, 2):
        numeric = (trajectory.derivative(t + h, order - 1) - trajectory.derivative(t - h, order - 1)) / (2 * h)
        exact = trajectory.derivative(t, order)
        assert np.abs(numeric - exact).max() < 1e-7 * max(1.0, np.abs(exact).max())
    assert trajectory.position(1.0).shape == (6,) and trajectory.acceleration(t).shape == (50, 6)
    # Eq. 9–10 literally, for one joint and one instant.
    k, w = np.arange(1, 6), 2 * np.pi * 0.2
    by_hand = trajectory.q0[2] + np.sum(trajectory.rho[2] * np.sin(k * w * 3.3)
                                        + trajectory.delta[2] * np.cos(k * w * 3.3))
    assert trajectory.position(3.3)[2] == pytest.approx(by_hand, abs=1e-12)


def test_rest_basis_spans_exactly_the_rest_constraints():
    for harmonics in (2, 3, 5, 8):
        B_rho, B_delta = rest_basis(harmonics)
        k = np.arange(1, harmonics + 1)
        assert B_rho.shape == (harmonics, harmonics - 1) and B_delta.shape == (harmonics, harmonics - 2)
        assert np.allclose(B_rho.T @ B_rho, np.eye(harmonics - 1))
        assert np.allclose(B_delta.T @ B_delta, np.eye(harmonics - 2))
        assert np.allclose(k @ B_rho, 0, atol=1e-12)
        assert np.allclose(np.vstack((np.ones(harmonics), k ** 2)) @ B_delta, 0, atol=1e-12)
    with pytest.raises(ValueError, match="2 harmonics"):
        rest_basis(1)


def test_starts_and_ends_at_rest_at_q0_and_is_periodic():
    rng = np.random.default_rng(1)
    trajectory = random_rest_trajectory(rng)
    for t in (0.0, trajectory.period, 3 * trajectory.period):
        assert np.abs(trajectory.position(t) - trajectory.q0).max() < 1e-12
        assert np.abs(trajectory.velocity(t)).max() < 1e-11
        assert np.abs(trajectory.acceleration(t)).max() < 1e-10
    t = rng.uniform(0, 5, 20)
    for order in (0, 1, 2):
        assert np.allclose(trajectory.derivative(t + 2 * trajectory.period, order), trajectory.derivative(t, order),
                           atol=1e-10)
    # Arbitrary coefficients (not from rest coordinates) are not at rest, and the residual says so.
    free = FourierTrajectory(0.2, rng.normal(size=(6, 5)), rng.normal(size=(6, 5)), np.zeros(6))
    assert free.rest_residual() > 0.1 and trajectory.rest_residual() < 1e-10


# --- the Drake trajectory --------------------------------------------------------

def test_drake_trajectory_matches_analytic_values_and_derivatives():
    rng = np.random.default_rng(2)
    trajectory = random_rest_trajectory(rng, base_frequency=0.5)
    duration, samples = 2 * trajectory.period, 401
    pp = trajectory.to_drake(duration, samples)
    knots = np.linspace(0, duration, samples)
    midpoints = knots[:-1] + np.diff(knots) / 2
    for order in (0, 1, 2):
        drake_knots = np.array([pp.EvalDerivative(t, order).ravel() for t in knots])
        drake_mid = np.array([pp.EvalDerivative(t, order).ravel() for t in midpoints])
        scale = max(1.0, np.abs(trajectory.derivative(knots, order)).max())
        assert np.abs(drake_knots - trajectory.derivative(knots, order)).max() < 1e-9 * scale
        assert np.abs(drake_mid - trajectory.derivative(midpoints, order)).max() < 1e-6 * scale
    # Held at rest at q0 after the end, as a TrajectorySource feeding slave.position_commanded sees it.
    source = TrajectorySource(pp)
    context = source.CreateDefaultContext()
    for t in (0.0, duration, duration + 5.0):
        context.SetTime(t)
        assert np.allclose(source.get_output_port().Eval(context), trajectory.q0, atol=1e-12)
    assert np.abs(pp.EvalDerivative(duration + 5.0, 1)).max() < 1e-10


def test_drake_trajectory_refuses_partial_periods_and_trajectories_not_at_rest():
    rng = np.random.default_rng(3)
    trajectory = random_rest_trajectory(rng, base_frequency=0.5)
    with pytest.raises(ValueError, match="whole number of periods"):
        trajectory.to_drake(1.5 * trajectory.period, 100)
    free = FourierTrajectory(0.5, rng.normal(size=(6, 5)), rng.normal(size=(6, 5)), np.zeros(6))
    with pytest.raises(ValueError, match="rest"):
        free.to_drake(free.period, 100)


# --- SensorFrameMotion against Drake ------------------------------------------------

@pytest.fixture(scope="module")
def slave():
    plant = MultibodyPlant(0.0)
    parts = AddSlave(plant, Scenario())
    plant.mutable_gravity_field().set_gravity_vector(GRAVITY_W)
    plant.Finalize()
    return plant, parts


def random_motion(rng):
    return rng.uniform(-1.5, 1.5, 6), rng.uniform(-2, 2, 6), rng.uniform(-5, 5, 6)


def vee(W):
    return np.array([W[2, 1], W[0, 2], W[1, 0]])


def test_sensor_frame_motion_matches_finite_differences_of_the_pose_of_S(slave):
    plant, parts = slave
    context = plant.CreateDefaultContext()
    motion = SensorFrameMotion(plant, plant.CreateDefaultContext(), parts.S)
    rng = np.random.default_rng(4)

    for _ in range(5):
        q, qd, qdd = random_motion(rng)

        def pose(t, q=q, qd=qd, qdd=qdd):
            plant.SetPositions(context, q + qd * t + 0.5 * qdd * t ** 2)
            X = parts.S.CalcPoseInWorld(context)
            return X.translation(), X.rotation().matrix()

        def omega_W(t, eps=1e-5):
            dR = (pose(t + eps)[1] - pose(t - eps)[1]) / (2 * eps)
            return vee(dR @ pose(t)[1].T)

        h = 1e-4
        a_W = (pose(h)[0] - 2 * pose(0)[0] + pose(-h)[0]) / h ** 2
        alpha_W = (omega_W(h) - omega_W(-h)) / (2 * h)
        R_SW = pose(0)[1].T
        a, alpha, omega, g = motion(q, qd, qdd)
        assert np.allclose(a, R_SW @ a_W, atol=1e-5 * max(1, np.abs(a).max()))
        assert np.allclose(alpha, R_SW @ alpha_W, atol=1e-5 * max(1, np.abs(alpha).max()))
        assert np.allclose(omega, R_SW @ omega_W(0), atol=1e-7)
        assert np.allclose(g, R_SW @ GRAVITY_W, atol=1e-12)


def test_sensor_frame_motion_matches_spatial_accelerations_from_vdot_batched(slave):
    plant, parts = slave
    context = plant.CreateDefaultContext()
    motion = SensorFrameMotion(plant, plant.CreateDefaultContext(), parts.S)
    rng = np.random.default_rng(5)
    samples = [random_motion(rng) for _ in range(8)]
    batch = motion(*(np.array(x) for x in zip(*samples)))
    B = parts.S.body()
    p_BS = parts.S.GetFixedPoseInBodyFrame().translation()
    for k, (q, qd, qdd) in enumerate(samples):
        plant.SetPositions(context, q)
        plant.SetVelocities(context, qd)
        A_WB: SpatialAcceleration = plant.CalcSpatialAccelerationsFromVdot(context, qdd)[B.index()]
        X_WB = plant.EvalBodyPoseInWorld(context, B)
        A_WS = A_WB.Shift(X_WB.rotation() @ p_BS, plant.EvalBodySpatialVelocityInWorld(context, B).rotational())
        R_SW = parts.S.CalcRotationMatrixInWorld(context).inverse().matrix()
        w_WS = parts.S.CalcSpatialVelocityInWorld(context).rotational()
        expected = (R_SW @ A_WS.translational(), R_SW @ A_WS.rotational(), R_SW @ w_WS, R_SW @ GRAVITY_W)
        for got, want in zip(batch, expected):
            assert np.allclose(got[k], want, rtol=0, atol=1e-10)
        single = motion(q, qd, qdd)
        assert all(np.array_equal(s, b[k]) for s, b in zip(single, batch))


def test_sensor_frame_motion_of_one_model_instance_in_a_larger_plant(slave):
    plant, parts = slave
    bigger = MultibodyPlant(0.0)
    other = bigger.AddModelInstance("slider")  # added first, so its DoF sits before the arm's
    body = bigger.AddRigidBody("block", other, SpatialInertia.SolidBoxWithMass(1.0, 0.1, 0.1, 0.1))
    bigger.AddJoint(PrismaticJoint("slide", bigger.world_frame(), body.body_frame(), [0, 0, 1]))
    big_parts = AddSlave(bigger, Scenario())
    bigger.mutable_gravity_field().set_gravity_vector(GRAVITY_W)
    bigger.Finalize()
    assert bigger.num_positions() == 7
    ours = SensorFrameMotion(bigger, bigger.CreateDefaultContext(), big_parts.S, big_parts.arm)
    reference = SensorFrameMotion(plant, plant.CreateDefaultContext(), parts.S)
    q, qd, qdd = random_motion(np.random.default_rng(6))
    for got, want in zip(ours(q, qd, qdd), reference(q, qd, qdd)):
        assert np.allclose(got, want, atol=1e-12)
    with pytest.raises(ValueError, match="must be"):
        ours(np.zeros(7), np.zeros(7), np.zeros(7))


# --- metrics, identifiability and the optimiser ---------------------------------------

def test_regressor_metrics_of_known_matrices():
    rng = np.random.default_rng(7)
    Q, _ = np.linalg.qr(rng.normal(size=(60, 16)))
    scales = np.geomspace(1e-3, 1e2, 16)
    metrics = regressor_metrics(Q * scales)   # orthogonal columns: column scaling makes it ideal
    assert metrics.condition_number == pytest.approx(1.0) and metrics.rank == 16
    assert metrics.min_singular_value == pytest.approx(1.0)
    assert metrics.log_det == pytest.approx(2 * np.log(scales).sum() - 16 * np.log(60))
    degenerate = regressor_metrics(np.hstack((Q[:, :15], Q[:, :1] * 3)))
    assert degenerate.rank == 15 and degenerate.condition_number == np.inf


@pytest.mark.parametrize("joint", [0, 5])
def test_moving_one_joint_leaves_the_regressor_rank_deficient(slave, joint):
    plant, parts = slave
    motion = SensorFrameMotion(plant, plant.CreateDefaultContext(), parts.S)
    x = np.zeros((6, 7))
    x[joint] = np.random.default_rng(8).normal(scale=0.5, size=7)
    trajectory = FourierTrajectory.from_rest_coordinates(0.2, x, Scenario().slave_initial_q)
    metrics = regressor_metrics(excitation_regressor(trajectory, motion, np.arange(60) * trajectory.period / 60))
    assert metrics.rank < 16 and metrics.condition_number == np.inf


@pytest.fixture(scope="module", params=["cond", "d_optimal"])
def optimised(slave, request):
    plant, parts = slave
    q0 = np.array(Scenario().slave_initial_q)
    limits = JointLimits.from_plant(plant, acceleration=10.0, velocity_fraction=0.5).within(q0, 0.5)
    motion = SensorFrameMotion(plant, plant.CreateDefaultContext(), parts.S)
    settings = ExcitationSettings.quick()
    settings.criterion = request.param
    result = optimize_excitation(motion, q0, limits, **dataclasses.asdict(settings))
    return result, q0, limits, motion


def test_optimised_excitation_respects_every_limit_on_a_fine_grid(optimised):
    result, q0, limits, _ = optimised
    trajectory = result.trajectory
    t = np.linspace(0, result.duration, 100_003)
    q, qd, qdd = (trajectory.derivative(t, order) for order in (0, 1, 2))
    assert np.all(q >= limits.lower) and np.all(q <= limits.upper)
    assert np.all(np.abs(qd) <= limits.velocity) and np.all(np.abs(qdd) <= limits.acceleration)
    assert result.margins.feasible() and 0.9 < result.repair_scale <= 1.0
    assert trajectory.rest_residual() < 1e-10 and np.allclose(trajectory.position(0.0), q0)
    # It uses the room it has: some limit is nearly reached.
    assert min(result.margins.position.min(), result.margins.velocity.min(), result.margins.acceleration.min()) < 0.05


def test_optimised_excitation_beats_the_random_start_and_identifies_all_16(optimised):
    result, _, _, motion = optimised
    before, after = result.initial_metrics, result.metrics
    if result.criterion == "cond":
        assert after.condition_number * 3 <= before.condition_number
    else:
        assert after.log_det > before.log_det + 10 and after.condition_number < before.condition_number
    assert after.rank == 16 and np.isfinite(after.log_det) and after.min_singular_value > before.min_singular_value
    # On a grid the optimiser never saw, over the whole duration.
    again = regressor_metrics(excitation_regressor(result.trajectory, motion,
                                                   np.linspace(0, result.duration, 173, endpoint=False)))
    assert again.rank == 16 and again.condition_number < 1.5 * after.condition_number


def test_optimizer_rejects_bad_requests(optimised):
    _, q0, limits, motion = optimised
    with pytest.raises(ValueError, match="criterion"):
        optimize_excitation(motion, q0, limits, criterion="a_optimal")
    with pytest.raises(ValueError, match="inside the position limits"):
        optimize_excitation(motion, limits.upper + 0.1, limits)
    with pytest.raises(ValueError, match="whole number of periods"):
        optimize_excitation(motion, q0, limits, base_frequency=0.1, duration=15.0)
