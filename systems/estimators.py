"""Estimating a load's inertial parameters and the sensor's offsets (Kubus & Wahl, Sec. IV).

Plain numpy/scipy, no Drake types. Conventions as in ``load_dynamics`` (DESIGN §4): all
signals in the sensor frame S; the wrench [f; τ] (N, N·m) is what the sensor exerts on the
load; a, α, ω, g in m/s², rad/s², rad/s, m/s². The unknowns are θ = [offsets (6); φ (10)]
(Eq. 7), with measured wrench = offsets + V(a, α, ω, g)·φ (Eqs. 8, 13), or φ alone.

* ``batch_estimate``: OLS, WLS, TLS or errors-in-variables maximum likelihood over a record
  → ``Estimate``.
* ``RecursiveLeastSquares``, ``RecursiveInstrumentalVariables``,
  ``RecursiveTotalLeastSquares``: one sample per ``update``, cheap enough for a 2 kHz loop;
  each keeps its whole state in one flat vector (``state_vector``) so that a Drake system
  can hold it as discrete state.
* ``project_to_physical``: physical consistency (Wensing et al. 2017; ``load_dynamics.pseudo_inertia``).

Identifiability. A parameter is identifiable iff its unit vector lies in the row space of the
data: its component in the span of the unidentifiable directions is at most 1e-6. Which
directions are unidentifiable:

* batch: the columns of the row-weighted regressor are scaled to unit norm (so the test does
  not depend on units) and a direction is unidentifiable when its singular value is below
  ``rcond`` (default 1e-6) times the largest;
* RLS and RIV: along the eigenvectors of the (instruments') information, read from its
  square root, the data's information is at most the prior's (1/initial_covariance) or below
  rcond² times the largest;
* RTLS: the centred information C of φ, scaled by 1/√(C_jj + N_jj) with N the expected
  information of the kinematic noise, has an eigenvalue of at most rcond (a vanishing
  fraction of one noise unit: never excited, or faded by forgetting); the offsets share
  those directions through the means.

An unidentifiable parameter keeps the minimum-norm value (batch, in the scaled coordinates:
0 for a column that was never excited) or its last value (recursive), and gets infinite
variance and NaN covariances: never a confident-looking number. This is a property of the
regressor *as measured*: a column excited only by accelerometer noise counts as excited,
and least squares then biases it towards zero (errors in variables: use TLS, RIV or eiv_ml).
"""

import abc
import copy
import dataclasses
import math

import numpy as np
import scipy.linalg
from scipy.linalg import block_diag, lapack, solve_triangular

from heft.systems.load_dynamics import (
    OFFSET_NAMES, PHI_NAMES, InertialParameters, inertia_entries, pseudo_inertia, regressor)

PARAMETER_NAMES = OFFSET_NAMES + PHI_NAMES
METHODS = ("ols", "wls", "tls", "eiv_ml")
# A parameter is identifiable iff its component in the unidentifiable subspace is below this.
_COMPONENT_TOL = 1e-6
# Forgetting drives the entries of unexcited directions towards zero and, in the end, into
# subnormal numbers, which x86 processes ~100× slower. Every _FLUSH_INTERVAL samples, state
# entries smaller than _FLUSH_BELOW in magnitude (far below any meaningful value) become 0;
# at λ ≥ 0.5 none can decay from _FLUSH_BELOW to subnormal (1e-308) in between.
_FLUSH_INTERVAL = 256
_FLUSH_BELOW = 1e-200
# method="eiv_ml" iterates until its Newton step would move the estimate by less than
# √(this) standard deviations, at most this many times, halving a step at most this often.
_EIV_ML_TOLERANCE = 1e-12
_EIV_ML_MAX_ITERATIONS = 200
_EIV_ML_MAX_HALVINGS = 40


@dataclasses.dataclass
class NoiseLevels:
    """RMS noise per axis of the measured signals; defaults are DESIGN §6's sensor model.
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


_DJ_DPHI = np.array([wrench_motion_jacobian(e) for e in np.eye(10)])  # (10, 6, 6): J = Σ_j φ_j·_DJ_DPHI[j]


def _motion_variances(noise: NoiseLevels) -> np.ndarray:
    """Variances of the accelerometer's [a; α] per axis ((m/s²)², (rad/s²)²)."""
    return np.repeat([noise.linear_acceleration ** 2, noise.angular_acceleration ** 2], 3)


def equation_error_covariance(phi, noise: NoiseLevels) -> np.ndarray:
    """Covariance (6, 6) of f − V(a, α, ω, g)·φ − o per sample when the wrench and the
    accelerometer's a, α carry white noise: Σ_f + J Σ_x Jᵀ, J = ``wrench_motion_jacobian(phi)``
    (N², N²·m, (N·m)²). The same for every sample: V is affine in a and α."""
    J = wrench_motion_jacobian(phi)
    return np.diag(1.0 / noise.wrench_weights()) + (J * _motion_variances(noise)) @ J.T


def _noise_gram_terms(noise: NoiseLevels, weights: np.ndarray):
    """First-order expected Gram matrix of the kinematic noise in the row-weighted V (rows
    scaled by √weights): over n samples with Ω = Σ ω ωᵀ it is
    n·Σ_k N_k + (Ω.ravel() @ K).reshape(10, 10). Returns (N_k (6, 10, 10), the per-sample
    covariance of wrench axis k's row from the a and α noise, and K (9, 100))."""
    axes = (noise.linear_acceleration ** 2 * np.einsum("lki,k,lkj->kij", _DV_DA, weights, _DV_DA)
            + noise.angular_acceleration ** 2 * np.einsum("lki,k,lkj->kij", _DV_DALPHA, weights, _DV_DALPHA))
    k = noise.angular_velocity ** 2 * np.einsum(
        "lmki,k,lnkj->mnij", _D2V_DOMEGA2, weights, _D2V_DOMEGA2)
    return axes, k.reshape(9, 100)


