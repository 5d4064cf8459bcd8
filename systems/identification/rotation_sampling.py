"""Sampled orientations R_WS(t): interpolation between samples and angular motion from them.

Plain numpy on batches of unit quaternions (w, x, y, z), Drake's order (docs/design.md §4), vectorised
over the millions of samples of a recording (per-sample pydrake objects would cost µs each).
A quaternion q describes R_WS: v_W = q ⊗ v_S ⊗ q*. ω and α are S's angular velocity and
acceleration in the world, expressed in S (rad/s, rad/s²), as ``load_dynamics`` takes them.
"""

from __future__ import annotations

import functools

import numpy as np
from scipy.spatial.transform import Rotation

ROTATION_TOLERANCE = 1e-3
"""How far a recorded rotation matrix may be from orthonormal (max |RᵀR − E|, and |det R − 1|), or a
recorded quaternion from unit norm: six printed digits are well within, a matrix that is not a
rotation far outside."""


def rotation_defects(R: np.ndarray) -> np.ndarray:
    """Per (3, 3) matrix of R (N, 3, 3): the larger of max |RᵀR − E| and |det R − 1|."""
    gram = np.einsum("nji,njk->nik", R, R) - np.eye(3)
    return np.maximum(np.abs(gram).max(axis=(1, 2)), np.abs(np.linalg.det(R) - 1.0))


def quaternions_from_matrices(R: np.ndarray) -> np.ndarray:
    """(N, 4) unit quaternions (w, x, y, z) of rotation matrices R (N, 3, 3) (checked beforehand)."""
    xyzw = Rotation.from_matrix(R).as_quat()
    return np.roll(xyzw, 1, axis=1)


def continuous(q: np.ndarray) -> np.ndarray:
    """q (N, 4) with signs chosen so that consecutive quaternions lie in one hemisphere
    (q and −q are the same rotation; interpolation needs neighbours that agree)."""
    q = np.asarray(q, dtype=float)
    if len(q) < 2:
        return q.copy()
    flips = np.einsum("ij,ij->i", q[:-1], q[1:]) < 0
    sign = np.concatenate(([1.0], np.where(np.cumsum(flips) % 2 == 1, -1.0, 1.0)))
    return q * sign[:, None]


def slerp(t: np.ndarray, q: np.ndarray, t_query: np.ndarray) -> np.ndarray:
    """Spherical linear interpolation of the samples (t (N,) increasing, q (N, 4) ``continuous``)
    at t_query (M,), within [t[0], t[-1]] (clamped outside). Returns (M, 4) unit quaternions."""
    k = np.clip(np.searchsorted(t, t_query, side="right") - 1, 0, len(t) - 2)
    u = np.clip((t_query - t[k]) / (t[k + 1] - t[k]), 0.0, 1.0)[:, None]
    q0, q1 = q[k], q[k + 1]
    cos = np.clip(np.einsum("ij,ij->i", q0, q1), -1.0, 1.0)[:, None]
    theta = np.arccos(cos)
    sin = np.sin(theta)
    small = sin < 1e-9
    safe = np.where(small, 1.0, sin)
    w0 = np.where(small, 1.0 - u, np.sin((1.0 - u) * theta) / safe)
    w1 = np.where(small, u, np.sin(u * theta) / safe)
    out = w0 * q0 + w1 * q1
    out /= np.linalg.norm(out, axis=1, keepdims=True)
    return out


def rotate_into_body(q: np.ndarray, v_W) -> np.ndarray:
    """v expressed in S, R_WSᵀ·v_W, for each quaternion of q (N, 4) and one vector v_W (3,):
    v − 2w(u × v) + 2u × (u × v) with q = (w, u)."""
    w, u = q[:, :1], q[:, 1:]
    v = np.broadcast_to(np.asarray(v_W, dtype=float), u.shape)
    uv = np.cross(u, v)
    return v - 2.0 * w * uv + 2.0 * np.cross(u, uv)


def _rotation_vectors(q: np.ndarray) -> np.ndarray:
    """The rotation vectors (axis·angle, rad) of unit quaternions q (N, 4)."""
    q = np.where(q[:, :1] < 0, -q, q)
    s = np.linalg.norm(q[:, 1:], axis=1)
    angle = 2.0 * np.arctan2(s, q[:, 0])
    scale = np.where(s > 1e-12, angle / np.where(s > 1e-12, s, 1.0), 2.0)
    return q[:, 1:] * scale[:, None]


def body_angular_velocity(t: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """ω in S between consecutive samples: (t_mid (N−1,), ω (N−1, 3)), ω_k the rotation vector of
    q_k* ⊗ q_{k+1} over t_{k+1} − t_k, exact for a constant ω between the two samples."""
    w0, u0 = q[:-1, :1], -q[:-1, 1:]  # conjugate of q_k
    w1, u1 = q[1:, :1], q[1:, 1:]
    relative = np.concatenate((w0 * w1 - np.einsum("ij,ij->i", u0, u1)[:, None],
                               w0 * u1 + w1 * u0 + np.cross(u0, u1)), axis=1)
    dt = np.diff(t)[:, None]
    return 0.5 * (t[:-1] + t[1:]), _rotation_vectors(relative) / dt


def savitzky_golay(x: np.ndarray, period: float, window: float, order: int, deriv: int = 0) -> np.ndarray:
    """x (N, k) sampled every ``period`` s (nearly), smoothed (deriv 0) or differentiated (deriv 1, per s)
    by a Savitzky–Golay filter: the least-squares polynomial of ``order`` over ``window`` seconds
    centred on each sample, evaluated there; the first and last half windows from the polynomial of
    the first and last full window (scipy's ``savgol_filter`` with mode "interp"; written out here so
    that a recording's commands need not import scipy.signal, seconds of start-up)."""
    samples = window_samples(period, window, order)
    n = len(x)
    if samples > n:
        raise ValueError(f"{n} samples are too few for a {samples}-sample Savitzky–Golay window")
    centre, first, last = _savitzky_golay_weights(samples, order, deriv, float(period))
    half = samples // 2
    out = np.empty_like(x, dtype=float)
    out[half:n - half] = np.lib.stride_tricks.sliding_window_view(x, samples, axis=0) @ centre
    out[:half] = first @ x[:samples]
    out[n - half:] = last @ x[n - samples:]
    return out


@functools.lru_cache(maxsize=32)
def _savitzky_golay_weights(samples: int, order: int, deriv: int, period: float):
    """Weights over a window's samples for the ``deriv``-th derivative of its least-squares polynomial:
    at the centre (samples,), at the first half window's samples (half, samples) and at the last's."""
    half = samples // 2
    offsets = np.arange(-half, half + 1) * period
    fit = np.linalg.pinv(offsets[:, None] ** np.arange(order + 1))  # polynomial coefficients from a window
    powers = np.arange(order + 1)
    factors = np.array([np.prod(np.arange(p - deriv + 1, p + 1)) if p >= deriv else 0.0 for p in powers])

    def rows(at):
        u = np.asarray(at, dtype=float)[:, None]
        return (factors * np.where(powers >= deriv, u ** np.maximum(powers - deriv, 0), 0.0)) @ fit
    return rows([0.0])[0], rows(offsets[:half]), rows(offsets[half + 1:])


def window_samples(period: float, window: float, order: int) -> int:
    """The number of samples ``savitzky_golay`` uses for ``window`` seconds at ``period``: odd, and at
    least order + 2."""
    return max(int(round(window / period)) // 2 * 2 + 1, order + 2 + (order + 1) % 2)
