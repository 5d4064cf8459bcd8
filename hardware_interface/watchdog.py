"""Receive watchdog over the hardware's LCM channels (DESIGN §6: UR 20 ms, dVRK 30 ms).

A channel is stale when its age (s, diagram time since its last good message;
inf or NaN before the first) exceeds the timeout. While any channel is stale the
station is unhealthy and the command gain is 0; once every channel is fresh the
gain ramps linearly back to 1 over ``ramp_time``, so commands never jump.
"""

import dataclasses

import numpy as np
from pydrake.systems.framework import BasicVector, LeafSystem


@dataclasses.dataclass
class WatchdogParams:
    """Watchdog limits; loadable with ``yaml_load_typed``."""

    timeout: float = 0.020
    """A channel whose last good message is older than this is stale (s)."""
    ramp_time: float = 0.2
    """Time for the gain to ramp from 0 to 1 once all channels are fresh (s)."""


def watchdog_step(ages: np.ndarray, gain: float, timeout: float, ramp_step: float) -> tuple[bool, float, int]:
    """One watchdog tick: (healthy, new gain, fault bitmask with bit i set for stale channel i).

    ``ages`` are in s (inf/NaN: never received); ``ramp_step`` is the gain increase per tick.
    """
    stale = ~(np.asarray(ages, dtype=float) <= timeout)
    fault = int(sum(1 << int(i) for i in np.flatnonzero(stale)))
    healthy = not stale.any()
    return healthy, (min(1.0, gain + ramp_step) if healthy else 0.0), fault


class Watchdog(LeafSystem):
    """Samples channel ages every ``period`` s and holds healthy, gain and fault as state.

    Starts unhealthy with every channel flagged: nothing is trusted until each
    channel has delivered. Outputs are state, so there is no direct feedthrough.

    .. pydrake_system::

        name: Watchdog
        input_ports:
        - ages
        output_ports:
        - healthy
        - gain
        - fault
    """

    def __init__(self, num_channels: int, period: float, params: WatchdogParams | None = None):
        super().__init__()
        self._params = params or WatchdogParams()
        self._ramp_step = period / self._params.ramp_time
        self._ages = self.DeclareVectorInputPort("ages", num_channels)
        self._healthy = self.DeclareDiscreteState(1)
        self._gain = self.DeclareDiscreteState(1)
        self._fault = self.DeclareDiscreteState(BasicVector([float((1 << num_channels) - 1)]))
        self.DeclareStateOutputPort("healthy", self._healthy)
        self.DeclareStateOutputPort("gain", self._gain)
        self.DeclareStateOutputPort("fault", self._fault)
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)

    def _update(self, context, discrete_state):
        gain = context.get_discrete_state(self._gain).GetAtIndex(0)
        healthy, gain, fault = watchdog_step(self._ages.Eval(context), gain, self._params.timeout, self._ramp_step)
        discrete_state.get_mutable_vector(self._healthy).SetAtIndex(0, float(healthy))
        discrete_state.get_mutable_vector(self._gain).SetAtIndex(0, gain)
        discrete_state.get_mutable_vector(self._fault).SetAtIndex(0, float(fault))
