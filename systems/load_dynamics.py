"""Rigid-load dynamics at a wrist force-torque sensor (Kubus & Wahl, Sec. III).

Plain numpy, no Drake types. Conventions (docs/design.md §4):

* Everything is expressed in the sensor frame S, origin at its measuring point.
* ``a`` is the translational acceleration of S's origin in the world, ``alpha``
  and ``omega`` are S's angular acceleration and velocity in the world, ``g``
  is gravity; all (3,) or (N, 3), in m/s², rad/s², rad/s, m/s².
* A wrench is ``[f; tau]`` (N, N·m): what the sensor exerts *on the load*
  (Eqs. 1–2), torque about S's origin.
* ``phi = [m, m cx, m cy, m cz, Ixx, Ixy, Ixz, Iyy, Iyz, Izz]`` (Eq. 6), the
  inertia taken about S's origin. Offsets ``[f_o; tau_o]`` come first in the
  extended vector (Eq. 7).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from heft.systems.compiled import compiled

GRAVITY_W = (0.0, 0.0, -9.81)
"""Gravity in the world frame W (m/s²). The slave's base R stands level, so it is also g in R."""

PHI_NAMES = ("m", "m*cx", "m*cy", "m*cz", "Ixx", "Ixy", "Ixz", "Iyy", "Iyz", "Izz")
OFFSET_NAMES = ("fx_o", "fy_o", "fz_o", "tx_o", "ty_o", "tz_o")
PARAMETER_NAMES = OFFSET_NAMES + PHI_NAMES  # the unknowns θ = [offsets; φ] of Eq. 7, in order

# Rows of the symmetric inertia matrix as indices into the 6 inertia entries
# [Ixx, Ixy, Ixz, Iyy, Iyz, Izz] of phi.
_SYM_INDEX = np.array([[0, 1, 2], [1, 3, 4], [2, 4, 5]])


def _finite_array(name: str, value, shape_tail: tuple[int, ...]) -> np.ndarray:
    """Returns ``value`` as a float array of shape ``shape_tail`` or (N, *shape_tail)."""
    x = np.asarray(value, dtype=float)
    if x.shape != shape_tail and x.shape[1:] != shape_tail:
        raise ValueError(
            f"{name} must have shape {shape_tail} or (N, {', '.join(map(str, shape_tail))}); "
            f"got {x.shape}"
        )
    finite = math.isfinite(sum(x.ravel().tolist())) if x.size <= 16 else np.isfinite(x).all()
    if not finite:
        raise ValueError(f"{name} contains NaN or inf; drop or repair that sample before use")
    return x


def _motion_inputs(a, alpha, omega, g):
    """Validates and broadcasts the four kinematic inputs to a common (N, 3) or (3,)."""
    arrays = [_finite_array(n, v, (3,)) for n, v in
              (("a", a), ("alpha", alpha), ("omega", omega), ("g", g))]
    batched = [x.ndim == 2 for x in arrays]
    if any(batched):
        lengths = {x.shape[0] for x in arrays if x.ndim == 2}
        if len(lengths) != 1:
            raise ValueError(f"a, alpha, omega and g have different sample counts {sorted(lengths)}")
        n = lengths.pop()
        arrays = [np.broadcast_to(x, (n, 3)) for x in arrays]
    return arrays, any(batched)


# [v]x as a gather of (0, ±v_k): flat 3×3 entries index into [0, v, −v].
_CROSS_GATHER = np.array([0, 6, 2, 3, 0, 4, 5, 1, 0])
# L(v) (3×6) with I·v = L(v)·[Ixx, Ixy, Ixz, Iyy, Iyz, Izz]: entry (r, _SYM_INDEX[r, c]) = v_c.
_INERTIA_ROWS = np.repeat(np.arange(3), 3)
_INERTIA_COLS = _SYM_INDEX.ravel()
_INERTIA_SOURCE = np.tile(np.arange(3), 3)


def _cross_matrix(v: np.ndarray) -> np.ndarray:
    """[v]x for v of shape (..., 3) → (..., 3, 3)."""
    padded = np.concatenate((np.zeros(v.shape[:-1] + (1,)), v, -v), axis=-1)
    return padded[..., _CROSS_GATHER].reshape(v.shape[:-1] + (3, 3))


