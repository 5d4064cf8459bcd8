"""Static-pose calibration: the load's m, m·c and offsets, and an accelerometer's R_SA, bias and
scale, against closed forms (the six-position method) and noise-free statics written here from
Newton's law (the weight m·g acting at c), not from heft's regressor."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from heft.systems.accelerometer_calibration import (
    STANDARD_GRAVITY, AccelerometerCalibration, checked_rotation, fit_to_gravity, rotation_angle)
from heft.systems.load_dynamics import InertialParameters
from heft.systems.identification.static_calibration import calibrate_static, point_mass_phi, static_gravity

G = 9.81
MASS = 3.13
COM = np.array([0.004, -0.012, 0.063])
OFFSETS = np.array([2.0, -1.5, 3.0, 0.04, -0.03, 0.02])
R_SA = Rotation.from_rotvec([0.3, -0.5, 0.9]).as_matrix()   # not about one axis
BIAS_G = np.array([0.0, 0.08, 0.0])
SIX_POSITIONS = G * np.vstack((np.eye(3), -np.eye(3)))


def statics(gravity_S, mass=MASS, com=COM, offsets=OFFSETS):
    """The wrench the sensor exerts on a load at rest: it holds the weight m·g acting at c,
    f = −m·g, τ = −c × m·g (about S), plus the sensor's offsets."""
    weight = mass * np.asarray(gravity_S)
    return np.hstack((-weight, -np.cross(com, weight))) + offsets


def accelerometer_readings(gravity_S, R_SA=R_SA, bias=BIAS_G, scale=1.0):
    """An accelerometer in g at rest: specific force −g, in its own axes A, gain ``scale``, plus bias."""
    return scale * (-np.asarray(gravity_S) @ R_SA) / STANDARD_GRAVITY + bias


def random_gravity(count, seed=0):
    return G * Rotation.random(count, random_state=seed).apply([0.0, 0.0, -1.0])


def test_six_positions_match_the_closed_form():
    wrench = statics(SIX_POSITIONS)
    result = calibrate_static(wrench, SIX_POSITIONS)
    # closed form: gravity sums to zero over the six, so the offsets are the means, and opposite poses
    # differ by twice the weight (force) and by 2G·(m·c × e_i) (torque).
    np.testing.assert_allclose(result.offsets, wrench.mean(axis=0), atol=1e-9)
    mass = (wrench[5, 2] - wrench[2, 2]) / (2 * G)  # g = −G·e_z: f_z = +m·G
    torque_x_pose = (wrench[3, 3:] - wrench[0, 3:]) / (2 * G)    # = m·c × e_x = (0, m·c_z, −m·c_y)
    torque_y_pose = (wrench[4, 3:] - wrench[1, 3:]) / (2 * G)    # = m·c × e_y = (−m·c_z, 0, m·c_x)
    mass_com = np.array([torque_y_pose[2], -torque_x_pose[2], torque_x_pose[1]])
    assert result.mass == pytest.approx(mass, rel=1e-10)
    np.testing.assert_allclose(result.estimate.phi[1:4], mass_com, atol=1e-10)
    np.testing.assert_allclose(result.com, COM, atol=1e-10)
    assert not result.estimate.identifiable[10:].any(), "the inertia is reported unidentifiable"
    assert result.estimate.identifiable[:10].all()


def test_noise_free_random_poses_recover_everything():
    gravity = random_gravity(24)
    result = calibrate_static(statics(gravity), gravity, accelerometer_readings(gravity, scale=1.02), "g")
    assert result.mass == pytest.approx(MASS, rel=1e-10)
    np.testing.assert_allclose(result.com, COM, atol=1e-10)
    np.testing.assert_allclose(result.offsets, OFFSETS, atol=1e-9)
    calibration = result.accelerometer.calibration
    assert rotation_angle(calibration.R_SA, R_SA) < 1e-9
    np.testing.assert_allclose(calibration.bias, BIAS_G, atol=1e-12)
    assert calibration.scale == pytest.approx(1.02, rel=1e-12)
    assert result.accelerometer.residual_rms < 1e-12


def test_noisy_poses_stay_within_their_standard_deviation():
    rng = np.random.default_rng(3)
    gravity = random_gravity(24, seed=1)
    noise = np.repeat([0.02, 0.001], 3)  # an averaged wrench (N, N·m)
    result = calibrate_static(statics(gravity) + noise * rng.standard_normal((24, 6)), gravity)
    std = result.estimate.std
    truth = np.concatenate((OFFSETS, [MASS], MASS * COM))
    estimated = np.concatenate((result.offsets, result.estimate.phi[:4]))
    assert np.all(np.abs(estimated - truth) < 4 * std[:10])
    assert std[0] < 0.01 and std[6] < 0.002   # a force offset (N), the mass (kg)


