"""The accelerometer convention: what a sensor hanging still reports, and the load's weight
found from that reading once, even when the controller's idea of gravity in S is off."""

import dataclasses

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from pydrake.multibody.math import SpatialAcceleration

from heft.systems.accelerometer_reading import AccelerometerConvention, motion_from_reading, reading_from_motion
from heft.systems.load_dynamics import regressor

G_W = np.array([0.0, 0.0, -9.81])
MASS, COM = 3.13, np.array([0.01, -0.02, 0.12])  # kg, m in S
PHI = np.concatenate(([MASS], MASS * COM, [0.05, 0.001, -0.002, 0.06, 0.003, 0.02]))


def test_hanging_still_the_reading_points_up_with_one_g():
    R_WS = Rotation.from_rotvec([0.4, -1.1, 0.3]).as_matrix()
    reading = reading_from_motion(np.zeros(6), R_WS.T @ G_W)
    np.testing.assert_allclose(R_WS @ reading[:3], [0.0, 0.0, 9.81], atol=1e-12)
    gravity_free = AccelerometerConvention(includes_gravity=False)
    np.testing.assert_array_equal(reading_from_motion(np.zeros(6), R_WS.T @ G_W, convention=gravity_free), 0.0)


@pytest.mark.parametrize("includes_gravity", [True, False])
def test_the_weight_is_found_once_whatever_error_gravity_in_S_has(includes_gravity):
    """At rest the sensor carries the weight: f = −m·g_S, τ = c × f (closed form). The
    controller's g_S comes from kinematics that are 3° off; with a specific-force reading
    that error cancels, with a gravity-free one it cannot be avoided and stays small."""
    R_WS = Rotation.from_rotvec([0.2, 2.5, -0.4]).as_matrix()
    g_true = R_WS.T @ G_W
    g_believed = Rotation.from_rotvec([0.0, np.radians(3.0), 0.0]).as_matrix() @ g_true
    convention = AccelerometerConvention(includes_gravity)
    reading = reading_from_motion(np.zeros(6), g_true, np.zeros(3), convention)
    acceleration = motion_from_reading(np.empty(6), reading, g_believed, np.zeros(3), convention)
    wrench = regressor(acceleration[:3], acceleration[3:], np.zeros(3), g_believed) @ PHI
    f = -MASS * g_true
    expected = np.concatenate((f, np.cross(COM, f)))
    error = np.abs(wrench - expected).max()
    if includes_gravity:
        assert error < 1e-12
    else:
        assert 0.1 < error < MASS * 9.81 * np.radians(3.0) * 1.01


def test_batches_convert_row_by_row():
    rng = np.random.default_rng(0)
    motion, gravity = rng.normal(size=(5, 6)), rng.normal(size=(5, 3))
    reading = reading_from_motion(motion, gravity)
    np.testing.assert_allclose(reading[:, :3], motion[:, :3] - gravity)
    np.testing.assert_array_equal(reading[:, 3:], motion[:, 3:])
    np.testing.assert_allclose(motion_from_reading(np.empty((5, 6)), reading, gravity), motion, atol=1e-15)


P_SA = (0.02, 0.01, -0.008)


def test_a_displaced_accelerometer_reads_the_motion_of_its_own_point():
    """The reading of an accelerometer at p_SA is Drake's spatial acceleration of S shifted to
    that point (``SpatialAcceleration.Shift``, an independent reference), less gravity; the
    conversion moves it back to S exactly, sample by sample and in batches."""
    rng = np.random.default_rng(3)
    convention = AccelerometerConvention(True, P_SA)
    rows = []
    for _ in range(4):
        a, alpha, omega, g = rng.normal(size=3) * 5, rng.normal(size=3) * 20, rng.normal(size=3) * 3, \
            rng.normal(size=3)
        shifted = SpatialAcceleration(alpha, a).Shift(np.array(P_SA), omega)
        reading = reading_from_motion(np.concatenate((a, alpha)), g, omega, convention)
        np.testing.assert_allclose(reading[:3], shifted.translational() - g, atol=1e-12)
        np.testing.assert_array_equal(reading[3:], alpha)
        np.testing.assert_allclose(motion_from_reading(np.empty(6), reading, g, omega, convention),
                                   np.concatenate((a, alpha)), atol=1e-12)
        rows.append((np.concatenate((a, alpha)), g, omega, reading))
    motion, g, omega, reading = (np.array(column) for column in zip(*rows))
    np.testing.assert_allclose(reading_from_motion(motion, g, omega, convention), reading, atol=1e-12)
    np.testing.assert_allclose(motion_from_reading(np.empty_like(reading), reading, g, omega, convention), motion,
                               atol=1e-12)


