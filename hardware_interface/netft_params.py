"""A lab's ATI Net F/T: its calibration and RDT port (``Scenario.lab.netft``), apart from the protocol
(``netft``) so that a scenario loads without the compiled kernels."""

import dataclasses
import math

import numpy as np

RDT_PORT = 49152
"""The UDP port a Net F/T answers RDT requests on."""


@dataclasses.dataclass
class NetFtParams:
    """A lab's Net F/T; ``Scenario.lab.netft``. The calibration has no default: its values are on the
    device's configuration page (Counts per Force, Counts per Torque), for forces in N and torques in
    N·m, and its tool transform must put the reported wrench at S, in S (docs/netft.md)."""

    counts_per_force: float = 0.0
    """Counts per N of Fx, Fy, Fz; 0: not stated."""
    counts_per_torque: float = 0.0
    """Counts per N·m of Tx, Ty, Tz; 0: not stated."""
    port: int = RDT_PORT
    """The device's RDT port (UDP)."""
    buffered: bool = True
    """Ask for buffered streaming (the device's RDT buffer size of records a packet: a packet per
    controller tick) rather than real-time streaming (one record a packet)."""

    def validate(self) -> None:
        """Raises ValueError naming a calibration not stated or not a positive number, or a bad port."""
        for name in ("counts_per_force", "counts_per_torque"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"state lab.netft.{name} (the Net F/T's calibration: {name.replace('_', ' ')}, "
                                 f"from its configuration page, for N and N*m); got {value}")
        if not 0 < self.port < 65536:
            raise ValueError(f"lab.netft.port must be a UDP port; got {self.port}")

    def counts_per_unit(self) -> np.ndarray:
        """Counts per N (×3) and per N·m (×3), in the records' order."""
        return np.array([self.counts_per_force] * 3 + [self.counts_per_torque] * 3)