def _require_kinematic_noise(noise: NoiseLevels, method: str):
    if noise.linear_acceleration == 0.0 or noise.angular_acceleration == 0.0:
        raise ValueError(f"{method} needs noise.linear_acceleration and noise.angular_acceleration > 0 "
                         "(with noise-free kinematics total least squares is least squares: use OLS/RLS)")


# --- input checks ----------------------------------------------------------------

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


def _vector(name: str, value, size: int) -> np.ndarray:
    """``value`` as a finite float array of shape (size,), cheaply when it already is one."""
    if type(value) is not np.ndarray or value.dtype != np.float64 or value.shape != (size,):
        value = np.asarray(value, dtype=float)
        if value.shape != (size,):
            raise ValueError(f"{name} must have shape ({size},); got {value.shape}")
    if not math.isfinite(sum(value.tolist())):
        raise ValueError(f"{name} contains NaN or inf; skip this sample")
    return value


def _check_rcond(rcond: float):
    if not 0.0 < rcond < 1.0:
        raise ValueError(f"rcond must lie in (0, 1); got {rcond}")


def stack(wrench, a, alpha, omega, g, offsets=True):
    """The stacked regression (A, y): A (6N, 16) = [E₆ V] per sample (Eq. 8), or (6N, 10) = V
    when ``offsets`` is False; y (6N,) the wrenches. Rows are sample-major, [f; τ] per sample."""
    wrench, a, alpha, omega, g = _batch_inputs(wrench, a, alpha, omega, g)
    A = _with_offsets(regressor(a, alpha, omega, g)) if offsets else regressor(a, alpha, omega, g)
    return A.reshape(-1, A.shape[-1]), wrench.reshape(-1)


def _with_offsets(V: np.ndarray) -> np.ndarray:
    out = np.zeros(V.shape[:-1] + (16,))
    out[..., :6] = np.eye(6)
    out[..., 6:] = V
    return out


# --- identifiability and covariance helpers --------------------------------------

@dataclasses.dataclass(frozen=True)
class _ScaledSVD:
    """SVD of a matrix whose columns were scaled to unit norm: A·diag(scale) = U S Vᵀ."""

    scale: np.ndarray
    U: np.ndarray       # first ``rank`` left singular vectors
    s: np.ndarray       # all singular values, descending
    Vt: np.ndarray
    rank: int

    @classmethod
    def of(cls, A: np.ndarray, rcond: float, norms: np.ndarray | None = None) -> "_ScaledSVD":
        """``norms``: the column norms to scale by (default A's own)."""
        norms = np.linalg.norm(A, axis=0) if norms is None else norms
        scale = 1.0 / np.where(norms > 0.0, norms, 1.0)
        U, s, Vt = np.linalg.svd(A * scale, full_matrices=False)
        rank = int(np.count_nonzero(s > rcond * max(s[0], 1.0)))  # s[0] ≥ 1 for A's own norms
        return cls(scale, U[:, :rank], s, Vt, rank)

    @property
    def basis(self) -> np.ndarray:
        """(p, rank): the identifiable subspace in physical coordinates, D·V_r."""
        return self.scale[:, None] * self.Vt[:self.rank].T

    @property
    def identifiable(self) -> np.ndarray:
        return np.linalg.norm(self.Vt[self.rank:], axis=0) <= _COMPONENT_TOL

    @property
    def condition_number(self) -> float:
        """s_max/s_min, inf when some direction is unidentifiable (rank < p)."""
        return float(self.s[0] / self.s[-1]) if self.rank == len(self.s) else math.inf


def _root_excitation(root: np.ndarray, prior: float, rcond: float):
    """Excitation of an information R = H + prior·E (H from the data) given a square root S,
    SᵀS = R: S's SVD gives R's eigenvectors and eigenvalues σ² to full accuracy (S has half
    R's condition number), and H's eigenvalues along them are exactly σ² − prior. A direction
    is unidentifiable when its data information is at most the prior's, or below rcond² times
    the largest. Returns (identifiable mask, basis (p, r) of the identified subspace,
    reciprocal condition √(h_min/h_max), 0 when some direction is unidentifiable)."""
    _, sigma, vt = np.linalg.svd(root)
    data = sigma ** 2 - prior
    top = data.max()
    null = data <= max(prior, rcond ** 2 * top)
    identifiable = np.linalg.norm(vt[null], axis=0) <= _COMPONENT_TOL
    reciprocal_condition = 0.0 if null.any() else math.sqrt(data.min() / top)
    return identifiable, vt[~null].T, reciprocal_condition


def _null_excitation(null: np.ndarray):
    """(identifiable mask, orthonormal basis of the complement) for unidentifiable directions
    given as the columns of ``null`` (p, k)."""
    if null.shape[1] == 0:
        return np.ones(len(null), bool), np.eye(len(null))
    orthonormal = np.linalg.qr(null)[0]
    return np.linalg.norm(orthonormal, axis=1) <= _COMPONENT_TOL, scipy.linalg.null_space(orthonormal.T)


def _restricted_inverse(matrix: np.ndarray, basis: np.ndarray) -> np.ndarray | None:
    """basis (basisᵀ M basis)⁻¹ basisᵀ: the inverse of M on the identifiable subspace, or None
    if M is not positive definite there."""
    reduced = basis.T @ matrix @ basis
    try:
        factor = np.linalg.cholesky(0.5 * (reduced + reduced.T))
    except np.linalg.LinAlgError:
        return None
    half = solve_triangular(factor, basis.T, lower=True)
    return half.T @ half


def _mask_unidentifiable(covariance: np.ndarray | None, identifiable: np.ndarray) -> np.ndarray:
    """Infinite variance and NaN covariances for unidentifiable parameters (all of them when
    ``covariance`` is None: the data do not determine the estimate's spread)."""
    p = len(identifiable)
    if covariance is None:
        covariance, identifiable = np.zeros((p, p)), np.zeros(p, bool)
    covariance = 0.5 * (covariance + covariance.T)
    bad = ~identifiable
    covariance[bad, :] = np.nan
    covariance[:, bad] = np.nan
    covariance[bad, bad] = np.inf
    return covariance


