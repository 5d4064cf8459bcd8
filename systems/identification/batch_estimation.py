"""Batch estimation of a load's inertial parameters and the sensor's offsets (Kubus & Wahl, Sec. IV).

Plain numpy/scipy, no Drake types. Conventions as in ``load_dynamics`` (docs/design.md §4): all
signals in the sensor frame S; the wrench [f; τ] (N, N·m) is what the sensor exerts on the
load; a, α, ω, g in m/s², rad/s², rad/s, m/s². The unknowns are θ = [offsets (6); φ (10)]
(Eq. 7), with measured wrench = offsets + V(a, α, ω, g)·φ (Eqs. 8, 13), or φ alone.
``batch_estimate``: OLS, WLS, TLS or errors-in-variables maximum likelihood over a record →
``Estimate``; which parameters the record determines as ``identifiability`` says, the noise
model as ``regression_noise`` states it. The recursive estimators are in ``recursive_estimation``.
"""

import dataclasses

import numpy as np
import scipy.linalg
from scipy.linalg import block_diag, solve_triangular

from heft.systems.identification.identifiability import ScaledSVD, check_rcond, mask_unidentifiable, restricted_inverse
from heft.systems.load_dynamics import (
    PARAMETER_NAMES, PHI_NAMES, InertialParameters, regressor, regressor_with_offsets, with_offsets)
from heft.systems.identification.regression_noise import (
    NoiseLevels, equation_error_covariance, motion_variances, noise_gram_terms, require_kinematic_noise,
    wrench_motion_jacobian)

METHODS = ("ols", "wls", "tls", "eiv_ml")
# method="eiv_ml" iterates until its Newton step would move the estimate by less than
# √(this) standard deviations, at most this many times, halving a step at most this often.
_EIV_ML_TOLERANCE = 1e-12
_EIV_ML_MAX_ITERATIONS = 200
_EIV_ML_MAX_HALVINGS = 40
_DJ_DPHI = np.array([wrench_motion_jacobian(e) for e in np.eye(10)])  # (10, 6, 6): J = Σ_j φ_j·_DJ_DPHI[j]


def _batch_inputs(wrench, a, alpha, omega, g):
    """The five arrays as float (N, 6) and (N, 3) (a (3,) kinematic input is held constant)."""
    wrench = np.asarray(wrench, dtype=float)
    if wrench.ndim != 2 or wrench.shape[1] != 6:
        raise ValueError(f"wrench must have shape (N, 6), one [f; τ] row per sample; got {wrench.shape}")
    n = wrench.shape[0]
    arrays = {"wrench": wrench}
    for name, value in (("a", a), ("alpha", alpha), ("omega", omega), ("g", g)):
        x = np.asarray(value, dtype=float)
        if x.shape == (3,):
            x = np.broadcast_to(x, (n, 3))
        elif x.shape != (n, 3):
            raise ValueError(f"{name} must have shape ({n}, 3) to match wrench, or (3,) for a constant; "
                             f"got {x.shape}")
        arrays[name] = x
    for name, x in arrays.items():
        bad = np.flatnonzero(~np.isfinite(x).all(axis=1))
        if bad.size:
            raise ValueError(f"{name} has NaN or inf in {bad.size} sample(s) (first rows {bad[:5].tolist()}); "
                             "drop those samples from every array before estimating")
    return tuple(arrays.values())



def stack(wrench, a, alpha, omega, g, offsets=True):
    """The stacked regression (A, y): A (6N, 16) = [E₆ V] per sample (Eq. 8), or (6N, 10) = V
    when ``offsets`` is False; y (6N,) the wrenches. Rows are sample-major, [f; τ] per sample."""
    wrench, a, alpha, omega, g = _batch_inputs(wrench, a, alpha, omega, g)
    A = regressor_with_offsets(a, alpha, omega, g) if offsets else regressor(a, alpha, omega, g)
    return A.reshape(-1, A.shape[-1]), wrench.reshape(-1)



