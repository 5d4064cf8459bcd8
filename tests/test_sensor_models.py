"""The simulated JR3: sample-and-hold, noise statistics, offsets and their drift,
quantisation, saturation, seeding, and the absence of direct feedthrough."""

import dataclasses

import numpy as np
import pytest
from pydrake.common.yaml import yaml_load_typed
from pydrake.systems.analysis import InitializeParams, Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import Adder, ConstantVectorSource, Gain, TrajectorySource
from pydrake.trajectories import PiecewisePolynomial
from scipy.signal import butter, lfilter, lfilter_zi

from heft.systems.station.sensor_models import (
    AccelerometerModel, AccelerometerParams, ForceTorqueSensorModel, ForceTorqueSensorParams, HeldLowpass,
    SixAxisMeasurement, drift_offsets, lowpass_coefficients, noise_key, quantize, standard_normals)

FT_FULL_SCALE = np.array(ForceTorqueSensorParams().full_scale)
ACCEL_FULL_SCALE = np.array(AccelerometerParams().full_scale)

# The true inputs are piecewise constant, changing every 0.125 ms at 0.0625 ms
# past the sample grid (multiples of 0.5 ms), so their value at each sample
# instant is unambiguous, and they change four times between 2 kHz samples.
INPUT_BREAKS = 0.0000625 + 0.000125 * np.arange(49_000)
INPUT_BREAKS[0] = 0.0
FAST_PERIOD = 0.0005
NUM_FAST_SAMPLES = 12_000  # 6 s at 2 kHz
IDEAL_PERIOD = 0.001
DRIFT = dict(drift_time_constant=0.5, sample_period=0.01,
             offset_random_walk=[0.2, 0.2, 0.2, 0.01, 0.01, 0.01])


def held_input(values, t):
    """The piecewise-constant input (6, N breaks) at times t (M,) → (M, 6)."""
    j = np.clip(np.searchsorted(INPUT_BREAKS, t, side="right") - 1, 0, len(INPUT_BREAKS) - 2)
    return values[:, j].T


@pytest.fixture(scope="module")
def recording():
    """One diagram, simulated once: 6 s of readings halfway between 2 kHz samples (the low-pass
    filter off: its own tests are below)."""
    rng = np.random.default_rng(11)
    wrench_values = rng.uniform(-0.5, 0.5, (6, len(INPUT_BREAKS))) * FT_FULL_SCALE[:, None]
    accel_values = rng.uniform(-0.5, 0.5, (6, len(INPUT_BREAKS))) * ACCEL_FULL_SCALE[:, None]
    builder = DiagramBuilder()
    wrench = builder.AddSystem(TrajectorySource(
        PiecewisePolynomial.ZeroOrderHold(INPUT_BREAKS, wrench_values)))
    accel = builder.AddSystem(TrajectorySource(
        PiecewisePolynomial.ZeroOrderHold(INPUT_BREAKS, accel_values)))
    sensors = {
        "ideal": ForceTorqueSensorModel(ForceTorqueSensorParams(noise=False, sample_period=IDEAL_PERIOD,
                                                                lowpass_cutoff=0.0)),
        "ft": ForceTorqueSensorModel(ForceTorqueSensorParams(lowpass_cutoff=0.0)),
        "accel": AccelerometerModel(AccelerometerParams(lowpass_cutoff=0.0)),
        "drifting": ForceTorqueSensorModel(ForceTorqueSensorParams(white_noise=False, lowpass_cutoff=0.0, **DRIFT)),
    }
    for name, sensor in sensors.items():
        builder.AddSystem(sensor)
        source = accel if name == "accel" else wrench
        builder.Connect(source.get_output_port(), sensor.get_input_port())
    diagram = builder.Build()
    simulator = Simulator(diagram)
    simulator.Initialize()
    root = simulator.get_context()
    contexts = {name: s.GetMyContextFromRoot(root) for name, s in sensors.items()}
    times = (np.arange(NUM_FAST_SAMPLES) + 0.5) * FAST_PERIOD
    log = {name: np.empty((3, NUM_FAST_SAMPLES, 6)) for name in sensors}
    for k, t in enumerate(times):
        simulator.AdvanceTo(t)
        for name, sensor in sensors.items():
            for port in range(3):
                log[name][port, k] = sensor.get_output_port(port).Eval(contexts[name])
    return dict(times=times, log=log, wrench=wrench_values, accel=accel_values)


