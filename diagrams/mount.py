"""The compliant tool mount: its constants for a load, its modes, whether the plant's step
integrates them, and its small-deflection response below a sensor whose motion is given (the
stand-in lab's, ``MountUnderMovingSensor``).

Drake's discrete plant integrates a force element such as the mount's bushing explicitly: its
force at the start of a step sets the velocity at the end, which then moves the position
(semi-implicit Euler). A mode of angular frequency ω and damping ratio ζ is stable only for
ω·h < 2(√(1 + ζ²) − ζ) (h the step; the trace and determinant of the step's 2×2 map), and a
mode beyond it makes the simulation diverge within milliseconds (Drake then reports a mass
matrix "not positive-definite"). The modes that count are those of the load on the mount
*with the arm's wrist free beside it* (the plant's mass matrix in the start pose, the
bushing's stiffness and damping at the mount's coordinates): the light wrist (flange, JR3)
ringing against a stiff mount sets the fastest of them, two to three times the fastest mode
of the load on a fixed sensor.

Measured in the station (h = 0.5 ms, a tap on the load, 0.3 s): every mount whose fastest
mode was within that bound ran; beyond it one (a thin rod lying across S, all of its fastest
mode in the load) diverged at 1.3 times the bound, while modes the wrist shares ran up to
1.8 times it (the arm's servo, implicit in the plant, damps the wrist). ``STEP_MARGIN`` keeps
every mode within 0.8 of the bound; the paper's tool's fastest, 363 Hz (15 % damped), uses 0.66.

Why not integrate the mount implicitly (joints with the plant's implicit PD actuators)? That
damps too: implicit Euler takes 1 − 1/√(1 + (ωh)²) of a 49 Hz mode's amplitude per 0.5 ms
step, 7.6 % of critical damping on top of the mount's own 4 %, which would change what the
paper's tool does on its mount (the dominant error of the realistic station, docs/scenarios.md). Sizing
the mount to the load keeps the paper's tool exactly as it was and the rest within the step.

Where the compliance sits. A tool's compliance is its adapter's at the sensor's face and its
stem's bending along it: a mass on a stem rocks about a point on the stem, not about S (a
cantilever's tip under a load at it turns as a rigid bar pivoting 2L/3 from the tip:
δ = FL³/3EI, θ = FL²/2EI, the cantilever's tip formulas of any beam table). With the
bushing at S a compact mass far out on a light stem has a mode far beyond the step, the mass
turning about its own centre of mass against the bushing's translational stiffness times the
lever arm squared (a 0.1 kg tungsten ball 0.25 m out, its stem left out: 32 times the bound);
softening the whole mount by that much left it rocking at 1 Hz, sagging centimetres, and Drake's
step then failed ("mass matrix … not positive-definite"); on a stem (0.9–1.8 times) it took the
tool to 20–40 Hz, far from the notch. So a mount whose constants are left out is placed (``at``)
on the line from S to the load's centre of mass, at S where the step integrates it there (the
paper's tool and every tool near S), else at the first eighth of the way out where it does, and
sized there: the same ratios of the load's inertia, now about that point. Only where no point
of the line does (a compact 3 kg block 0.25 m out, its stem left out: the modes with the wrist
beside it stay at 1.0 of the bound or more) is it softened, at the point that needs least.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import scipy.linalg

from heft.diagrams.scenario import DEFAULT_MOUNT, MountSpec
from heft.systems.compiled import compiled
from heft.systems.load_dynamics import inertia_matrix

CONSTANTS = ("torque_stiffness", "torque_damping", "force_stiffness", "force_damping")
_WRENCH_ORDER = np.r_[3:6, 0:3]
"""[rotation; translation] → heft's [translation; rotation]."""
STEP_MARGIN = 0.8
"""The share of the step's stability bound a mount's mode may use (see the module's notes)."""
PLACEMENTS = np.linspace(0.0, 1.0, 9)
"""Where an unstated mount may sit: these shares of the way from S to the load's centre of mass."""


@dataclasses.dataclass(frozen=True)
class Modes:
    """Undamped modes of a mount, slowest first: frequencies (Hz), their damping ratios (the
    damping projected on each mode), and the mode shapes as columns (mass-normalized)."""
    frequencies: np.ndarray
    damping_ratios: np.ndarray
    shapes: np.ndarray


def placement(mount: MountSpec) -> np.ndarray:
    """T (6×6): the bushing's deflection [θ; d_P] at its point P (``mount.at``; S when None) from the
    load frame's [θ; d] at S, d_P = d + θ × p_SP (rad, m; S's axes)."""
    T = np.eye(6)
    if mount.at is not None:
        x, y, z = mount.at
        T[3:, :3] = [[0.0, z, -y], [-z, 0.0, x], [y, -x, 0.0]]  # −[p_SP]×
    return T


