"""Physical consistency of a load's inertial parameters φ (Kubus & Wahl, Eq. 6).

An estimate of φ from noisy data need not be a body: its mass may be negative, its inertia
may break the triangle inequalities. ``project_to_physical`` maps it to the nearest φ whose
pseudo-inertia (``load_dynamics.pseudo_inertia``; Wensing, Kim & Slotine, IEEE RA-L 2017)
is positive definite; ``phi_from_pseudo_inertia`` is that matrix's inverse map. Units as
``load_dynamics``: kg, kg·m, kg·m² about S's origin.
"""

import math

import numpy as np

from heft.systems.load_dynamics import inertia_entries, pseudo_inertia


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