# --- sample and hold ------------------------------------------------------------

def test_without_effects_the_output_is_the_input_at_the_last_sample_instant(recording):
    times, (measured, offsets, saturated) = recording["times"], recording["log"]["ideal"]
    last_sample = np.floor(times / IDEAL_PERIOD) * IDEAL_PERIOD
    np.testing.assert_array_equal(measured, held_input(recording["wrench"], last_sample))
    # Not the input now: it changed since the sample in most readings.
    assert np.mean(np.any(measured != held_input(recording["wrench"], times), axis=1)) > 0.9
    assert not offsets.any() and not saturated.any()


# --- noise statistics -------------------------------------------------------------

def noise_of(recording, name, values):
    """measured − true − offsets at each 2 kHz sample, with all effects on (defaults)."""
    measured, offsets, saturated = recording["log"][name]
    assert not saturated.any()
    sample_instants = np.floor(recording["times"] / FAST_PERIOD) * FAST_PERIOD
    return measured - held_input(values, sample_instants) - offsets


@pytest.mark.parametrize("name,values_key,rms", [
    ("ft", "wrench", ForceTorqueSensorParams().noise_rms),
    ("accel", "accel", AccelerometerParams().noise_rms)])
def test_noise_is_white_zero_mean_and_of_the_configured_rms(recording, name, values_key, rms):
    noise = noise_of(recording, name, recording[values_key])
    n = len(noise)
    assert n >= 10_000
    rms = np.array(rms)
    # Quantisation adds step²/12 to the variance: < 0.1 % of σ² with the defaults.
    np.testing.assert_allclose(np.sqrt(np.mean(noise**2, axis=0)), rms, rtol=0.03)
    assert np.all(np.abs(noise.mean(axis=0)) < 4 * rms / np.sqrt(n))
    chance = 4 / np.sqrt(n)
    correlation = np.corrcoef(noise.T)
    assert np.abs(correlation - np.eye(6)).max() < chance
    lag_one = [np.corrcoef(noise[1:, i], noise[:-1, i])[0, 1] for i in range(6)]
    assert np.abs(lag_one).max() < chance


def test_force_torque_and_accelerometer_noise_are_independent(recording):
    ft = noise_of(recording, "ft", recording["wrench"])
    accel = noise_of(recording, "accel", recording["accel"])
    cross = np.corrcoef(ft.T, accel.T)[:6, 6:]
    assert np.abs(cross).max() < 4 / np.sqrt(len(ft))


def test_standard_normals_statistics_over_a_million_draws():
    draws = standard_normals(noise_key(3, 0), np.arange(100_000), 12).reshape(-1, 6)
    n = len(draws)
    assert np.all(np.abs(draws.mean(axis=0)) < 4 / np.sqrt(n))
    np.testing.assert_allclose(draws.std(axis=0), 1.0, atol=4 / np.sqrt(2 * n))
    assert np.abs(np.corrcoef(draws.T) - np.eye(6)).max() < 4 / np.sqrt(n)
    # Gaussian tails: P(|z| > 3) = 0.0027.
    assert np.mean(np.abs(draws) > 3) == pytest.approx(0.0027, rel=0.1)
    # One sample's draws do not depend on how many samples are drawn with it.
    np.testing.assert_array_equal(standard_normals(noise_key(3, 0), 4321, 12),
                                  standard_normals(noise_key(3, 0), np.arange(100_000), 12)[4321])


# --- seeding and per-context state ----------------------------------------------

@pytest.fixture(scope="module")
def seeded():
    """FT sensors with seeds 7, 7 and 8, and an accelerometer with every setting of the
    first (seed 7 included), all on zero input."""
    builder = DiagramBuilder()
    zero = builder.AddSystem(ConstantVectorSource(np.zeros(6)))
    ft_settings = dataclasses.asdict(ForceTorqueSensorParams(seed=7))
    sensors = [ForceTorqueSensorModel(ForceTorqueSensorParams(**ft_settings)),
               ForceTorqueSensorModel(ForceTorqueSensorParams(seed=7)),
               ForceTorqueSensorModel(ForceTorqueSensorParams(seed=8)),
               AccelerometerModel(AccelerometerParams(**ft_settings))]
    for sensor in sensors:
        builder.AddSystem(sensor)
        builder.Connect(zero.get_output_port(), sensor.get_input_port())
    return builder.Build(), sensors


