"""Which of a load's parameters the data determine, and the covariance of an estimate on them.

A parameter is identifiable iff its unit vector lies in the row space of the data: its
component in the span of the unidentifiable directions is at most ``COMPONENT_TOL``. Which
directions are unidentifiable:

* batch (``batch_estimation``): the columns of the row-weighted regressor are scaled to unit
  norm (so the test does not depend on units) and a direction is unidentifiable when its
  singular value is below ``rcond`` (default 1e-6) times the largest (``ScaledSVD``);
* RLS and RIV (``recursive_estimation``): along the eigenvectors of the (instruments')
  information, read from its square root, the data's information is at most the prior's
  (1/initial_covariance) or below rcond² times the largest (``root_excitation``);
* RTLS: the centred information C of φ, scaled by 1/√(C_jj + N_jj) with N the expected
  information of the kinematic noise, has an eigenvalue of at most rcond (a vanishing
  fraction of one noise unit: never excited, or faded by forgetting); the offsets share
  those directions through the means (``null_excitation``).

An unidentifiable parameter keeps the minimum-norm value (batch, in the scaled coordinates:
0 for a column that was never excited) or its last value (recursive), and gets infinite
variance and NaN covariances (``mask_unidentifiable``): never a confident-looking number.
This is a property of the regressor *as measured*: a column excited only by accelerometer
noise counts as excited, and least squares then biases it towards zero (errors in variables:
use TLS, RIV or eiv_ml).
"""

import dataclasses
import math

import numpy as np
import scipy.linalg
from scipy.linalg import solve_triangular

COMPONENT_TOL = 1e-6
"""A parameter is identifiable iff its component in the unidentifiable subspace is below this."""


def check_rcond(rcond: float):
    """Raises ValueError unless the identifiability tolerance ``rcond`` lies in (0, 1)."""
    if not 0.0 < rcond < 1.0:
        raise ValueError(f"rcond must lie in (0, 1); got {rcond}")



@dataclasses.dataclass(frozen=True)
class ScaledSVD:
    """SVD of a matrix whose columns were scaled to unit norm: A·diag(scale) = U S Vᵀ."""

    scale: np.ndarray
    U: np.ndarray       # first ``rank`` left singular vectors
    s: np.ndarray       # all singular values, descending
    Vt: np.ndarray
    rank: int

    @classmethod
    def of(cls, A: np.ndarray, rcond: float, norms: np.ndarray | None = None) -> "ScaledSVD":
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
        return np.linalg.norm(self.Vt[self.rank:], axis=0) <= COMPONENT_TOL

    @property
    def condition_number(self) -> float:
        """s_max/s_min, inf when some direction is unidentifiable (rank < p)."""
        return float(self.s[0] / self.s[-1]) if self.rank == len(self.s) else math.inf


def root_excitation(root: np.ndarray, prior: float, rcond: float):
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
    identifiable = np.linalg.norm(vt[null], axis=0) <= COMPONENT_TOL
    reciprocal_condition = 0.0 if null.any() else math.sqrt(data.min() / top)
    return identifiable, vt[~null].T, reciprocal_condition


def null_excitation(null: np.ndarray):
    """(identifiable mask, orthonormal basis of the complement) for unidentifiable directions
    given as the columns of ``null`` (p, k)."""
    if null.shape[1] == 0:
        return np.ones(len(null), bool), np.eye(len(null))
    orthonormal = np.linalg.qr(null)[0]
    return np.linalg.norm(orthonormal, axis=1) <= COMPONENT_TOL, scipy.linalg.null_space(orthonormal.T)


def restricted_inverse(matrix: np.ndarray, basis: np.ndarray) -> np.ndarray | None:
    """basis (basisᵀ M basis)⁻¹ basisᵀ: the inverse of M on the identifiable subspace, or None
    if M is not positive definite there."""
    reduced = basis.T @ matrix @ basis
    try:
        factor = np.linalg.cholesky(0.5 * (reduced + reduced.T))
    except np.linalg.LinAlgError:
        return None
    half = solve_triangular(factor, basis.T, lower=True)
    return half.T @ half


def mask_unidentifiable(covariance: np.ndarray | None, identifiable: np.ndarray) -> np.ndarray:
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