@dataclasses.dataclass(frozen=True)
class Estimate:
    """A batch estimate. ``phi`` (10,) per Eq. 6; ``offsets`` (6,) [f_o; τ_o] (N, N·m), zeros
    when not estimated; ``covariance`` (16×16 offsets first, or 10×10) in the parameters'
    units; ``identifiable`` the matching bool mask (``identifiability``);
    ``residual_rms`` (6,) per wrench axis (N, N·m); ``condition_number`` of the row-weighted,
    column-scaled regressor (inf if rank deficient)."""

    phi: np.ndarray
    offsets: np.ndarray
    covariance: np.ndarray
    identifiable: np.ndarray
    method: str
    num_samples: int
    residual_rms: np.ndarray
    condition_number: float

    def __post_init__(self):
        for name in ("phi", "offsets", "covariance", "identifiable", "residual_rms"):
            array = np.array(getattr(self, name))
            array.flags.writeable = False
            object.__setattr__(self, name, array)

    @property
    def std(self) -> np.ndarray:
        """Standard deviations (sqrt of the covariance's diagonal; inf if unidentifiable)."""
        return np.sqrt(np.diag(self.covariance))

    @property
    def names(self) -> tuple[str, ...]:
        """The parameter names, in the order of ``covariance`` and ``identifiable``."""
        return PARAMETER_NAMES if len(self.identifiable) == 16 else PHI_NAMES

    @property
    def phi_identifiable(self) -> np.ndarray:
        return self.identifiable[-10:]

    def violations(self) -> list[str]:
        """Names every reason ``phi`` is not a trustworthy physical body (empty if none)."""
        problems = [f"{name} is not identifiable from these data"
                    for name, ok in zip(PHI_NAMES, self.phi_identifiable) if not ok]
        if self.phi_identifiable[0] and not self.phi[0] > 0.0:
            problems.append(f"mass {self.phi[0]:g} kg is not positive")
        elif not problems:
            problems += InertialParameters.from_phi(self.phi).violations()
        return problems

    def inertial_parameters(self) -> InertialParameters:
        """The estimated body (mass, COM, inertia about the COM); raises ValueError when some
        entry of φ is not identifiable or the mass is not positive. The body may still violate
        the triangle inequalities: check ``violations()`` or use ``project_to_physical``."""
        unidentified = [name for name, ok in zip(PHI_NAMES, self.phi_identifiable) if not ok]
        if unidentified:
            raise ValueError(f"cannot form a body: {', '.join(unidentified)} not identifiable from these "
                             "data; excite the load more (rotation about several axes) or fix them")
        if not self.phi[0] > 0.0:
            raise ValueError(f"cannot form a body: estimated mass {self.phi[0]:g} kg is not positive")
        return InertialParameters.from_phi(self.phi)