def run(diagram, sensors, context, num_samples, start=0):
    """Readings of every sensor's measurement halfway after samples start … start + num_samples − 1
    (start > 0 resumes a context, without a second initialization sample)."""
    simulator = Simulator(diagram, context)
    simulator.Initialize(InitializeParams(suppress_initialization_events=start > 0))
    readings = []
    for k in range(start, start + num_samples):
        simulator.AdvanceTo((k + 0.5) * FAST_PERIOD)
        readings.append([s.get_output_port(0).Eval(s.GetMyContextFromRoot(context)) for s in sensors])
    return np.array(readings)  # (samples, sensors, 6)


def test_same_seed_same_samples_different_seed_different_samples(seeded):
    diagram, sensors = seeded
    readings = run(diagram, sensors, diagram.CreateDefaultContext(), 200)
    np.testing.assert_array_equal(readings[:, 0], readings[:, 1])
    # Quantised draws of two independent streams coincide a few % of the time.
    assert np.mean(readings[:, 0] == readings[:, 2]) < 0.1
    # Same seed and settings, other instrument: another stream.
    assert np.mean(readings[:, 0] == readings[:, 3]) < 0.1
    # A fresh context replays the run.
    np.testing.assert_array_equal(run(diagram, sensors, diagram.CreateDefaultContext(), 200), readings)


def test_a_cloned_context_continues_on_its_own(seeded):
    diagram, sensors = seeded
    reference = run(diagram, sensors, diagram.CreateDefaultContext(), 120)
    context = diagram.CreateDefaultContext()
    run(diagram, sensors, context, 60)
    clone = context.Clone()
    clone_readings = run(diagram, sensors, clone, 60, start=60)
    np.testing.assert_array_equal(clone_readings, reference[60:])
    # Running the clone did not advance the original's noise.
    np.testing.assert_array_equal(run(diagram, sensors, context, 60, start=60), reference[60:])


# --- offsets and drift --------------------------------------------------------------

def test_offsets_follow_the_drift_model_and_are_in_the_measurement(recording):
    params = ForceTorqueSensorParams(**DRIFT)
    measured, offsets, saturated = recording["log"]["drifting"]
    period = params.sample_period
    step = FT_FULL_SCALE / params.counts_per_full_scale
    first = np.flatnonzero(np.diff(np.floor(recording["times"] / period), prepend=-1))
    t = np.round(recording["times"][first] / period) * period
    offsets, measured = offsets[first], measured[first]
    np.testing.assert_array_equal(offsets[0], params.initial_offsets)
    # Offsets = deterministic approach + random walk with steps N(0, q² T).
    walk = offsets - drift_offsets(t, params.initial_offsets, params.drifted_offsets,
                                   params.drift_time_constant)
    steps = np.diff(walk, axis=0) / (np.array(params.offset_random_walk) * np.sqrt(period))
    assert np.std(steps) == pytest.approx(1.0, rel=0.06)
    assert abs(np.mean(steps)) < 4 / np.sqrt(steps.size)
    # After 5 τ the deterministic part has closed 99 % of the gap.
    late = t >= 5 * params.drift_time_constant
    gap = np.abs(np.subtract(params.initial_offsets, params.drifted_offsets))
    assert np.all(np.abs(offsets[late] - walk[late] - params.drifted_offsets) <= 0.01 * gap)
    # Without white noise, measured − true = offsets within half a quantisation step.
    error = measured - held_input(recording["wrench"], t) - offsets
    assert np.all(np.abs(error) <= step / 2 + 1e-12) and not saturated.any()


