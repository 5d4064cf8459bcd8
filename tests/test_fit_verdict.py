"""The fit's verdict on constructed recordings: each cause found where it was built in, and only
there; the noise floor against a Monte Carlo of the sensors' noise through the regressor."""

import numpy as np
import pytest

from heft.analysis.fit_verdict import (MOUNT_SHARE, NEAR_FULL_SCALE, RESIDUAL_RATIO_LIMIT, OFF_COMMAND_LIMIT,
                                       FitEvidence,
                                       fit_verdict, noise_floor)
from heft.systems.accelerometer_reading import AccelerometerConvention, motion_from_reading, reading_from_motion
from heft.systems.load_dynamics import regressor

PERIOD = 0.0005  # s, the controller's 2 kHz
SAMPLES = 20000  # one 10 s excitation period
T = np.arange(SAMPLES) * PERIOD
FLOOR = np.array([0.2, 0.2, 0.2, 0.015, 0.015, 0.005])
FULL_SCALE = np.array([200.0, 200, 200, 12, 12, 12])
PHI = np.array([3.13, 0.0, 0.0, 0.199, 0.0306, 0.0, 0.0, 0.0323, 0.0, 0.0048])  # the paper's tool about S


def command(t=T) -> np.ndarray:
    """A 0.1 Hz Fourier excitation of six joints, 5 harmonics, over whole periods (rad)."""
    harmonics = np.arange(1, 6)
    amplitude = np.random.default_rng(1).uniform(-0.1, 0.1, (6, 5))
    return np.sin(2 * np.pi * 0.1 * np.multiply.outer(t, harmonics)) @ amplitude.T


def evidence(residual, **changes) -> FitEvidence:
    """A recording of the paper's tool whose fit left ``residual``: the wrench well inside the
    sensor's range, the arm following its command exactly, unless ``changes`` say otherwise."""
    wrench = 30.0 * np.sin(2 * np.pi * 0.3 * T)[:, None] * np.ones(6) * FULL_SCALE / 200
    fields = dict(residual=residual, noise_floor=FLOOR, sample_period=PERIOD, wrench=wrench,
                  wrench_full_scale=FULL_SCALE, acceleration=None, acceleration_full_scale=None, mass=3.13,
                  payload_max=12.0, robot="rx90", q_measured=command(), q_commanded=command())
    return FitEvidence(**{**fields, **changes})


def white(seed=0, scale=1.0) -> np.ndarray:
    return scale * FLOOR * np.random.default_rng(seed).normal(size=(SAMPLES, 6))


def test_noise_floor_is_the_sensors_noise_through_the_regressor():
    """Monte Carlo: wrench and accelerometer noise, the reading moved to S from a displaced
    accelerometer as identification does, the fit at the true φ."""
    rng = np.random.default_rng(2)
    n = 100_000
    a, alpha, omega = rng.normal(size=(n, 3)), 3 * rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    g = np.tile([0.0, 0.0, -9.81], (n, 1))
    wrench_rms, acceleration_rms = np.array([0.1, 0.1, 0.1, 0.005, 0.005, 0.005]), np.array([0.05] * 3 + [0.5] * 3)
    convention = AccelerometerConvention(True, (0.02, 0.01, -0.008))
    reading = reading_from_motion(np.hstack((a, alpha)), g, omega, convention)
    reading += acceleration_rms * rng.normal(size=(n, 6))
    moved = motion_from_reading(np.empty_like(reading), reading, g, omega, convention)
    wrench = regressor(a, alpha, omega, g) @ PHI + wrench_rms * rng.normal(size=(n, 6))
    residual = wrench - regressor(moved[:, :3], moved[:, 3:], omega, g) @ PHI
    expected = noise_floor(PHI, wrench_rms, acceleration_rms, convention.p_SA)
    np.testing.assert_allclose(np.sqrt(np.mean(residual ** 2, axis=0)), expected, rtol=0.01)
    # The displaced accelerometer's α noise adds to a's: at S it would be less on the force axes.
    assert (noise_floor(PHI, wrench_rms, acceleration_rms)[:3] < 0.99 * expected[:3]).all()
    np.testing.assert_allclose(noise_floor(PHI, wrench_rms, np.zeros(6)), wrench_rms)


def test_a_residual_at_the_noise_floor_is_ok():
    verdict = fit_verdict(evidence(white()))
    assert verdict["ok"] and verdict["causes"] == []
    np.testing.assert_allclose(verdict["residual_ratio"], 1.0, atol=0.02)
    assert verdict["saturated_samples"] == 0 and max(verdict["off_command_motion"]) < 1e-9


