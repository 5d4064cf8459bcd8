"""Recursive estimation of a load's inertial parameters and the sensor's offsets (Kubus & Wahl, Sec. IV).

``RecursiveLeastSquares``, ``RecursiveInstrumentalVariables``, ``RecursiveTotalLeastSquares``
take one sample per ``update``, cheap enough for a 2 kHz loop; each keeps its whole state in
one flat vector (``state_vector``) so that a Drake system can hold it as discrete state.
Conventions and unknowns as ``batch_estimation``'s (signals in S; θ = [offsets; φ] or φ);
identifiability and covariances as ``identifiability`` says, the noise model ``regression_noise``'s.
"""

import abc
import copy
import math

import numpy as np
from scipy.linalg import lapack, solve_triangular

from heft.systems.identification.batch_estimation import tls_covariance
from heft.systems.compiled import compiled
from heft.systems.identification.identifiability import (
    check_rcond, mask_unidentifiable, null_excitation, root_excitation)
from heft.systems.load_dynamics import regressor, regressor_into
from heft.systems.identification.regression_noise import NoiseLevels, noise_gram_terms, require_kinematic_noise

# Forgetting drives the entries of unexcited directions towards zero and, in the end, into
# subnormal numbers, which x86 processes ~100× slower. Every _FLUSH_INTERVAL samples, state
# entries smaller than _FLUSH_BELOW in magnitude (far below any meaningful value) become 0;
# at λ ≥ 0.5 none can decay from _FLUSH_BELOW to subnormal (1e-308) in between.
_FLUSH_INTERVAL = 256
_FLUSH_BELOW = 1e-200


def _vector(name: str, value, size: int) -> np.ndarray:
    """``value`` as a finite, writeable float array of shape (size,) (what the compiled kernels take),
    cheaply when it already is one."""
    if (type(value) is not np.ndarray or value.dtype != np.float64 or value.shape != (size,)
            or not value.flags.writeable):
        value = np.array(value, dtype=float)
        if value.shape != (size,):
            raise ValueError(f"{name} must have shape ({size},); got {value.shape}")
    if not math.isfinite(sum(value.tolist())):
        raise ValueError(f"{name} contains NaN or inf; skip this sample")
    return value


@compiled("void(float64[:, :], float64[:], float64[:, :], float64, float64, float64[:])")
def information_update(root, theta, rows, sqrt_forgetting, pull, row):
    """One update of the square-root information [S z; 0 ρ] (``root``, (p+1, p+1), upper
    triangular) by the rows [√λ·S √λ·z; c·E c·θ̂; ``rows``] (``rows``: (k, p+1) new data rows,
    c = ``pull``, θ̂ = ``theta`` (p,) before the update), each row rotated into S by Givens
    rotations (the R factor of the stack's QR, up to the rows' signs); then θ̂ solves S θ = z,
    unchanged if S is singular. ``row`` (p+1) is scratch."""
    n = root.shape[0]
    p = n - 1
    for i in range(n):
        for j in range(i, n):
            root[i, j] *= sqrt_forgetting
    for k in range(p + rows.shape[0] if pull > 0.0 else rows.shape[0]):
        if pull > 0.0 and k < p:
            row[:] = 0.0
            row[k], row[p], first = pull, pull * theta[k], k
        else:
            row[:] = rows[k - p if pull > 0.0 else k]
            first = 0
        for c in range(first, n):
            b = row[c]
            if b == 0.0:
                continue
            a = root[c, c]
            h = math.sqrt(a * a + b * b)
            if not 1e-150 < h < 1e150:  # squares near or beyond a double's range: hypot, slower, is exact there
                h = math.hypot(a, b)
            cosine, sine = a / h, b / h
            root[c, c] = h
            for j in range(c + 1, n):
                upper, lower = root[c, j], row[j]
                root[c, j] = cosine * upper + sine * lower
                row[j] = cosine * lower - sine * upper
    for i in range(p):
        if root[i, i] == 0.0:
            return
    for i in range(p - 1, -1, -1):
        total = root[i, p]
        for j in range(i + 1, p):
            total -= root[i, j] * theta[j]
        theta[i] = total / root[i, i]


@compiled("void(float64[:, :, :], float64[:, :], float64[:], float64)")
def accumulate_moments(moments, V, wrench, forgetting):
    """``moments`` (6, 12, 12) ← λ·moments + m mᵀ per wrench axis k, m = [1, V_k, y_k] (V (6, 10),
    ``wrench`` y (6,), λ = ``forgetting``)."""
    for k in range(6):
        for i in range(12):
            mi = 1.0 if i == 0 else (wrench[k] if i == 11 else V[k, i - 1])
            for j in range(12):
                mj = 1.0 if j == 0 else (wrench[k] if j == 11 else V[k, j - 1])
                moments[k, i, j] = forgetting * moments[k, i, j] + mi * mj