def test_drift_offsets_closed_form():
    initial, drifted = np.array([1.0, 2, 3, 4, 5, 6]), np.array([2.0, 2, 2, 2, 2, 2])
    np.testing.assert_allclose(drift_offsets(0.0, initial, drifted, 60.0), initial)
    one_tau = drift_offsets(60.0, initial, drifted, 60.0)
    np.testing.assert_allclose(one_tau, drifted + (initial - drifted) / np.e)
    np.testing.assert_allclose(drift_offsets([0.0, 60.0], initial, drifted, 60.0), [initial, one_tau])


# --- quantisation and saturation ---------------------------------------------------------

def take_one_sample(sensor, true_value):
    """The outputs after the initialization sample of ``true_value``."""
    context = sensor.CreateDefaultContext()
    sensor.get_input_port().FixValue(context, true_value)
    Simulator(sensor, context).Initialize()
    return [sensor.get_output_port(i).Eval(context) for i in range(3)]


def test_quantisation_error_is_at_most_half_a_step_and_on_the_grid():
    rng = np.random.default_rng(5)
    step = FT_FULL_SCALE / 16384
    x = rng.uniform(-1, 1, (100_000, 6)) * FT_FULL_SCALE
    q = quantize(x, step)
    assert np.all(np.abs(q - x) <= step / 2 * (1 + 1e-12))
    np.testing.assert_allclose(q / step, np.round(q / step), rtol=0, atol=1e-6)
    sensor = ForceTorqueSensorModel(ForceTorqueSensorParams(
        white_noise=False, offsets=False, saturation=False))
    true_value = rng.uniform(-1, 1, 6) * FT_FULL_SCALE
    measured, _, _ = take_one_sample(sensor, true_value)
    assert np.all(np.abs(measured - true_value) <= step / 2)
    np.testing.assert_allclose(measured / step, np.round(measured / step), rtol=0, atol=1e-6)
    assert np.any(measured != true_value)


@pytest.mark.parametrize("axis,excess", [(2, 1.25), (4, -1.1)])
def test_a_value_beyond_range_is_clipped_and_flagged_on_that_axis_only(axis, excess):
    sensor = ForceTorqueSensorModel(ForceTorqueSensorParams(
        white_noise=False, offsets=False, quantization=False, lowpass_cutoff=0.0))
    true_value = 0.5 * FT_FULL_SCALE
    true_value[axis] = excess * FT_FULL_SCALE[axis]
    measured, _, saturated = take_one_sample(sensor, true_value)
    expected = true_value.copy()
    expected[axis] = np.sign(excess) * FT_FULL_SCALE[axis]
    np.testing.assert_array_equal(measured, expected)
    np.testing.assert_array_equal(saturated, np.eye(6)[axis])


# --- no direct feedthrough ------------------------------------------------------------

def test_a_loop_closed_through_the_sensor_builds_and_delays_by_one_sample():
    """u = c + g·y: with the sample-and-hold (filter off), y_n = c (1 − g^(n+1)) / (1 − g)."""
    for sensor in (ForceTorqueSensorModel(), AccelerometerModel()):
        assert not any(sensor.HasDirectFeedthrough(0, j) for j in range(3))
    c, g = np.arange(1.0, 7.0), 0.5
    builder = DiagramBuilder()
    sensor = builder.AddSystem(ForceTorqueSensorModel(ForceTorqueSensorParams(noise=False, lowpass_cutoff=0.0)))
    constant = builder.AddSystem(ConstantVectorSource(c))
    gain = builder.AddSystem(Gain(g, 6))
    adder = builder.AddSystem(Adder(2, 6))
    builder.Connect(constant.get_output_port(), adder.get_input_port(0))
    builder.Connect(sensor.get_output_port(0), gain.get_input_port())
    builder.Connect(gain.get_output_port(), adder.get_input_port(1))
    builder.Connect(adder.get_output_port(), sensor.get_input_port())
    diagram = builder.Build()
    simulator = Simulator(diagram)
    simulator.Initialize()
    n = 5
    simulator.AdvanceTo((n + 0.5) * FAST_PERIOD)
    y = sensor.get_output_port(0).Eval(sensor.GetMyContextFromRoot(simulator.get_context()))
    np.testing.assert_allclose(y, c * (1 - g ** (n + 1)) / (1 - g), rtol=1e-14)


# --- parameters -------------------------------------------------------------------------