def _inertia_product_matrix(v: np.ndarray) -> np.ndarray:
    """L(v) of shape (..., 3, 6) with I·v = L(v)·[Ixx, Ixy, Ixz, Iyy, Iyz, Izz]."""
    out = np.zeros(v.shape[:-1] + (3, 6))
    out[..., _INERTIA_ROWS, _INERTIA_COLS] = v[..., _INERTIA_SOURCE]
    return out


def regressor(a, alpha, omega, g) -> np.ndarray:
    """The matrix V of Eq. 5 with wrench = V(a, alpha, omega, g) @ phi.

    Inputs of shape (3,) give (6, 10); inputs of shape (N, 3) give (N, 6, 10)
    (a (3,) input is broadcast against (N, 3) ones). Derived from Eqs. 1–2:
    f = m(a − g) + α×(mc) + ω×(ω×(mc)),  τ = Iα + ω×(Iω) + (mc)×(a − g).
    """
    single = _single_sample_regressor(a, alpha, omega, g)
    if single is not None:
        return single
    (a, alpha, omega, g), batched = _motion_inputs(a, alpha, omega, g)
    a_minus_g = a - g
    w_x = _cross_matrix(omega)
    V = np.zeros(a.shape[:-1] + (6, 10))
    V[..., 0:3, 0] = a_minus_g
    V[..., 0:3, 1:4] = _cross_matrix(alpha) + w_x @ w_x
    V[..., 3:6, 1:4] = -_cross_matrix(a_minus_g)
    V[..., 3:6, 4:10] = _inertia_product_matrix(alpha) + w_x @ _inertia_product_matrix(omega)
    return V if batched else V.reshape(6, 10)


def _single_sample_regressor(a, alpha, omega, g):
    """The (6, 10) V of one sample (``regressor_into``, a few µs, for per-tick use), or None when the
    inputs are not four finite (3,) arrays (the general path then handles or rejects them)."""
    if not all(isinstance(x, np.ndarray) and x.shape == (3,) for x in (a, alpha, omega, g)):
        return None
    if not math.isfinite(a.sum() + alpha.sum() + omega.sum() + g.sum()):
        return None
    V = np.empty((6, 10))
    regressor_into(*(np.asarray(x, dtype=float) for x in (a, alpha, omega, g)), V)
    return V


@compiled("void(float64[:], float64[:], float64[:], float64[:], float64[:, :])")
def regressor_into(a, alpha, omega, g, V) -> None:
    """``regressor`` of one sample, (6, 10), written into ``V``, in scalar arithmetic."""
    ax, ay, az = a[0] - g[0], a[1] - g[1], a[2] - g[2]
    alx, aly, alz = alpha[0], alpha[1], alpha[2]
    wx, wy, wz = omega[0], omega[1], omega[2]
    wxx, wyy, wzz, wxy, wxz, wyz = wx * wx, wy * wy, wz * wz, wx * wy, wx * wz, wy * wz
    V[:, :] = 0.0
    V[0, 0], V[0, 1], V[0, 2], V[0, 3] = ax, -wyy - wzz, wxy - alz, wxz + aly
    V[1, 0], V[1, 1], V[1, 2], V[1, 3] = ay, wxy + alz, -wxx - wzz, wyz - alx
    V[2, 0], V[2, 1], V[2, 2], V[2, 3] = az, wxz - aly, wyz + alx, -wxx - wyy
    V[3, 2], V[3, 3], V[3, 4], V[3, 5], V[3, 6], V[3, 7], V[3, 8], V[3, 9] = \
        az, -ay, alx, aly - wxz, alz + wxy, -wyz, wyy - wzz, wyz
    V[4, 1], V[4, 3], V[4, 4], V[4, 5], V[4, 6], V[4, 7], V[4, 8], V[4, 9] = \
        -az, ax, wxz, alx + wyz, wzz - wxx, aly, alz - wxy, -wxz
    V[5, 1], V[5, 2], V[5, 4], V[5, 5], V[5, 6], V[5, 7], V[5, 8], V[5, 9] = \
        ay, -ax, -wxy, wxx - wyy, alx - wyz, wxy, aly + wxz, alz


def regressor_with_offsets(a, alpha, omega, g) -> np.ndarray:
    """The extended matrix [E₆ V] of Eq. 8, (6, 16) or (N, 6, 16); unknowns as Eq. 7."""
    return with_offsets(regressor(a, alpha, omega, g))


def with_offsets(V: np.ndarray) -> np.ndarray:
    """[E₆ V] (6, 16) or (N, 6, 16) of a regressor V (6, 10) or (N, 6, 10) already computed."""
    out = np.zeros(V.shape[:-1] + (16,))
    out[..., :, :6] = np.eye(6)
    out[..., :, 6:] = V
    return out


