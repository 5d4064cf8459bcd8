"""The simulated JR3 85M35A3-I40-D 200N12: a six-axis force-torque sensor with a
built-in six-axis accelerometer, as a sampled, noisy, offset, saturating and
quantising instrument.

Measurement model, per axis, at the sample instants t_k (period T):

    y_k = Q(sat(L(u)_k + o_k + n_k)),   held constant until t_{k+1}

* u, the true value on the input port;
* L, the JR3 DSP's low-pass filter (``lowpass_cutoff``; the DSP offers cascaded
  filters whose cut-offs fall by 4 from 1/16 of its sample rate, 500 Hz at 8 kHz):
  a second-order Butterworth, discretised by the bilinear transform at T with the
  cut-off prewarped, starting in steady state on the first sample. Not a
  disturbance, so ``noise`` False leaves it on; the noise figures are the
  filtered output's;
* o_k, the offset: o_k = o_d + (o_0 − o_d)·exp(−t_k/τ) + w_k, a first-order
  approach from the initial offset o_0 to the drifted offset o_d with a time
  constant τ of minutes (warm-up of the gauges and electronics), plus a random
  walk w_k = w_{k−1} + q·√T·ν_k, w_0 = 0 (slow temperature wander);
* n_k, white Gaussian noise of RMS σ, independent across axes and samples;
* sat, clipping to ±full scale with a per-axis flag (JR3: an axis is saturated
  when it reaches or exceeds its limit);
* Q, rounding to the step full_scale / counts_per_full_scale (the JR3 DSP scales
  its decoupled data so that ±16384 counts are ±full scale).

Noise is reproducible and lives in the Context. Each draw is SplitMix64
(Steele, Lea & Flood, OOPSLA 2014) evaluated at a position given by the seed,
the instrument and the sample index, paired into normals by Box–Muller; the
only generator state is the sample index, kept in the discrete state. So a
cloned Context continues the same stream on its own, a fresh Context replays
it, and the seed comes from the parameters. Drake's RandomSource was the
alternative, but in pydrake 1.51 its seed can only be drawn from
`SetRandomContext` on the whole diagram (`set_fixed_seed` is not bound), not
set per sensor.

Port conventions (docs/design.md §4): the wrench is [f; τ] that the sensor exerts on
the load, at S, expressed in S; the accelerometer's input is its ideal reading
(``accelerometer_reading``: [a − g; α] of its point A, in S's axes). The sign flip of
real sensors belongs to the hardware interface.
"""

import math

import numpy as np
from pydrake.systems.framework import LeafSystem
from scipy.signal import butter, lfilter_zi

from heft.systems.compiled import compiled, float_array
from heft.systems.station.sensor_params import (NUM_AXES, AccelerometerParams, ForceTorqueSensorParams,
                                                SixAxisSensorParams)

FORCE_TORQUE_STREAM = 0
"""Noise streams (``noise_key``) of the force-torque sensor and of the accelerometer."""
ACCELEROMETER_STREAM = 1
# Samples of noise drawn at once (each sample's draws depend on its index only).
_NOISE_BLOCK = 256

# SplitMix64's increment and finaliser constants.
_GOLDEN_GAMMA = np.uint64(0x9E3779B97F4A7C15)
_MIX_1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX_2 = np.uint64(0x94D049BB133111EB)


# --- pure helpers -------------------------------------------------------------

def quantize(value, step) -> np.ndarray:
    """``value`` rounded to the nearest multiple of ``step`` (per axis, step > 0)."""
    step = np.asarray(step, dtype=float)
    return step * np.rint(np.asarray(value, dtype=float) / step)


