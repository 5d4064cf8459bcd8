"""The settings of the passivity observer and controller at the master port (``passivity_controller``):
``controller.passivity`` of a scenario, apart from the block and its compiled kernels, so that a
scenario loads without numba (``heft load``)."""

import dataclasses
import math


@dataclasses.dataclass
class PassivityParams:
    """Settings of `PassivityController`."""

    max_translational_damping: float = 5.0
    """Bound of α_t (N·s/m): the Phantom Premium 1.5's maximum linear damping as
    tabulated by CHAI3D."""

    max_rotational_damping: float = 0.004
    """Bound of α_r (N·m·s/rad): CHAI3D's maximum angular damping for the Phantom
    Premium 1.5 6DOF (m_maxAngularDamping in its cPhantomDevice specifications)."""

    enabled: bool = True
    """False keeps the observer running but never damps (α = 0)."""

    def validate(self) -> None:
        """Raises ValueError naming the first field that is out of range."""
        for name in ("max_translational_damping", "max_rotational_damping"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be finite and >= 0; got {value}")