# --- physical consistency ----------------------------------------------------------

def phi_from_pseudo_inertia(J) -> np.ndarray:
    """The inverse of ``pseudo_inertia``."""
    J = np.asarray(J, dtype=float)
    if J.shape != (4, 4):
        raise ValueError(f"J must have shape (4, 4); got {J.shape}")
    J = 0.5 * (J + J.T)
    second_moment = J[:3, :3]
    inertia = np.trace(second_moment) * np.eye(3) - second_moment
    return np.concatenate(([J[3, 3]], J[:3, 3], inertia_entries(inertia)))


def project_to_physical(phi, length_scale: float = 0.1, margin: float = 1e-6) -> np.ndarray:
    """The physically consistent φ nearest to ``phi``.

    "Nearest" is in the Frobenius norm of the length-scaled pseudo-inertia
    J_ℓ = L J L, L = diag(1/ℓ, 1/ℓ, 1/ℓ, 1), ℓ = ``length_scale`` (m): every entry of J_ℓ is
    in kg, so mass, first and second moments are weighed alike for a body of size ~ℓ. The
    nearest matrix in {J_ℓ ⪰ δ·E} is J_ℓ with its eigenvalues clipped from below at
    δ = margin·max|eig(J_ℓ)| (exact projection onto that convex set), mapped back to φ. The
    margin makes the result strictly physical: m > 0, inertia about the COM positive definite
    with strict triangle inequalities. A φ already in the set is returned unchanged.
    """
    if not (length_scale > 0.0 and math.isfinite(length_scale)):
        raise ValueError(f"length_scale must be a positive length in m; got {length_scale}")
    if not 0.0 < margin < 1.0:
        raise ValueError(f"margin must lie in (0, 1); got {margin}")
    phi = np.asarray(phi, dtype=float)
    J = pseudo_inertia(phi)
    if not np.isfinite(J).all():
        raise ValueError("phi contains NaN or inf")
    L = np.array([1.0 / length_scale] * 3 + [1.0])
    eigenvalues, vectors = np.linalg.eigh(J * L * L[:, None])
    delta = margin * np.abs(eigenvalues).max()
    if delta == 0.0:
        raise ValueError("phi is zero: there is no body to project")
    if eigenvalues[0] >= delta:
        return phi.copy()
    clipped = (vectors * np.maximum(eigenvalues, delta)) @ vectors.T
    return phi_from_pseudo_inertia(clipped / L / L[:, None])


# --- batch estimation ---------------------------------------------------------------

@dataclasses.dataclass(frozen=True)
class Estimate:
    """A batch estimate. ``phi`` (10,) per Eq. 6; ``offsets`` (6,) [f_o; τ_o] (N, N·m), zeros
    when not estimated; ``covariance`` (16×16 offsets first, or 10×10) in the parameters'
    units; ``identifiable`` the matching bool mask (see the module docstring);
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
      to first order in the kinematic noise. Covariance: the asymptotic sandwich of ``_tls_covariance``
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

    ``rcond`` sets the identifiability tolerance (module docstring). Raises ValueError for
    shape mismatches, NaN/inf, fewer than p/6 + 1 samples, or an unknown method.
    """
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}; got {method!r}")
    noise = (noise or NoiseLevels()).checked()
    if weights is not None and method != "wls":
        raise ValueError(f"weights apply to method='wls' only; got method={method!r}")
    _check_rcond(rcond)
    wrench, a, alpha, omega, g = _batch_inputs(wrench, a, alpha, omega, g)
    n, p = len(wrench), (16 if offsets else 10)
    if 6 * n <= p:
        raise ValueError(f"wrench has {n} sample(s); {p} unknowns need at least {p // 6 + 1} samples")
    if method == "tls":
        _require_kinematic_noise(noise, "method='tls'")
    if method == "eiv_ml" and noise.angular_velocity > 0.0:
        raise ValueError("method='eiv_ml' models noise on a and α only; noise.angular_velocity must be 0 "
                         "(use method='tls' for a noisy ω)")
    V = regressor(a, alpha, omega, g)
    A = (_with_offsets(V) if offsets else V).reshape(-1, p)
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
        svd = _ScaledSVD.of(Aw, rcond)
        phi, noise_axes, noise_v, eigenvalue = _total_least_squares(V, wrench, omega, offsets, noise, rcond)
        theta = np.concatenate((np.mean(wrench - V @ phi, axis=0), phi)) if offsets else phi
        residual_w = ((y - A @ theta) * np.tile(row_scale, n)).reshape(n, 6)
        error_variance = np.sum(residual_w ** 2, axis=0) / max(n - svd.rank / 6, 1.0)
        Aw = Aw.reshape(n, 6, p)
        covariance = _tls_covariance(np.einsum("nki,nkj->kij", Aw, Aw), error_variance, noise_axes, noise_v,
                                     phi, n, eigenvalue, svd.basis)
    elif method == "eiv_ml":
        svd = _ScaledSVD.of(A * np.tile(row_scale, n)[:, None], rcond)
        if noise.linear_acceleration > 0.0 and noise.angular_acceleration > 0.0:
            start = _total_least_squares(V, wrench, omega, offsets, noise, rcond)[0]
        else:
            start = _least_squares(A, y, row_scale, n, rcond).theta[-10:]
        theta, information, objective = _errors_in_variables_ml(V, wrench, offsets, noise, rcond, start)
        inverse = _restricted_inverse(information, svd.basis)
        covariance = None if inverse is None else objective / max(6 * n - svd.rank, 1) * inverse
    else:
        fit = _least_squares(A, y, row_scale, n, rcond)
        theta, covariance, svd = fit.theta, fit.covariance, fit.svd

    residual = (y - A @ theta).reshape(n, 6)
    return Estimate(
        phi=theta[-10:], offsets=theta[:6] if offsets else np.zeros(6),
        covariance=_mask_unidentifiable(covariance, svd.identifiable),
        identifiable=svd.identifiable, method=method, num_samples=n,
        residual_rms=np.sqrt(np.mean(residual ** 2, axis=0)),
        condition_number=svd.condition_number)


