"""Eqs. 1–14 against Drake's dynamics, Newton–Euler by hand, and invariances."""

import numpy as np
import pytest
from pydrake.multibody.math import SpatialForce
from pydrake.multibody.plant import ExternallyAppliedSpatialForce

from heft.diagrams.stations.load_on_sensor import LoadOnSensorPlant, simulate_random_motion
from heft.systems.drake_conventions import spatial_force_from_wrench, wrench_from_spatial_force
from heft.systems.controller.force_scaling import scale_wrench
from heft.systems.load_dynamics import (
    InertialParameters, inertia_entries, inertia_matrix, noncontact_wrench, regressor, regressor_with_offsets)


def random_rotation(rng):
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q))


# --- Drake as the reference ---------------------------------------------------

def test_regressor_matches_drake_weld_reaction_for_random_loads_and_states():
    rng = np.random.default_rng(1)
    worst = 0.0
    for _ in range(40):
        load = InertialParameters.random(rng)
        reference = LoadOnSensorPlant(load, gravity_W=rng.normal(size=3) * 6)
        for _ in range(5):
            q, v, vdot = reference.random_state(rng, scale=rng.uniform(0.1, 10))
            expected = reference.reaction_wrench(q, v, vdot)
            got = regressor(*reference.motion_in_S(q, v, vdot)) @ load.to_phi()
            worst = max(worst, np.abs(got - expected).max() / max(1.0, np.abs(expected).max()))
    assert worst < 1e-9


def test_batched_regressor_matches_drake_along_simulated_motion():
    rng = np.random.default_rng(2)
    load = InertialParameters.random(rng)
    t, wrench, a, alpha, omega, g = simulate_random_motion(load, rng, duration=0.3)
    assert np.abs(omega).max() > 0.5 and np.abs(alpha).max() > 1.0  # it really moved
    V = regressor(a, alpha, omega, g)
    assert V.shape == (len(t), 6, 10)
    np.testing.assert_allclose(V @ load.to_phi(), wrench, atol=1e-9 * np.abs(wrench).max())
    # the batch V·φ, evaluated without forming V, against Drake too
    np.testing.assert_allclose(noncontact_wrench(load.to_phi(), a, alpha, omega, g), wrench,
                               atol=1e-9 * np.abs(wrench).max())
    np.testing.assert_allclose(noncontact_wrench(load.to_phi(), a, alpha, omega, g[0]),
                               regressor(a, alpha, omega, g[0]) @ load.to_phi(), atol=1e-12)


def test_contact_wrench_recovers_an_external_force_applied_in_drake():
    """A force from the environment on the load (at the tool tip) is what Eq. 13 leaves:
    in our convention the contact wrench is minus the environment's wrench, shifted to S."""
    rng = np.random.default_rng(3)
    load = InertialParameters.random(rng)
    reference = LoadOnSensorPlant(load)
    plant = reference.plant
    context = plant.CreateDefaultContext()
    q, v, _ = reference.random_state(rng)
    plant.SetPositions(context, q)
    plant.SetVelocities(context, v)
    p_tip_S = np.array([0.02, -0.01, 0.25])
    F_env_W = SpatialForce(tau=rng.normal(size=3), f=rng.normal(size=3) * 20)
    push = ExternallyAppliedSpatialForce()
    push.body_index, push.p_BoBq_B, push.F_Bq_W = reference.load_body.index(), p_tip_S, F_env_W
    plant.get_applied_spatial_force_input_port().FixValue(context, [push])
    plant.get_applied_generalized_force_input_port().FixValue(context, np.zeros(6))
    vdot = plant.get_generalized_acceleration_output_port().Eval(context)
    sensor_wrench = wrench_from_spatial_force(
        plant.get_reaction_forces_output_port().Eval(context)[int(reference.weld.index())])
    a, alpha, omega, g = reference.motion_in_S(q, v, vdot)
    offsets = rng.normal(size=6)
    _, recovered, _ = scale_wrench(sensor_wrench + offsets, offsets, load.to_phi(), np.concatenate((a, alpha)), omega,
                                   g, sigma=0.0, gamma=1.0, eta=1.0)  # Eq. 13's contact wrench
    R_SW = plant.EvalBodyPoseInWorld(context, reference.sensor).rotation().inverse()
    F_env_S_at_S = F_env_W.Rotate(R_SW).Shift(-p_tip_S)
    np.testing.assert_allclose(recovered, -wrench_from_spatial_force(F_env_S_at_S), atol=1e-9)