def batch_estimate(wrench, a, alpha, omega, g, method="ols", offsets=True, weights=None, *,
                   noise: NoiseLevels | None = None, rcond: float = 1e-6) -> Estimate:
    """Estimates φ (and the offsets) from N samples: ``wrench`` (N, 6) [f; τ] exerted by the
    sensor on the load, ``a``, ``alpha``, ``omega``, ``g`` (N, 3) or (3,), all in S.

    ``method``:

    * "ols": ordinary least squares. Its covariance is the sandwich
      (VᵀV)⁺ Vᵀ Σ̂ V (VᵀV)⁺ with per-axis residual variances Σ̂ (force and torque noise differ
      by orders of magnitude, so one pooled σ̂² would be wrong); it reduces to σ̂²(VᵀV)⁻¹ for
      equal noise.
    * "wls": rows weighted by ``weights`` (6,), per wrench axis (inverse noise variances,
      1/N² and 1/(N·m)²), or — when None — by the inverse per-axis residual variances of an
      OLS fit. Same sandwich covariance.
    * "tls": total least squares for noisy a and α (errors in variables), with the noise
      model ``noise`` (None: ``NoiseLevels()``). Offsets columns are exact, so they are eliminated first (mixed LS–TLS:
      per-axis centring). Rows are scaled by 1/σ per wrench axis, so the wrench column carries
      unit noise whether it holds N or N·m; then each column of V is scaled by the inverse
      RMS of the noise that a, α (and ω) put into it, from the first-order expected noise
      Gram matrix N of V's columns (built from ∂V/∂a, ∂V/∂α, ∂V/∂ω and ``noise``). Every
      column of the augmented matrix [V y] then carries unit noise, whatever its units
      (m/s², rad/s², rad²/s², N, N·m) — the assumption of classical TLS. (Precisely, the
      scaling is N's Cholesky factor restricted to the identifiable subspace; N is diagonal
      when ω is exact, and it is then a plain column scaling.) φ comes from the right
      singular vector of the smallest singular value of the scaled [V y]. This is consistent
      to first order in the kinematic noise. Covariance: the asymptotic sandwich of ``tls_covariance``
      (noise-corrected information VᵀWV − λN, λ the smallest squared singular value, per-axis
      equation-error variances, and the second-order term of the accelerations' noise).
    * "eiv_ml": maximum likelihood of the errors-in-variables model: white noise on the wrench
      and on the accelerometer's a and α (``noise``; ω must be exact), the true a, α unknown.
      Eliminating them leaves the negative log-likelihood Σ_k r_kᵀ W(φ)⁻¹ r_k,
      r_k = f_k − o − V_k φ, W = ``equation_error_covariance(φ, noise)``; the offsets'
      minimiser is the mean of f_k − V_k φ. Its gradient vanishes where
      (Σ_k V_kᵀW⁻¹V_k − Q(φ)) φ = Σ_k V_kᵀW⁻¹f_k (centred sums), Q_ji = tr(D_j Σ_x D_iᵀ M),
      M = Σ_k W⁻¹r_k r_kᵀW⁻¹, D_j = ∂J/∂φ_j, Σ_x the accelerometer's noise covariance: the
      term of W's dependence on φ, which removes the noise's share of the information.
      Solved by that fixed point with safeguarded steps (``_errors_in_variables_ml``),
      started from the TLS estimate (WLS's when a or α is exact); without Q (iterated
      generalised least squares) the result would keep least squares' bias towards zero.
      With noise-free a, α it is weighted least squares. Covariance: s²·(information − Q)⁻¹
      on θ (the errors-in-variables Cramér–Rao bound as the data estimate it), s² the
      minimised negative log-likelihood per degree of freedom (≈ 1 when ``noise`` is
      right). Raises ValueError when the motion excites φ not at all, or too little against
      the accelerometer's noise for the iteration to converge.

    ``rcond`` sets the identifiability tolerance (``identifiability``). Raises ValueError for
    shape mismatches, NaN/inf, fewer than p/6 + 1 samples, or an unknown method.
    """
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}; got {method!r}")
    noise = (noise or NoiseLevels()).checked()
    if weights is not None and method != "wls":
        raise ValueError(f"weights apply to method='wls' only; got method={method!r}")
    check_rcond(rcond)
    wrench, a, alpha, omega, g = _batch_inputs(wrench, a, alpha, omega, g)
    n, p = len(wrench), (16 if offsets else 10)
    if 6 * n <= p:
        raise ValueError(f"wrench has {n} sample(s); {p} unknowns need at least {p // 6 + 1} samples")
    if method == "tls":
        require_kinematic_noise(noise, "method='tls'")
    if method == "eiv_ml" and noise.angular_velocity > 0.0:
        raise ValueError("method='eiv_ml' models noise on a and α only; noise.angular_velocity must be 0 "
                         "(use method='tls' for a noisy ω)")
    V = regressor(a, alpha, omega, g)
    A = (with_offsets(V) if offsets else V).reshape(-1, p)
    y = wrench.reshape(-1)

    if method == "ols":
        row_scale = np.ones(6)
    elif method in ("tls", "eiv_ml"):
        row_scale = np.sqrt(noise.wrench_weights())
    elif weights is not None:
        weights = np.asarray(weights, dtype=float)
        if weights.shape != (6,) or not (np.isfinite(weights).all() and (weights > 0).all()):
            raise ValueError(f"weights must be 6 positive finite inverse variances per wrench axis; got {weights}")
        row_scale = np.sqrt(weights)
    else:
        row_scale = 1.0 / np.sqrt(_least_squares(A, y, np.ones(6), n, rcond).axis_variance)

    if method == "tls":
        Aw = A * np.tile(row_scale, n)[:, None]
        svd = ScaledSVD.of(Aw, rcond)
        phi, noise_axes, noise_v, eigenvalue = _total_least_squares(V, wrench, omega, offsets, noise, rcond)
        theta = np.concatenate((np.mean(wrench - V @ phi, axis=0), phi)) if offsets else phi
        residual_w = ((y - A @ theta) * np.tile(row_scale, n)).reshape(n, 6)
        error_variance = np.sum(residual_w ** 2, axis=0) / max(n - svd.rank / 6, 1.0)
        Aw = Aw.reshape(n, 6, p)
        covariance = tls_covariance(np.einsum("nki,nkj->kij", Aw, Aw), error_variance, noise_axes, noise_v,
                                     phi, n, eigenvalue, svd.basis)
    elif method == "eiv_ml":
        svd = ScaledSVD.of(A * np.tile(row_scale, n)[:, None], rcond)
        if noise.linear_acceleration > 0.0 and noise.angular_acceleration > 0.0:
            start = _total_least_squares(V, wrench, omega, offsets, noise, rcond)[0]
        else:
            start = _least_squares(A, y, row_scale, n, rcond).theta[-10:]
        theta, information, objective = _errors_in_variables_ml(V, wrench, offsets, noise, rcond, start)
        inverse = restricted_inverse(information, svd.basis)
        covariance = None if inverse is None else objective / max(6 * n - svd.rank, 1) * inverse
    else:
        fit = _least_squares(A, y, row_scale, n, rcond)
        theta, covariance, svd = fit.theta, fit.covariance, fit.svd

    residual = (y - A @ theta).reshape(n, 6)
    return Estimate(
        phi=theta[-10:], offsets=theta[:6] if offsets else np.zeros(6),
        covariance=mask_unidentifiable(covariance, svd.identifiable),
        identifiable=svd.identifiable, method=method, num_samples=n,
        residual_rms=np.sqrt(np.mean(residual ** 2, axis=0)),
        condition_number=svd.condition_number)