@dataclasses.dataclass(frozen=True)
class _LeastSquaresFit:
    theta: np.ndarray
    covariance: np.ndarray
    axis_variance: np.ndarray   # estimated noise variance per wrench axis (N², (N·m)²)
    svd: _ScaledSVD


def _least_squares(A, y, row_scale, n, rcond) -> _LeastSquaresFit:
    """Row-weighted least squares (weights row_scale² per wrench axis) via the column-scaled
    SVD, minimum-norm in unidentifiable directions, with the sandwich covariance.

    The per-axis noise variances σ_l² are estimated without bias from the per-axis residual
    sums of squares: with M = E − UUᵀ the residual maker, E[RSS_k] = Σ_l Q_kl σ_l²,
    Q_kl = Σ_{i∈k, j∈l} M_ij² = δ_kl(N − 2 tr G_k) + ⟨G_k, G_l⟩, G_k = U_kᵀU_k over axis k's
    rows. (Simply dividing RSS_k by its degrees of freedom would let the large force noise
    leak into the torque axes' estimate through the hat matrix.)"""
    rows = np.tile(row_scale, n)
    svd = _ScaledSVD.of(A * rows[:, None], rcond)
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


def _tls_covariance(axis_information, axis_error_variance, noise_axes, noise_v, phi, count, eigenvalue,
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
    inverse = _restricted_inverse(information, basis)
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
    svd = _ScaledSVD.of(Ac, rcond)
    if svd.rank == 0:
        raise ValueError("the data excite none of phi's directions; nothing to estimate")
    basis = svd.basis
    noise_axes, k = _noise_gram_terms(noise, row_scale ** 2)
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
        Q = np.einsum("jab,b,icb,ca->ji", _DJ_DPHI, _motion_variances(noise), _DJ_DPHI,
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
    svd = _ScaledSVD.of((X[:, :, :10] * row_scale).reshape(-1, 10), rcond, norms)
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


# --- recursive estimation --------------------------------------------------------------

class _RecursiveEstimator(abc.ABC):
    """Shared machinery of the recursive estimators: the whole state in one flat float vector
    (named views into it), preallocated work buffers, input checks, residual tracking."""

    def __init__(self, offsets: bool, forgetting: float, noise: NoiseLevels | None, rcond: float,
                 fields: dict[str, tuple[int, ...]]):
        if not 0.5 <= forgetting <= 1.0:
            raise ValueError(f"forgetting must lie in [0.5, 1] (a memory of at least 2 samples); got {forgetting}")
        _check_rcond(rcond)
        self._offsets = bool(offsets)
        self._p = 16 if offsets else 10
        self._forgetting = float(forgetting)
        noise = (noise or NoiseLevels()).checked()
        self._rcond = rcond
        self._row_scale = np.sqrt(noise.wrench_weights())
        self._row_scale_column = self._row_scale[:, None].copy()
        self._layout = {"theta": (self._p,), "count": (1,), "weight": (1,), "axis_moments": (6, 12, 12),
                        **fields}
        self._state = np.zeros(sum(math.prod(shape) for shape in self._layout.values()))
        self._bind_state_views()
        self._moment_rows = np.ones((6, 12))     # [1, V_k, y_k] per wrench axis k
        self._outer_rows = np.empty((6, 12, 12))
        self._residual_vectors = np.zeros((6, 12))

    def _bind_state_views(self) -> None:
        """self._<name> for each field of the layout: a view into self._state."""
        start = 0
        for name, shape in self._layout.items():
            size = math.prod(shape)
            setattr(self, "_" + name, self._state[start:start + size].reshape(shape))
            start += size

    def __deepcopy__(self, memo):
        """An independent copy whose fields are views into its own state (numpy's deepcopy of
        each attribute would cut them loose; Drake deep-copies the estimator it keeps as
        scratch in a cache entry)."""
        clone = copy.copy(self)
        for name, value in vars(self).items():
            if isinstance(value, np.ndarray):
                setattr(clone, name, value.copy(order="K"))
        clone._bind_state_views()
        return clone

    # --- state ---------------------------------------------------------------------
    def state_vector(self) -> np.ndarray:
        """A copy of the complete state (restore it with ``load_state_vector``); its first 16
        (or 10) entries are θ = [offsets; φ] (or φ)."""
        return self._state.copy()

    def load_state_vector(self, state) -> None:
        np.copyto(self._state, state)

    def reset(self) -> None:
        """Back to no data: θ = 0."""
        self._state[:] = 0.0

    # --- results -------------------------------------------------------------------
    @property
    def phi(self) -> np.ndarray:
        return self._theta[-10:].copy()

    @property
    def offsets(self) -> np.ndarray:
        """[f_o; τ_o] (N, N·m); zeros when offsets are not estimated."""
        return self._theta[:6].copy() if self._offsets else np.zeros(6)

    @property
    def num_samples(self) -> int:
        return int(self._count[0])

    @property
    def residual_rms(self) -> np.ndarray:
        """RMS per wrench axis of y − A·θ̂ over the forgetting-weighted data, θ̂ the current
        estimate (N, N·m): with forgetting 1, the batch residual of all samples. Computed from
        second moments, so it resolves down to ~1e-8 of the wrench's magnitude."""
        weight = self._weight[0]
        return np.sqrt(self._residual_sum_of_squares() / weight) if weight > 0.0 else np.zeros(6)

    @property
    def identifiable(self) -> np.ndarray:
        """Bool mask over the unknowns (offsets first when estimated); see the module docstring."""
        return self._excitation()[0]

    @property
    def condition_number(self) -> float:
        """√(h_max/h_min) of the data information (inf if some direction is unexcited)."""
        reciprocal = self._excitation()[2]
        return 1.0 / reciprocal if reciprocal > 0.0 else math.inf

    @property
    def covariance(self) -> np.ndarray:
        """Covariance of the unknowns (their units²), unidentifiable ones inf/NaN."""
        identifiable, basis, _ = self._excitation()
        return _mask_unidentifiable(self._covariance(basis), identifiable)

    @abc.abstractmethod
    def _excitation(self):
        """(identifiable mask, basis (p, r) of the identified subspace, reciprocal condition,
        0 when some direction is unidentifiable)."""

    @abc.abstractmethod
    def _covariance(self, basis: np.ndarray) -> np.ndarray | None:
        """Covariance of the unknowns restricted to ``basis`` (None before enough samples)."""

    def _axis_error_variance(self) -> np.ndarray | None:
        """Row-weighted residual variance per wrench axis (≈ 1 where the noise model fits), or
        None before there are more samples than unknowns."""
        dof = self._weight[0] - self._p / 6.0
        return self._residual_sum_of_squares() * self._row_scale ** 2 / dof if dof > 0.0 else None

    def _axis_information(self) -> np.ndarray:
        """(6, p, p): Σ λ^(t−i) w_k A_kᵀA_k, the row-weighted information of each wrench axis k
        (A_k = [e_kᵀ V_k] or V_k), from the per-axis second moments."""
        S = self._axis_moments[:, :11, :11] * (self._row_scale ** 2)[:, None, None]
        if not self._offsets:
            return S[:, 1:, 1:].copy()
        out = np.zeros((6, 16, 16))
        k = np.arange(6)
        out[k, k, k] = S[:, 0, 0]
        out[k, k, 6:] = S[:, 0, 1:]
        out[k, 6:, k] = S[:, 1:, 0]
        out[:, 6:, 6:] = S[:, 1:, 1:]
        return out

    # --- per-sample helpers ----------------------------------------------------------
    @staticmethod
    def _regressor(a, alpha, omega, g, what: str = "") -> np.ndarray:
        """V (6, 10) of one sample; ValueError (prefixed by ``what``) unless a, alpha, omega, g
        are finite and of shape (3,)."""
        try:
            V = regressor(a, alpha, omega, g)
        except ValueError as error:
            raise ValueError(f"{what}{error}") from None
        if V.shape != (6, 10):
            raise ValueError(f"{what}a, alpha, omega and g must each have shape (3,): one sample per update")
        return V

    def _track_residual(self, wrench: np.ndarray, V: np.ndarray) -> None:
        """Accumulates the per-axis second moments S_k = Σ λ^(t−i) m m ᵀ, m = [1, V_k, y_k],
        from which any estimate's residual follows; counts the sample; flushes tiny entries."""
        rows = self._moment_rows
        rows[:, 1:11] = V
        rows[:, 11] = wrench
        np.multiply(rows[:, :, None], rows[:, None, :], out=self._outer_rows)
        if self._forgetting != 1.0:
            self._axis_moments *= self._forgetting
        self._axis_moments += self._outer_rows
        self._count[0] += 1.0
        if self._count[0] % _FLUSH_INTERVAL == 0.0:
            self._state[np.abs(self._state) < _FLUSH_BELOW] = 0.0

    def _residual_sum_of_squares(self) -> np.ndarray:
        """Σ λ^(t−i) (y_k − o_k − V_kφ̂)² per wrench axis k, for the current θ̂."""
        v = self._residual_vectors
        if self._offsets:
            v[:, 0] = self._theta[:6]
        v[:, 1:11] = self._theta[-10:]
        v[:, 11] = -1.0
        return np.maximum(np.einsum("ki,kij,kj->k", v, self._axis_moments, v), 0.0)

    def _advance_weight(self) -> float:
        """Forgetting-weighted sample count s ← λs + 1; returns it."""
        self._weight[0] = self._forgetting * self._weight[0] + 1.0
        return self._weight[0]


class _InformationFormEstimator(_RecursiveEstimator):
    """RLS and RIV: square-root information with stabilized forgetting towards a prior
    R₀ = E/P₀. ``_weighted`` holds the current sample's rows [W^½A  W^½y] (6 × (p+1), the
    offsets block fixed)."""

    def __init__(self, offsets, forgetting, initial_covariance, noise, rcond, fields):
        if not (initial_covariance > 0.0 and math.isfinite(initial_covariance)):
            raise ValueError(f"initial_covariance must be positive and finite; got {initial_covariance}")
        super().__init__(offsets, forgetting, noise, rcond, fields)
        p = self._p
        self._prior = 1.0 / float(initial_covariance)
        self._weighted = np.zeros((6, p + 1))
        if offsets:
            self._weighted[:, :6] = np.diag(self._row_scale)
        self.reset()

    def _load_sample(self, wrench: np.ndarray, V: np.ndarray, into: np.ndarray) -> None:
        np.multiply(V, self._row_scale_column, out=into[:, self._p - 10:self._p])
        np.multiply(wrench, self._row_scale, out=into[:, self._p])


class RecursiveLeastSquares(_InformationFormEstimator):
    """Recursive weighted least squares: square-root information filter with stabilized
    forgetting.

    Information R = Σ λ^(t−i)·A_iᵀWA_i + prior and b = Σ λ^(t−i)·A_iᵀWy_i + prior·θ̂, with
    A_i = [E₆ V_i], W = diag(1/σ²) per wrench axis from ``noise`` and the prior
    R₀ = E/``initial_covariance``. The state is the upper-triangular square root
    [S z; 0 ρ] of the augmented information [R b; bᵀ ·] (SᵀS = R, Sᵀz = b); each update is one
    Householder QR (LAPACK geqrf) of the stacked rows [√λ·S √λ·z; c·E c·θ̂; W^½A W^½y],
    c = √((1−λ)/initial_covariance), then θ̂ solves the triangular S θ = z (trtrs).

    The forgetting (λ = ``forgetting``) is thus stabilized (Kulhavý & Zarrop, Int. J. Control
    1993): R ← λR + (1−λ)R₀ + AᵀWA and b ← λb + (1−λ)R₀θ̂ + AᵀWy. Hence R ⪰ R₀ at all times —
    in directions the motion stops exciting, information relaxes to the prior instead of to
    zero, so the covariance R⁻¹ stays below ``initial_covariance`` (no blow-up) and the
    estimate is held there (R₀θ̂ is re-added, not R₀θ₀). Working with S rather than R squares
    the attainable accuracy: R's condition number (steady information / prior, ~1e15 for
    λ = 0.999) would otherwise swamp the weakly informed directions in rounding error. R = SᵀS
    is symmetric positive definite by construction.
    """

    def __init__(self, offsets: bool = True, forgetting: float = 1.0, initial_covariance: float = 1e6,
                 noise: NoiseLevels | None = None, rcond: float = 1e-6):
        p = 16 if offsets else 10
        super().__init__(offsets, forgetting, initial_covariance, noise, rcond, {"root": (p + 1, p + 1)})
        stabilizing = self._forgetting < 1.0
        self._stack = np.zeros((p + 1 + (p if stabilizing else 0) + 6, p + 1), order="F")
        self._upper = np.triu(np.ones((p + 1, p + 1)))
        self._sqrt_forgetting = math.sqrt(self._forgetting)
        self._pull = math.sqrt((1.0 - self._forgetting) * self._prior)
        self._pull_rows = np.hstack((self._pull * np.eye(p), np.zeros((p, 1))))

    def reset(self) -> None:
        super().reset()
        self._root.flat[0:self._p * (self._p + 2):self._p + 2] = math.sqrt(self._prior)

    def start_from(self, theta) -> None:
        """No data, but the estimate ``theta`` ([offsets; φ] or φ) held by the prior: the
        information is reset, the estimate kept where the data will not say otherwise (a
        covariance reset, e.g. on a known change of load)."""
        theta = _vector("theta", theta, self._p)
        self.reset()
        self._theta[:] = theta
        self._root[:self._p, self._p] = math.sqrt(self._prior) * theta

    def update(self, wrench, a, alpha, omega, g) -> None:
        """Adds one sample: wrench (6,), a, alpha, omega, g (3,), all in S."""
        wrench = _vector("wrench", wrench, 6)
        V = self._regressor(a, alpha, omega, g)
        p, stack = self._p, self._stack
        self._load_sample(wrench, V, self._weighted)
        self._advance_weight()
        np.multiply(self._root, self._sqrt_forgetting, out=stack[:p + 1])
        if self._forgetting < 1.0:
            stack[p + 1:2 * p + 1] = self._pull_rows
            np.multiply(self._theta, self._pull, out=stack[p + 1:2 * p + 1, p])
        stack[-6:] = self._weighted
        factored, _, _, _ = lapack.dgeqrf(stack, overwrite_a=1)
        np.multiply(factored[:p + 1], self._upper, out=self._root)
        solution, info = lapack.dtrtrs(self._root[:p, :p], self._root[:p, p])
        if info == 0:
            self._theta[:] = solution
        self._track_residual(wrench, V)

    @property
    def information_root(self) -> np.ndarray:
        """S, upper triangular with SᵀS = R; R⁻¹ ⪯ initial_covariance·E ⟺ σ_min(S)² ≥ 1/initial_covariance."""
        return self._root[:self._p, :self._p].copy()

    @property
    def information(self) -> np.ndarray:
        """R = SᵀS (symmetric, ⪰ E/initial_covariance), in the weighted units of the unknowns."""
        root = self._root[:self._p, :self._p]
        return root.T @ root

    def _excitation(self):
        return _root_excitation(self._root[:self._p, :self._p], self._prior, self._rcond)

    def _covariance(self, basis):
        """The sandwich R⁻¹ (Σ_k σ̂_k² w_k A_kᵀA_k) R⁻¹ with per-axis residual variances, as in
        ``batch_estimate`` (right even when ``noise`` misstates the wrench noise)."""
        variance = self._axis_error_variance()
        if variance is None:
            return None
        inverse_root = solve_triangular(self._root[:self._p, :self._p], np.eye(self._p))
        inverse = inverse_root @ inverse_root.T
        return inverse @ np.einsum("k,kij->ij", variance, self._axis_information()) @ inverse


class RecursiveInstrumentalVariables(_InformationFormEstimator):
    """Recursive instrumental variables (Kubus, Kröger & Wahl, IROS 2007 [paper ref. 8]).

    The regressor A = [E₆ V(a, α, ω, g)] uses the measured (noisy, accelerometer) signals; the
    instrument Z = [E₆ V(a_i, α_i, ω_i, g_i)] is the same regressor built from signals whose
    noise is independent of A's — typically a, α, ω derived from the joint encoders and the
    kinematics (sinusoidal excitation makes those accurate, paper Sec. IV). Then
    θ̂ = (Σ λ ZᵀWA + prior)⁻¹(Σ λ ZᵀWy + prior·θ̂): the correlation of A's noise with the
    wrench equation error averages out, so unlike least squares the estimate is not biased
    towards zero by accelerometer noise. (The text of ref. 8 was not available; this is the
    standard IV construction, Söderström & Stoica, "System Identification", 1989, ch. 8.)

    Square-root form, for the reasons given in ``RecursiveLeastSquares``: with the instrument
    information LᵀL = Σ λ ZᵀWZ + prior (L upper triangular, Z = Q·L), the state holds L and
    [F f] = Qᵀ[W^½A W^½y], so ZᵀWA = LᵀF and the estimate solves F θ = f (LU, gesv) — F has
    about the square root of ZᵀWA's condition number. Each update is one Householder QR of
    the stacked instrument rows [√λL; c·E; W^½Z] (geqrf) applied to [√λF √λf; c·E c·θ̂;
    W^½A W^½y] (ormqr); the rows c·E (c = √((1−λ)/initial_covariance)) stabilize the
    forgetting as in ``RecursiveLeastSquares``. Identifiability is judged on the instruments'
    information; the covariance is the IV sandwich σ̂²(ZᵀWA)⁻¹ZᵀWZ(ZᵀWA)⁻ᵀ = σ̂²F⁻¹F⁻ᵀ with σ̂²
    the mean row-weighted residual variance.
    """

    def __init__(self, offsets: bool = True, forgetting: float = 1.0, initial_covariance: float = 1e6,
                 noise: NoiseLevels | None = None, rcond: float = 1e-6):
        p = 16 if offsets else 10
        super().__init__(offsets, forgetting, initial_covariance, noise, rcond, {"root": (p, 2 * p + 1)})
        stabilizing = self._forgetting < 1.0
        self._instrument = self._weighted.copy()
        self._stack = np.zeros((p + (p if stabilizing else 0) + 6, 2 * p + 1), order="F")
        self._upper = np.triu(np.ones((p, p)))
        self._sqrt_forgetting = math.sqrt(self._forgetting)
        self._pull = math.sqrt((1.0 - self._forgetting) * self._prior)
        self._workspace = 64 * (p + 1)
        self._pull_rows = np.hstack((self._pull * np.eye(p), self._pull * np.eye(p), np.zeros((p, 1))))

    def reset(self) -> None:
        super().reset()
        self._root[:, :self._p].flat[::self._p + 1] = math.sqrt(self._prior)
        self._root[:, self._p:2 * self._p].flat[::self._p + 1] = math.sqrt(self._prior)

    def update(self, wrench, a, alpha, omega, g, instrument) -> None:
        """Adds one sample: wrench (6,) and the measured a, alpha, omega, g (3,) that build the
        regressor; ``instrument`` = (a_i, alpha_i, omega_i, g_i), each (3,), the same
        quantities from independent measurements (e.g. encoder-derived), all in S."""
        if instrument is None or len(instrument) != 4:
            raise ValueError("instrument must be (a_i, alpha_i, omega_i, g_i), each of shape (3,)")
        wrench = _vector("wrench", wrench, 6)
        V = self._regressor(a, alpha, omega, g)
        Vz = self._regressor(*instrument, what="instrument: ")
        p, stack = self._p, self._stack
        self._load_sample(wrench, V, self._weighted)
        self._load_sample(wrench, Vz, self._instrument)
        self._advance_weight()
        np.multiply(self._root, self._sqrt_forgetting, out=stack[:p])
        if self._forgetting < 1.0:
            stack[p:2 * p] = self._pull_rows
            np.multiply(self._theta, self._pull, out=stack[p:2 * p, 2 * p])
        stack[-6:, :p] = self._instrument[:, :p]
        stack[-6:, p:] = self._weighted
        factored, tau, _, _ = lapack.dgeqrf(stack[:, :p], overwrite_a=1)
        rotated, _, _ = lapack.dormqr("L", "T", factored, tau, stack[:, p:], self._workspace, overwrite_c=1)
        np.multiply(factored[:p], self._upper, out=self._root[:, :p])
        self._root[:, p:] = rotated[:p]
        _, _, solution, info = lapack.dgesv(self._root[:, p:2 * p], self._root[:, 2 * p])
        if info == 0:
            self._theta[:] = solution
        self._track_residual(wrench, V)

    def _excitation(self):
        return _root_excitation(self._root[:, :self._p], self._prior, self._rcond)

    def _covariance(self, basis):
        variance = self._axis_error_variance()
        if variance is None:
            return None
        inverse = np.linalg.inv(self._root[:, self._p:2 * self._p])
        return variance.mean() * inverse @ inverse.T


class RecursiveTotalLeastSquares(_RecursiveEstimator):
    """Recursive total least squares for noisy a and α (after Kubus, Kröger & Wahl, IROS 2008
    [paper ref. 9]; its text was not available, so the construction is stated here).

    Data: rows [V y] of each sample scaled by 1/σ per wrench axis. The offsets columns are
    exact, so they are eliminated (mixed LS–TLS) by centring each wrench axis on its own
    forgetting-weighted mean μ_k: the state holds the weighted count s, the means μ (6×11),
    the centred scatter C (11×11) — updated in Welford's form C ← λC + ((s−1)/s)·DᵀD,
    D = rows − μ, which avoids the cancellation of G − TᵀT/s — and Ω = Σ λ^(t−i) ω_iωᵢᵀ.
    The kinematic noise's expected Gram matrix N_V = s·N₀ + f(Ω) (as in
    ``batch_estimate(method='tls')``) and N_y = 6s for the whitened wrench form the pencil
    (C, N); its eigenvector v = [φ; −1] of the smallest eigenvalue is the (generalized) TLS
    estimate, i.e. TLS after scaling the columns to white noise.

    Each update does one step of inverse iteration warm-started from the previous estimate
    (cf. Davila, IEEE Trans. Signal Process. 1994, who tracks the same eigenvector
    recursively), shifted by κ = ``prior_weight`` units of noise: x = (C + κN)⁻¹ N v,
    v ← −x/x_y, solved by Cholesky (LAPACK posv). Equivalently, C is augmented by the
    pseudo-measurement "the direction of v is v̂ (previous)" worth κ units of noise,
    P = κ(N − N v̂ v̂ᵀN / v̂ᵀN v̂), which vanishes on v̂ and lifts every direction N-orthogonal
    to it by κ (Sherman–Morrison: (C + P)⁻¹ N v̂ ∝ (C + κN)⁻¹ N v̂). C + κN is positive
    definite whatever the data; the fixed points are exactly the pencil's eigenvectors, so
    nothing is biased, and only the smallest one attracts: from any estimate, the other
    components shrink relative to it by (μ₀ + κ)/(μⱼ + κ) per sample (μ the pencil's
    eigenvalues), and a direction the data excite less than the solution (never, or below
    the assumed noise) grows by at most 1 + μ₀/κ per sample. The pseudo-measurement must be
    on the direction, not on φ: "φ = φ̂", κ·[E φ̂]ᵀN_V[E φ̂], weighs changes of v's scale by
    κ(1 + φ̂ᵀN_Vφ̂/N_y) instead of κ, so an estimate once inflated along weakly excited
    directions (as a start-up transient does when the kinematics are much cleaner than the
    assumed noise) can no longer shrink back and runs away. The offsets follow as the
    per-axis means of y − Vφ.
    """

    def __init__(self, offsets: bool = True, forgetting: float = 1.0, noise: NoiseLevels | None = None,
                 prior_weight: float = 100.0, rcond: float = 1e-6):
        noise = (noise or NoiseLevels()).checked()
        _require_kinematic_noise(noise, "RecursiveTotalLeastSquares")
        if not (prior_weight > 1.0 and math.isfinite(prior_weight)):
            raise ValueError(f"prior_weight must be finite and > 1 (units of noise); got {prior_weight}")
        super().__init__(offsets, forgetting, noise, rcond, {"C": (11, 11), "mu": (6, 11), "Omega": (3, 3)})
        self._kappa = float(prior_weight)
        self._noise_axes, self._k = _noise_gram_terms(noise, self._row_scale ** 2)
        self._n0 = self._noise_axes.sum(axis=0)
        self._omega_noise = noise.angular_velocity > 0.0
        self._D = np.empty((6, 11))
        self._scatter = np.empty((11, 11))
        self._H = np.empty((11, 11))
        self._noise_v = np.empty((10, 10))
        self._rhs = np.empty(11)
        self._offset_scale = 1.0 / self._row_scale

    def update(self, wrench, a, alpha, omega, g) -> None:
        """Adds one sample: wrench (6,), a, alpha, omega, g (3,), all in S."""
        wrench = _vector("wrench", wrench, 6)
        V = self._regressor(a, alpha, omega, g)
        lam = self._forgetting
        D = self._D
        np.multiply(V, self._row_scale_column, out=D[:, :10])
        np.multiply(wrench, self._row_scale, out=D[:, 10])
        s = self._advance_weight()
        C = self._C
        if lam != 1.0:
            C *= lam
        if self._offsets:
            D -= self._mu
            np.matmul(D.T, D, out=self._scatter)
            self._scatter *= (s - 1.0) / s
            C += self._scatter
            D *= 1.0 / s
            self._mu += D
        else:
            C += np.matmul(D.T, D, out=self._scatter)
        noise_v = np.multiply(self._n0, s, out=self._noise_v)
        if self._omega_noise:
            self._Omega *= lam
            self._Omega += np.outer(omega, omega)
            noise_v += (self._Omega.ravel() @ self._k).reshape(10, 10)
        phi = self._theta[-10:]
        H, rhs = self._H, self._rhs
        np.matmul(noise_v, phi, out=rhs[:10])                  # N_V φ
        rhs[10] = -6.0 * s                                     # N_y · (−1)
        np.multiply(noise_v, self._kappa, out=H[:10, :10])     # H = C + κN
        H[:10, 10] = 0.0
        H[10, :10] = 0.0
        H[10, 10] = 6.0 * s * self._kappa
        H += C
        _, x, info = lapack.dposv(H, rhs)
        if info == 0 and abs(x[10]) > 1e-12 * np.abs(x).max():
            np.divide(x[:10], -x[10], out=phi)
        if self._offsets:
            self._theta[:6] = (self._mu[:, 10] - self._mu[:, :10] @ phi) * self._offset_scale
        self._track_residual(wrench, V)

    def _noise_gram(self) -> np.ndarray:
        return self._weight[0] * self._n0 + (self._Omega.ravel() @ self._k).reshape(10, 10)

    def _excitation(self):
        """From the centred information C of φ (no cancellation against the offsets), scaled
        by 1/√(C_jj + N_jj) with N_V the expected noise information: a direction is
        unidentifiable when its scaled eigenvalue is at most rcond — its information is a
        vanishing fraction of one noise unit (never excited, or faded by forgetting). Offsets
        share φ's unidentified directions through the means: (−V̄u, u)."""
        information = self._C[:10, :10]
        total = np.diag(information) + np.diag(self._noise_gram())
        d = 1.0 / np.sqrt(np.where(total > 0.0, total, 1.0))
        mu, vectors = np.linalg.eigh(information * d * d[:, None])
        top = mu[-1]
        null = mu <= self._rcond
        directions = d[:, None] * vectors[:, null]
        if self._offsets:
            means = self._mu[:, :10] * self._offset_scale[:, None]
            directions = np.vstack((-means @ directions, directions))
        identifiable, basis = _null_excitation(directions)
        return identifiable, basis, (0.0 if null.any() else math.sqrt(mu[0] / top))

    def _covariance(self, basis):
        variance = self._axis_error_variance()
        if variance is None:
            return None
        noise_v = self._noise_gram()
        v = np.append(self._theta[-10:], -1.0)
        eigenvalue = max(v @ self._C @ v, 0.0) / (v[:10] @ noise_v @ v[:10] + 6.0 * self._weight[0])
        return _tls_covariance(self._axis_information(), variance, self._noise_axes, noise_v,
                               self._theta[-10:], self._weight[0], eigenvalue, basis)


def feed(estimator, wrench, a, alpha, omega, g, instruments=None):
    """Updates a recursive estimator with every sample of (N, 6)/(N, 3) arrays, yielding the
    number of samples taken so far after each. ``instruments`` (a, α, ω, g arrays) are
    required by, and only passed to, RecursiveInstrumentalVariables."""
    needs_instruments = isinstance(estimator, RecursiveInstrumentalVariables)
    if needs_instruments and instruments is None:
        raise ValueError("RecursiveInstrumentalVariables needs instruments (a, alpha, omega, g)")
    for k in range(len(wrench)):
        if needs_instruments:
            estimator.update(wrench[k], a[k], alpha[k], omega[k], g[k],
                             instrument=tuple(x[k] for x in instruments))
        else:
            estimator.update(wrench[k], a[k], alpha[k], omega[k], g[k])
        yield k + 1