@compiled("void(float64[:, :], float64[:], float64[:], float64[:, :], float64[:, :])")
def measure_rows(values, full_scale, step, out, saturated) -> None:
    """Q(sat(v)) of each disturbed value v in ``values`` (m, 6) into ``out``, and into ``saturated``
    1.0 on each axis that reached or passed its limit ±``full_scale`` (inf: no limit), else 0.0;
    Q rounds to the nearest multiple of ``step`` (0: no rounding), as ``quantize``."""
    for j in range(values.shape[0]):
        for k in range(values.shape[1]):
            v, limit = values[j, k], full_scale[k]
            saturated[j, k] = 1.0 if abs(v) >= limit else 0.0
            v = min(max(v, -limit), limit)
            out[j, k] = step[k] * np.round(v / step[k]) if step[k] > 0.0 else v


def drift_offsets(t, initial_offsets, drifted_offsets, time_constant: float) -> np.ndarray:
    """The deterministic part of the offsets at time ``t`` (s, scalar → (6,), (N,) →
    (N, 6)): o_d + (o_0 − o_d)·exp(−t/τ) (``_disturbance_rows`` without the walk)."""
    times = float_array(np.atleast_1d(t))
    offsets, zeros = np.empty((len(times), NUM_AXES)), np.zeros(NUM_AXES)
    no_draws = np.zeros((len(times), 2 * NUM_AXES))
    _disturbance_rows(times, no_draws, zeros, False, True, True, float_array(initial_offsets),
                      float_array(drifted_offsets), time_constant, zeros, False, zeros, offsets, offsets)
    return offsets if np.ndim(t) else offsets[0]


@compiled("void(float64[:], float64[:, :], float64[:], boolean, boolean, boolean, float64[:], float64[:], float64, "
          "float64[:], boolean, float64[:], float64[:, :], float64[:, :])")
def _disturbance_rows(t, normals, walk, advance_walk, drift_on, offsets_on, initial, drifted, time_constant,
                      walk_step_rms, white_noise_on, white_noise_rms, offsets, disturbed) -> None:
    """``SixAxisMeasurement.disturbance`` of the samples at times ``t`` into ``offsets`` and ``disturbed``
    (N, 6), ``walk`` (6) advanced in place: o = o_d + (o_0 − o_d)·exp(−t/τ) + w (w ← w + q·√T·ν at each
    sample) with drift, the initial offsets without it, zero without offsets; plus σ·n with white noise."""
    for j in range(t.shape[0]):
        decay = math.exp(-t[j] / time_constant) if drift_on else 0.0
        for k in range(walk.shape[0]):
            if drift_on:
                if advance_walk:
                    walk[k] += walk_step_rms[k] * normals[j, NUM_AXES + k]
                offset = drifted[k] + (initial[k] - drifted[k]) * decay + walk[k]
            else:
                offset = initial[k] if offsets_on else 0.0
            offsets[j, k] = offset
            disturbed[j, k] = offset + white_noise_rms[k] * normals[j, k] if white_noise_on else offset


def lowpass_coefficients(cutoff: float, period: float) -> np.ndarray | None:
    """(b0, b1, b2, a1, a2) of the second-order Butterworth low-pass of ``cutoff`` (Hz) at sample
    ``period`` (s) by the prewarped bilinear transform (a0 = 1), or None for cutoff 0."""
    if cutoff == 0:
        return None
    b, a = butter(2, cutoff, fs=1.0 / period)
    return np.concatenate((b, a[1:]))


def start_lowpass(coefficients: np.ndarray, state: np.ndarray, value: np.ndarray) -> None:
    """Starts a filter not started (its ``state`` (2, n) NaN) in the steady state of ``value`` (n,);
    leaves a started one alone."""
    if math.isnan(state[0, 0]):
        state[:] = lfilter_zi(coefficients[:3], np.concatenate(([1.0], coefficients[3:])))[:, np.newaxis] * value


