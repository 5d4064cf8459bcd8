"""Excitation trajectories for load identification (Kubus & Wahl, Sec. IV, Eqs. 9–10).

Each joint follows a finite Fourier series with a common base frequency f (Hz),

    q_i(t) = q_i0 + Σ_k ρ_ik sin(2πkft) + δ_ik cos(2πkft),   k = 1 … N,

periodic with period 1/f, band-limited to N·f, with analytic derivatives (Swevers
et al. [16], [17]). The coefficients are chosen to make the extended regressor
[E₆ V] of Eq. 8, stacked over one period, well excited while every joint
stays within its position, velocity and acceleration limits.

Rest at start and end. At t = 0 (and so at every whole period):
q − q0 = Σδ_k, q̇ = 2πf Σkρ_k, q̈ = −(2πf)² Σk²δ_k. The three linear constraints
Σδ_k = 0, Σkρ_k = 0, Σk²δ_k = 0 per joint make the trajectory start and end at
q0 with zero velocity and acceleration. The optimiser never sees them: it
works in *rest coordinates*, the coefficients in orthonormal bases of their
null spaces (N − 1 for ρ, N − 2 for δ, see :func:`rest_basis`), so every
iterate is at rest by construction and the limits are the only constraints.

Kinematics come from a caller-provided function of (q, q̇, q̈) returning
(a, α, ω, g) in S, so this module never imports the diagrams.
:class:`SensorFrameMotion` is that function for a Drake MultibodyPlant.

Criteria (all on the stacked 6T × 16 regressor V over one period, T samples;
:class:`RegressorMetrics` reports all three whichever is optimised):

* ``"cond"``: κ(V D⁻¹), D the column norms (column scaling makes κ independent
  of the parameters' units). The criterion of Swevers et al.'s earlier
  Fourier-series design (ASME J. Manuf. Sci. Eng. 119(4A), 1997) and of
  Gautier & Khalil.
* ``"d_optimal"``: −log det(VᵀV / 6T) in physical units, i.e. the log-volume of
  the Cramér–Rao covariance σ²(VᵀV)⁻¹; [16] argues for such an uncertainty
  criterion over the condition number. Its ranking does not depend on units.
* ``"e_optimal"``: −log σ_min(V D⁻¹).

Default: ``"d_optimal"``. Measured on the RX90 with the 3.13 kg tool about the
scenario's start pose (default settings, seed 0, positions within q0 ± 0.5 rad,
half the URDF velocities, 10 rad/s²), as (κ, log det, σ_min): random start
(11.2, −23.7, 0.137); cond (2.00, −2.1, 0.637); d_optimal (3.25, 15.5, 0.455);
e_optimal (2.17, 3.2, 0.654). Then 10 s at 2 kHz through the docs/design.md §6 sensor
model (FT 0.1 N / 0.005 N·m, accelerometer 0.05 m/s² / 0.5 rad/s²) and least
squares, 10 trials: RMS error of Ixx, Iyy 2.4e-3, 4.0e-3 kg·m² (cond),
4.4e-4, 5.1e-4 (d_optimal), 1.6e-3, 2.0e-3 (e_optimal), of true 0.024, 0.026;
mass within 0.4–0.6 g for all three. Column scaling makes κ and σ_min blind to
the motion's size, while the noise in the measured a and α (errors in the
variables) is beaten only by large α and ω: the d_optimal design reaches
15 rad/s² and 4.7 rad/s at S where the cond design stays at 5.3 rad/s² and
1.9 rad/s. Its κ of 3.3 is still well conditioned, and it converges in the
fewest iterations.
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np
from pydrake.multibody.tree import JacobianWrtVariable
from pydrake.polynomial import Polynomial
from pydrake.trajectories import PiecewisePolynomial
from scipy.linalg import null_space
from scipy.optimize import minimize

from heft.systems.drake_conventions import swap_halves
from heft.systems.load_dynamics import regressor_with_offsets

CRITERIA = ("cond", "d_optimal", "e_optimal")
NUM_UNKNOWNS = 16
# Relative singular-value threshold (of the column-scaled V) below which a direction counts as unexcited.
RANK_TOLERANCE = 1e-9
# Relative column norm below which a regressor column counts as zero (round-off, not excitation).
ZERO_COLUMN = 1e-10
# Fine grid, in samples per period, on which the limits are verified and repaired.
_CHECK_SAMPLES = 4000


def rest_basis(harmonics: int) -> tuple[np.ndarray, np.ndarray]:
    """Orthonormal bases (N × (N−1), N × (N−2)) of the sine and cosine coefficients
    with Σkρ_k = 0 (q̇(0) = 0) and Σδ_k = Σk²δ_k = 0 (q(0) = q0, q̈(0) = 0)."""
    if harmonics < 2:
        raise ValueError(f"a trajectory at rest needs at least 2 harmonics; got {harmonics}")
    k = np.arange(1, harmonics + 1, dtype=float)
    return null_space(k[None, :]), null_space(np.vstack((np.ones_like(k), k ** 2)))


@dataclasses.dataclass(frozen=True)
class FourierTrajectory:
    """Eqs. 9–10 for n joints: base frequency (Hz), sine and cosine coefficients
    ρ, δ (n × N, rad) and offsets q0 (n, rad). Methods take t (s) scalar or (T,)
    and return (n,) or (T, n)."""

    base_frequency: float
    rho: np.ndarray
    delta: np.ndarray
    q0: np.ndarray

    def __post_init__(self):
        f = float(self.base_frequency)
        rho, delta = np.array(self.rho, dtype=float), np.array(self.delta, dtype=float)
        q0 = np.array(self.q0, dtype=float)
        if not (math.isfinite(f) and f > 0):
            raise ValueError(f"base_frequency must be finite and > 0 (Hz); got {self.base_frequency}")
        if rho.ndim != 2 or rho.shape != delta.shape or q0.shape != rho.shape[:1]:
            raise ValueError(f"rho and delta must be (n_joints, N) and q0 (n_joints,); got "
                             f"{rho.shape}, {delta.shape}, {q0.shape}")
        if not all(np.isfinite(x).all() for x in (rho, delta, q0)):
            raise ValueError("rho, delta and q0 must be finite")
        object.__setattr__(self, "base_frequency", f)
        object.__setattr__(self, "rho", rho)
        object.__setattr__(self, "delta", delta)
        object.__setattr__(self, "q0", q0)

    @classmethod
    def from_rest_coordinates(cls, base_frequency: float, x, q0) -> FourierTrajectory:
        """The trajectory at rest at q0 with rest coordinates x (n × (2N − 3), rad):
        ρ_i = B_ρ x_i[:N−1], δ_i = B_δ x_i[N−1:] with the bases of :func:`rest_basis`."""
        x = np.asarray(x, dtype=float)
        if x.ndim != 2 or x.shape[1] % 2 == 0:
            raise ValueError(f"x must be (n_joints, 2N − 3); got {x.shape}")
        harmonics = (x.shape[1] + 3) // 2
        B_rho, B_delta = rest_basis(harmonics)
        return cls(base_frequency, x[:, :harmonics - 1] @ B_rho.T, x[:, harmonics - 1:] @ B_delta.T, q0)

    @property
    def harmonics(self) -> int:
        return self.rho.shape[1]

    @property
    def period(self) -> float:
        """1/f (s)."""
        return 1.0 / self.base_frequency

    def derivative(self, t, order: int) -> np.ndarray:
        """d^order q / dt^order (rad/s^order), using dⁿ/dtⁿ sin(ωt) = ωⁿ sin(ωt + nπ/2)."""
        t = np.asarray(t, dtype=float)
        omega = 2 * np.pi * self.base_frequency * np.arange(1, self.harmonics + 1)
        phase = np.multiply.outer(t, omega) + order * np.pi / 2           # (..., N)
        gain = omega ** order
        value = np.sin(phase) @ (gain * self.rho).T + np.cos(phase) @ (gain * self.delta).T
        return value + self.q0 if order == 0 else value

    def position(self, t) -> np.ndarray:
        """q(t) (rad)."""
        return self.derivative(t, 0)

    def velocity(self, t) -> np.ndarray:
        """q̇(t) (rad/s)."""
        return self.derivative(t, 1)

    def acceleration(self, t) -> np.ndarray:
        """q̈(t) (rad/s²)."""
        return self.derivative(t, 2)

    def rest_residual(self) -> float:
        """max(|q(0) − q0|, |q̇(0)|, |q̈(0)|) in rad, rad/s, rad/s²; 0 for a trajectory at rest."""
        return max(np.abs(self.position(0.0) - self.q0).max(), np.abs(self.velocity(0.0)).max(),
                   np.abs(self.acceleration(0.0)).max())

    def to_drake(self, duration: float, samples: int) -> PiecewisePolynomial:
        """A C² quintic-Hermite PiecewisePolynomial through ``samples`` equally spaced
        knots on [0, duration], exact in q, q̇, q̈ at every knot (elsewhere its error
        is O((2πNf·h)⁶)). ``duration`` must be whole periods and the trajectory at
        rest, so the command starts and ends at q0, still; Drake holds the end value
        after ``duration``. For a TrajectorySource feeding ``slave.position_commanded``."""
        periods = duration * self.base_frequency
        if not (duration > 0 and abs(periods - round(periods)) < 1e-9 * max(1.0, periods)):
            raise ValueError(f"duration must be a positive whole number of periods ({self.period:g} s); "
                             f"got {duration} s")
        scale = max(1.0, np.abs(self.rho).max(), np.abs(self.delta).max()) * (2 * np.pi * self.base_frequency
                                                                              * self.harmonics) ** 2
        if self.rest_residual() > 1e-9 * scale:
            raise ValueError("the trajectory does not start at rest at q0 (see rest_basis); "
                             "commanding it would step the robot")
        if samples < 2:
            raise ValueError(f"samples must be >= 2 knots; got {samples}")
        breaks = np.linspace(0.0, duration, samples)
        h = np.diff(breaks)[:, None]
        p, v, a = (self.derivative(breaks, order) for order in (0, 1, 2))
        p0, v0, a0, p1, v1, a1 = p[:-1], v[:-1], a[:-1], p[1:], v[1:], a[1:]
        dp = p1 - p0
        coefficients = np.stack((
            p0, v0, a0 / 2,
            (20 * dp - (8 * v1 + 12 * v0) * h - (3 * a0 - a1) * h ** 2) / (2 * h ** 3),
            (-30 * dp + (14 * v1 + 16 * v0) * h + (3 * a0 - 2 * a1) * h ** 2) / (2 * h ** 4),
            (12 * dp - 6 * (v1 + v0) * h - (a0 - a1) * h ** 2) / (2 * h ** 5)), axis=-1)  # (segments, n, 6)
        segments = []
        for segment in coefficients:
            matrix = np.empty((len(self.q0), 1), dtype=object)
            matrix[:, 0] = [Polynomial(c) for c in segment]
            segments.append(matrix)
        return PiecewisePolynomial(segments, breaks.tolist())


class SensorFrameMotion:
    """(a, α, ω, g) of frame S from joint motion (q, q̇, q̈), by Drake.

    a is the translational acceleration of S's origin in W (m/s²), α and ω S's
    angular acceleration and velocity in W (rad/s², rad/s), g the plant's gravity
    (m/s²), all expressed in S: the inputs of Eq. 5. Computed as
    A_WS = J_WS(q)·q̈ + J̇_WS(q, q̇)·q̇ with Drake's spatial-velocity Jacobian and
    bias acceleration. The joints are ``model_instance``'s (else the whole
    plant's) and need q̇ = v (revolute, prismatic); other DoFs keep the context's
    state with zero v̇. ``plant_context`` is scratch: its state is overwritten.
    """

    def __init__(self, plant, plant_context, frame_S, model_instance=None):
        self._plant, self._context, self._S = plant, plant_context, frame_S
        self._instance = model_instance
        self._g_W = np.array(plant.gravity_field().gravity_vector())
        nv = plant.num_velocities()
        if model_instance is None:
            nq, self._v_index = plant.num_positions(), np.arange(nv)
        else:
            nq = plant.num_positions(model_instance)
            self._v_index = plant.GetVelocitiesFromArray(model_instance, np.arange(nv, dtype=float)).astype(int)
        if nq != len(self._v_index):
            raise ValueError("SensorFrameMotion needs q̇ = v (revolute or prismatic joints only)")
        self.num_joints = nq

    def _set_state(self, qv):
        if self._instance is None:
            self._plant.SetPositionsAndVelocities(self._context, qv)
        else:
            self._plant.SetPositionsAndVelocities(self._context, self._instance, qv)

    def __call__(self, q, qdot, qddot):
        """(a, α, ω, g), each (3,) for (n,) inputs or (T, 3) for (T, n) inputs."""
        q, qdot, qddot = (np.asarray(x, dtype=float) for x in (q, qdot, qddot))
        single = q.ndim == 1
        q, qdot, qddot = (np.atleast_2d(x) for x in (q, qdot, qddot))
        if not (q.shape == qdot.shape == qddot.shape and q.shape[1] == self.num_joints):
            raise ValueError(f"q, q̇, q̈ must be ({self.num_joints},) or (T, {self.num_joints}); "
                             f"got {q.shape}, {qdot.shape}, {qddot.shape}")
        plant, context, S, W = self._plant, self._context, self._S, self._plant.world_frame()
        kV, origin, T = JacobianWrtVariable.kV, np.zeros(3), len(q)
        qv = np.hstack((q, qdot))
        J = np.empty((T, 6, plant.num_velocities()))      # rows [ω; v] of S in W, in W
        bias = np.empty((T, 6))                            # J̇·v, Drake order [α; a]
        R_WS = np.empty((T, 3, 3))
        for k in range(T):
            self._set_state(qv[k])
            J[k] = plant.CalcJacobianSpatialVelocity(context, kV, S, origin, W, W)
            bias[k] = plant.CalcBiasSpatialAcceleration(context, kV, S, origin, W, W).get_coeffs()
            R_WS[k] = S.CalcRotationMatrixInWorld(context).matrix()
        J = J[:, :, self._v_index]
        A_WS_W = np.einsum("tij,tj->ti", J, qddot) + bias
        w_WS_W = np.einsum("tij,tj->ti", J[:, :3], qdot)
        to_S = lambda x_W: np.einsum("tji,tj->ti", R_WS, x_W)  # R_SW · x_W
        acceleration = swap_halves(A_WS_W)  # [a; α] in W
        out = (to_S(acceleration[:, :3]), to_S(acceleration[:, 3:]), to_S(w_WS_W),
               to_S(np.broadcast_to(self._g_W, (T, 3))))
        return tuple(x[0] for x in out) if single else out


def excitation_regressor(trajectory: FourierTrajectory, kinematics_fn, times) -> np.ndarray:
    """The extended regressors [E₆ V] (Eq. 8) at ``times`` (s, (T,)), stacked to (6T, 16).

    ``kinematics_fn(q, q̇, q̈)`` maps (T, n) joint arrays to (a, α, ω, g), each
    (T, 3) in S (e.g. a :class:`SensorFrameMotion`)."""
    times = np.atleast_1d(np.asarray(times, dtype=float))
    return _stacked_regressor(kinematics_fn, trajectory.position(times), trajectory.velocity(times),
                              trajectory.acceleration(times))


def _stacked_regressor(kinematics_fn, q, qdot, qddot) -> np.ndarray:
    return regressor_with_offsets(*kinematics_fn(q, qdot, qddot)).reshape(-1, NUM_UNKNOWNS)


@dataclasses.dataclass(frozen=True)
class RegressorMetrics:
    """Quality of a stacked regressor V (rows × 16).

    condition_number: κ(V D⁻¹), D = diag of column norms (inf if a column is zero or
    V is singular); log_det: log det(VᵀV / rows) in physical units (−inf if singular);
    min_singular_value: σ_min(V D⁻¹) (unit-norm columns, so within [0, 1]);
    rank: numerical rank (singular values of V D⁻¹ above RANK_TOLERANCE·σ_max).
    """

    condition_number: float
    log_det: float
    min_singular_value: float
    rank: int


def _singular_values(V: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Singular values of V with unit-norm columns and of V/√rows. A column below
    ZERO_COLUMN × the largest column norm is round-off of an unexcited one (e.g. ω_x·ω_z
    when S turns about its own z only) and is zeroed, not scaled up into noise."""
    norms = np.linalg.norm(V, axis=0)
    live = norms > ZERO_COLUMN * norms.max()
    scaled = np.linalg.svd(np.where(live, V / np.where(live, norms, 1.0), 0.0), compute_uv=False)
    return scaled, np.linalg.svd(V / math.sqrt(len(V)), compute_uv=False)