def stiffness(mount: MountSpec) -> np.ndarray:
    """The bushing's stiffness at rest, [rotation; translation] of the load frame at S (6×6): its
    constants about and along S's axes at its point P (``placement``), Tᵀ·K_P·T."""
    T = placement(mount)
    return T.T @ np.diag(mount.torque_stiffness + mount.force_stiffness) @ T


def damping(mount: MountSpec) -> np.ndarray:
    """The bushing's damping at rest, as ``stiffness`` (6×6)."""
    T = placement(mount)
    return T.T @ np.diag(mount.torque_damping + mount.force_damping) @ T


def modes(M: np.ndarray, K: np.ndarray, C: np.ndarray) -> Modes:
    """The generalized eigenproblem K·x = ω²·M·x (M positive definite, K semi-definite); modes
    of zero stiffness (free coordinates) left out."""
    eigenvalues, shapes = scipy.linalg.eigh(K, M)
    keep = eigenvalues > 1e-9 * eigenvalues.max()
    omega, shapes = np.sqrt(eigenvalues[keep]), shapes[:, keep]
    zeta = np.einsum("ik,ij,jk->k", shapes, C, shapes) / (2 * omega)
    return Modes(omega / (2 * np.pi), zeta, shapes)


def spatial_inertia_about_S(phi) -> np.ndarray:
    """The load's spatial inertia about S's origin in S, [rotation; translation] (6×6), from φ (Eq. 6)."""
    m, h = phi[0], np.asarray(phi[1:4])
    hx = np.array([[0, -h[2], h[1]], [h[2], 0, -h[0]], [-h[1], h[0], 0]])
    return np.block([[inertia_matrix(phi[4:]), hx], [hx.T, m * np.eye(3)]])


def inertia_in_wrench_order(phi) -> np.ndarray:
    """``spatial_inertia_about_S`` in heft's order [translation; rotation]: M·[a; α] = V(a, α, 0, 0)·φ."""
    return spatial_inertia_about_S(phi)[np.ix_(_WRENCH_ORDER, _WRENCH_ORDER)]


def modes_on_fixed_sensor(phi, mount: MountSpec) -> Modes:
    """The modes of a load of inertial parameters ``phi`` (about S) on ``mount``, S held fixed:
    the rocking a tap test finds with the arm holding still."""
    return modes(spatial_inertia_about_S(phi), stiffness(mount), damping(mount))


def step_bound_hz(damping_ratio, time_step: float):
    """The fastest mode (Hz) of that damping ratio the plant's step integrates stably."""
    zeta = np.asarray(damping_ratio)
    return (np.sqrt(1 + zeta ** 2) - zeta) / (np.pi * time_step)


def step_usage(found: Modes, time_step: float) -> tuple[float, int]:
    """(the largest share of its step bound any mode takes, that mode's index)."""
    shares = found.frequencies / step_bound_hz(found.damping_ratios, time_step)
    worst = int(np.argmax(shares))
    return float(shares[worst]), worst


def inertia_about(phi, point) -> np.ndarray:
    """The load's rotational inertia (kg·m², S's axes) about ``point`` (m, in S), from φ (Eq. 6)."""
    mass, r = phi[0], np.asarray(point, dtype=float)
    h = np.asarray(phi[1:4])  # m·c
    # The parallel-axis theorem from S to r: m(|r|²E − r rᵀ) − (2 r·h E − r hᵀ − h rᵀ).
    return (inertia_matrix(phi[4:]) + mass * (r @ r * np.eye(3) - np.outer(r, r))
            - (2 * (r @ h) * np.eye(3) - np.outer(r, h) - np.outer(h, r)))


def sized_for_load(spec: MountSpec, phi, phi_paper_tool) -> MountSpec:
    """``spec`` with each constant it leaves out taken from ``DEFAULT_MOUNT`` and sized for the
    load: on each axis where the load's inertia about the mount's point (``spec.at``, S when None;
    ``phi``; mass for the force constants) is below the paper's tool's about S
    (``phi_paper_tool``), stiffness and damping shrink by that ratio, which keeps the uncoupled
    modes' frequencies and damping ratios the paper's tool's; where it is not, they stay the
    default's (stiffer would put the wrist beside a heavy tool beyond the step), and the tool
    rocks lower, as a heavy tool on a given adapter does."""
    torque = np.minimum(1.0, np.diag(inertia_about(phi, spec.at or np.zeros(3)))
                        / np.array([phi_paper_tool[4], phi_paper_tool[7], phi_paper_tool[9]]))
    force = np.full(3, min(1.0, phi[0] / phi_paper_tool[0]))
    ratios = {"torque_stiffness": torque, "torque_damping": torque, "force_stiffness": force, "force_damping": force}
    return dataclasses.replace(spec, **{
        name: (np.asarray(getattr(DEFAULT_MOUNT, name)) * ratios[name]).tolist()
        for name in CONSTANTS if getattr(spec, name) is None})


