"""The settings of the force feedback to the master (``feedback_mapping``, Fig. 4): ``controller.feedback``
of a scenario, apart from the block and its compiled kernels, so that a scenario loads without numba
(``heft load``)."""

import dataclasses
import math


@dataclasses.dataclass
class FeedbackMappingParams:
    """Scaling and device limits of the force feedback; loadable with ``yaml_load_typed``."""

    force_scale: float = 1 / 17.5
    """k_f (master N per slave N): the paper's 1/17.5 (Sec. VI-B)."""

    torque_scale: float = 1 / 17.5
    """k_τ (master N·m per slave N·m)."""

    max_force: float = 8.5
    """Largest force magnitude rendered (N): Phantom Premium 1.5 6DoF, CHAI3D's table (docs/design.md §6)."""

    max_torque: float = 0.188
    """Largest torque magnitude rendered (N·m): same source."""

    def validate(self) -> None:
        """Raises ValueError naming the first field out of range."""
        for name in ("force_scale", "torque_scale"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be finite and >= 0 (a negative one reverses the feedback); "
                                 f"got {value}")
        for name in ("max_force", "max_torque"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be finite and > 0; got {value}")