def regressor_metrics(V) -> RegressorMetrics:
    """:class:`RegressorMetrics` of a stacked regressor (rows × 16)."""
    V = np.asarray(V, dtype=float)
    scaled, physical = _singular_values(V)
    rank = int(np.sum(scaled > RANK_TOLERANCE * scaled[0]))
    full = rank == V.shape[1]
    return RegressorMetrics(
        condition_number=float(scaled[0] / scaled[-1]) if full else math.inf,
        log_det=float(2 * np.log(physical).sum()) if physical[-1] > 0 else -math.inf,
        min_singular_value=float(scaled[-1]), rank=rank)


def _criterion_value(V: np.ndarray, criterion: str) -> float:
    """The quantity to minimise, finite even for a singular V. From the 16 × 16 Gram
    matrix with unit diagonal (column scaling keeps its eigenvalues accurate; ~10×
    cheaper than an SVD of V): log det(VᵀV/rows) = Σ log(|v_j|²/rows) + log det(G_s)."""
    G = V.T @ V
    norms = np.sqrt(np.diag(G))
    live = norms > ZERO_COLUMN * norms.max()
    inverse = np.where(live, 1.0 / np.maximum(norms, 1e-300), 0.0)
    eigenvalues = np.maximum(np.linalg.eigvalsh(G * np.outer(inverse, inverse)), 1e-300)
    if criterion == "d_optimal":
        return float(-np.log(np.maximum(norms ** 2 / len(V), 1e-300)).sum() - np.log(eigenvalues).sum())
    smallest = np.log(eigenvalues[0])
    return float(0.5 * (np.log(eigenvalues[-1]) - smallest) if criterion == "cond" else -0.5 * smallest)


