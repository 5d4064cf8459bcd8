"""An accelerometer mounted at any angle, in any unit, with a bias: its calibration against S,
and that calibration found from static poses with a known gravity.

Plain numpy, no Drake types. The model of a reading r (3, in the accelerometer's own axes A and
its own unit u, m/s² per unit) of the specific force s_S (m/s², in S; ``accelerometer_reading``)::

    r = scale · R_SAᵀ · s_S / u + bias          s_S = R_SA · (r − bias) · u / scale

R_SA holds A's axes in S (v_S = R_SA v_A), ``bias`` is in A's axes and the reading's unit, and
``scale`` is the reading's gain against the truth (1 for a perfect instrument). The unit "g" is
standard gravity, 9.80665 m/s² (the unit's definition, not the local gravity).

At rest the specific force is −g_S, so static poses with a known gravity g_S give pairs
(−g_S/u, r) related by a similarity transform plus the bias: ``fit_to_gravity`` finds R_SA, scale
and bias in closed form (Umeyama, IEEE T-PAMI 13(4), 1991: the orthogonal Procrustes / Kabsch
rotation with a scale and a translation).
"""

import dataclasses

import numpy as np

STANDARD_GRAVITY = 9.80665
"""m/s² per g (CGPM 1901)."""

UNITS = {"m/s^2": 1.0, "g": STANDARD_GRAVITY}
"""An accelerometer's linear unit → m/s² per unit."""

ROTATION_TOLERANCE = 1e-3
"""Largest |R·Rᵀ − 1| entry and |det R − 1| of a matrix taken as a rotation (entries typed with
four decimals pass); it is then replaced by the nearest rotation."""

MIN_GRAVITY_SPREAD = 0.02
"""Least RMS spread of the poses' gravity directions about their mean, in their second principal
direction (unit vectors; ≈ 1.1°), for R_SA to be determined: with directions along one line only,
a rotation about it is not seen."""


def unit_factor(unit: str) -> float:
    """m/s² per unit of an accelerometer's ``unit`` ("g" or "m/s^2")."""
    try:
        return UNITS[unit]
    except (KeyError, TypeError):
        raise ValueError(f"accelerometer unit must be one of {', '.join(UNITS)}; got {unit!r}") from None


def checked_rotation(name: str, matrix) -> np.ndarray:
    """The rotation nearest ``matrix`` ((3, 3) float) if it is one within ``ROTATION_TOLERANCE``, or
    ValueError naming ``name`` and what is wrong."""
    R = np.asarray(matrix, dtype=float)
    if R.shape != (3, 3) or not np.isfinite(R).all():
        raise ValueError(f"{name} must be a 3×3 rotation matrix of finite numbers; got {np.asarray(matrix).tolist()}")
    orthogonality = float(np.abs(R @ R.T - np.eye(3)).max())
    determinant = float(np.linalg.det(R))
    if orthogonality > ROTATION_TOLERANCE or abs(determinant - 1.0) > ROTATION_TOLERANCE:
        raise ValueError(f"{name} is not a rotation (|R·Rᵀ − 1| = {orthogonality:.2g}, det = {determinant:.6g}): "
                         "give orthonormal rows with determinant +1 (a mirror cannot be mounted)")
    U, _, Vt = np.linalg.svd(R)
    return U @ Vt


@dataclasses.dataclass(frozen=True)
class AccelerometerCalibration:
    """The model of the module docstring: ``R_SA`` (3, 3) A's axes in S, ``bias`` (3) in A's axes
    and ``unit``, ``scale`` (> 0), ``unit`` one of ``UNITS``. The identity calibration (defaults) is
    an accelerometer with S's axes reporting m/s² without a bias."""

    R_SA: np.ndarray = dataclasses.field(default_factory=lambda: np.eye(3))
    bias: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(3))
    scale: float = 1.0
    unit: str = "m/s^2"

    def __post_init__(self):
        object.__setattr__(self, "R_SA", checked_rotation("the accelerometer's R_SA", self.R_SA))
        bias = np.asarray(self.bias, dtype=float)
        if bias.shape != (3,) or not np.isfinite(bias).all():
            raise ValueError(f"the accelerometer's bias needs 3 finite numbers (its own axes and unit); "
                             f"got {self.bias}")
        object.__setattr__(self, "bias", bias)
        if not (np.isfinite(self.scale) and self.scale > 0.0):
            raise ValueError(f"the accelerometer's scale must be finite and > 0; got {self.scale}")
        object.__setattr__(self, "scale", float(self.scale))
        unit_factor(self.unit)

    @property
    def meters_per_second_squared(self) -> float:
        """m/s² per unit of the reading."""
        return UNITS[self.unit]

    def to_sensor_axes(self, reading) -> np.ndarray:
        """The specific force (or gravity-free acceleration) in S, m/s², (3,) or (N, 3), of ``reading``
        (same shape, A's axes and unit)."""
        reading = np.asarray(reading, dtype=float)
        return (reading - self.bias) @ self.R_SA.T * (self.meters_per_second_squared / self.scale)

    def reading_of(self, specific_force_S) -> np.ndarray:
        """What the accelerometer reports, (3,) or (N, 3), for ``specific_force_S`` (m/s², in S)."""
        specific_force_S = np.asarray(specific_force_S, dtype=float)
        return specific_force_S @ self.R_SA * (self.scale / self.meters_per_second_squared) + self.bias

    def as_dict(self) -> dict:
        """Plain lists and numbers (YAML, JSON)."""
        return {"R_SA": self.R_SA.tolist(), "bias": self.bias.tolist(), "scale": self.scale, "unit": self.unit}