def test_drake_spatial_force_conversion_round_trip():
    wrench = np.arange(1.0, 7.0)
    F = spatial_force_from_wrench(wrench)
    np.testing.assert_array_equal(F.translational(), [1, 2, 3])
    np.testing.assert_array_equal(F.rotational(), [4, 5, 6])
    np.testing.assert_array_equal(wrench_from_spatial_force(F), wrench)


# --- Newton–Euler by hand -----------------------------------------------------

def test_static_load_in_gravity():
    """At rest the sensor holds the weight: f = −m g, τ = c × (−m g)."""
    m, c, g = 2.0, np.array([0.1, 0.0, 0.2]), np.array([0.0, 0.0, -9.81])
    load = InertialParameters(m, c, np.diag([0.01, 0.02, 0.015]))
    zero = np.zeros(3)
    wrench = noncontact_wrench(load.to_phi(), zero, zero, zero, g)
    np.testing.assert_allclose(wrench[:3], [0, 0, m * 9.81])
    np.testing.assert_allclose(wrench[3:], np.cross(c, -m * g))  # = [0, −0.1·19.62, 0]
    assert wrench[4] == pytest.approx(-0.1 * m * 9.81)


def test_spin_about_a_principal_axis():
    """COM on the spin axis: no force, τ = J α about that axis, no gyroscopic torque."""
    load = InertialParameters(1.5, [0, 0, 0.1], np.diag([0.02, 0.03, 0.01]))
    zero = np.zeros(3)
    omega, alpha = np.array([0, 0, 7.0]), np.array([0, 0, 3.0])
    wrench = noncontact_wrench(load.to_phi(), zero, alpha, omega, zero)
    np.testing.assert_allclose(wrench, [0, 0, 0, 0, 0, 0.01 * 3.0], atol=1e-14)


def test_centripetal_force_of_an_offset_com():
    m, r, w = 3.0, 0.2, 5.0
    load = InertialParameters(m, [r, 0, 0], np.eye(3) * 1e-3)
    zero = np.zeros(3)
    wrench = noncontact_wrench(load.to_phi(), zero, zero, [0, 0, w], zero)
    np.testing.assert_allclose(wrench[:3], [-m * w * w * r, 0, 0])
    np.testing.assert_allclose(wrench[3:], 0, atol=1e-15)


def test_linear_acceleration_without_rotation():
    load = InertialParameters(2.0, [0, 0.1, 0], np.eye(3) * 1e-3)
    zero = np.zeros(3)
    a = np.array([4.0, 0, 0])
    wrench = noncontact_wrench(load.to_phi(), a, zero, zero, zero)
    np.testing.assert_allclose(wrench, [8, 0, 0, 0, 0, -0.1 * 8])