@dataclasses.dataclass(frozen=True)
class JointLimits:
    """Per-joint limits: positions lower, upper (rad), |q̇| ≤ velocity (rad/s),
    |q̈| ≤ acceleration (rad/s²); each (n,)."""

    lower: np.ndarray
    upper: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray

    def __post_init__(self):
        arrays = [np.array(getattr(self, name), dtype=float) for name in ("lower", "upper", "velocity", "acceleration")]
        if len({a.shape for a in arrays}) != 1 or arrays[0].ndim != 1:
            raise ValueError(f"limits must be four (n,) arrays; got shapes {[a.shape for a in arrays]}")
        if not (np.all(arrays[0] < arrays[1]) and np.all(arrays[2] > 0) and np.all(arrays[3] > 0)
                and all(np.isfinite(a).all() for a in arrays)):
            raise ValueError("limits need finite lower < upper and velocity, acceleration > 0")
        for name, a in zip(("lower", "upper", "velocity", "acceleration"), arrays):
            object.__setattr__(self, name, a)

    @classmethod
    def from_plant(cls, plant, acceleration, model_instance=None, velocity_fraction: float = 1.0) -> JointLimits:
        """Position and velocity limits from a finalized plant (e.g. the URDF's
        ``<limit>``), velocities scaled by ``velocity_fraction``; ``acceleration``
        (rad/s², scalar or (n,)) from the caller, as URDFs carry none."""
        get = (lambda limits: limits) if model_instance is None else (
            lambda limits: plant.GetPositionsFromArray(model_instance, limits))
        get_v = (lambda limits: limits) if model_instance is None else (
            lambda limits: plant.GetVelocitiesFromArray(model_instance, limits))
        upper_v = get_v(plant.GetVelocityUpperLimits())
        return cls(get(plant.GetPositionLowerLimits()), get(plant.GetPositionUpperLimits()),
                   velocity_fraction * upper_v, np.broadcast_to(np.asarray(acceleration, dtype=float),
                                                                upper_v.shape))

    def within(self, center, half_range) -> JointLimits:
        """These limits with positions also kept within center ± half_range (rad,
        scalar or (n,)): a simple way to keep an excitation clear of the
        surroundings, which joint limits alone do not."""
        center = np.asarray(center, dtype=float)
        return JointLimits(np.maximum(self.lower, center - half_range), np.minimum(self.upper, center + half_range),
                           self.velocity, self.acceleration)

    def margins(self, trajectory: FourierTrajectory, times) -> LimitMargins:
        """Smallest distances to the limits over ``times`` (s); negative means violated."""
        q, qd, qdd = (trajectory.derivative(times, order) for order in (0, 1, 2))
        return LimitMargins(position=np.minimum(q - self.lower, self.upper - q).min(axis=0),
                            velocity=(self.velocity - np.abs(qd)).min(axis=0),
                            acceleration=(self.acceleration - np.abs(qdd)).min(axis=0))


