"""The low-pass before the online estimator: Eq. 5 still holds between its outputs, the load's
rocking and the sensors' noise do not pass, and it starts and restarts without a transient."""

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import LogVectorOutput, TrajectorySource
from pydrake.trajectories import PiecewisePolynomial

from heft.systems.controller.estimator_prefilter import SIGNALS, EstimatorPrefilter
from heft.systems.load_dynamics import InertialParameters, regressor

PERIOD = 0.0005
CUTOFF = 10.0


def filtered(signals: dict, count: int):
    """Runs the prefilter on ``signals`` (name → (count, size) held over each tick): its outputs
    logged at every tick, as the estimator reads them."""
    builder = DiagramBuilder()
    prefilter = builder.AddSystem(EstimatorPrefilter(CUTOFF, PERIOD))
    breaks = np.arange(count + 1) * PERIOD - 0.5 * PERIOD
    breaks[0] = 0.0
    for name, _ in SIGNALS:
        values = signals[name]
        source = builder.AddSystem(TrajectorySource(PiecewisePolynomial.ZeroOrderHold(
            breaks, np.vstack((values, values[-1:])).T)))
        builder.Connect(source.get_output_port(), prefilter.GetInputPort(name))
    loggers = {name: LogVectorOutput(prefilter.GetOutputPort(name), builder, PERIOD) for name, _ in SIGNALS}
    diagram = builder.Build()
    simulator = Simulator(diagram)
    simulator.AdvanceTo((count - 1) * PERIOD)
    return {name: logger.FindLog(simulator.get_context()).data().T for name, logger in loggers.items()}


def motion(count: int, rocking: float = 0.0):
    """A smooth motion of S (2.5 Hz and 4 Hz swings, gravity turning), the wrench of a load on
    it by Eq. 5, and a 48 Hz rocking of ``rocking`` N added to the wrench alone."""
    t = np.arange(count) * PERIOD
    w1, w2 = 2 * np.pi * 2.5, 2 * np.pi * 4.0
    omega = np.column_stack((0.8 * np.sin(w1 * t), 0.5 * np.cos(w2 * t), 0.3 * np.sin(w2 * t + 1.0)))
    alpha = np.column_stack((0.8 * w1 * np.cos(w1 * t), -0.5 * w2 * np.sin(w2 * t), 0.3 * w2 * np.cos(w2 * t + 1.0)))
    a = np.column_stack((3 * np.sin(w1 * t), -2 * np.cos(w2 * t), 6 * np.sin(w1 * t + 0.5)))
    tilt = 0.3 * np.sin(w1 * t)
    g = 9.81 * np.column_stack((np.sin(tilt), np.zeros(count), -np.cos(tilt)))
    phi = InertialParameters(2.2, np.array([0.01, -0.005, 0.1]), np.diag([0.01, 0.012, 0.004])).to_phi()
    wrench = regressor(a, alpha, omega, g) @ phi
    wrench[:, 1] += rocking * np.sin(2 * np.pi * 48.0 * t)
    return {"wrench": wrench, "acceleration": np.hstack((a, alpha)), "omega": omega, "gravity": g}, phi


def test_eq_5_holds_between_the_filtered_signals_and_the_rocking_does_not_pass():
    """Filtered on both sides, W = V·φ still holds to 1 % of the wrench's swing (the ω terms are
    quadratic: exact only to second order), while a 2 N rocking at 48 Hz on the wrench comes
    through below 0.1 N (the Butterworth's −27 dB there)."""
    count = 4000
    signals, phi = motion(count, rocking=2.0)
    out = filtered(signals, count)
    settled = slice(1000, count)
    acceleration, omega, gravity = (out[name][settled] for name in ("acceleration", "omega", "gravity"))
    residual = out["wrench"][settled] - regressor(acceleration[:, :3], acceleration[:, 3:], omega, gravity) @ phi
    swing = np.ptp(signals["wrench"][settled], axis=0)
    assert np.all(np.abs(residual).max(axis=0)[[0, 2, 3, 4, 5]] < 0.01 * swing[[0, 2, 3, 4, 5]])
    assert np.abs(residual[:, 1]).max() < 0.1
    unfiltered = signals["wrench"][settled, 1] - (regressor(
        signals["acceleration"][:, :3], signals["acceleration"][:, 3:], signals["omega"], signals["gravity"]) @ phi)[
        settled, 1]
    assert np.abs(unfiltered).max() > 1.9  # the rocking was there


def test_it_starts_in_steady_state_and_restarts_after_a_bad_sample():
    count = 200
    signals = {name: np.tile(np.arange(1.0, size + 1.0), (count, 1)) for name, size in SIGNALS}
    signals["omega"][100] = np.nan
    out = filtered(signals, count)
    for name, size in SIGNALS:
        values = out[name]
        assert np.isnan(values[0]).all()  # nothing filtered before the first update
        assert np.isnan(values[101]).all()  # the tick after the bad sample: every output NaN
        for rows in (slice(1, 101), slice(102, count)):  # the constant, without a transient
            np.testing.assert_allclose(values[rows], np.tile(np.arange(1.0, size + 1.0), (len(values[rows]), 1)),
                                       rtol=1e-12)


def test_a_cut_off_outside_the_band_is_refused():
    for cutoff in (0.0, 1000.0, np.nan):
        with pytest.raises(ValueError, match="controller.estimator.prefilter.*set 0"):
            EstimatorPrefilter(cutoff, PERIOD)


def test_one_sample_step_is_scipys_filter_started_in_its_steady_state():
    """``prefilter_step``, the per-tick recursion the prefilter block runs,
    against scipy's ``lfilter`` started at ``lfilter_zi`` times the first sample; a NaN restarts it."""
    from scipy.signal import lfilter, lfilter_zi

    from heft.systems.controller.estimator_prefilter import STATE_SIZE, WIDTH, prefilter_coefficients, prefilter_step

    coefficients = prefilter_coefficients(CUTOFF, PERIOD)
    b, a = coefficients[:3], np.concatenate(([1.0], coefficients[3:]))
    samples = np.random.default_rng(5).normal(size=(300, WIDTH)) + np.linspace(0, 3, WIDTH)
    expected, _ = lfilter(b, a, samples, axis=0, zi=lfilter_zi(b, a)[:, None] * samples[0])
    state, out = np.full(STATE_SIZE, np.nan), []
    for sample in samples:
        prefilter_step(coefficients, state, sample)
        out.append(state[:WIDTH].copy())
    np.testing.assert_allclose(out, expected, rtol=0, atol=1e-12)
    prefilter_step(coefficients, state, np.full(WIDTH, np.nan))
    assert np.isnan(state).all()
    prefilter_step(coefficients, state, samples[7])
    np.testing.assert_allclose(state[:WIDTH], samples[7], rtol=0, atol=1e-12)