def fitted_to_step(spec: MountSpec, phi, phi_paper_tool, time_step: float, modes_of) -> MountSpec:
    """The mount the station builds for a load of ``phi`` on ``spec`` (the scenario's) with the plant's
    ``time_step`` (s); ``modes_of(constants)`` gives the modes with the arm beside it (``Modes``).

    Constants left out are sized for the load (``sized_for_load``). A mount that states neither
    constants nor its point is placed where the step integrates it (``PLACEMENTS`` of the way to the
    load's centre of mass, the first that does; see the module's notes), or softened (``softened``)
    at the point that needs the least; one that states some is kept where it is, softened only if
    it states no constant. A mount with a stated constant the step cannot integrate is refused
    (ValueError) with its mode, the bound and what to change."""
    def usage(candidate):
        found = modes_of(candidate)
        share, worst = step_usage(found, time_step)
        return share, found.frequencies[worst], found.damping_ratios[worst]

    states_constant = any(getattr(spec, name) is not None for name in CONSTANTS)
    com = np.asarray(phi[1:4]) / phi[0]
    points = [spec.at] if states_constant or spec.at is not None or not com.any() else \
        [None] + [(share * com).tolist() for share in PLACEMENTS[1:]]
    tried = []
    for point in points:
        candidate = sized_for_load(dataclasses.replace(spec, at=point), phi, phi_paper_tool)
        share, frequency, zeta = usage(candidate)
        if share <= STEP_MARGIN:
            return candidate
        tried.append((share, frequency, zeta, candidate))
    share, frequency, zeta, candidate = min(tried, key=lambda entry: entry[0])
    if not states_constant:
        return softened(candidate, (STEP_MARGIN / share) ** 2 * (1 - 1e-9))
    stated = ", ".join(f"{name}: {getattr(spec, name)}" for name in CONSTANTS if getattr(spec, name) is not None)
    raise ValueError(
        f"the {phi[0]:.3g} kg load on its stated mount (load.mount {stated}) has a mode at {frequency:.0f} Hz "
        f"({100 * zeta:.0f} % damped, with the arm's wrist), beyond the "
        f"{STEP_MARGIN * step_bound_hz(zeta, time_step):.0f} Hz that the plant's step of "
        f"{1e3 * time_step:g} ms integrates stably: soften the mount's stiffness (or leave its constants out to have "
        f"the default sized for the load), make plant.time_step at most "
        f"{1e3 * time_step * STEP_MARGIN / share:.2g} ms, or set load.mount.rigid: true")


def softened(mount: MountSpec, factor: float) -> MountSpec:
    """``mount`` with its stiffnesses times ``factor`` and its dampings times √factor: every mode
    √factor as fast, with the same damping ratio."""
    return dataclasses.replace(
        mount, **{name: (np.asarray(getattr(mount, name)) * (factor if "stiffness" in name else np.sqrt(factor))
                         ).tolist() for name in CONSTANTS})


