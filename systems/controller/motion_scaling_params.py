"""The settings of motion scaling with a clutch (``motion_scaling``, Fig. 4): ``controller.motion`` of a
scenario, apart from the block and its compiled kernels, so that a scenario loads without numba
(``heft load``)."""

import dataclasses
import math


@dataclasses.dataclass
class MotionScalingParams:
    """Master-to-slave motion mapping; loadable with ``yaml_load_typed``."""

    translation_scale: float = 1.0
    """k_t (slave m per master m), ≥ 0; used while the ``translation_scale`` port is unconnected."""

    rotation_scale: float = 1.0
    """k_r (slave rad per master rad), ≥ 0; used while the ``rotation_scale`` port is unconnected."""

    R_RB: list[float] = dataclasses.field(default_factory=lambda: [0.0, 0.0, 0.0])
    """The fixed rotation from the master base B to the slave base R as roll-pitch-yaw (rad)."""

    master_filter: float = 0.0
    """Cut-off (Hz) of the low-pass on the master's measured joint positions (``master_position_filter``), below
    the controller's Nyquist frequency; 0: none. At 60 Hz (group delay 3.8 ms) the Phantom's encoder counts no
    longer ring the tool on its mount: fig6, σ = 0, leaves 0.68 % of the non-contact peak, against 1.15 %
    without; its delay costs the contact loop stability margin (docs/scenarios.md)."""

    master_notch: float = 110.0
    """Centre (Hz) of a notch on the master's measured joint positions (``master_position_filter``), after the
    low-pass if both are set, below the controller's Nyquist frequency; 0: none. At the translational modes of the
    tool on its compliant mount (a lab's from a tap test, as for ``controller.force.mount_notch``), which the
    encoder counts ring: at 110 Hz (the default) in the default station fig6, σ = 0, leaves 0.84 % of the
    non-contact peak, against 1.15 % without, for 5° of phase at 7 Hz, where the contact loop's poles leave the
    unit circle (docs/scenarios.md)."""

    master_notch_quality: float = 0.7
    """Q of that notch, its centre over its −3 dB width: low, so that one notch covers the modes (60–220 Hz)."""

    def validate(self) -> None:
        """Raises ValueError naming the first field out of range."""
        for name in ("translation_scale", "rotation_scale"):
            if not valid_scale(getattr(self, name)):
                raise ValueError(f"{name} must be finite and >= 0; got {getattr(self, name)}")
        if not (math.isfinite(self.master_filter) and self.master_filter >= 0):
            raise ValueError(f"master_filter must be a cut-off (Hz) >= 0, 0 for none; got {self.master_filter}")
        if not (math.isfinite(self.master_notch) and self.master_notch >= 0):
            raise ValueError(f"master_notch must be a frequency (Hz) >= 0, 0 for none; got {self.master_notch}")
        if not (math.isfinite(self.master_notch_quality) and self.master_notch_quality > 0):
            raise ValueError(f"master_notch_quality must be finite and > 0; got {self.master_notch_quality}")
        if len(self.R_RB) != 3 or not all(math.isfinite(x) for x in self.R_RB):
            raise ValueError(f"R_RB must be 3 finite roll-pitch-yaw angles (rad); got {self.R_RB}")


def valid_scale(k: float) -> bool:
    """True if ``k`` is a usable motion scale: finite and ≥ 0 (as ``motion_scaling.motion_scaling_step`` checks it)."""
    return math.isfinite(k) and k >= 0