_MOMENTS = 6 * 12 * 12
"""Entries of the per-axis second moments (``accumulate_moments``) in the state vector."""


def information_start(p: int) -> int:
    """Where the square-root information [S z; 0 ρ] starts in the state of an estimator of ``p`` unknowns (θ,
    the count, the weight, the moments before it)."""
    return p + 2 + _MOMENTS


@compiled("void(float64[::1], int64, float64[:, :], float64[:], float64)")
def track_residual(state, p, V, wrench, forgetting):
    """Adds one sample (V (6, 10), ``wrench`` (6,)) to the per-axis second moments of ``state`` (the
    layout ``_RecursiveEstimator``'s: θ (p), count, weight, moments), counts it and, every
    ``_FLUSH_INTERVAL`` samples, flushes entries below ``_FLUSH_BELOW`` to 0."""
    accumulate_moments(state[p + 2:p + 2 + _MOMENTS].reshape((6, 12, 12)), V, wrench, forgetting)
    state[p] += 1.0
    if state[p] % _FLUSH_INTERVAL == 0.0:
        for i in range(state.shape[0]):
            if abs(state[i]) < _FLUSH_BELOW:
                state[i] = 0.0


@compiled("float64(float64[::1], int64, float64)")
def advance_weight(state, p, forgetting):
    """The forgetting-weighted sample count of ``state`` s ← λs + 1 (λ = ``forgetting``); returns it."""
    state[p + 1] = forgetting * state[p + 1] + 1.0
    return state[p + 1]


@compiled("void(float64[:, :], float64[:], float64[:], float64[:, :])")
def load_sample(V, wrench, row_scale, into):
    """The sample's weighted rows into ``into`` (6, p + 1): W^½V (V (6, 10)) in the 10 columns before the
    last, W^½y (y = ``wrench``) in the last, W^½ = diag(``row_scale``); the offsets' columns untouched."""
    last = into.shape[1] - 1
    for k in range(6):
        for j in range(10):
            into[k, last - 10 + j] = V[k, j] * row_scale[k]
        into[k, last] = wrench[k] * row_scale[k]


@compiled("void(float64[::1], int64, float64, float64[:])")
def least_squares_start_from(state, p, sqrt_prior, theta):
    """``RecursiveLeastSquares``' ``state`` back to no data but the estimate ``theta`` (p) held by the
    prior: S = √prior·E, z = √prior·θ, everything else 0."""
    state[:] = 0.0
    root = state[p + 2 + _MOMENTS:].reshape((p + 1, p + 1))
    for i in range(p):
        state[i] = theta[i]
        root[i, i] = sqrt_prior
        root[i, p] = sqrt_prior * theta[i]


@compiled("void(float64[::1], int64, float64[:, :], float64[:], float64[:, :], float64[:], float64[:], float64[:], "
          "float64[:], float64[:], float64[:], float64, float64, float64)")
def least_squares_update(state, p, weighted, row, V, row_scale, wrench, a, alpha, omega, g, forgetting,
                         sqrt_forgetting, pull):
    """``RecursiveLeastSquares.update`` on its ``state``: one sample (``wrench`` (6,), a, α, ω, g (3,), in S)
    into V (6, 10), its weighted rows into ``weighted`` (6, p + 1), then the information update
    (``information_update``, ``row`` its scratch) and the residual moments (``track_residual``)."""
    regressor_into(a, alpha, omega, g, V)
    load_sample(V, wrench, row_scale, weighted)
    advance_weight(state, p, forgetting)
    information_update(state[p + 2 + _MOMENTS:].reshape((p + 1, p + 1)), state[:p], weighted, sqrt_forgetting,
                       pull, row)
    track_residual(state, p, V, wrench, forgetting)


class _RecursiveEstimator(abc.ABC):
    """Shared machinery of the recursive estimators: the whole state in one flat float vector
    (named views into it), preallocated work buffers, input checks, residual tracking."""

    def __init__(self, offsets: bool, forgetting: float, noise: NoiseLevels | None, rcond: float,
                 fields: dict[str, tuple[int, ...]]):
        if not 0.5 <= forgetting <= 1.0:
            raise ValueError(f"forgetting must lie in [0.5, 1] (a memory of at least 2 samples); got {forgetting}")
        check_rcond(rcond)
        self._offsets = bool(offsets)
        self._p = 16 if offsets else 10
        self._forgetting = float(forgetting)
        noise = (noise or NoiseLevels()).checked()
        self._rcond = rcond
        self._row_scale = np.sqrt(noise.wrench_weights())
        self._layout = {"theta": (self._p,), "count": (1,), "weight": (1,), "axis_moments": (6, 12, 12),
                        **fields}
        self._state = np.zeros(sum(math.prod(shape) for shape in self._layout.values()))
        self._bind_state_views()
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
        """Bool mask over the unknowns (offsets first when estimated); as ``identifiability`` says."""
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
        return mask_unidentifiable(self._covariance(basis), identifiable)

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
        from which any estimate's residual follows (``track_residual``)."""
        track_residual(self._state, self._p, V, wrench, self._forgetting)

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
        return advance_weight(self._state, self._p, self._forgetting)


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
        load_sample(V, wrench, self._row_scale, into)