def lowpass(coefficients: np.ndarray, state: np.ndarray, values: np.ndarray) -> np.ndarray:
    """The filter (transposed direct form II, ``scipy.signal.lfilter``) on ``values`` (count, n),
    one sample a row, each column alone: returns the outputs and advances ``state`` (2, n) in
    place. A NaN state (a filter not started) starts in the steady state of the first row."""
    start_lowpass(coefficients, state, values[0])
    out = np.empty(np.shape(values))
    _lowpass_rows(coefficients, state, float_array(values), out)
    return out


@compiled("void(float64[:], float64[:, :], float64[:, :], float64[:, :])")
def _lowpass_rows(coefficients, state, values, out) -> None:
    """``lowpass`` of a started filter: y = b0·x + z1, z1 ← b1·x − a1·y + z2, z2 ← b2·x − a2·y."""
    b0, b1, b2, a1, a2 = coefficients[0], coefficients[1], coefficients[2], coefficients[3], coefficients[4]
    for k in range(values.shape[1]):
        z1, z2 = state[0, k], state[1, k]
        for j in range(values.shape[0]):
            x = values[j, k]
            y = b0 * x + z1
            z1 = b1 * x - a1 * y + z2
            z2 = b2 * x - a2 * y
            out[j, k] = y
        state[0, k], state[1, k] = z1, z2


@compiled("void(float64[:], float64[:, :], float64[:], boolean, boolean, boolean, float64[:], float64[:], float64, "
          "float64[:], boolean, float64[:], boolean, float64[:], float64[:, :], float64[:, :], float64[:], float64[:], "
          "float64[:, :], float64[:, :], float64[:, :])")
def _sample_into(t, normals, walk, advance_walk, drift_on, offsets_on, initial, drifted, time_constant, walk_step_rms,
                 white_noise_on, white_noise_rms, filtered, coefficients, lowpass_state, value, full_scale, step,
                 offsets, measured, saturated) -> None:
    """``SixAxisMeasurement.sample_into``: the disturbance into ``offsets`` and ``measured``, plus the value
    (low-passed if ``filtered``; ``saturated`` holds it meanwhile), then ``measure_rows`` in place."""
    _disturbance_rows(t, normals, walk, advance_walk, drift_on, offsets_on, initial, drifted, time_constant,
                      walk_step_rms, white_noise_on, white_noise_rms, offsets, measured)
    if filtered:
        _lowpass_rows(coefficients, lowpass_state, value, saturated)
    else:
        saturated[:, :] = value
    for j in range(measured.shape[0]):
        for k in range(measured.shape[1]):
            measured[j, k] += saturated[j, k]
    measure_rows(measured, full_scale, step, measured, saturated)


_NO_DRAWS, _NO_LOWPASS = np.zeros((1, 2 * NUM_AXES)), np.zeros(5)  # stand-ins where a model draws none, filters not
WALK, NEXT_INDEX, LAST_TIME, LOWPASS = slice(0, NUM_AXES), NUM_AXES, NUM_AXES + 1, slice(NUM_AXES + 2, 3 * NUM_AXES + 2)
"""A sampled sensor's memory: the random walk of its offsets (6), the next sample's index, the last sample's time
(s) and its low-pass filter's state (2 × 6)."""


