"""Incremental encoders: joint angles quantised to whole counts."""

import numpy as np
from pydrake.systems.framework import LeafSystem


class EncoderQuantizer(LeafSystem):
    """Input ``position`` (n, rad) → output ``position`` rounded to 2π/counts_per_rev."""

    def __init__(self, size: int, counts_per_rev: float):
        super().__init__()
        if not counts_per_rev > 0:
            raise ValueError(f"counts_per_rev must be > 0; got {counts_per_rev}")
        self.step = 2 * np.pi / counts_per_rev  # rad per count
        self._input = self.DeclareVectorInputPort("position", size)
        self.DeclareVectorOutputPort("position", size, self._calc)

    def _calc(self, context, output):
        q = self._input.Eval(context)
        output.SetFromVector(np.round(q / self.step) * self.step)


class EncoderVelocityEstimator(LeafSystem):
    """A robot controller's joint velocity estimate from its encoders: every ``period`` s the
    backward difference of input ``position`` (n, rad, encoder-quantised) through a first-order
    low-pass of ``cutoff_hz`` (exact discretisation: v ← v + (1 − e^(−2π·f_c·T))·(Δq/T − v)).
    Output ``velocity`` (n, rad/s) is state: no feedthrough. Starts at rest on the first input
    (initialization event)."""

    def __init__(self, size: int, period: float, cutoff_hz: float):
        super().__init__()
        if not (period > 0 and cutoff_hz > 0):
            raise ValueError(f"period and cutoff_hz must be > 0; got {period}, {cutoff_hz}")
        self._size, self._period = size, period
        self._gain = 1.0 - np.exp(-2 * np.pi * cutoff_hz * period)
        self._input = self.DeclareVectorInputPort("position", size)
        self._velocity = self.DeclareDiscreteState(size)
        self._last_position = self.DeclareDiscreteState(size)
        self.DeclareInitializationDiscreteUpdateEvent(self._start)
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)
        self.DeclareStateOutputPort("velocity", self._velocity)

    def _start(self, context, discrete_state):
        discrete_state.set_value(self._velocity, np.zeros(self._size))
        discrete_state.set_value(self._last_position, self._input.Eval(context))

    def _update(self, context, discrete_state):
        v = context.get_discrete_state(self._velocity).get_value()
        last = context.get_discrete_state(self._last_position).get_value()
        q = self._input.Eval(context)
        discrete_state.set_value(self._velocity, v + self._gain * ((q - last) / self._period - v))
        discrete_state.set_value(self._last_position, q)