@pytest.mark.parametrize("field,value", [
    ("noise_rms", [0.1, 0.1, -0.1, 0.005, 0.005, 0.005]),
    ("noise_rms", [0.1] * 5),
    ("full_scale", [200.0, 200.0, 0.0, 12.0, 12.0, 12.0]),
    ("initial_offsets", [0.0] * 7),
    ("drifted_offsets", [0.0, 0.0, float("nan"), 0.0, 0.0, 0.0]),
    ("offset_random_walk", [-1.0] * 6),
    ("sample_period", 0.0),
    ("sample_period", -0.001),
    ("drift_time_constant", 0.0),
    ("counts_per_full_scale", 0),
    ("seed", -1),
])
def test_invalid_parameters_are_rejected_naming_the_field(field, value):
    for params_type, model in ((ForceTorqueSensorParams, ForceTorqueSensorModel),
                               (AccelerometerParams, AccelerometerModel)):
        params = dataclasses.replace(params_type(), **{field: value})
        with pytest.raises(ValueError, match=f"^{field} "):
            model(params)


def test_parameters_load_from_yaml():
    params = yaml_load_typed(schema=ForceTorqueSensorParams, data="""
        noise: false
        sample_period: 0.000125
        noise_rms: [0.2, 0.2, 0.2, 0.01, 0.01, 0.01]
        seed: 42
    """)
    assert params == ForceTorqueSensorParams(noise=False, sample_period=0.000125,
                                             noise_rms=[0.2, 0.2, 0.2, 0.01, 0.01, 0.01], seed=42)
    params.validate()
    accel = yaml_load_typed(schema=AccelerometerParams, data="full_scale: [50, 50, 50, 500, 500, 500]")
    assert accel.full_scale == [50.0, 50.0, 50.0, 500.0, 500.0, 500.0]
    assert accel.noise_rms == [0.05, 0.05, 0.05, 0.5, 0.5, 0.5]


# --- the sensor's own low-pass filter -----------------------------------------------

def filtered_sine(frequency: float, cutoff: float, period: float = FAST_PERIOD, seconds: float = 0.2):
    """The model's output (noise off) for a unit sine of ``frequency`` (Hz) on every axis, at its
    samples, after a simulation of ``seconds``; and the input at those instants."""
    builder = DiagramBuilder()
    times = np.arange(0.0, seconds + period, period / 8)
    source = builder.AddSystem(TrajectorySource(PiecewisePolynomial.FirstOrderHold(
        times, np.tile(np.sin(2 * np.pi * frequency * times), (6, 1)))))
    sensor = builder.AddSystem(ForceTorqueSensorModel(ForceTorqueSensorParams(
        noise=False, sample_period=period, lowpass_cutoff=cutoff)))
    builder.Connect(source.get_output_port(), sensor.get_input_port())
    simulator = Simulator(builder.Build())
    context = sensor.GetMyContextFromRoot(simulator.get_context())
    samples = np.arange(int(seconds / period))
    out = np.empty(len(samples))
    for k in samples:
        simulator.AdvanceTo((k + 0.5) * period)
        out[k] = sensor.GetOutputPort("wrench_measured").Eval(context)[2]
    return out, np.sin(2 * np.pi * frequency * samples * period)