def noncontact_wrench(phi, a, alpha, omega, g) -> np.ndarray:
    """Eq. 12: the load's own wrench V·phi, (6,) or (N, 6). A batch is evaluated as V·φ's products
    (``regressor``'s docstring) without forming the (N, 6, 10) V: a tenth of the cost per sample."""
    phi = _finite_array("phi", phi, (10,))
    if phi.ndim != 1:
        raise ValueError(f"phi must have shape (10,); got {phi.shape}")
    if all(np.ndim(x) == 1 for x in (a, alpha, omega, g)):
        return regressor(a, alpha, omega, g) @ phi
    (a, alpha, omega, g), _ = _motion_inputs(a, alpha, omega, g)
    h, inertia = phi[1:4], inertia_matrix(phi[4:])
    specific = a - g
    out = np.empty(specific.shape[:-1] + (6,))
    out[..., :3] = phi[0] * specific + np.cross(alpha, h) + np.cross(omega, np.cross(omega, h))
    out[..., 3:] = alpha @ inertia + np.cross(omega, omega @ inertia) + np.cross(h, specific)
    return out


def inertia_matrix(entries) -> np.ndarray:
    """The symmetric 3×3 matrix of Eq. 3 from [Ixx, Ixy, Ixz, Iyy, Iyz, Izz]."""
    entries = np.asarray(entries, dtype=float)
    return entries[_SYM_INDEX]


def inertia_entries(matrix) -> np.ndarray:
    """[Ixx, Ixy, Ixz, Iyy, Iyz, Izz] of a symmetric 3×3 matrix."""
    m = np.asarray(matrix, dtype=float)
    return np.array([m[0, 0], m[0, 1], m[0, 2], m[1, 1], m[1, 2], m[2, 2]])


def _steiner(mass: float, p) -> np.ndarray:
    """Parallel-axis term m([p]ₓᵀ[p]ₓ) = m(|p|²E − ppᵀ) for a point mass at p."""
    p = np.asarray(p, dtype=float)
    return mass * (p @ p * np.eye(3) - np.outer(p, p))