@dataclasses.dataclass(frozen=True)
class LimitMargins:
    """Per-joint smallest distance to the position (rad), velocity (rad/s) and
    acceleration (rad/s²) limits; all ≥ 0 for a feasible trajectory."""

    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray

    def feasible(self) -> bool:
        return bool(min(self.position.min(), self.velocity.min(), self.acceleration.min()) >= 0)


@dataclasses.dataclass
class ExcitationSettings:
    """Settings of :func:`optimize_excitation` (YAML-loadable). Defaults: a 10 s
    period with 5 harmonics (band ≤ 0.5 Hz), 3–25 s of optimisation on 2 shared
    cores (d_optimal 3–5 s); :meth:`quick` (3 harmonics) takes 0.2–1.5 s."""

    base_frequency: float = 0.1       # Hz
    harmonics: int = 5
    duration: float = 10.0            # s, whole periods
    criterion: str = "d_optimal"      # one of CRITERIA
    seed: int = 0                     # of the random start
    max_iterations: int = 100         # SLSQP iterations
    samples: int = 100                # criterion grid, per period
    constraint_samples: int = 200     # limit grid of the optimiser, per period

    @classmethod
    def quick(cls) -> ExcitationSettings:
        return cls(harmonics=3, samples=40, constraint_samples=100, max_iterations=40)


