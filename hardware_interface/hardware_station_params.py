"""The hardware station's limits (``hardware_station``): ``lab.station`` of a scenario, apart from
the station, so that a scenario loads without the station's imports (Drake's plant for the arm's
kinematics, numba's kernels; ``heft load``)."""

import dataclasses
import math


@dataclasses.dataclass
class WatchdogParams:
    """Limits of the receive watchdog (``watchdog``); loadable with ``yaml_load_typed``."""

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


@dataclasses.dataclass
class HardwareStationParams:
    """Limits of the hardware station; loadable with ``yaml_load_typed``."""

    watchdog: WatchdogParams = dataclasses.field(default_factory=WatchdogParams)
    tick_on_slave_status: bool = True
    """The control loop ticks as the arm driver's status arrives, one tick per status, where it runs at
    the status's nominal rate and does not wait busy (``HardwareStation.loop_anchor``); else on its own
    clock, whose phase against the arm's steps is then chance."""
