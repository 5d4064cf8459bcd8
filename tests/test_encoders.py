"""The arm's encoders: quantised joint angles and the velocity estimate made from them."""

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import TrajectorySource
from pydrake.trajectories import PiecewisePolynomial

from heft.systems.station.encoders import AddEncoderVelocityEstimate, EncoderQuantizer, EncoderVelocityEstimator

PERIOD, CUTOFF = 0.0005, 100.0
STEP = 2 * np.pi / 2**20  # rad per count


def estimate(positions, times, samples):
    """The estimator's output after each of ``samples`` periods, on the quantised piecewise-linear
    ``positions`` (n, len(times)) through ``times``."""
    builder = DiagramBuilder()
    source = builder.AddSystem(TrajectorySource(PiecewisePolynomial.FirstOrderHold(times, positions)))
    encoders = builder.AddSystem(EncoderQuantizer(positions.shape[0], 2**20))
    builder.Connect(source.get_output_port(), encoders.get_input_port())
    builder.ExportOutput(AddEncoderVelocityEstimate(builder, encoders.get_output_port(), PERIOD, CUTOFF), "velocity")
    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = simulator.get_context()
    out = []
    for k in range(samples):
        simulator.AdvanceTo((k + 0.5) * PERIOD)
        out.append(diagram.GetOutputPort("velocity").Eval(context).copy())
    return np.array(out)


def test_a_constant_speed_is_found_with_the_first_order_lag():
    """A ramp from rest at sample 200: after n differences the estimate is v·(1 − e^(−2π·f_c·n·T))
    (closed form of the exact discretisation), to within two counts per period of quantisation."""
    speeds = np.array([0.5, -1.0, 2.0])
    start = 0.3 + np.zeros(3)
    positions = np.column_stack((start, start, start + speeds * 0.3))
    out = estimate(positions, np.array([0.0, 200 * PERIOD, 200 * PERIOD + 0.3]), 600)
    n = np.maximum(np.arange(600) - 200, 0)[:, None]
    expected = speeds * (1 - np.exp(-2 * np.pi * CUTOFF * n * PERIOD))
    assert np.abs(out - expected).max() < 2 * STEP / PERIOD


def test_at_rest_the_estimate_is_exactly_zero():
    out = estimate(np.full((6, 2), 0.123456), np.array([0.0, 1.0]), 50)
    np.testing.assert_array_equal(out, 0.0)


def test_bad_settings_are_refused():
    builder = DiagramBuilder()
    encoders = builder.AddSystem(EncoderQuantizer(6, 2**20))
    with pytest.raises(ValueError, match="cutoff_hz"):
        AddEncoderVelocityEstimate(builder, encoders.get_output_port(), PERIOD, 0.0)


def test_the_per_sample_estimator_is_the_diagram_on_the_same_encoder_readings():
    """``EncoderVelocityEstimator`` (the stand-in's) against Drake's DiscreteDerivative and LinearSystem
    of ``AddEncoderVelocityEstimate`` (the simulated station's) on the same motion: at rest for 10
    samples, then a non-smooth path through random knots; equal to round-off at every sample."""
    rng = np.random.default_rng(4)
    times = np.concatenate(([0.0], 10 * PERIOD + np.cumsum(rng.uniform(0.01, 0.03, 8))))
    positions = np.cumsum(rng.normal(0.0, 0.05, (3, len(times))), axis=1)
    positions[:, 1] = positions[:, 0]  # at rest until sample 10
    samples = 400
    expected = estimate(positions, times, samples)
    path = PiecewisePolynomial.FirstOrderHold(times, positions)
    estimator = EncoderVelocityEstimator(np.round(positions[:, 0] / STEP) * STEP, PERIOD, CUTOFF)
    got = np.array([estimator.update(np.round(path.value(k * PERIOD)[:, 0] / STEP) * STEP).copy()
                    for k in range(samples)])
    assert np.abs(expected).max() > 0.5  # it moved
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9 * np.abs(expected).max())
    with pytest.raises(ValueError, match="cutoff_hz"):
        EncoderVelocityEstimator(np.zeros(3), PERIOD, -1.0)