@dataclasses.dataclass(frozen=True)
class GravityFit:
    """``fit_to_gravity``'s result: the ``calibration``, the RMS over poses and axes of the reading's
    residual (its unit), and the poses' gravity spread (``MIN_GRAVITY_SPREAD``)."""

    calibration: AccelerometerCalibration
    residual_rms: float
    gravity_spread: float


def fit_to_gravity(readings, gravity_S, unit: str = "m/s^2") -> GravityFit:
    """R_SA, bias and scale from N static poses: ``readings`` (N, 3) in A's axes and ``unit``, and
    the gravity ``gravity_S`` (N, 3; m/s², in S) of each pose. Least squares over
    Σ|r_i − scale·R_SAᵀ(−g_i)/u − bias|² in closed form (Umeyama 1991). Raises ValueError when the
    poses cannot determine it: fewer than 3, or gravity directions along one line."""
    u = unit_factor(unit)
    readings = np.asarray(readings, dtype=float)
    gravity_S = np.asarray(gravity_S, dtype=float)
    if readings.ndim != 2 or readings.shape[1] != 3 or gravity_S.shape != readings.shape:
        raise ValueError(f"static poses: the accelerometer readings {readings.shape} and the gravity {gravity_S.shape} "
                         "need one row of 3 per pose each")
    if not (np.isfinite(readings).all() and np.isfinite(gravity_S).all()):
        raise ValueError("static poses: an accelerometer reading or a gravity vector is NaN or inf")
    count = len(readings)
    if count < 3:
        raise ValueError(f"static poses: the accelerometer's orientation, bias and scale need at least 3 poses with "
                         f"gravity in different directions; got {count}")
    x = -gravity_S / u                     # the specific force at rest, in S and the reading's unit
    y = readings
    x_mean, y_mean = x.mean(axis=0), y.mean(axis=0)
    X, Y = x - x_mean, y - y_mean
    directions = gravity_S / np.linalg.norm(gravity_S, axis=1, keepdims=True)
    spread = float(np.linalg.svd(directions - directions.mean(axis=0), compute_uv=False)[1] / np.sqrt(count))
    if spread < MIN_GRAVITY_SPREAD:
        raise ValueError(f"static poses: gravity's directions in S lie along one line (spread {spread:.3g} < "
                         f"{MIN_GRAVITY_SPREAD:g} across it), so a rotation of the accelerometer about it cannot be "
                         "seen: add poses with the sensor tilted about another axis")
    U, D, Vt = np.linalg.svd(Y.T @ X / count)   # covariance of reading (A) and specific force (S)
    flip = np.diag([1.0, 1.0, np.sign(np.linalg.det(U) * np.linalg.det(Vt))])
    R_AS = U @ flip @ Vt
    scale = float(np.trace(np.diag(D) @ flip) / np.mean(np.sum(X ** 2, axis=1)))
    bias = y_mean - scale * R_AS @ x_mean
    if not scale > 0.0:
        raise ValueError(f"static poses: the accelerometer's readings do not follow gravity (scale {scale:.3g}); "
                         "check that its columns and the poses' gravity belong to the same rows")
    calibration = AccelerometerCalibration(R_SA=R_AS.T, bias=bias, scale=scale, unit=unit)
    residual = readings - calibration.reading_of(-gravity_S)
    return GravityFit(calibration, float(np.sqrt(np.mean(residual ** 2))), spread)


def rotation_angle(R_a, R_b) -> float:
    """The angle (rad) of the rotation between two rotation matrices."""
    cosine = (np.trace(np.asarray(R_a, dtype=float).T @ np.asarray(R_b, dtype=float)) - 1.0) / 2.0
    return float(np.arccos(np.clip(cosine, -1.0, 1.0)))