@dataclasses.dataclass(frozen=True)
class InertialParameters:
    """A rigid load: mass (kg), centre of mass p_SC_S (m) and inertia about
    the COM I_C_S (kg·m², axes parallel to S), all expressed in the frame S
    they are given in."""

    mass: float
    com: np.ndarray
    inertia_com: np.ndarray

    def __post_init__(self):
        mass = float(self.mass)
        if not np.isfinite(mass):
            raise ValueError(f"mass must be finite; got {self.mass}")
        com = _finite_array("com", self.com, (3,))
        inertia = _finite_array("inertia_com", self.inertia_com, (3, 3))
        if com.ndim != 1 or inertia.ndim != 2:
            raise ValueError("com must be (3,) and inertia_com (3, 3)")
        if not np.allclose(inertia, inertia.T, rtol=0, atol=1e-12 * max(1.0, np.abs(inertia).max())):
            raise ValueError("inertia_com must be symmetric")
        object.__setattr__(self, "mass", mass)
        object.__setattr__(self, "com", com.copy())
        object.__setattr__(self, "inertia_com", 0.5 * (inertia + inertia.T))

    # --- conversions -------------------------------------------------------
    @classmethod
    def from_inertia_about_origin(cls, mass, com, inertia_origin) -> InertialParameters:
        """From the inertia about S's origin (parallel-axis theorem)."""
        if not mass > 0:
            raise ValueError(f"mass must be > 0 to locate the COM; got {mass}")
        inertia_origin = _finite_array("inertia_origin", inertia_origin, (3, 3))
        return cls(mass, com, inertia_origin - _steiner(mass, com))

    @classmethod
    def from_phi(cls, phi) -> InertialParameters:
        """From the Eq. 6 vector; needs m > 0 (a massless phi has no COM)."""
        phi = _finite_array("phi", phi, (10,))
        if phi.ndim != 1:
            raise ValueError(f"phi must have shape (10,); got {phi.shape}")
        if not phi[0] > 0:
            raise ValueError(f"phi[0] (mass) must be > 0 to convert to a COM; got {phi[0]}")
        return cls.from_inertia_about_origin(phi[0], phi[1:4] / phi[0], inertia_matrix(phi[4:]))

    @property
    def inertia_origin(self) -> np.ndarray:
        """Inertia about S's origin, expressed in S (kg·m²)."""
        return self.inertia_com + _steiner(self.mass, self.com)

    def to_phi(self) -> np.ndarray:
        """The Eq. 6 vector."""
        return np.concatenate(([self.mass], self.mass * self.com, inertia_entries(self.inertia_origin)))

    def expressed_in(self, R_AS, p_AS) -> InertialParameters:
        """The same body described in frame A, given S's pose in A (R_AS (3,3), p_AS (3,))."""
        R_AS = _finite_array("R_AS", R_AS, (3, 3))
        p_AS = _finite_array("p_AS", p_AS, (3,))
        if not np.allclose(R_AS.T @ R_AS, np.eye(3), atol=1e-9) or np.linalg.det(R_AS) < 0:
            raise ValueError("R_AS must be a proper rotation matrix")
        return InertialParameters(self.mass, R_AS @ self.com + p_AS, R_AS @ self.inertia_com @ R_AS.T)

    @classmethod
    def random(cls, rng: np.random.Generator, mass_range=(0.2, 5.0), com_radius=0.15,
               size_range=(0.01, 0.15)) -> InertialParameters:
        """A physically valid random body: a solid with random second moments of mass
        (m), randomly rotated, its COM within ``com_radius`` (m) of S's origin."""
        mass = rng.uniform(*mass_range)
        second_moments = mass * rng.uniform(*size_range, 3) ** 2  # ∫x², ∫y², ∫z² (kg·m²)
        principal = second_moments.sum() - second_moments          # Jx = ∫y² + ∫z², …
        from scipy.spatial.transform import Rotation  # not at the top: 0.3 s to import, for this alone

        R = Rotation.random(random_state=rng).as_matrix()
        com = rng.normal(size=3)
        com *= com_radius * rng.uniform() ** (1 / 3) / np.linalg.norm(com)
        return cls(mass, com, R @ np.diag(principal) @ R.T)

    # --- body algebra ------------------------------------------------------
    def __add__(self, other: InertialParameters) -> InertialParameters:
        """The composite of two bodies described in the same frame."""
        return InertialParameters.from_phi(self.to_phi() + other.to_phi())

    def __sub__(self, other: InertialParameters) -> InertialParameters:
        """The body that, added to ``other``, gives ``self`` (e.g. object = load − gripper)."""
        return InertialParameters.from_phi(self.to_phi() - other.to_phi())

    # --- physical consistency ----------------------------------------------
    def violations(self, tol: float = 1e-12) -> list[str]:
        """Names every physical-consistency condition this body violates (empty if none)."""
        problems = []
        if not self.mass > 0:
            problems.append(f"mass {self.mass:g} kg is not positive")
        principal = np.linalg.eigvalsh(self.inertia_com)
        scale = tol * max(1.0, np.abs(principal).max())
        if principal[0] <= scale:
            problems.append(
                f"inertia about the COM is not positive definite (principal moments {principal} kg·m²)")
        j1, j2, j3 = principal
        for name, lhs, rhs in (("J1 + J2 >= J3", j1 + j2, j3), ("J1 + J3 >= J2", j1 + j3, j2),
                               ("J2 + J3 >= J1", j2 + j3, j1)):
            if lhs < rhs - scale:
                problems.append(f"triangle inequality {name} fails for principal moments {principal} kg·m²")
        return problems

    def is_physical(self) -> bool:
        return not self.violations()

    def require_physical(self, what: str = "inertial parameters") -> InertialParameters:
        """Returns self, or raises ValueError naming every violated condition."""
        problems = self.violations()
        if problems:
            raise ValueError(f"{what} are not physical: " + "; ".join(problems))
        return self


PSEUDO_INERTIA_TOLERANCE = 1e-2
"""How far (× its trace) the pseudo-inertia's smallest eigenvalue may fall below zero in a load
estimate: an identified thin rod's second moment across it (m·r²/4, 10⁻⁶ kg·m² for 0.1 kg at
5 mm) sits within the estimation's noise, a negative or absurd mass far outside."""