@dataclasses.dataclass(frozen=True)
class ExcitationResult:
    """An optimised excitation and its report.

    ``metrics`` and ``initial_metrics`` are the optimised and random-start
    trajectories' :class:`RegressorMetrics` on the criterion grid (every criterion
    reported, whichever was optimised); ``margins`` are verified on a fine grid
    (4000 samples per period). ``iterations`` counts SLSQP's over ``restarts``
    restarts, ``message`` is its last;
    ``repair_scale`` ≤ 1 is the amplitude factor that made the fine grid feasible."""

    trajectory: FourierTrajectory
    duration: float
    criterion: str
    metrics: RegressorMetrics
    initial_metrics: RegressorMetrics
    margins: LimitMargins
    iterations: int
    restarts: int
    message: str
    repair_scale: float
    seconds: float


def _rest_design_matrices(base_frequency, harmonics, times) -> list[np.ndarray]:
    """Φ^(n) (T × (2N−3)) with q_i^(n)(t) − (q_i0 if n = 0) = Φ^(n)(t) x_i, for n = 0, 1, 2."""
    B_rho, B_delta = rest_basis(harmonics)
    omega = 2 * np.pi * base_frequency * np.arange(1, harmonics + 1)
    out = []
    for order in range(3):
        phase = np.outer(times, omega) + order * np.pi / 2
        gain = omega ** order
        out.append(np.hstack(((np.sin(phase) * gain) @ B_rho, (np.cos(phase) * gain) @ B_delta)))
    return out