class MountUnderMovingSensor:
    """A load of inertial parameters ``phi`` (about S at rest, Eq. 6) on a mount of ``constants`` below
    a sensor frame S whose motion is prescribed (the stand-in's arm), linear in the load frame L's
    deflection ξ = [d; θ] against S (m, rad; S's axes; heft's order [translation; rotation], as
    wrenches [f; τ]):

        M·ξ̈ + C·ξ̇ + K·ξ = −w,    w_S = −(K·ξ + C·ξ̇) = w + M·ξ̈,

    w = V(a, α, ω, g)·φ the wrench that moves the load rigidly with S (Eq. 5), w_S the wrench the sensor
    exerts on the load through the mount, M the load's spatial inertia about S, K and C the bushing's
    (``stiffness``, ``damping``). Left out, second order in the deflection: ξ̇'s Coriolis terms with
    S's ω, gravity's turn with θ (m·g·|c| against the torque stiffness: 7e-4 for the paper's tool), the
    moment of the deflection d (|d| ≈ 30 µm for the tool's weight). Discretised exactly for w going
    linearly from one step's value to the next over each ``period`` s (the matrix exponential of the
    12-state system with w and ẇ): stable at any step for M, K positive and C ≥ 0, where the plant's
    semi-implicit step needs the bound of the module's notes; and, unlike w held over the period, with
    no lag of half a period behind S's motion."""

    def __init__(self, constants: MountSpec, phi, period: float):
        order = np.ix_(_WRENCH_ORDER, _WRENCH_ORDER)
        inertia, K, C = inertia_in_wrench_order(phi), stiffness(constants)[order], damping(constants)[order]
        inverse_inertia = np.linalg.inv(inertia)
        generator = np.zeros((24, 24))  # d/dt [ξ; ξ̇; w; ẇ] with ẇ constant over the period
        generator[:6, 6:12] = np.eye(6)
        generator[6:12, :6], generator[6:12, 6:12] = -inverse_inertia @ K, -inverse_inertia @ C
        generator[6:12, 12:18] = -inverse_inertia
        generator[12:18, 18:] = np.eye(6)
        step = scipy.linalg.expm(generator * period)
        rate_gain = step[:12, 18:] / period  # of w's change over the period
        self.transition, self.gain_start, self.gain_end = step[:12, :12], step[:12, 12:18] - rate_gain, rate_gain
        """State [ξ; ξ̇] one period on: transition @ state + gain_start @ w_start + gain_end @ w_end."""
        self.inverse_inertia, self.stiffness = inverse_inertia, K
        self.output = -np.hstack((K, C))
        """w_S = output @ state (6×12)."""
        self._next = np.empty(12)

    def at_rest(self, wrench) -> np.ndarray:
        """The state [ξ; ξ̇] (12,) at rest under a constant rigid wrench ``wrench`` (w, (6,)): ξ = −K⁻¹·w."""
        return np.concatenate((-np.linalg.solve(self.stiffness, wrench), np.zeros(6)))

    def step(self, state: np.ndarray, previous_wrench: np.ndarray, wrench: np.ndarray, sensor_wrench: np.ndarray,
             deflection_acceleration: np.ndarray) -> None:
        """Advances ``state`` (12) over the period that ends now, the rigid wrench w going linearly from
        ``previous_wrench`` (the period's start) to ``wrench`` (now), and writes w_S and ξ̈ (6 each) now;
        all in place (``mount_step``)."""
        mount_step(self.transition, self.gain_start, self.gain_end, self.output, self.inverse_inertia, state,
                   previous_wrench, wrench, sensor_wrench, deflection_acceleration, self._next)

    def deflection_acceleration(self, sensor_wrench: np.ndarray, wrench: np.ndarray, out: np.ndarray) -> None:
        """Writes ξ̈ = M⁻¹·(w_S − w) (6) into ``out``: this load's, at a deflection whose w_S another
        load's step gave (the load changes now)."""
        deflection_acceleration(self.inverse_inertia, sensor_wrench, wrench, out)


@compiled("void(float64[:, :], float64[:], float64[:], float64[:])")
def deflection_acceleration(inverse_inertia, sensor_wrench, wrench, out) -> None:
    """ξ̈ = M⁻¹·(w_S − w) into ``out`` (6)."""
    for r in range(6):
        total = 0.0
        for c in range(6):
            total += inverse_inertia[r, c] * (sensor_wrench[c] - wrench[c])
        out[r] = total


@compiled("void(float64[:, :], float64[:, :], float64[:, :], float64[:, :], float64[:, :], float64[:], float64[:], "
          "float64[:], float64[:], float64[:], float64[:])")
def mount_step(transition, gain_start, gain_end, output, inverse_inertia, state, previous_wrench, wrench,
               sensor_wrench, acceleration, scratch) -> None:
    """``MountUnderMovingSensor.step`` with its matrices: x ← transition·x + gain_start·w_start +
    gain_end·w (``scratch`` (12) holding the new state until it is copied), then w_S = output·x and
    the ``acceleration`` ξ̈ = M⁻¹·(w_S − w)."""
    for r in range(12):
        total = 0.0
        for c in range(12):
            total += transition[r, c] * state[c]
        for c in range(6):
            total += gain_start[r, c] * previous_wrench[c] + gain_end[r, c] * wrench[c]
        scratch[r] = total
    state[:] = scratch
    for r in range(6):
        total = 0.0
        for c in range(12):
            total += output[r, c] * state[c]
        sensor_wrench[r] = total
    deflection_acceleration(inverse_inertia, sensor_wrench, wrench, acceleration)
