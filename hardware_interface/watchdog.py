"""Receive watchdog over the hardware's LCM channels, in wall-clock time
(docs/design.md §6: UR 20 ms, dVRK 30 ms).

A channel is stale when its age (s of the station's clock since its last good
message; inf before the first) exceeds the timeout; the controller itself is
stalled when its ticks are further apart than the timeout; a channel whose
source is in doubt (a second publisher, a new source on probation:
``message_order``) is a fault too. While anything is stale, stalled or in doubt
the station is unhealthy and the command gain is 0; once all is
fresh again the gain ramps linearly back to 1 over ``ramp_time``, so commands
never jump.
"""

import dataclasses
import math


@dataclasses.dataclass
class WatchdogParams:
    """Watchdog limits; loadable with ``yaml_load_typed``."""

    timeout: float = 0.020
    """A channel whose last good message is older than this is stale (s, wall clock)."""
    ramp_time: float = 0.2
    """Time for the gain to ramp from 0 to 1 once all channels are fresh (s)."""

    def validate(self) -> None:
        """Raises ValueError naming the field out of range."""
        for name in ("timeout", "ramp_time"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive number of seconds; got {value}")


def watchdog_step(ages, gain: float, timeout: float, ramp_step: float,
                  stalled: bool = False, conflicts: int = 0) -> tuple[bool, float, int]:
    """One watchdog tick: (healthy, new gain, fault bitmask).

    Bit i is set for stale channel i (``ages`` in s; inf or NaN: never received), bit
    ``len(ages)`` when the controller ``stalled`` and bit ``len(ages) + 1 + i`` for channel i
    whose source is in doubt (``conflicts``: bit i per channel); ``ramp_step`` is the gain increase over
    this tick (its duration / ramp time)."""
    fault = conflicts << (len(ages) + 1)
    for i, age in enumerate(ages):
        if not age <= timeout:
            fault |= 1 << i
    if stalled:
        fault |= 1 << len(ages)
    healthy = fault == 0
    return healthy, (min(1.0, gain + ramp_step) if healthy else 0.0), fault