def test_frame_change_invariance():
    """Describing the same motion and body in another sensor frame S' gives the same
    physical wrench, transformed to S' (with the moment shifted to its origin)."""
    rng = np.random.default_rng(4)
    for _ in range(20):
        load = InertialParameters.random(rng)
        a, alpha, omega, g = (rng.normal(size=3) * 3 for _ in range(4))
        R, p = random_rotation(rng), rng.normal(size=3) * 0.1  # S' expressed in S: R_SS', p_SS'
        wrench_S = noncontact_wrench(load.to_phi(), a, alpha, omega, g)
        a_origin = a + np.cross(alpha, p) + np.cross(omega, np.cross(omega, p))
        load_prime = load.expressed_in(R.T, -R.T @ p)
        wrench_prime = noncontact_wrench(load_prime.to_phi(), R.T @ a_origin, R.T @ alpha, R.T @ omega, R.T @ g)
        f_S = wrench_S[:3]
        np.testing.assert_allclose(wrench_prime[:3], R.T @ f_S, atol=1e-10)
        np.testing.assert_allclose(wrench_prime[3:], R.T @ (wrench_S[3:] - np.cross(p, f_S)), atol=1e-10)


# --- conversions and algebra --------------------------------------------------

def test_conversions_round_trip():
    rng = np.random.default_rng(5)
    for _ in range(50):
        load = InertialParameters.random(rng)
        back = InertialParameters.from_phi(load.to_phi())
        np.testing.assert_allclose(back.com, load.com, atol=1e-14)
        np.testing.assert_allclose(back.inertia_com, load.inertia_com, atol=1e-14)
        again = InertialParameters.from_inertia_about_origin(load.mass, load.com, load.inertia_origin)
        np.testing.assert_allclose(again.inertia_com, load.inertia_com, atol=1e-14)
        R, p = random_rotation(rng), rng.normal(size=3)
        there_and_back = load.expressed_in(R, p).expressed_in(R.T, -R.T @ p)
        np.testing.assert_allclose(there_and_back.to_phi(), load.to_phi(), atol=1e-12)
        entries = rng.normal(size=6)
        np.testing.assert_array_equal(inertia_entries(inertia_matrix(entries)), entries)


def test_parallel_axis_theorem_for_a_point_mass():
    point = InertialParameters(2.0, [0, 0, 0.5], np.zeros((3, 3)))
    np.testing.assert_allclose(point.inertia_origin, np.diag([0.5, 0.5, 0.0]))
    assert point.to_phi()[9] == 0.0 and point.to_phi()[4] == pytest.approx(0.5)


def test_sum_and_difference_of_bodies():
    """Two point masses compose to their known composite; subtracting gives one back."""
    rng = np.random.default_rng(6)
    a = InertialParameters(1.0, [0.1, 0, 0], np.zeros((3, 3)))
    b = InertialParameters(3.0, [-0.1, 0, 0], np.zeros((3, 3)))
    both = a + b
    assert both.mass == 4.0
    np.testing.assert_allclose(both.com, [-0.05, 0, 0])
    # about the composite COM at x = −0.05: 1·0.15² + 3·0.05² = 0.03 about y and z
    np.testing.assert_allclose(both.inertia_com, np.diag([0, 0.03, 0.03]), atol=1e-15)
    gripper, obj = InertialParameters.random(rng), InertialParameters.random(rng)
    np.testing.assert_allclose(((gripper + obj) - gripper).to_phi(), obj.to_phi(), atol=1e-12)


def test_extended_regressor_adds_offsets_first():
    rng = np.random.default_rng(8)
    a, alpha, omega, g = (rng.normal(size=(4, 3)) for _ in range(4))
    phi, offsets = rng.normal(size=10), rng.normal(size=6)
    V_ext = regressor_with_offsets(a, alpha, omega, g)
    assert V_ext.shape == (4, 6, 16)
    np.testing.assert_allclose(V_ext @ np.concatenate((offsets, phi)),
                               regressor(a, alpha, omega, g) @ phi + offsets)
    assert regressor_with_offsets(a[0], alpha[0], omega[0], g[0]).shape == (6, 16)