@dataclasses.dataclass(frozen=True)
class _LeastSquaresFit:
    theta: np.ndarray
    covariance: np.ndarray
    axis_variance: np.ndarray   # estimated noise variance per wrench axis (N², (N·m)²)
    svd: ScaledSVD


def _least_squares(A, y, row_scale, n, rcond) -> _LeastSquaresFit:
    """Row-weighted least squares (weights row_scale² per wrench axis) via the column-scaled
    SVD, minimum-norm in unidentifiable directions, with the sandwich covariance.

    The per-axis noise variances σ_l² are estimated without bias from the per-axis residual
    sums of squares: with M = E − UUᵀ the residual maker, E[RSS_k] = Σ_l Q_kl σ_l²,
    Q_kl = Σ_{i∈k, j∈l} M_ij² = δ_kl(N − 2 tr G_k) + ⟨G_k, G_l⟩, G_k = U_kᵀU_k over axis k's
    rows. (Simply dividing RSS_k by its degrees of freedom would let the large force noise
    leak into the torque axes' estimate through the hat matrix.)"""
    rows = np.tile(row_scale, n)
    svd = ScaledSVD.of(A * rows[:, None], rcond)
    r = svd.rank
    gain = svd.basis / svd.s[:r]                      # D V_r S⁻¹, (p, r)
    theta = gain @ (svd.U.T @ (y * rows))
    residual_w = ((y - A @ theta) * rows).reshape(n, 6)
    U = svd.U.reshape(n, 6, r)
    grams = np.einsum("nki,nkj->kij", U, U)
    Q = np.diag(n - 2.0 * np.einsum("kii->k", grams)) + np.einsum("kij,lij->kl", grams, grams)
    weighted_variance = np.linalg.lstsq(Q, np.sum(residual_w ** 2, axis=0), rcond=None)[0]
    floor = 1e-24 * np.mean((y * rows).reshape(n, 6) ** 2, axis=0) + 1e-300
    weighted_variance = np.maximum(weighted_variance, floor)
    middle = (svd.U * np.tile(weighted_variance, n)[:, None]).T @ svd.U
    return _LeastSquaresFit(theta, gain @ middle @ gain.T, weighted_variance / row_scale ** 2, svd)