def _feasible_scale(x, q0, limits, design, base_frequency: float, spacing: float = 0.0) -> float:
    """The largest s with s·x within every limit: on the grid of ``design`` when
    ``spacing`` is 0, everywhere when ``spacing`` (s) is that grid's step. Between
    samples h apart a function with |f''| ≤ M exceeds its larger end value by at
    most M·h²/8; M for q^(n) is bounded by Σ_k |c_k| (kω)^(n+2), |c_k| the
    amplitude of harmonic k."""
    peaks = [phi @ x.T for phi in design]                                   # (T, n) each
    up, down = peaks[0].max(axis=0), -peaks[0].min(axis=0)
    velocity, acceleration = np.abs(peaks[1]).max(axis=0), np.abs(peaks[2]).max(axis=0)
    if spacing:
        harmonics = (x.shape[1] + 3) // 2
        B_rho, B_delta = rest_basis(harmonics)
        amplitude = np.hypot(x[:, :harmonics - 1] @ B_rho.T, x[:, harmonics - 1:] @ B_delta.T)  # (n, N)
        omega = 2 * np.pi * base_frequency * np.arange(1, harmonics + 1)
        slack = [spacing ** 2 / 8 * amplitude @ omega ** (order + 2) for order in range(3)]
        up, down, velocity, acceleration = up + slack[0], down + slack[0], velocity + slack[1], acceleration + slack[2]
    with np.errstate(divide="ignore"):
        ratios = np.concatenate(((limits.upper - q0) / up, (q0 - limits.lower) / down,
                                 limits.velocity / velocity, limits.acceleration / acceleration))
    return float(np.where(ratios > 0, ratios, np.inf).min())