@pytest.mark.parametrize("ratio", [0.1, 1.0, 1.6])
def test_the_lowpass_has_the_butterworth_gain_and_phase(ratio):
    """Steady state of a sine through the filter: a second-order Butterworth, bilinear with the
    cut-off prewarped, has the analog filter's response at the prewarped frequency (closed form:
    |H| = 1/√(1 + x⁴), ∠H = −atan2(√2·x, 1 − x²), x = tan(πfT)/tan(πf_cT)); −3 dB and −90° at f_c."""
    cutoff, period = 200.0, FAST_PERIOD
    frequency = ratio * cutoff
    out, sine = filtered_sine(frequency, cutoff, period)
    x = np.tan(np.pi * frequency * period) / np.tan(np.pi * cutoff * period)
    expected_gain, expected_phase = 1 / np.sqrt(1 + x**4), -np.arctan2(np.sqrt(2) * x, 1 - x**2)
    k = np.arange(len(out))[len(out) // 2:]  # transient gone (time constant ≈ 1 ms)
    basis = np.column_stack((np.sin(2 * np.pi * frequency * k * period), np.cos(2 * np.pi * frequency * k * period)))
    (s, c), *_ = np.linalg.lstsq(basis, out[k], rcond=None)
    assert np.hypot(s, c) == pytest.approx(expected_gain, rel=1e-3)
    assert np.arctan2(c, s) == pytest.approx(expected_phase, abs=1e-3)
    if ratio == 1.0:
        assert np.hypot(s, c) == pytest.approx(np.sqrt(0.5), rel=1e-3)


def test_the_lowpass_starts_in_steady_state_and_can_be_turned_off():
    """A constant input is passed unchanged from the first sample (no start-up transient); with
    cut-off 0 a sine is sampled and held unfiltered."""
    sensor = ForceTorqueSensorModel(ForceTorqueSensorParams(noise=False, lowpass_cutoff=500.0))
    context = sensor.CreateDefaultContext()
    value = np.array([3.0, -2.0, 50.0, 0.1, -0.2, 0.3])
    sensor.get_input_port().FixValue(context, value)
    simulator = Simulator(sensor, context)
    for k in range(5):
        simulator.AdvanceTo((k + 0.5) * FAST_PERIOD)
        np.testing.assert_allclose(sensor.GetOutputPort("wrench_measured").Eval(context), value, rtol=1e-12)
    out, sine = filtered_sine(300.0, 0.0)
    np.testing.assert_allclose(out, sine, atol=1e-9)


@pytest.mark.parametrize("cutoff", [-1.0, 1000.0, float("nan")])
def test_a_lowpass_at_or_above_nyquist_is_refused(cutoff):
    with pytest.raises(ValueError, match="^lowpass_cutoff .*Nyquist"):
        ForceTorqueSensorModel(ForceTorqueSensorParams(lowpass_cutoff=cutoff))


def test_the_held_input_lowpass_is_scipys_filter_on_the_repeated_rows():
    """``HeldLowpass`` (the stand-in's) against ``scipy.signal.lfilter`` on each held value repeated
    ``count`` times, the state carried from one hold to the next: equal to round-off over 50 holds."""
    rng = np.random.default_rng(2)
    values = rng.normal(0.0, 50.0, (50, 6))
    b, a = butter(2, 500.0, fs=8000.0)
    expected, _ = lfilter(b, a, np.repeat(values, 4, axis=0), axis=0, zi=lfilter_zi(b, a)[:, None] * values[0])
    held = HeldLowpass(lowpass_coefficients(500.0, 1 / 8000.0), 4)
    state = lfilter_zi(b, a)[:, None] * values[0]
    got = np.concatenate([held(state, value) for value in values])
    assert np.abs(np.diff(expected, axis=0)).max() > 1.0  # the filter moved
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-10 * np.abs(expected).max())


def test_the_held_measurement_is_the_held_lowpass_disturbed_then_measured():
    """``HeldLowpass.measure`` (one kernel for the stand-in's sensor) equals its parts: the held outputs
    plus the disturbance, then ``SixAxisMeasurement.measure``, saturated axes among them."""
    rng = np.random.default_rng(3)
    params = ForceTorqueSensorParams()
    model = SixAxisMeasurement(params, 0, 1 / 8000.0)
    held = HeldLowpass(lowpass_coefficients(500.0, 1 / 8000.0), 4)
    state, parts_state = np.zeros((2, 6)), np.zeros((2, 6))
    out, saturated, flagged = np.empty((4, 6)), np.empty((4, 6)), []
    for _ in range(20):
        value = rng.normal(0.0, 1.2, 6) * np.array(params.full_scale)
        disturbance = rng.normal(0.0, 0.5, (4, 6))
        held.measure(model, state, value, disturbance, out, saturated)
        expected, expected_saturated = model.measure(held(parts_state, value) + disturbance)
        np.testing.assert_array_equal(out, expected)
        np.testing.assert_array_equal(saturated, expected_saturated)
        np.testing.assert_array_equal(state, parts_state)
        flagged.append(saturated.copy())
    assert 0 < np.mean(flagged) < 1