def tls_covariance(axis_information, axis_error_variance, noise_axes, noise_v, phi, count, eigenvalue,
                    basis):
    """Asymptotic covariance of the (generalized) TLS estimate, as a sandwich H₀⁻¹ B H₀⁻¹ on the
    identifiable subspace: H₀ = Σ_k G_k − λN (noise-corrected information, G_k the row-weighted
    information of wrench axis k) and B = Σ_k σ²_e,k G_k + count·Σ_k (N_kφ)(N_kφ)ᵀ, the
    variance of the estimating equation with per-axis equation-error variances σ²_e,k; its last
    term (Gleser's second-order term) matters when the accelerations' noise is comparable to
    their signal. The ω noise is left out of that term. None if H₀ is not positive definite."""
    p = axis_information.shape[1]
    information = axis_information.sum(axis=0)
    information[-10:, -10:] -= eigenvalue * noise_v
    inverse = restricted_inverse(information, basis)
    if inverse is None:
        return None
    spread = np.einsum("k,kij->ij", axis_error_variance, axis_information)
    pulled = noise_axes @ phi
    spread[p - 10:, p - 10:] += count * pulled.T @ pulled
    return inverse @ spread @ inverse


def _total_least_squares(V, wrench, omega, offsets, noise, rcond):
    """Mixed LS–TLS for φ (see ``batch_estimate``). Returns (φ, per-axis row noise covariances
    N_k (6, 10, 10), noise Gram N_V of the row-weighted V (10×10), smallest generalized
    eigenvalue λ)."""
    n = len(wrench)
    row_scale = np.sqrt(noise.wrench_weights())
    Vw, yw = V * row_scale[:, None], wrench * row_scale
    if offsets:
        Vw, yw = Vw - Vw.mean(axis=0), yw - yw.mean(axis=0)
    Ac, bc = Vw.reshape(-1, 10), yw.reshape(-1)
    svd = ScaledSVD.of(Ac, rcond)
    if svd.rank == 0:
        raise ValueError("the data excite none of phi's directions; nothing to estimate")
    basis = svd.basis
    noise_axes, k = noise_gram_terms(noise, row_scale ** 2)
    noise_v = n * noise_axes.sum(axis=0) + ((omega.T @ omega).ravel() @ k).reshape(10, 10)
    factor = np.linalg.cholesky(block_diag(basis.T @ noise_v @ basis, 6.0 * n))
    whitened = solve_triangular(factor, np.column_stack((Ac @ basis, bc)).T, lower=True).T
    _, singular_values, right = np.linalg.svd(whitened, full_matrices=False)
    direction = solve_triangular(factor, right[-1], lower=True, trans="T")
    if abs(direction[-1]) <= 1e-12 * np.linalg.norm(direction):
        raise ValueError("total least squares has no solution for these data (the smallest singular "
                         "vector has no wrench component); use method='ols' or 'wls'")
    return basis @ (-direction[:-1] / direction[-1]), noise_axes, noise_v, singular_values[-1] ** 2


class _EivLikelihood:
    """The concentrated negative log-likelihood of ``batch_estimate(method="eiv_ml")`` at one φ,
    from the second moments (6, 11, 6, 11) of the samples' [V_k f_k] (centred when the offsets
    are estimated): ``objective`` Σ_k r_kᵀW⁻¹r_k, ``W_inv``, ``information`` Σ V_kᵀW⁻¹V_k,
    ``corrected`` = information − Q, and ``pull`` = Σ V_kᵀW⁻¹r_k + Qφ (minus half the gradient)."""

    def __init__(self, moments: np.ndarray, phi: np.ndarray, noise: NoiseLevels):
        self.phi = phi
        self.W_inv = np.linalg.inv(equation_error_covariance(phi, noise))
        v = np.append(-phi, 1.0)
        scatter = np.einsum("aibj,i,j->ab", moments, v, v)                  # Σ_k r_k r_kᵀ
        self.objective = float(np.sum(self.W_inv * scatter))
        self.information = np.einsum("ab,aibj->ij", self.W_inv, moments[:, :10, :, :10])
        Q = np.einsum("jab,b,icb,ca->ji", _DJ_DPHI, motion_variances(noise), _DJ_DPHI,
                      self.W_inv @ scatter @ self.W_inv)
        self.corrected = self.information - Q
        self.pull = np.einsum("ab,aibj,j->i", self.W_inv, moments[:, :10], v) + Q @ phi


