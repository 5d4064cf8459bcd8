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

from .sample_period import require_period
from .sensor_models import lowpass, lowpass_coefficients

# The signals filtered, in the order of the state's columns: name, size.
SIGNALS = (("wrench", 6), ("acceleration", 6), ("omega", 3), ("gravity", 3))
_WIDTH = sum(size for _, size in SIGNALS)


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
        period = require_period(period)
        if not (math.isfinite(cutoff) and 0 < cutoff < 0.5 / period):
            raise ValueError(f"controller.estimator.prefilter must lie between 0 and the controller's Nyquist "
                             f"frequency {0.5 / period:g} Hz (set 0 for no prefilter); got {cutoff}")
        self._coefficients = lowpass_coefficients(cutoff, period)
        self._inputs = [self.DeclareVectorInputPort(name, size) for name, size in SIGNALS]
        # The filtered values (NaN until the first update), then the filter's state (2 × width,
        # NaN: to start in the steady state of the next sample).
        self._state = self.DeclareDiscreteState(np.full(3 * _WIDTH, np.nan))
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
        filter_state = state[_WIDTH:].reshape(2, _WIDTH)
        if np.isfinite(sample).all():
            state[:_WIDTH] = lowpass(self._coefficients, filter_state, sample[np.newaxis])[0]
        else:
            state[:] = np.nan
        discrete_state.set_value(self._state, state)
