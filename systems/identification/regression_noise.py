"""The sensors' noise and what it puts into the regression of Kubus & Wahl's Eq. 8.

``NoiseLevels`` states the RMS noise of the wrench and of the accelerometer's signals; the
functions here carry it through the regressor V(a, α, ω, g) of ``load_dynamics``: the
covariance of a sample's equation error, and the expected Gram matrix of the noise in V's
columns that total least squares and errors-in-variables estimation correct for
(``batch_estimation``, ``recursive_estimation``). Signals in the sensor frame S; units as
``load_dynamics`` (docs/design.md §4).
"""

import dataclasses
import math

import numpy as np

from heft.systems.load_dynamics import regressor


@dataclasses.dataclass
class NoiseLevels:
    """RMS noise per axis of the measured signals; defaults are docs/design.md §6's sensor model.
    Loadable with ``yaml_load_typed``; the estimators check it (``checked``) when they take it.

    force (N) and torque (N·m) of the wrench; linear_acceleration (m/s²) and
    angular_acceleration (rad/s²) of the accelerometer; angular_velocity (rad/s), derived
    from encoders, 0 meaning exact.
    """

    force: float = 0.1
    torque: float = 0.005
    linear_acceleration: float = 0.05
    angular_acceleration: float = 0.5
    angular_velocity: float = 0.0

    def __post_init__(self):
        self.checked()

    def checked(self) -> "NoiseLevels":
        """Returns self, or raises ValueError naming a negative, non-finite or zero-wrench level."""
        for field in dataclasses.fields(self):
            value = getattr(self, field.name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"noise.{field.name} must be finite and >= 0; got {value}")
        if self.force == 0.0 or self.torque == 0.0:
            raise ValueError("noise.force and noise.torque must be > 0 (they weight the wrench rows)")
        return self

    def wrench_weights(self) -> np.ndarray:
        """Inverse noise variances of [fx, fy, fz, τx, τy, τz] (1/N², 1/(N·m)²)."""
        return np.repeat([self.force ** -2, self.torque ** -2], 3)


def _regressor_derivatives():
    """V is affine in a and α and quadratic in ω: returns ∂V/∂a_l and ∂V/∂α_l (constant,
    (3, 6, 10) each) and H[l, m] = ∂²V/∂ω_l∂ω_m ((3, 3, 6, 10)), so ∂V/∂ω_l = Σ_m ω_m H[l, m]."""
    zero, eye = np.zeros(3), np.eye(3)
    d_a = np.array([regressor(e, zero, zero, zero) for e in eye])
    d_alpha = np.array([regressor(zero, e, zero, zero) for e in eye])
    quadratic = [[regressor(zero, zero, eye[l] + eye[m], zero) for m in range(3)] for l in range(3)]
    pure = [regressor(zero, zero, e, zero) for e in eye]
    hessian = np.array([[quadratic[l][m] - pure[l] - pure[m] for m in range(3)] for l in range(3)])
    return d_a, d_alpha, hessian


_DV_DA, _DV_DALPHA, _D2V_DOMEGA2 = _regressor_derivatives()


def wrench_motion_jacobian(phi) -> np.ndarray:
    """∂(V·φ)/∂[a; α] (6, 6): how the load's wrench moves with S's accelerations. V is affine in
    a and α, so it does not depend on the motion."""
    phi = np.asarray(phi, dtype=float)
    return np.hstack(((_DV_DA @ phi).T, (_DV_DALPHA @ phi).T))


def motion_variances(noise: NoiseLevels) -> np.ndarray:
    """Variances of the accelerometer's [a; α] per axis ((m/s²)², (rad/s²)²)."""
    return np.repeat([noise.linear_acceleration ** 2, noise.angular_acceleration ** 2], 3)


def equation_error_covariance(phi, noise: NoiseLevels) -> np.ndarray:
    """Covariance (6, 6) of f − V(a, α, ω, g)·φ − o per sample when the wrench and the
    accelerometer's a, α carry white noise: Σ_f + J Σ_x Jᵀ, J = ``wrench_motion_jacobian(phi)``
    (N², N²·m, (N·m)²). The same for every sample: V is affine in a and α."""
    J = wrench_motion_jacobian(phi)
    return np.diag(1.0 / noise.wrench_weights()) + (J * motion_variances(noise)) @ J.T


def noise_gram_terms(noise: NoiseLevels, weights: np.ndarray):
    """First-order expected Gram matrix of the kinematic noise in the row-weighted V (rows
    scaled by √weights): over n samples with Ω = Σ ω ωᵀ it is
    n·Σ_k N_k + (Ω.ravel() @ K).reshape(10, 10). Returns (N_k (6, 10, 10), the per-sample
    covariance of wrench axis k's row from the a and α noise, and K (9, 100))."""
    axes = (noise.linear_acceleration ** 2 * np.einsum("lki,k,lkj->kij", _DV_DA, weights, _DV_DA)
            + noise.angular_acceleration ** 2 * np.einsum("lki,k,lkj->kij", _DV_DALPHA, weights, _DV_DALPHA))
    k = noise.angular_velocity ** 2 * np.einsum(
        "lmki,k,lnkj->mnij", _D2V_DOMEGA2, weights, _D2V_DOMEGA2)
    return axes, k.reshape(9, 100)


def require_kinematic_noise(noise: NoiseLevels, method: str):
    if noise.linear_acceleration == 0.0 or noise.angular_acceleration == 0.0:
        raise ValueError(f"{method} needs noise.linear_acceleration and noise.angular_acceleration > 0 "
                         "(with noise-free kinematics total least squares is least squares: use OLS/RLS)")