def test_single_sample_path_equals_batch_path():
    rng = np.random.default_rng(9)
    a, alpha, omega, g = (rng.normal(size=(30, 3)) for _ in range(4))
    batch = regressor(a, alpha, omega, g)
    for k in range(30):
        np.testing.assert_allclose(regressor(a[k], alpha[k], omega[k], g[k]), batch[k], atol=1e-13)
    # a single gravity vector broadcasts against a batch
    np.testing.assert_allclose(regressor(a, alpha, omega, g[0]), regressor(a, alpha, omega, np.tile(g[0], (30, 1))))


# --- physical consistency -----------------------------------------------------

def test_physical_check_names_what_is_violated():
    good = InertialParameters(1.0, [0, 0, 0.1], np.diag([0.01, 0.01, 0.015]))
    assert good.is_physical() and good.require_physical() is good
    assert any("mass" in v for v in InertialParameters(-1.0, [0, 0, 0], np.eye(3)).violations())
    assert any("positive definite" in v for v in
               InertialParameters(1.0, [0, 0, 0], np.diag([0.01, -0.01, 0.01])).violations())
    rod_too_thin = InertialParameters(1.0, [0, 0, 0], np.diag([0.01, 0.01, 0.03]))
    problems = rod_too_thin.violations()
    assert problems and all("triangle" in p for p in problems)
    with pytest.raises(ValueError, match="triangle inequality J1 \\+ J2 >= J3"):
        rod_too_thin.require_physical("gripper")
    assert all(InertialParameters.random(np.random.default_rng(s)).is_physical() for s in range(100))


# --- bad input ----------------------------------------------------------------

@pytest.mark.parametrize("bad_index,name", [(0, "a"), (1, "alpha"), (2, "omega"), (3, "g")])
def test_nan_input_names_the_argument(bad_index, name):
    args = [np.zeros(3) for _ in range(4)]
    args[bad_index] = np.array([0.0, np.nan, 0.0])
    with pytest.raises(ValueError, match=f"^{name} contains NaN"):
        regressor(*args)
    batch = [np.zeros((5, 3)) for _ in range(4)]
    batch[bad_index][3, 2] = np.inf
    with pytest.raises(ValueError, match=f"^{name} contains NaN"):
        regressor(*batch)


def test_wrong_shapes_are_rejected_with_the_argument_name():
    z = np.zeros(3)
    with pytest.raises(ValueError, match="^omega must have shape"):
        regressor(z, z, np.zeros(4), z)
    with pytest.raises(ValueError, match="different sample counts"):
        regressor(np.zeros((4, 3)), np.zeros((5, 3)), z, z)
    with pytest.raises(ValueError, match="^phi must have shape"):
        noncontact_wrench(np.zeros(9), z, z, z, z)
    with pytest.raises(ValueError, match="^a contains NaN"):
        noncontact_wrench(np.zeros(10), [np.nan] * 3, z, z, z)
    with pytest.raises(ValueError, match="mass"):
        InertialParameters.from_phi(np.zeros(10))
    with pytest.raises(ValueError, match="symmetric"):
        InertialParameters(1.0, z, [[1, 2, 0], [0, 1, 0], [0, 0, 1]])
    with pytest.raises(ValueError, match="rotation"):
        InertialParameters(1.0, z, np.eye(3)).expressed_in(2 * np.eye(3), z)


def test_swap_halves_puts_drakes_spatial_order_into_heft_order_and_back():
    """Drake's SpatialAcceleration [α; a] → heft's [a; α]; Jacobian rows likewise (axis 0)."""
    from pydrake.multibody.math import SpatialAcceleration

    from heft.systems.drake_conventions import swap_halves

    A = SpatialAcceleration(alpha=[1.0, 2.0, 3.0], a=[4.0, 5.0, 6.0])
    np.testing.assert_array_equal(swap_halves(A.get_coeffs()), [4, 5, 6, 1, 2, 3])
    J = np.arange(36.0).reshape(6, 6)
    np.testing.assert_array_equal(swap_halves(swap_halves(J, axis=0), axis=0), J)
    np.testing.assert_array_equal(swap_halves(J, axis=0)[:3], J[3:])
