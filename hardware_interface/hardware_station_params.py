"""The hardware station's limits (``hardware_station``): ``lab.station`` of a scenario, apart from
the station, so that a scenario loads without the station's imports (Drake's plant for the arm's
kinematics, numba's kernels; ``heft load``)."""

import dataclasses

from heft.hardware_interface.watchdog import WatchdogParams


@dataclasses.dataclass
class HardwareStationParams:
    """Limits of the hardware station; loadable with ``yaml_load_typed``."""

    watchdog: WatchdogParams = dataclasses.field(default_factory=WatchdogParams)