class HeldLowpass:
    """``lowpass`` of an input held constant over ``count`` samples in closed form (the filter's
    state space, z' = A·z + B·u, y = C·z + D·u, with the transposed direct form II state of
    ``lfilter``): y_j = C·Aʲ·z + (D + C·Σ_{i<j} Aⁱ·B)·u. Equal to ``lowpass`` on ``count`` repeated
    rows to round-off, for a driver that holds its input between its own steps (a few µs instead of
    ``lfilter``'s tens)."""

    def __init__(self, coefficients: np.ndarray, count: int):
        b0, b1, b2, a1, a2 = coefficients
        A, B = np.array([[-a1, 1.0], [-a2, 0.0]]), np.array([b1 - a1 * b0, b2 - a2 * b0])
        self.count = count
        self._free = np.empty((count, 2))  # rows C·Aʲ
        self._forced = np.empty(count)  # D + C·Σ_{i<j} Aⁱ·B
        power, accumulated = np.eye(2), np.zeros(2)
        for j in range(count):
            self._free[j], self._forced[j] = power[0], b0 + accumulated[0]
            accumulated, power = accumulated + power @ B, A @ power
        self._advance, self._input = power, accumulated

    def __call__(self, state: np.ndarray, value: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """The ``count`` outputs (count, n) for ``value`` (n,) held, into ``out`` if given; advances
        ``state`` (2, n, started: not NaN) in place."""
        out = np.empty((self.count, len(value))) if out is None else out
        _held_lowpass(self._free, self._forced, self._advance, self._input, state, value, out)
        return out

    def measure(self, model: "SixAxisMeasurement", state: np.ndarray, value: np.ndarray, disturbance: np.ndarray,
                out: np.ndarray, saturated: np.ndarray) -> None:
        """``model``'s measurement (count, 6) of ``value`` (6,) held: these outputs plus each sample's
        ``disturbance`` (count, 6: offsets and noise), then ``SixAxisMeasurement.measure``, into ``out`` and
        ``saturated``; advances ``state`` (2, 6, started) in place (``_measure_held``)."""
        _measure_held(self._free, self._forced, self._advance, self._input, state, value, disturbance,
                      model.limits, model.steps, out, saturated)


@compiled("void(float64[:, :], float64[:], float64[:, :], float64[:], float64[:, :], float64[:], float64[:, :])")
def _held_lowpass(free, forced, advance, gain, state, value, out) -> None:
    """``HeldLowpass.__call__``: out_j = free_j·z + forced_j·u, then z ← advance·z + gain·u, per column."""
    for k in range(value.shape[0]):
        z0, z1, u = state[0, k], state[1, k], value[k]
        for j in range(out.shape[0]):
            out[j, k] = free[j, 0] * z0 + free[j, 1] * z1 + forced[j] * u
        state[0, k] = advance[0, 0] * z0 + advance[0, 1] * z1 + gain[0] * u
        state[1, k] = advance[1, 0] * z0 + advance[1, 1] * z1 + gain[1] * u


@compiled("void(float64[:, :], float64[:], float64[:, :], float64[:], float64[:, :], float64[:], float64[:, :], "
          "float64[:], float64[:], float64[:, :], float64[:, :])")
def _measure_held(free, forced, advance, gain, state, value, disturbance, full_scale, step, out, saturated) -> None:
    """``HeldLowpass.measure``: ``_held_lowpass`` into ``out``, plus ``disturbance``, then ``measure_rows`` in
    place."""
    _held_lowpass(free, forced, advance, gain, state, value, out)
    for j in range(out.shape[0]):
        for k in range(out.shape[1]):
            out[j, k] += disturbance[j, k]
    measure_rows(out, full_scale, step, out, saturated)


def _mix64(z: np.ndarray) -> np.ndarray:
    """SplitMix64's finaliser, a bijection of uint64 arrays."""
    z = (z ^ (z >> np.uint64(30))) * _MIX_1
    z = (z ^ (z >> np.uint64(27))) * _MIX_2
    return z ^ (z >> np.uint64(31))


def noise_key(seed: int, stream: int) -> np.uint64:
    """The 64-bit key of the noise stream ``stream`` under ``seed``."""
    mixed_seed = _mix64(np.array([seed], dtype=np.uint64))
    return _mix64(mixed_seed ^ np.array([stream], dtype=np.uint64))[0]


def standard_normals(key: np.uint64, sample_index, size: int) -> np.ndarray:
    """The ``size`` (even) standard normal draws of sample ``sample_index`` (int → (size,),
    int array (N,) → (N, size)): SplitMix64 of stream ``key`` at positions
    sample_index·size + 1 … (sample_index + 1)·size, paired by Box–Muller."""
    lanes = np.arange(1, size + 1, dtype=np.uint64)
    positions = np.asarray(sample_index, dtype=np.uint64)[..., np.newaxis] * np.uint64(size) + lanes
    bits = _mix64(key + positions * _GOLDEN_GAMMA)
    uniform = (bits >> np.uint64(11)).astype(float) * 2.0**-53  # [0, 1)
    half = size // 2
    radius = np.sqrt(-2.0 * np.log1p(-uniform[..., :half]))
    angle = 2.0 * np.pi * uniform[..., half:]
    return np.concatenate((radius * np.cos(angle), radius * np.sin(angle)), axis=-1)


class SixAxisMeasurement:
    """The measurement model of the module docstring for one instrument, sampled every
    ``period`` s, but for the low-pass filter L (``lowpass``, which the sampled systems below
    and the stand-in lab apply at their own rates): the settings ``params`` implies and the
    arithmetic on them."""

    def __init__(self, params: SixAxisSensorParams, stream: int, period: float):
        params.validate()
        effects = params.noise
        self.white_noise_rms = (np.array(params.noise_rms, dtype=float)
                                if effects and params.white_noise else None)
        self.offsets_on = effects and params.offsets
        self.drift_on = self.offsets_on and params.drift
        self.initial_offsets = np.array(params.initial_offsets, dtype=float)
        self.drifted_offsets = np.array(params.drifted_offsets, dtype=float)
        self.drift_time_constant = params.drift_time_constant
        self.walk_step_rms = np.array(params.offset_random_walk, dtype=float) * math.sqrt(period)
        self.full_scale = np.array(params.full_scale, dtype=float) if effects and params.saturation else None
        self.step = (np.array(params.full_scale, dtype=float) / params.counts_per_full_scale
                     if effects and params.quantization else None)
        self.draws_noise = self.white_noise_rms is not None or self.drift_on
        self.limits = np.full(NUM_AXES, np.inf) if self.full_scale is None else self.full_scale
        """The clipping limits ±(6) that ``measure_rows`` takes: ``full_scale``, or inf without saturation."""
        self.steps = np.zeros(NUM_AXES) if self.step is None else self.step
        """The rounding steps (6) that ``measure_rows`` takes: ``step``, or 0 without quantisation."""
        self.key = noise_key(params.seed, stream)
        self._disturbance_settings = (
            self.drift_on, self.offsets_on, self.initial_offsets, self.drifted_offsets, self.drift_time_constant,
            self.walk_step_rms, self.white_noise_rms is not None,
            np.zeros(NUM_AXES) if self.white_noise_rms is None else self.white_noise_rms)
        """The model as ``_disturbance_rows`` takes it, after its draws and walk."""

    def normals(self, sample_index) -> np.ndarray | None:
        """The 12 standard normal draws of each sample (white noise, then walk steps), or
        None if the model draws none; ``sample_index`` as ``standard_normals``."""
        return standard_normals(self.key, sample_index, 2 * NUM_AXES) if self.draws_noise else None

    def disturbance(self, t, normals, walk, advance_walk: bool = True):
        """(offsets o_k, o_k + n_k, the walk w after the last sample) for the samples at
        times ``t`` (N,) (s) with their draws ``normals`` (N, 12) or None; ``walk`` (6) is
        w before the first, advanced at each sample unless ``advance_walk`` is False."""
        t = float_array(np.atleast_1d(t))
        count = len(t)
        offsets, disturbed, walk = np.empty((count, NUM_AXES)), np.empty((count, NUM_AXES)), np.array(walk, dtype=float)
        _disturbance_rows(t, np.zeros((count, 2 * NUM_AXES)) if normals is None else float_array(normals), walk,
                          advance_walk, *self._disturbance_settings, offsets, disturbed)
        return offsets, disturbed, walk

    def sample_arguments(self, lowpass_coefficients: np.ndarray | None) -> tuple[tuple, tuple]:
        """``sample_into``'s ``settings`` for this model and the low-pass ``lowpass_coefficients`` (None: no filter):
        (those of ``_sample_into`` after the draws, the walk and whether it advances; those after the filter's state
        and the value), bound once by a sensor that samples often."""
        filtered = lowpass_coefficients is not None
        return ((*self._disturbance_settings, filtered, lowpass_coefficients if filtered else _NO_LOWPASS),
                (self.limits, self.steps))

    def sample_into(self, time: np.ndarray, normals: np.ndarray | None, walk: np.ndarray, advance_walk: bool,
                    settings: tuple[tuple, tuple], lowpass_state: np.ndarray, value: np.ndarray,
                    offsets: np.ndarray, measured: np.ndarray, saturated: np.ndarray) -> None:
        """One sample at ``time`` (1,) (s) with its draws ``normals`` (1, 12) or None: ``disturbance``
        into ``offsets``, ``walk`` advanced in place, then the measurement of ``value`` (1, 6) low-passed
        (``settings``: ``sample_arguments`` of the filter's coefficients; its ``lowpass_state`` (2, 6) started)
        into ``measured`` and ``saturated`` (1, 6 each)."""
        before, after = settings
        _sample_into(time, _NO_DRAWS if normals is None else normals, walk, advance_walk, *before, lowpass_state, value,
                     *after, offsets, measured, saturated)

    def measure(self, value, out: np.ndarray | None = None,
                saturated: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(Q(sat(value)), the saturation flags (0/1)) of disturbed values (…, 6), into ``out`` and
        ``saturated`` (same shape, float) if given (``measure_rows``)."""
        value = np.asarray(value, dtype=float)
        out = np.empty(value.shape) if out is None else out
        saturated = np.empty(value.shape) if saturated is None else saturated
        measure_rows(value.reshape(-1, NUM_AXES), self.limits, self.steps, out.reshape(-1, NUM_AXES),
                     saturated.reshape(-1, NUM_AXES))
        return out, saturated


# --- Drake systems ------------------------------------------------------------

class _SampledSixAxisSensor(LeafSystem):
    """The measurement model of the module docstring behind one vector input.

    An initialization event takes the first sample at the initial time, a
    periodic event the next ones at t = T, 2T, …; before initialization the
    outputs are zero. To resume a Context with a new Simulator, initialize it
    with ``InitializeParams(suppress_initialization_events=True)``, or the
    initialization event takes an extra sample. Outputs are discrete state, so
    the system has no direct feedthrough.
    """

    def __init__(self, params: SixAxisSensorParams, stream: int, input_name: str,
                 output_name: str):
        super().__init__()
        self._model = SixAxisMeasurement(params, stream, params.sample_period)
        self._lowpass = lowpass_coefficients(params.lowpass_cutoff, params.sample_period)
        self._settings = self._model.sample_arguments(self._lowpass)
        # (first sample index, draws): a memo of the pure function standard_normals,
        # not generator state, so Contexts and their clones stay independent.
        self._noise_block = (0, np.empty((0, 2 * NUM_AXES)))
        self._time = np.empty(1)  # scratch of ``_take_sample``

        self._input = self.DeclareVectorInputPort(input_name, NUM_AXES)
        self._measured = self.DeclareDiscreteState(NUM_AXES)
        self._offsets = self.DeclareDiscreteState(NUM_AXES)
        self._saturated = self.DeclareDiscreteState(NUM_AXES)
        # The memory (``WALK``, ``NEXT_INDEX``, ``LAST_TIME``, ``LOWPASS``), the filter's state NaN until the first
        # sample.
        self._memory = self.DeclareDiscreteState(np.concatenate((np.zeros(NUM_AXES + 1), [-np.inf],
                                                                 np.full(2 * NUM_AXES, np.nan))))
        # Offset 0, like a discrete plant's steps: sample instants k·T then coincide exactly
        # with the plant's (an offset of T gives T + k·T, which round-off can put just after).
        self.DeclareInitializationDiscreteUpdateEvent(self._take_first_sample)
        self.DeclarePeriodicDiscreteUpdateEvent(params.sample_period, 0.0, self._take_next_sample)
        self.DeclareStateOutputPort(output_name, self._measured)
        self.DeclareStateOutputPort("offsets_true", self._offsets)
        self.DeclareStateOutputPort("saturated", self._saturated)

    def _take_first_sample(self, context, discrete_state):
        self._take_sample(context, discrete_state, discrete_state.get_mutable_value(self._memory), advance_walk=False)

    def _take_next_sample(self, context, discrete_state):
        # discrete_state holds the current values: each group is updated in place. The periodic event also
        # fires at the start time, already sampled at initialization: one sample per instant, so it stays.
        memory = discrete_state.get_mutable_value(self._memory)
        if context.get_time() == memory[LAST_TIME]:
            return
        self._take_sample(context, discrete_state, memory, advance_walk=True)

    def _normals(self, index: int) -> np.ndarray | None:
        """The draws of sample ``index`` (1, 12), from a memo of ``_NOISE_BLOCK`` samples."""
        if not self._model.draws_noise:
            return None
        start, block = self._noise_block
        if not start <= index < start + len(block):
            start = index
            block = self._model.normals(np.arange(index, index + _NOISE_BLOCK))
            self._noise_block = (start, block)
        return block[index - start:index - start + 1]

    def _take_sample(self, context, discrete_state, memory: np.ndarray, advance_walk: bool):
        index, t = int(memory[NEXT_INDEX]), context.get_time()
        value = self._input.Eval(context)[np.newaxis]
        lowpass_state = memory[LOWPASS].reshape(2, NUM_AXES)
        if self._lowpass is not None:
            start_lowpass(self._lowpass, lowpass_state, value[0])
        self._time[0] = t
        self._model.sample_into(self._time, self._normals(index), memory[WALK], advance_walk, self._settings,
                                lowpass_state, value, discrete_state.get_mutable_value(self._offsets)[np.newaxis],
                                discrete_state.get_mutable_value(self._measured)[np.newaxis],
                                discrete_state.get_mutable_value(self._saturated)[np.newaxis])
        memory[NEXT_INDEX], memory[LAST_TIME] = index + 1, t


class ForceTorqueSensorModel(_SampledSixAxisSensor):
    """The JR3's force-torque channels: samples the true wrench [f; τ] that the
    sensor exerts on the load (at S, in S; N, N·m) every T and holds the
    measurement. ``offsets_true`` is the offset inside the held measurement,
    ``saturated`` its per-axis flags (0/1).

    .. pydrake_system::

        name: ForceTorqueSensorModel
        input_ports:
        - wrench_true
        output_ports:
        - wrench_measured
        - offsets_true
        - saturated
    """

    def __init__(self, params: ForceTorqueSensorParams | None = None):
        super().__init__(params or ForceTorqueSensorParams(), FORCE_TORQUE_STREAM,
                         "wrench_true", "wrench_measured")


class AccelerometerModel(_SampledSixAxisSensor):
    """The JR3's accelerometer: samples the ideal reading of S's motion (in S; m/s², rad/s²;
    ``accelerometer_reading``) every T and holds the measurement. ``offsets_true`` is the bias
    inside the held measurement, ``saturated`` its per-axis flags (0/1).

    .. pydrake_system::

        name: AccelerometerModel
        input_ports:
        - acceleration_true
        output_ports:
        - acceleration_measured
        - offsets_true
        - saturated
    """

    def __init__(self, params: AccelerometerParams | None = None):
        super().__init__(params or AccelerometerParams(), ACCELEROMETER_STREAM,
                         "acceleration_true", "acceleration_measured")
