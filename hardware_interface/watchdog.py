"""Receive watchdog over the hardware's LCM channels, in wall-clock time
(docs/design.md §6: UR 20 ms, dVRK 30 ms).

A channel is stale when its age (s of the station's clock since its last good
message; inf before the first) exceeds the timeout; the controller itself is
stalled when its ticks are further apart than the timeout; a channel whose
source is in doubt (a second publisher, a new source on probation:
``message_order``) is a fault too. While anything is stale, stalled or in doubt
the station is unhealthy and the command gain is 0; once all is
fresh again the gain ramps linearly back to 1 over ``ramp_time``, so commands
never jump. Its limits are ``hardware_station_params.WatchdogParams``.
"""

from heft.systems.compiled import compiled


@compiled("Tuple((boolean, float64, int64))(float64[:], float64, float64, float64, boolean, int64)")
def watchdog_step(ages, gain: float, timeout: float, ramp_step: float, stalled: bool,
                  conflicts: int) -> tuple[bool, float, int]:
    """One watchdog tick: (healthy, new gain, fault bitmask).

    Bit i is set for stale channel i (``ages`` in s; inf or NaN: never received), bit
    ``len(ages)`` when the controller ``stalled`` and bit ``len(ages) + 1 + i`` for channel i
    whose source is in doubt (``conflicts``: bit i per channel); ``ramp_step`` is the gain increase over
    this tick (its duration / ramp time)."""
    fault = conflicts << (len(ages) + 1)
    for i in range(len(ages)):
        if not ages[i] <= timeout:
            fault |= 1 << i
    if stalled:
        fault |= 1 << len(ages)
    healthy = fault == 0
    return healthy, (min(1.0, gain + ramp_step) if healthy else 0.0), fault