def test_rocking_on_the_mount_is_named_with_its_frequency():
    """Twice the noise on τ_y, the excess a 47 Hz ring-down repeated every second."""
    rocking = np.zeros((SAMPLES, 6))
    since = T % 1.0
    rocking[:, 4] = 0.15 * np.exp(-since / 0.15) * np.sin(2 * np.pi * 47.0 * since)
    verdict = fit_verdict(evidence(white() + rocking))
    assert not verdict["ok"] and verdict["causes"] == ["compliant_mount"]
    assert verdict["residual_ratio"][4] > RESIDUAL_RATIO_LIMIT
    assert verdict["mount_mode_hz"] == pytest.approx(47.0, abs=1.0) and verdict["mount_window_share"] > MOUNT_SHARE
    assert "47 Hz" in verdict["message"] and "mount" in verdict["message"]


def test_a_residual_that_moves_with_the_arm_is_unmodelled_dynamics():
    """A force the model lacks (a cable pulling on the load), at the excitation's frequencies."""
    pull = np.zeros((SAMPLES, 6))
    pull[:, 2] = 0.5 * np.sin(2 * np.pi * 0.2 * T)
    verdict = fit_verdict(evidence(white() + pull))
    assert not verdict["ok"] and verdict["causes"] == ["unmodelled_dynamics"]
    assert verdict["low_frequency_share"] > 0.95 and "fz" in verdict["message"]


def test_a_residual_another_method_does_not_leave_is_the_estimators():
    pull = np.zeros((SAMPLES, 6))
    pull[:, 4] = 0.03 * np.sin(2 * np.pi * 0.2 * T)
    verdict = fit_verdict(evidence(white() + pull, other_methods={"ols": 1.6, "tls": 1.06, "wls": 1.2}))
    assert verdict["causes"] == ["estimator"] and "--method tls" in verdict["message"]
    assert fit_verdict(evidence(white() + pull, other_methods={"ols": 1.6}))["causes"] == ["unmodelled_dynamics"]


def test_broadband_excess_is_not_blamed_on_the_mount():
    verdict = fit_verdict(evidence(white(scale=2.0)))
    assert verdict["causes"] == ["unmodelled_dynamics"] and verdict["mount_window_share"] < MOUNT_SHARE


def test_readings_at_full_scale_are_saturation():
    base = evidence(white())
    wrench = base.wrench.copy()
    wrench[:, 4] = 14.0 * np.sin(2 * np.pi * 0.3 * T)  # τ_y swings past the 12 N·m range
    clipped = np.abs(wrench[:, 4]) >= NEAR_FULL_SCALE * 12.0
    wrench[:, 4] = np.clip(wrench[:, 4], -12.0, 12.0)
    verdict = fit_verdict(evidence(white(), wrench=wrench))
    assert verdict["causes"] == ["saturation"] and verdict["saturated_axes"] == ["ty"]
    assert verdict["saturated_samples"] == clipped.sum() > 0
    assert verdict["peak_share_of_full_scale"]["wrench"][4] == 1.0
    accelerometer = np.zeros((SAMPLES, 6))
    accelerometer[::100, 0] = 99.0  # spikes at 99 of 100 m/s²
    verdict = fit_verdict(evidence(white(), acceleration=accelerometer,
                                   acceleration_full_scale=[100.0] * 3 + [1e3] * 3))
    assert verdict["causes"] == ["saturation"] and verdict["saturated_axes"] == ["ax"]
    assert verdict["saturated_samples"] == SAMPLES // 100


def test_a_load_beyond_the_arms_payload_is_refused():
    verdict = fit_verdict(evidence(white(), mass=12.5))
    assert verdict["causes"] == ["payload"] and "RX90" in verdict["message"] and "12 kg" in verdict["message"]


def test_a_lagging_servo_follows_but_a_joint_at_its_limit_does_not():
    lagged = command(T - 0.0165)  # a servo 16.5 ms behind, as the simulated arm's
    assert fit_verdict(evidence(white(), q_measured=0.98 * lagged))["ok"]
    held = lagged.copy()
    limit = 0.8 * np.abs(held[:, 5]).max()
    held[:, 5] = np.clip(held[:, 5], -limit, limit)  # joint 6 stalls at 80 % of its swing
    verdict = fit_verdict(evidence(white(), q_measured=held))
    assert verdict["causes"] == ["not_following"] and "joint 6" in verdict["message"]
    assert verdict["off_command_motion"][5] > OFF_COMMAND_LIMIT > max(verdict["off_command_motion"][:5])


def test_a_saturated_fit_names_every_cause_it_has():
    wrench = np.clip(evidence(white()).wrench * 20, -FULL_SCALE, FULL_SCALE)
    verdict = fit_verdict(evidence(white(scale=5.0), wrench=wrench, mass=13.0))
    assert verdict["causes"] == ["saturation", "payload"]  # the residual explained by them, not "unmodelled"
    assert verdict["residual_ratio"] == pytest.approx([5.0] * 6, abs=0.2)
    assert f"{max(verdict['residual_ratio']):.1f}× the sensor's noise" in verdict["message"]


def test_a_floor_without_noise_is_refused_with_what_to_state():
    with pytest.raises(ValueError, match="noise_rms"):
        fit_verdict(evidence(white(), noise_floor=np.zeros(6)))
