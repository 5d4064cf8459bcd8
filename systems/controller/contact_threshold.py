"""When the contact estimate c (Eq. 13: c = f − o − V·φ̂, at S in S) counts as contact.

Out of contact, c holds only the sensor's noise and what φ̂ and the offsets miss; a |c| beyond
these thresholds is a touch, or a load model that no longer fits. The estimator's gate takes no
such sample (``estimator_gate``) and offset tracking pauses on it (``offset_tracking``): both
judge contact as c ``beyond`` these thresholds (``load_dynamics.beyond``).
"""

import dataclasses
import math


@dataclasses.dataclass
class ContactThresholdParams:
    """|c_f| (N) and |c_τ| (N·m) above which c counts as contact: some 20 and 40 times the
    simulated JR3's noise per axis (``ForceTorqueSensorParams.noise_rms``: 0.1 N, 0.005 N·m RMS)."""

    force: float = 2.0
    torque: float = 0.2

    def validate(self) -> None:
        """Raises ValueError naming the threshold (``controller.contact``) that is not finite and >= 0."""
        for name in ("force", "torque"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"controller.contact.{name} must be finite and >= 0; got {value}")