def pseudo_inertia(phi) -> np.ndarray:
    """The 4×4 pseudo-inertia J = ∫ [r; 1][r; 1]ᵀ dm = [[Σ, h], [hᵀ, m]] of φ (Eq. 6), with
    h = m·c (kg·m) and Σ = ∫ r rᵀ dm = ½ tr(I)·E − I (kg·m²) from the inertia I about S's
    origin (I = tr(Σ)E − Σ). φ is the inertia of some mass distribution iff J ⪰ 0 and of a
    body with positive-definite inertia iff J ≻ 0 (Wensing, Kim & Slotine, "Linear matrix
    inequalities for physically consistent inertial parameter identification", IEEE RA-L 2017)."""
    phi = np.asarray(phi, dtype=float)
    if phi.shape != (10,):
        raise ValueError(f"phi must have shape (10,); got {phi.shape}")
    inertia = inertia_matrix(phi[4:])
    J = np.empty((4, 4))
    J[:3, :3] = 0.5 * np.trace(inertia) * np.eye(3) - inertia
    J[:3, 3] = J[3, :3] = phi[1:4]
    J[3, 3] = phi[0]
    return J


def checked_load(phi, offsets, wrench_full_scale=None) -> tuple[np.ndarray, np.ndarray]:
    """(φ̂, offsets) as float arrays, or a ValueError naming every problem: the one check of a
    load estimate, from a file or over LCM.

    φ̂ needs 10 and the offsets 6 finite entries. φ̂ = 0 is "no load model" (nothing is
    eliminated); any other φ̂ needs a positive mass and a positive semidefinite pseudo-inertia
    (``pseudo_inertia``, within ``PSEUDO_INERTIA_TOLERANCE``). With ``wrench_full_scale`` (the
    sensor's range [f; τ], N, N·m) the load's weight, its largest static moment |m·c|·|g| and
    each offset must lie within it: the sensor could not have measured more."""
    phi, offsets = np.asarray(phi, dtype=float), np.asarray(offsets, dtype=float)
    if phi.shape != (10,) or offsets.shape != (6,) or not (np.isfinite(phi).all() and np.isfinite(offsets).all()):
        raise ValueError(f"a load estimate needs 10 finite φ entries (Eq. 6) and 6 finite offsets; "
                         f"got {phi.tolist()} and {offsets.tolist()}")
    problems = []
    if phi.any():
        eigenvalues = np.linalg.eigvalsh(pseudo_inertia(phi))
        if not phi[0] > 0:
            problems.append(f"its mass {phi[0]:g} kg is not positive")
        elif eigenvalues[0] < -PSEUDO_INERTIA_TOLERANCE * eigenvalues.sum():
            problems.append(f"no body has these inertial parameters (the pseudo-inertia's eigenvalues are "
                            f"{np.array2string(eigenvalues, precision=4)}, one well below zero)")
    if wrench_full_scale is not None:
        full_scale = np.asarray(wrench_full_scale, dtype=float)
        gravity = math.hypot(*GRAVITY_W)
        weight, moment = phi[0] * gravity, np.linalg.norm(phi[1:4]) * gravity
        if weight > full_scale[:3].min():
            problems.append(f"its weight {weight:.4g} N is beyond the sensor's range ({full_scale[:3].min():g} N)")
        if moment > full_scale[3:].min():
            problems.append(f"its static moment |m·c|·g = {moment:.4g} N·m is beyond the sensor's range "
                            f"({full_scale[3:].min():g} N·m)")
        beyond = [f"{OFFSET_NAMES[i]} = {offsets[i]:.4g}" for i in range(6) if abs(offsets[i]) > full_scale[i]]
        if beyond:
            problems.append(f"offsets beyond the sensor's range {full_scale.tolist()}: {', '.join(beyond)}")
    if problems:
        raise ValueError("the load estimate is refused: " + "; ".join(problems)
                         + "; identify the load again (`heft identify`) or check what was sent")
    return phi, offsets


@compiled("UniTuple(float64, 2)(float64[:])")
def wrench_norms(wrench) -> tuple[float, float]:
    """(|f| in N, |τ| in N·m) of a wrench [f; τ] (6)."""
    fx, fy, fz, tx, ty, tz = wrench[0], wrench[1], wrench[2], wrench[3], wrench[4], wrench[5]
    return math.sqrt(fx * fx + fy * fy + fz * fz), math.sqrt(tx * tx + ty * ty + tz * tz)


@compiled("boolean(float64[:], float64, float64)")
def beyond(wrench, max_force, max_torque) -> bool:
    """Whether a wrench [f; τ] (6) has |f| > ``max_force`` (N) or |τ| > ``max_torque`` (N·m)."""
    force, torque = wrench_norms(wrench)
    return force > max_force or torque > max_torque
