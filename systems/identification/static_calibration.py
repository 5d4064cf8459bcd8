"""The load's mass, first moment and the sensor's offsets from static poses — the most common
calibration data there is (KTH force_torque_tools, ros2 control_toolbox, Vougioukas 2001): a few
dozen poses, each an averaged wrench with gravity's direction in S, and where the poses carry an
accelerometer's readings, its calibration too (``accelerometer_calibration``).

Plain numpy, no Drake types; conventions of ``load_dynamics`` (docs/design.md §4). At rest a = α = ω = 0
and Eq. 5 keeps f = o_f − m·g and τ = o_τ − (m·c) × g: the 6 offsets, m and m·c are linear in the
poses' wrenches, and the estimate is ``batch_estimation.batch_estimate`` with the motion at zero. The
inertia never enters (reported unidentifiable); ``point_mass_phi`` completes φ with the inertia of a
point mass at the centre of mass so that the controller can load it.
"""

import dataclasses

import numpy as np

from heft.systems.accelerometer_calibration import GravityFit, fit_to_gravity
from heft.systems.identification.batch_estimation import Estimate, batch_estimate
from heft.systems.load_dynamics import OFFSET_NAMES, PHI_NAMES

STATIC_NAMES = OFFSET_NAMES + PHI_NAMES[:4]
"""The parameters static poses identify: the offsets, m, m·c."""


@dataclasses.dataclass(frozen=True)
class StaticCalibration:
    """What static poses give. ``estimate``: the batch estimate of [offsets; φ] (its inertia entries
    unidentifiable, 0); ``accelerometer``: the accelerometer's fit (None without readings);
    ``poses``: how many."""

    estimate: Estimate
    accelerometer: GravityFit | None
    poses: int

    @property
    def mass(self) -> float:
        """kg"""
        return float(self.estimate.phi[0])

    @property
    def com(self) -> np.ndarray:
        """The centre of mass c (m, in S)."""
        return self.estimate.phi[1:4] / self.estimate.phi[0]

    @property
    def offsets(self) -> np.ndarray:
        """[f_o; τ_o] (N, N·m)."""
        return np.asarray(self.estimate.offsets)


def point_mass_phi(mass: float, com) -> np.ndarray:
    """φ (Eq. 6) of a point mass ``mass`` (kg) at ``com`` (m, in S): inertia m(|c|²·1 − c·cᵀ) about S."""
    c = np.asarray(com, dtype=float)
    inertia = mass * (c @ c * np.eye(3) - np.outer(c, c))
    return np.concatenate(([mass], mass * c, inertia[0], inertia[1, 1:], inertia[2, 2:]))


def static_gravity(orientation_R_WS, gravity_W) -> np.ndarray:
    """g in S, (N, 3) m/s², of poses given as R_WS (N, 3, 3) and gravity in W (3, m/s²): g_S = R_WSᵀ g_W."""
    return np.einsum("nji,j->ni", np.asarray(orientation_R_WS, dtype=float), np.asarray(gravity_W, dtype=float))


def calibrate_static(wrench, gravity_S, accelerometer=None, accelerometer_unit: str = "m/s^2") -> StaticCalibration:
    """m, m·c and the offsets from N poses at rest: ``wrench`` (N, 6) [f; τ] the sensor exerts on
    the load (N, N·m, averaged per pose), ``gravity_S`` (N, 3) g in S (m/s²); with ``accelerometer``
    (N, 3) readings in its own axes and ``accelerometer_unit``, also its calibration
    (``fit_to_gravity``). Raises ValueError naming what the poses cannot determine and what to add."""
    wrench = np.asarray(wrench, dtype=float)
    gravity_S = np.asarray(gravity_S, dtype=float)
    if wrench.ndim != 2 or wrench.shape[1] != 6 or gravity_S.shape != (len(wrench), 3):
        raise ValueError(f"static poses: the wrench {wrench.shape} and the gravity {gravity_S.shape} need one row per "
                         "pose, of 6 and 3 columns")
    if not (np.isfinite(wrench).all() and np.isfinite(gravity_S).all()):
        rows = np.flatnonzero(~(np.isfinite(wrench).all(axis=1) & np.isfinite(gravity_S).all(axis=1)))
        raise ValueError(f"static poses: pose {rows[0]} has a NaN or inf wrench or gravity; drop or repair it")
    if len(wrench) < 3:
        raise ValueError(f"static poses: the mass, its first moment and the 6 offsets need at least 3 poses with "
                         f"gravity in different directions; got {len(wrench)}")
    zeros = np.zeros(3)
    estimate = batch_estimate(wrench, zeros, zeros, zeros, gravity_S, method="ols")
    unidentified = [name for name, ok in zip(STATIC_NAMES, estimate.identifiable[:10]) if not ok]
    if unidentified:
        raise ValueError(f"static poses: {', '.join(unidentified)} cannot be told apart from these poses (gravity in "
                         "S takes too few directions): add poses with the sensor tilted about two axes, gravity along "
                         "at least three directions")
    if not estimate.phi[0] > 0.0:
        raise ValueError(f"static poses: the estimated mass {estimate.phi[0]:.4g} kg is not positive: check the "
                         "wrench's sign (exerted_on) and that gravity is given in S")
    fit = None if accelerometer is None else fit_to_gravity(accelerometer, gravity_S, accelerometer_unit)
    return StaticCalibration(estimate=estimate, accelerometer=fit, poses=len(wrench))
