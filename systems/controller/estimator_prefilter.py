"""One low-pass filter on both sides of Eq. 5 before the online load estimator.

W = V(a, α, ω, g)·φ holds sample by sample, so a linear filter F applied to both sides keeps
it, F(W) = F(V)·φ for a constant φ. V is linear in a − g and α, so filtering a, α and g
filters those terms exactly; its ω terms are quadratic, and below the cut-off, where F acts
as a pure delay, the square of the filtered ω equals the filtered square to second order.
Above the cut-off go what V of S's measured motion cannot explain: the sensors' noise, which
biases least squares on a noisy regressor (errors in variables), and the load's rocking on a
compliant mount, which the accelerometer in the sensor does not see.
"""

import math

import numpy as np

from heft.systems.compiled import compiled
from heft.systems.sample_period import require_period
from heft.systems.station.sensor_models import lowpass_coefficients
from heft.systems.tick_system import TickSystem

# The signals filtered, in the order of the state's columns: name, size.
SIGNALS = (("wrench", 6), ("acceleration", 6), ("omega", 3), ("gravity", 3))
WIDTH = sum(size for _, size in SIGNALS)
STATE_SIZE = 3 * WIDTH
"""The filtered values (NaN until the first sample), then the filter's state (2 × ``WIDTH``,
transposed direct form II; NaN: to start in the steady state of the next sample)."""


def prefilter_coefficients(cutoff: float, period: float) -> np.ndarray:
    """The low-pass's (b0, b1, b2, a1, a2) (``sensor_models.lowpass_coefficients``), or a ValueError
    saying how to set ``controller.estimator.prefilter`` (Hz) for a controller ``period`` (s)."""
    if not (math.isfinite(cutoff) and 0 < cutoff < 0.5 / period):
        raise ValueError(f"controller.estimator.prefilter must lie between 0 and the controller's Nyquist "
                         f"frequency {0.5 / period:g} Hz (set 0 for no prefilter); got {cutoff}")
    return lowpass_coefficients(cutoff, period)


@compiled("void(float64[:], float64[:], float64[:])")
def prefilter_step(coefficients, state, sample) -> None:
    """One sample (``WIDTH``: wrench, acceleration, omega, gravity as ``SIGNALS``) through the filter
    (``coefficients`` (b0, b1, b2, a1, a2)), in place on ``state`` (``STATE_SIZE``): its first
    ``WIDTH`` entries become the filtered sample (``sensor_models.lowpass``'s recursion for one
    row); a non-finite sample makes the whole state NaN, so that the next finite one restarts the
    filter in its steady state (out = sample: unit DC gain)."""
    width = sample.shape[0]
    for i in range(width):
        if not math.isfinite(sample[i]):
            state[:] = np.nan
            return
    b0, b1, b2, a1, a2 = coefficients[0], coefficients[1], coefficients[2], coefficients[3], coefficients[4]
    steady = math.isnan(state[width])
    for i in range(width):
        x = sample[i]
        z1 = x * (b1 + b2 - a1 - a2) if steady else state[width + i]
        z2 = x * (b2 - a2) if steady else state[2 * width + i]
        y = b0 * x + z1
        state[i] = y
        state[width + i] = b1 * x + z2 - a1 * y
        state[2 * width + i] = b2 * x - a2 * y


@compiled("void(float64[:], float64[:], float64[:], float64[:], float64[:], float64[:], float64[:])")
def prefilter_update(state, wrench, acceleration, omega, gravity, coefficients, sample) -> None:
    """``prefilter_step`` on the block's inputs, laid out into ``sample`` (``WIDTH``) as ``SIGNALS``."""
    for i in range(6):
        sample[i] = wrench[i]
        sample[6 + i] = acceleration[i]
    for i in range(3):
        sample[12 + i] = omega[i]
        sample[15 + i] = gravity[i]
    prefilter_step(coefficients, state, sample)


class EstimatorPrefilter(TickSystem):
    """The second-order Butterworth low-pass of ``cutoff`` (Hz; ``sensor_models.lowpass``) on
    each of the load estimator's inputs, sampled every ``period`` s.

    Inputs and outputs (same names and units, in S): ``wrench`` (6), ``acceleration`` (6,
    kinematic [a; α]), ``omega`` (3), ``gravity`` (3). Each output holds the filter's value at
    the last update, so every signal arrives one tick late. The filter starts in the steady
    state of its first sample; a sample with a NaN or inf puts NaN on every output for the
    next tick (the estimator skips it) and the filter restarts on the next finite sample."""

    def __init__(self, cutoff: float, period: float):
        super().__init__(require_period(period))
        self.coefficients = prefilter_coefficients(cutoff, period)
        for name, size in SIGNALS:
            self.DeclareTickInput(name, size)
        self.DeclareTickState("state", np.full(STATE_SIZE, np.nan))  # ``STATE_SIZE``
        self.DeclareTickUpdate(prefilter_update, "next:state", *(f"in:{name}" for name, _ in SIGNALS),
                               self.coefficients, np.empty(WIDTH))
        start = 0
        for name, size in SIGNALS:
            self.DeclareTickOutput(name, "x:state", start, start + size)
            start += size
