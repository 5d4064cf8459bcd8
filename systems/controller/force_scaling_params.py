"""The settings of force scaling and elimination (``force_scaling``, Kubus & Wahl, Sec. V, Fig. 2):
``controller.force`` of a scenario, apart from the block and its compiled kernels, so that a scenario
loads without numba (``heft load``)."""

import dataclasses
import math


@dataclasses.dataclass
class ForceScalingParams:
    """Settings of `ForceScalingElimination`."""

    sigma: float = 1.0
    """σ ≥ 0: scale of the non-contact wrench (of the gripper's, with a split),
    in effect at the start and requested while the `sigma` input is unconnected."""

    gamma: float = 1.0
    """γ ≥ 0: scale of the contact wrench (start value and default request)."""

    eta: float = 1.0
    """η ∈ [0, 1]: share of the gripped object's non-contact wrench that is kept
    (start value and default request); used only with `phi_gripper`."""

    slew_rate: float = 2.0
    """Largest change of each of σ, γ, η per second (1/s), so that a new request
    fades in instead of jumping (default: 0 → 1 in 0.5 s)."""

    phi_gripper: list[float] | None = None
    """The gripper's φ (Eq. 6, about S's origin, in S) for the Eq. 14 split; None
    treats the whole load as one body."""

    mount_notch: float = 0.0
    """Centre (Hz) of the notch through which c is fed back (``force_scaling``'s docstring): the load's
    first mode on its mount, from a tap test; 0: no notch (a rigid mount). Below the
    controller's Nyquist frequency."""

    mount_notch_quality: float = 0.7
    """Q of that notch, its centre over its −3 dB width: low, so that one notch covers the
    mode as it shifts with the load held and with the hand's and the arm's coupling."""

    fault_decay_time: float = 0.01
    """Time constant τ (s) with which f′ decays to zero while faulted, applied per
    tick as exp(−period/τ) from the last f′ in effect; 0 drops it to zero at once."""

    def mount_notch_summary(self) -> str:
        """One line on the notch for a lab's console: what is set and how to set it."""
        if self.mount_notch == 0:
            return "contact fed back without a mount notch (controller.force.mount_notch: 0, a rigid tool mount)"
        return (f"contact fed back through a notch at {self.mount_notch:g} Hz, Q {self.mount_notch_quality:g} "
                "(controller.force.mount_notch: the tool's rocking mode on its mount, the frequency it rings at "
                "in the wrench when tapped; 0 for a rigid mount)")

    def validate(self) -> None:
        """Raises ValueError naming the first field that is out of range."""
        for name in ("sigma", "gamma"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be finite and >= 0; got {value}")
        if not 0.0 <= self.eta <= 1.0:
            raise ValueError(f"eta must lie in [0, 1]; got {self.eta}")
        for name in ("slew_rate",):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be finite and > 0; got {value}")
        if not (math.isfinite(self.mount_notch) and self.mount_notch >= 0):
            raise ValueError(f"mount_notch must be finite and >= 0 Hz (0: none); got {self.mount_notch}")
        if not (math.isfinite(self.mount_notch_quality) and self.mount_notch_quality > 0):
            raise ValueError(f"mount_notch_quality must be finite and > 0; got {self.mount_notch_quality}")
        if not (math.isfinite(self.fault_decay_time) and self.fault_decay_time >= 0):
            raise ValueError(
                f"fault_decay_time must be finite and >= 0; got {self.fault_decay_time}")
        if self.phi_gripper is not None and (
                len(self.phi_gripper) != 10 or not all(math.isfinite(x) for x in self.phi_gripper)):
            raise ValueError(f"phi_gripper needs 10 finite entries (Eq. 6); got {self.phi_gripper}")