def test_six_position_accelerometer_matches_its_closed_form():
    readings = accelerometer_readings(SIX_POSITIONS, scale=0.98)
    fit = fit_to_gravity(readings, SIX_POSITIONS, "g")
    # closed form: the bias is the mean; opposite poses differ by 2·scale·(column of R_SAᵀ) in g
    columns = (readings[3:] - readings[:3]).T / (2 * G / STANDARD_GRAVITY)  # column i: scale·R_SAᵀ e_i
    scale = np.cbrt(np.linalg.det(columns))
    np.testing.assert_allclose(fit.calibration.bias, readings.mean(axis=0), atol=1e-12)
    assert fit.calibration.scale == pytest.approx(scale, rel=1e-12)
    np.testing.assert_allclose(fit.calibration.R_SA, (columns / scale).T, atol=1e-12)


def test_calibration_round_trips_and_converts_units():
    calibration = AccelerometerCalibration(R_SA=R_SA, bias=BIAS_G, scale=1.01, unit="g")
    specific_force = np.array([[0.3, -2.0, 9.81], [1.0, 2.0, 3.0]])
    reading = calibration.reading_of(specific_force)
    np.testing.assert_allclose(calibration.to_sensor_axes(reading), specific_force, atol=1e-12)
    np.testing.assert_allclose(calibration.to_sensor_axes(reading[0]), specific_force[0], atol=1e-12)
    # at rest, gravity pointing along −z of S, an accelerometer with S's axes reads +1 g (over scale) on z
    level = AccelerometerCalibration(unit="g").reading_of([0.0, 0.0, STANDARD_GRAVITY])
    np.testing.assert_allclose(level, [0.0, 0.0, 1.0], atol=1e-15)


def test_point_mass_phi_is_a_physical_body_at_the_com():
    body = InertialParameters.from_phi(point_mass_phi(MASS, COM))
    assert body.mass == pytest.approx(MASS)
    np.testing.assert_allclose(body.com, COM, atol=1e-15)
    np.testing.assert_allclose(body.inertia_com, np.zeros((3, 3)), atol=1e-15)


def test_gravity_from_orientation():
    R_WS = Rotation.random(5, random_state=2).as_matrix()
    gravity = static_gravity(R_WS, [0.0, 0.0, -G])
    np.testing.assert_allclose(gravity, np.array([R.T @ [0.0, 0.0, -G] for R in R_WS]), atol=1e-12)


def test_too_few_poses_are_refused():
    gravity = random_gravity(2)
    with pytest.raises(ValueError, match="at least 3 poses"):
        calibrate_static(statics(gravity), gravity)
    with pytest.raises(ValueError, match="at least 3 poses"):
        fit_to_gravity(accelerometer_readings(gravity), gravity, "g")


def test_poses_turned_about_gravity_only_are_refused():
    # the sensor turned about the vertical, its z axis vertical: gravity is the same in S
    gravity = np.tile([0.0, 0.0, -G], (8, 1))
    with pytest.raises(ValueError, match="m, m\\*cx.*cannot be told apart.*tilted about two axes"):
        calibrate_static(statics(gravity), gravity)


def test_gravity_along_one_line_leaves_the_accelerometer_undetermined():
    gravity = G * np.array([[0, 0, -1], [0, 0, 1], [0, 0, -1], [0, 0, 1.0]])
    with pytest.raises(ValueError, match="along one line.*another axis"):
        fit_to_gravity(accelerometer_readings(gravity), gravity, "g")


def test_mirrored_wrench_sign_is_refused():
    gravity = random_gravity(6)
    with pytest.raises(ValueError, match="mass .* not positive.*exerted_on"):
        calibrate_static(-statics(gravity, offsets=np.zeros(6)), gravity)


@pytest.mark.parametrize("matrix, words", [
    (np.diag([1.0, 1.0, -1.0]), "not a rotation"),
    (np.eye(3) * 1.01, "not a rotation"),
    (np.eye(2), "3×3"),
])
def test_a_matrix_that_is_not_a_rotation_is_refused(matrix, words):
    with pytest.raises(ValueError, match=words):
        checked_rotation("R_SA", matrix)


def test_a_rotation_typed_with_four_decimals_is_taken():
    typed = np.round(R_SA, 4)
    assert rotation_angle(checked_rotation("R_SA", typed), R_SA) < 1e-3


def test_unknown_unit_is_refused():
    with pytest.raises(ValueError, match="unit must be one of m/s\\^2, g; got 'mg'"):
        AccelerometerCalibration(unit="mg")