def optimize_excitation(motion, q0, limits: JointLimits, base_frequency: float = 0.1, harmonics: int = 5,
                        duration: float = 10.0, criterion: str = "d_optimal", seed: int = 0,
                        max_iterations: int = 100, samples: int = 100,
                        constraint_samples: int = 200) -> ExcitationResult:
    """Fourier coefficients that minimise ``criterion`` of the stacked [E₆ V] over one period.

    ``motion(q, q̇, q̈)`` → (a, α, ω, g) in S (e.g. :class:`SensorFrameMotion`); q0
    (n, rad) the rest pose, strictly inside the position limits. Variables are the
    rest coordinates (module docstring), so start and end at rest hold exactly;
    the limits, linear in them, are SLSQP inequality constraints with exact
    Jacobians on ``constraint_samples`` points per period; the criterion's gradient
    is by forward differences. The start is a random direction scaled to touch the
    nearest limit. Afterwards the limits are bounded everywhere from a
    4000-sample grid (with the curvature bound of ``_feasible_scale``) and, if
    SLSQP overstepped between its points, the amplitude is scaled down (all
    limits are about q0, so this always restores feasibility).
    """
    started = time.perf_counter()
    if criterion not in CRITERIA:
        raise ValueError(f"criterion must be one of {CRITERIA}; got {criterion!r}")
    q0 = np.asarray(q0, dtype=float)
    n = len(q0)
    if limits.lower.shape != (n,):
        raise ValueError(f"limits are for {len(limits.lower)} joints, q0 has {n}")
    if not np.all((limits.lower < q0) & (q0 < limits.upper)):
        raise ValueError(f"q0 {q0} must lie strictly inside the position limits")
    period = 1.0 / base_frequency
    periods = duration * base_frequency
    if not (duration > 0 and abs(periods - round(periods)) < 1e-9 * max(1.0, periods)):
        raise ValueError(f"duration must be a positive whole number of periods ({period:g} s); got {duration} s")
    m = 2 * harmonics - 3
    grid = _rest_design_matrices(base_frequency, harmonics, np.arange(samples) * period / samples)
    check = _rest_design_matrices(base_frequency, harmonics, np.arange(_CHECK_SAMPLES) * period / _CHECK_SAMPLES)

    def regressor_of(x_flat):
        x = x_flat.reshape(n, m)
        return _stacked_regressor(motion, q0 + grid[0] @ x.T, grid[1] @ x.T, grid[2] @ x.T)

    # Limits as 1 − (A x)_r / b_r ≥ 0, block-diagonal over joints (x ordered joint-major).
    phis = _rest_design_matrices(base_frequency, harmonics, np.arange(constraint_samples) * period / constraint_samples)
    blocks = []
    for i in range(n):
        rows = np.vstack((phis[0], -phis[0], phis[1], -phis[1], phis[2], -phis[2]))
        b = np.repeat([limits.upper[i] - q0[i], q0[i] - limits.lower[i], limits.velocity[i], limits.velocity[i],
                       limits.acceleration[i], limits.acceleration[i]], constraint_samples)
        block = np.zeros((len(rows), n * m))
        block[:, i * m:(i + 1) * m] = rows / b[:, None]
        blocks.append(block)
    A = np.vstack(blocks)
    constraint = {"type": "ineq", "fun": lambda x: 1.0 - A @ x, "jac": lambda x: -A}

    rng = np.random.default_rng(seed)
    x0 = rng.normal(size=(n, m))
    x0 *= _feasible_scale(x0, q0, limits, phis, base_frequency)
    initial_metrics = regressor_metrics(regressor_of(x0.ravel()))
    objective = lambda x: _criterion_value(regressor_of(x), criterion)
    x = x_best = x0.ravel()
    best, iterations, restarts = objective(x), 0, 0
    while True:
        solution = minimize(objective, x, method="SLSQP", jac="2-point", constraints=[constraint],
                            options={"maxiter": max_iterations - iterations, "ftol": 1e-7,
                                     "finite_diff_rel_step": 1e-6})
        iterations += solution.nit
        # Back onto the constraint grid's feasible set (SLSQP may end slightly outside).
        x = solution.x * min(1.0, _feasible_scale(solution.x.reshape(n, m), q0, limits, phis, base_frequency))
        value = objective(x)
        improved = value < best - 1e-7 * abs(best)
        if value < best:
            x_best, best = x, value
        # SLSQP's subproblem can fail on the many near-parallel limit rows ("Inequality constraints
        # incompatible", status 4) or in its line search (8); restarting from the point reached helps.
        if solution.status not in (4, 8) or iterations >= max_iterations or not improved:
            break
        restarts += 1
    x = x_best.reshape(n, m)
    repair_scale = min(1.0, (1 - 1e-12) * _feasible_scale(x, q0, limits, check, base_frequency,
                                                               period / _CHECK_SAMPLES))
    x = x * repair_scale
    trajectory = FourierTrajectory.from_rest_coordinates(base_frequency, x, q0)
    return ExcitationResult(
        trajectory=trajectory, duration=float(duration), criterion=criterion,
        metrics=regressor_metrics(regressor_of(x.ravel())), initial_metrics=initial_metrics,
        margins=limits.margins(trajectory, np.arange(_CHECK_SAMPLES) * period / _CHECK_SAMPLES),
        iterations=iterations, restarts=restarts, message=str(solution.message), repair_scale=repair_scale,
        seconds=time.perf_counter() - started)
