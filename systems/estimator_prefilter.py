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
from pydrake.systems.framework import LeafSystem

from heft.systems.sample_period import require_period
from heft.systems.sensor_models import lowpass_coefficients

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


def prefilter_step(coefficients: np.ndarray, state: np.ndarray, sample: np.ndarray, scratch: np.ndarray) -> None:
    """One sample (``WIDTH``: wrench, acceleration, omega, gravity as ``SIGNALS``) through the filter,
    in place on ``state`` (``STATE_SIZE``): its first ``WIDTH`` entries become the filtered sample
    (``sensor_models.lowpass``'s recursion for one row, in scalar-coefficient form: no allocation);
    a non-finite sample makes the whole state NaN, so that the next finite one restarts the filter
    in its steady state. ``scratch`` (``WIDTH``) is work space."""
    if not math.isfinite(sum(sample.tolist())):
        state[:] = np.nan
        return
    b0, b1, b2, a1, a2 = coefficients.tolist()
    out, z1, z2 = state[:WIDTH], state[WIDTH:2 * WIDTH], state[2 * WIDTH:]
    if math.isnan(z1[0]):  # the steady state for ``sample``: out = sample (unit DC gain)
        np.multiply(sample, b1 + b2 - a1 - a2, out=z1)
        np.multiply(sample, b2 - a2, out=z2)
    np.multiply(sample, b0, out=out)
    out += z1
    np.multiply(sample, b1, out=z1)
    z1 += z2
    np.multiply(out, a1, out=scratch)
    z1 -= scratch
    np.multiply(sample, b2, out=z2)
    np.multiply(out, a2, out=scratch)
    z2 -= scratch


class EstimatorPrefilter(LeafSystem):
    """The second-order Butterworth low-pass of ``cutoff`` (Hz; ``sensor_models.lowpass``) on
    each of the load estimator's inputs, sampled every ``period`` s.

    Inputs and outputs (same names and units, in S): ``wrench`` (6), ``acceleration`` (6,
    kinematic [a; α]), ``omega`` (3), ``gravity`` (3). Each output holds the filter's value at
    the last update, so every signal arrives one tick late. The filter starts in the steady
    state of its first sample; a sample with a NaN or inf puts NaN on every output for the
    next tick (the estimator skips it) and the filter restarts on the next finite sample."""

    def __init__(self, cutoff: float, period: float):
        super().__init__()
        self._coefficients = prefilter_coefficients(cutoff, require_period(period))
        self._inputs = [self.DeclareVectorInputPort(name, size) for name, size in SIGNALS]
        self._state = self.DeclareDiscreteState(np.full(STATE_SIZE, np.nan))  # ``STATE_SIZE``
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)
        start = 0
        for name, size in SIGNALS:
            self.DeclareVectorOutputPort(
                name, size, lambda context, output, part=slice(start, start + size): output.SetFromVector(
                    context.get_discrete_state(self._state).get_value()[part]),
                prerequisites_of_calc={self.xd_ticket()})
            start += size

    def _update(self, context, discrete_state):
        sample = np.concatenate([port.Eval(context) for port in self._inputs])
        state = context.get_discrete_state(self._state).get_value().copy()
        prefilter_step(self._coefficients, state, sample, np.empty(WIDTH))
        discrete_state.set_value(self._state, state)