def test_an_accelerometer_position_must_be_three_finite_numbers():
    with pytest.raises(ValueError, match="p_SA"):
        AccelerometerConvention(True, (0.0, np.nan, 0.0))
    with pytest.raises(ValueError, match="p_SA"):
        AccelerometerConvention(True, (0.0, 0.0))


def test_a_displaced_accelerometer_without_omega_is_refused():
    with pytest.raises(ValueError, match="only with ω"):
        motion_from_reading(np.empty(6), np.zeros(6), np.zeros(3), None, AccelerometerConvention(True, P_SA))


MOUNTED = AccelerometerConvention(True, (0.02, 0.01, -0.008), Rotation.from_rotvec([0.5, -0.9, 1.7]).as_matrix(),
                                  "g", (0.01, -0.08, 0.03), 1.02, (0.3, -0.2, 0.25))
"""An IMU rotated against S about no single axis, reporting in g with a bias and a 2 % gain error, its
angular channels with a bias of their own (rad/s²)."""


def test_a_mounted_accelerometer_reports_what_its_calibration_model_says():
    """The reading in A's axes and unit is r = scale·R_SAᵀ·s/u + bias of the specific force s at A in S
    (the model, written out here), and α turned into A's axes plus the angular channels' bias; converted
    back it is S's motion again,
    one sample (the compiled kernel) and a batch (numpy) alike."""
    rng = np.random.default_rng(8)
    motion, gravity, omega = rng.normal(0, 3, (50, 6)), rng.normal(0, 5, (50, 3)), rng.normal(0, 2, (50, 3))
    at_S = reading_from_motion(motion, gravity, omega, AccelerometerConvention(True, MOUNTED.p_SA))  # S's axes, m/s²
    reading = reading_from_motion(motion, gravity, omega, MOUNTED)
    R_AS = np.array(MOUNTED.R_SA).T
    expected = np.array([MOUNTED.scale * R_AS @ s / 9.80665 + MOUNTED.bias for s in at_S[:, :3]])
    np.testing.assert_allclose(reading[:, :3], expected, rtol=0, atol=1e-12)
    np.testing.assert_allclose(reading[:, 3:], at_S[:, 3:] @ np.array(MOUNTED.R_SA) + MOUNTED.angular_bias, rtol=0,
                               atol=1e-12)
    assert np.abs(reading[:, :3] - at_S[:, :3]).max() > 1.0  # not S's axes
    np.testing.assert_allclose(motion_from_reading(np.empty((50, 6)), reading, gravity, omega, MOUNTED), motion,
                               rtol=0, atol=1e-12)
    for k in range(50):
        np.testing.assert_allclose(motion_from_reading(np.empty(6), reading[k], gravity[k], omega[k], MOUNTED),
                                   motion[k], rtol=0, atol=1e-12)


@pytest.mark.parametrize("convention", [AccelerometerConvention(), AccelerometerConvention(False),
                                        AccelerometerConvention(True, P_SA), MOUNTED,
                                        dataclasses.replace(MOUNTED, includes_gravity=False, p_SA=(0.0, 0.0, 0.0))],
                         ids=["at S", "gravity-free", "displaced", "mounted", "mounted at S, gravity-free"])
def test_one_sample_reads_as_its_row_of_a_batch(convention):
    """One sample goes through the compiled kernel (``reading_from_motion_into``), a batch through numpy: they
    agree, row by row, and the kernel's reading converts back to the motion."""
    rng = np.random.default_rng(9)
    motion, gravity, omega = rng.normal(0, 3, (20, 6)), rng.normal(0, 5, (20, 3)), rng.normal(0, 2, (20, 3))
    batch = reading_from_motion(motion, gravity, omega, convention)
    for k in range(20):
        one = reading_from_motion(motion[k], gravity[k], omega[k], convention)
        np.testing.assert_allclose(one, batch[k], rtol=0, atol=1e-12)
        np.testing.assert_allclose(motion_from_reading(np.empty(6), one, gravity[k], omega[k], convention), motion[k],
                                   rtol=0, atol=1e-12)


def test_a_mounting_that_is_not_one_is_refused():
    with pytest.raises(ValueError, match="R_SA is not a rotation"):
        AccelerometerConvention(R_SA=np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(ValueError, match="unit must be one of"):
        AccelerometerConvention(unit="G")
    with pytest.raises(ValueError, match="bias needs 3 finite numbers"):
        AccelerometerConvention(bias=(0.0, np.nan, 0.0))
    with pytest.raises(ValueError, match="scale must be finite and > 0"):
        AccelerometerConvention(scale=0.0)
    with pytest.raises(ValueError, match="angular_bias needs 3 finite numbers"):
        AccelerometerConvention(angular_bias=(0.0, 0.0, np.inf))