class RecursiveLeastSquares(_InformationFormEstimator):
    """Recursive weighted least squares: square-root information filter with stabilized
    forgetting.

    Information R = Σ λ^(t−i)·A_iᵀWA_i + prior and b = Σ λ^(t−i)·A_iᵀWy_i + prior·θ̂, with
    A_i = [E₆ V_i], W = diag(1/σ²) per wrench axis from ``noise`` and the prior
    R₀ = E/``initial_covariance``. The state is the upper-triangular square root
    [S z; 0 ρ] of the augmented information [R b; bᵀ ·] (SᵀS = R, Sᵀz = b); each update is the
    R factor of the stacked rows [√λ·S √λ·z; c·E c·θ̂; W^½A W^½y], c = √((1−λ)/initial_covariance),
    by Givens rotations (``information_update``, compiled), then θ̂ solves the triangular S θ = z.

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
        self._sqrt_forgetting = math.sqrt(self._forgetting)
        self._pull = math.sqrt((1.0 - self._forgetting) * self._prior)
        self._V = np.empty((6, 10))
        self._row = np.empty(p + 1)

    def reset(self) -> None:
        least_squares_start_from(self._state, self._p, math.sqrt(self._prior), np.zeros(self._p))

    def start_from(self, theta) -> None:
        """No data, but the estimate ``theta`` ([offsets; φ] or φ) held by the prior: the
        information is reset, the estimate kept where the data will not say otherwise (a
        covariance reset, e.g. on a known change of load)."""
        least_squares_start_from(self._state, self._p, math.sqrt(self._prior), _vector("theta", theta, self._p))

    def update(self, wrench, a, alpha, omega, g) -> None:
        """Adds one sample: wrench (6,), a, alpha, omega, g (3,), all in S (``least_squares_update``)."""
        least_squares_update(self._state, self._p, self._weighted, self._row, self._V, self._row_scale,
                             _vector("wrench", wrench, 6), _vector("a", a, 3), _vector("alpha", alpha, 3),
                             _vector("omega", omega, 3), _vector("g", g, 3), self._forgetting,
                             self._sqrt_forgetting, self._pull)

    @property
    def kernel_arguments(self) -> tuple:
        """What ``least_squares_update`` and ``least_squares_start_from`` take of this estimator, in their
        order: (state, p, weighted, row, V, row_scale) and (forgetting, √forgetting, pull, √prior)."""
        return ((self._state, self._p, self._weighted, self._row, self._V, self._row_scale),
                (self._forgetting, self._sqrt_forgetting, self._pull, math.sqrt(self._prior)))

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
        return root_excitation(self._root[:self._p, :self._p], self._prior, self._rcond)

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
        return root_excitation(self._root[:, :self._p], self._prior, self._rcond)

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
        require_kinematic_noise(noise, "RecursiveTotalLeastSquares")
        if not (prior_weight > 1.0 and math.isfinite(prior_weight)):
            raise ValueError(f"prior_weight must be finite and > 1 (units of noise); got {prior_weight}")
        super().__init__(offsets, forgetting, noise, rcond, {"C": (11, 11), "mu": (6, 11), "Omega": (3, 3)})
        self._kappa = float(prior_weight)
        self._noise_axes, self._k = noise_gram_terms(noise, self._row_scale ** 2)
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
        load_sample(V, wrench, self._row_scale, D)
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
        identifiable, basis = null_excitation(directions)
        return identifiable, basis, (0.0 if null.any() else math.sqrt(mu[0] / top))

    def _covariance(self, basis):
        variance = self._axis_error_variance()
        if variance is None:
            return None
        noise_v = self._noise_gram()
        v = np.append(self._theta[-10:], -1.0)
        eigenvalue = max(v @ self._C @ v, 0.0) / (v[:10] @ noise_v @ v[:10] + 6.0 * self._weight[0])
        return tls_covariance(self._axis_information(), variance, self._noise_axes, noise_v,
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