def _errors_in_variables_ml(V, wrench, offsets, noise, rcond, start):
    """Maximum likelihood of θ under noise on the wrench and on a, α (see ``batch_estimate``),
    iterated from φ = ``start``. Each step solves the fixed-point equation's linearisation,
    (information − Q)·Δφ = pull, or, where information − Q is not positive definite (far from
    the optimum, weak excitation), the preconditioned gradient step information·Δφ = pull;
    both descend, and the step is halved until the likelihood does not fall. Returns (θ,
    information of θ (p, p) with Q removed, minimised Σ_k r_kᵀ W⁻¹ r_k (dimensionless))."""
    n = len(wrench)
    X = np.concatenate((V, wrench[:, :, None]), axis=2)        # r_k = X_k·[−φ; 1]
    row_scale = np.sqrt(noise.wrench_weights())[:, None]
    norms = np.linalg.norm((V * row_scale).reshape(-1, 10), axis=0)
    if offsets:
        X = X - X.mean(axis=0)           # the offsets' ML value is the mean of r_k, whatever φ and W
    moments = (X.reshape(n, 66).T @ X.reshape(n, 66)).reshape(6, 11, 6, 11)
    # Columns scaled by their uncentred norms: a column that centring leaves in rounding is unexcited.
    svd = ScaledSVD.of((X[:, :, :10] * row_scale).reshape(-1, 10), rcond, norms)
    if svd.rank == 0:
        raise ValueError("the data excite none of phi's directions; nothing to estimate")
    basis = svd.basis
    z = np.linalg.lstsq(basis, start, rcond=None)[0]
    here = _EivLikelihood(moments, basis @ z, noise)
    for _ in range(_EIV_ML_MAX_ITERATIONS):
        try:
            factor, newton = scipy.linalg.cho_factor(basis.T @ here.corrected @ basis), True
        except np.linalg.LinAlgError:
            factor, newton = scipy.linalg.cho_factor(basis.T @ here.information @ basis), False
        step = scipy.linalg.cho_solve(factor, basis.T @ here.pull)
        decrement = step @ basis.T @ here.pull       # ≈ the distance to the optimum², in units of σ²
        slack = _EIV_ML_TOLERANCE * max(here.objective, 6.0 * n)
        if newton and decrement <= _EIV_ML_TOLERANCE * max(here.objective / (6.0 * n), 1.0):
            break
        for _ in range(_EIV_ML_MAX_HALVINGS):
            trial = _EivLikelihood(moments, basis @ (z + step), noise)
            if trial.objective <= here.objective + slack:
                break
            step /= 2.0
        else:
            raise ValueError("method='eiv_ml' found no descent: the motion excites phi too little against the "
                             "accelerometer's noise; excite the load more or check the noise levels")
        z, here = z + step, trial
    else:
        raise ValueError(f"method='eiv_ml' did not converge in {_EIV_ML_MAX_ITERATIONS} iterations: the motion "
                         "excites phi too little against the accelerometer's noise; excite the load more or "
                         "check the noise levels")
    if not offsets:
        return here.phi, here.corrected, here.objective
    mean_v = V.mean(axis=0)
    full = np.empty((16, 16))
    full[:6, :6] = n * here.W_inv
    full[:6, 6:] = n * here.W_inv @ mean_v
    full[6:, :6] = full[:6, 6:].T
    full[6:, 6:] = here.corrected + n * mean_v.T @ here.W_inv @ mean_v
    return np.concatenate((np.mean(wrench - V @ here.phi, axis=0), here.phi)), full, here.objective
