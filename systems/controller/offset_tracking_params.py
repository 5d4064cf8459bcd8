"""The settings of re-zeroing and offset tracking (``offset_tracking``): ``controller.offsets`` of a
scenario, apart from the block (which needs ``load_dynamics``'s compiled kernels), so that a scenario
loads without numba (``heft load``)."""

import dataclasses
import math


@dataclasses.dataclass
class OffsetTrackingParams:
    """Settings of re-zeroing and tracking (``offset_tracking``'s docstring)."""

    tracking: bool = True
    """Tracking on at start (a run-time request can turn it off and on)."""

    time_constant: float = 5.0
    """Time constant (s) with which tracking follows c + o: averages the sensor's noise
    (0.1 N RMS at 2 kHz → under 1 mN) and lags a drift of r N/s by r·τ (the simulated
    JR3's fastest, 0.005 N/s at power-on, by 0.025 N)."""

    max_force_rate: float = 0.02
    """Largest tracking step of each force offset (N/s): ten times the simulated JR3's
    warm-up drift rate."""

    max_torque_rate: float = 0.002
    """Largest tracking step of each torque offset (N·m/s)."""


    rezero_window: float = 0.5
    """Length (s) of the re-zero average."""

    rezero_force: float = 5.0
    """|c_f| (N) above which a re-zero is refused as contact: larger than any drift."""

    rezero_torque: float = 0.5
    """|c_τ| (N·m) above which a re-zero is refused as contact."""

    rest_joint_speed: float = 0.01
    """Every slave joint below this speed (rad/s) counts as at rest."""

    def validate(self) -> None:
        """Raises ValueError naming the first field that is not finite and > 0 (the contact
        thresholds: >= 0)."""
        for field in dataclasses.fields(self):
            value = getattr(self, field.name)
            if field.name != "tracking" and not (math.isfinite(value) and value > 0):
                raise ValueError(f"offset tracking: {field.name} must be finite and > 0; got {value}")
