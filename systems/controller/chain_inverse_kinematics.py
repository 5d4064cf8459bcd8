"""Inverse kinematics of any 6- or 7-joint serial chain of revolute joints: damped least squares on its
screw axes, one tick at a time, within the joints' position and speed limits.

A tick (``dls_ik_step``) starts from the last command q_last and takes up to ``iterations`` damped
least-squares steps (Nakamura & Hanafusa 1986; Wampler 1986) toward the desired pose X_BE* of the
chain's end frame E in its base B:

    Δq = J⁺ e + (I − J⁺J)·k·(q_start − q),    J⁺ = Jᵀ (J Jᵀ + λ² I)⁻¹,

with e = [p* − p; θ] the position error (m) and the rotation vector of R*·Rᵀ (rad), both in B, and J
E's geometric Jacobian (rows [v; ω] in B, ``serial_chain.chain_kinematics``). The second term, on a
chain of 7 and in a tick's first step only, draws the redundant joint motion toward the start posture
q_start by the share k = null rate × dt without moving E to first order (the damped projector moves it
by λ²(JJᵀ + λ²I)⁻¹·J·z, which the tick's later steps take back, so that the pull leaves no lasting pose
error); a chain of 6 has no null space and takes none. A step that would carry a joint past its limit
holds it there, and the tick's later steps leave it out (its column of J zeroed). The command then
moves from q_last toward the result, every joint's move scaled by one factor so that none exceeds its
velocity × dt: a slewing arm stays on the line in joint space between two postures of the path, which
keeps the orientation a joint-by-joint clip would tilt (the joints that move E's orientation together
no longer move by different shares of their way).

Steps stop when both errors are within the tolerance. The kernel answers with a status of bit flags:
``NON_FINITE`` (the pose is not one: the command stays at q_last), ``NOT_CONVERGED`` (the tick's
steps ended further from the pose than the tolerance: unreachable, or still on the way), ``JOINT_LIMIT``
(a joint was held at its limit), ``SLEWING`` (a speed limit held the command back).
"""

from __future__ import annotations

import math

import numpy as np
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import Frame

from heft.systems.compiled import compiled, float_array, record_views
from heft.systems.pose_vectors import POSE_SIZE, rotation_into
from heft.systems.serial_chain import CHAIN_JOINTS, MOTION_SIZE, SerialChain, chain_kinematics
from heft.systems.tick_system import TickSystem

NON_FINITE = 1
NOT_CONVERGED = 2
JOINT_LIMIT = 4
SLEWING = 8


# ``dls_ik_step``'s settings (a float64 array: λ (m), the null rate (1/s), the tolerance (m and rad)), and
# the rows of its scratch for a chain of n joints (n + _ROWS rows, max(n, MOTION_SIZE) columns).
DAMPING, NULL_RATE, TOLERANCE = 0, 1, 2
_R, _P, _J, _ZEROS, _GRAVITY, _MOTION, _A, _E, _Y, _Q, _Z, _LOCKED, _R_TARGET, _P_TARGET, _ROWS = (
    0, 3, 4, 10, 11, 12, 13, 19, 20, 21, 22, 23, 24, 27, 28)


def work_shape(n: int) -> tuple[int, int]:
    """The shape of ``dls_ik_step``'s scratch for a chain of ``n`` joints."""
    return _ROWS + n, max(n, MOTION_SIZE)


@compiled("boolean(float64[:, :])")
def _cholesky(A):
    """A (6, 6), symmetric positive definite, overwritten by its lower Cholesky factor L (A = L·Lᵀ; the
    strict upper triangle left as it was); False if A is not positive definite."""
    for j in range(6):
        s = A[j, j]
        for k in range(j):
            s -= A[j, k] * A[j, k]
        if not s > 0.0:
            return False
        A[j, j] = math.sqrt(s)
        for i in range(j + 1, 6):
            t = A[i, j]
            for k in range(j):
                t -= A[i, k] * A[j, k]
            A[i, j] = t / A[j, j]
    return True


@compiled("void(float64[:, :], float64[:])")
def _solve(L, b):
    """b (6) overwritten by A⁻¹·b, L being A's lower Cholesky factor (``_cholesky``)."""
    for i in range(6):
        t = b[i]
        for k in range(i):
            t -= L[i, k] * b[k]
        b[i] = t / L[i, i]
    for i in range(5, -1, -1):
        t = b[i]
        for k in range(i + 1, 6):
            t -= L[k, i] * b[k]
        b[i] = t / L[i, i]


@compiled("void(float64[:, :], float64[:, :], float64[:])")
def rotation_error(R_target, R, theta):
    """Writes into theta (3, rad) the rotation vector θ of R_target·Rᵀ (R_target·Rᵀ = exp([θ]), |θ| ≤ π)."""
    # E = R_target·Rᵀ: E_ij = Σ_k R_target[i, k]·R[j, k]; its skew part is sin|θ|·θ/|θ|.
    e00 = R_target[0, 0] * R[0, 0] + R_target[0, 1] * R[0, 1] + R_target[0, 2] * R[0, 2]
    e11 = R_target[1, 0] * R[1, 0] + R_target[1, 1] * R[1, 1] + R_target[1, 2] * R[1, 2]
    e22 = R_target[2, 0] * R[2, 0] + R_target[2, 1] * R[2, 1] + R_target[2, 2] * R[2, 2]
    e01 = R_target[0, 0] * R[1, 0] + R_target[0, 1] * R[1, 1] + R_target[0, 2] * R[1, 2]
    e10 = R_target[1, 0] * R[0, 0] + R_target[1, 1] * R[0, 1] + R_target[1, 2] * R[0, 2]
    e02 = R_target[0, 0] * R[2, 0] + R_target[0, 1] * R[2, 1] + R_target[0, 2] * R[2, 2]
    e20 = R_target[2, 0] * R[0, 0] + R_target[2, 1] * R[0, 1] + R_target[2, 2] * R[0, 2]
    e12 = R_target[1, 0] * R[2, 0] + R_target[1, 1] * R[2, 1] + R_target[1, 2] * R[2, 2]
    e21 = R_target[2, 0] * R[1, 0] + R_target[2, 1] * R[1, 1] + R_target[2, 2] * R[1, 2]
    v0, v1, v2 = 0.5 * (e21 - e12), 0.5 * (e02 - e20), 0.5 * (e10 - e01)
    sine, cosine = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2), 0.5 * (e00 + e11 + e22 - 1.0)
    angle = math.atan2(sine, cosine)
    if sine > 1e-9 * max(angle, 1.0) or cosine > 0.0:
        scale = angle / sine if sine > 0.0 else 1.0
        theta[0], theta[1], theta[2] = scale * v0, scale * v1, scale * v2
        return
    # A half turn: the axis from the symmetric part, E + I = 2·a·aᵀ, through its largest diagonal entry.
    if e00 >= e11 and e00 >= e22:
        a0 = math.sqrt(max(0.5 * (e00 + 1.0), 0.0))
        a1, a2 = 0.25 * (e01 + e10) / a0, 0.25 * (e02 + e20) / a0
    elif e11 >= e22:
        a1 = math.sqrt(max(0.5 * (e11 + 1.0), 0.0))
        a0, a2 = 0.25 * (e01 + e10) / a1, 0.25 * (e12 + e21) / a1
    else:
        a2 = math.sqrt(max(0.5 * (e22 + 1.0), 0.0))
        a0, a1 = 0.25 * (e02 + e20) / a2, 0.25 * (e12 + e21) / a2
    theta[0], theta[1], theta[2] = angle * a0, angle * a1, angle * a2


@compiled("int64(float64[:, :], float64[:, :], float64[:, :], float64[:], float64[:], float64[:], float64[:], "
          "float64[:], int64, float64[:], float64[:], float64[:], float64, float64[:], float64[:, :])")
def dls_ik_step(axes, points, M_R, M_p, lower, upper, velocity, settings, iterations, pose, q_last, q_start, dt,
                command, work):
    """One tick (module notes): writes into ``command`` (n, rad) the last command ``q_last`` moved toward the
    joint positions damped least squares finds for the desired pose ``pose`` of E ([p (m); w, x, y, z] in
    B), all joints by one share of their way such that none moves by more than its ``velocity`` × dt
    (rad/s × s; a dt that is NaN or negative moves none), all
    within [``lower``, ``upper``] (rad). The chain: ``axes``, ``points``, ``M_R``, ``M_p`` as in
    ``chain_kinematics``; ``settings`` [λ (m), null rate (1/s), tolerance (m and rad)]; ``q_start`` (n, rad)
    the posture the null space is drawn to; ``work`` (``work_shape``): scratch. Returns the status bits.
    ``command`` may be ``q_last`` itself."""
    n = q_last.shape[0]
    R, p, J = work[_R:_R + 3, 0:3], work[_P, 0:3], work[_J:_J + 6, 0:n]
    chain_work, zeros = work[_ROWS:_ROWS + n, 0:6], work[_ZEROS, 0:n]
    gravity, motion = work[_GRAVITY, 0:3], work[_MOTION, 0:MOTION_SIZE]
    A, e, y = work[_A:_A + 6, 0:6], work[_E, 0:6], work[_Y, 0:6]
    q, z, locked = work[_Q, 0:n], work[_Z, 0:n], work[_LOCKED, 0:n]
    R_target, p_target = work[_R_TARGET:_R_TARGET + 3, 0:3], work[_P_TARGET, 0:3]
    if not rotation_into(pose, R_target):
        for j in range(n):
            command[j] = q_last[j]
        return NON_FINITE
    if not dt >= 0.0:  # NaN or negative: no time to move in
        dt = 0.0
    damping, tolerance = settings[DAMPING], settings[TOLERANCE]
    for i in range(3):
        p_target[i] = pose[i]
    for j in range(n):
        q[j], zeros[j], locked[j] = q_last[j], 0.0, 0.0
    status, converged = 0, False
    for step in range(iterations + 1):
        chain_kinematics(axes, points, M_R, M_p, q, zeros, zeros, gravity, R, p, J, motion, chain_work)
        for i in range(3):
            e[i] = p_target[i] - p[i]
        rotation_error(R_target, R, e[3:6])
        converged = max(abs(e[0]), abs(e[1]), abs(e[2]), abs(e[3]), abs(e[4]), abs(e[5])) <= tolerance
        share = min(settings[NULL_RATE] * dt, 1.0) if step == 0 else 0.0
        if (converged and share == 0.0) or step == iterations:
            break
        for j in range(n):
            if locked[j] != 0.0:
                for r in range(6):
                    J[r, j] = 0.0
        for r in range(6):  # A = J·Jᵀ + λ²·I
            for c in range(r + 1):
                s = 0.0
                for j in range(n):
                    s += J[r, j] * J[c, j]
                A[r, c] = s
                A[c, r] = s
            A[r, r] += damping * damping
        if not _cholesky(A):  # only a non-finite J or λ = 0 at a singularity
            break
        for r in range(6):
            y[r] = e[r]
        _solve(A, y)
        for j in range(n):  # the null-space pull, projected: z − J⁺·J·z
            z[j] = 0.0 if locked[j] != 0.0 else share * (q_start[j] - q[j])
        if share != 0.0:
            for r in range(6):
                s = 0.0
                for j in range(n):
                    s += J[r, j] * z[j]
                e[r] = s
            _solve(A, e)
            for j in range(n):
                s = 0.0
                for r in range(6):
                    s += J[r, j] * e[r]
                z[j] -= s
        for j in range(n):
            s = z[j]
            for r in range(6):
                s += J[r, j] * y[r]
            q[j] += s
            if q[j] < lower[j] or q[j] > upper[j]:
                q[j] = min(max(q[j], lower[j]), upper[j])
                locked[j] = 1.0
                status |= JOINT_LIMIT
    if not converged:
        status |= NOT_CONVERGED
    share = 1.0  # of the way to q, the same for every joint
    for j in range(n):
        move, limit = abs(q[j] - q_last[j]), velocity[j] * dt
        if move > limit:
            share = min(share, limit / move)
            status |= SLEWING
    for j in range(n):
        command[j] = q_last[j] + share * (q[j] - q_last[j])
    return status


def chain_ik_dtype(n: int) -> np.dtype:
    """The record of ``ChainIk`` for a chain of ``n`` joints (``ChainIk.record``): ``dls_ik_step``'s arguments
    besides the pose, the commands and dt, by name (``axes``, ``points``, ``M_R``, ``M_p``, ``lower``, ``upper``,
    ``velocity``, ``settings``, ``iterations``, ``q_start``, ``work``)."""
    return np.dtype([("axes", float, (n, 3)), ("points", float, (n, 3)), ("M_R", float, (3, 3)), ("M_p", float, 3),
                     ("lower", float, n), ("upper", float, n), ("velocity", float, n), ("settings", float, 3),
                     ("iterations", np.int64), ("q_start", float, n), ("work", float, work_shape(n))])


class ChainIk:
    """``dls_ik_step`` for the revolute chain of ``plant`` from frame ``B`` to frame ``E`` (``SerialChain``),
    or to a frame T at ``X_ET`` on E, its scratch preallocated: a call allocates nothing. Its arguments besides
    the pose, the commands and dt live in ``record`` (``chain_ik_dtype``), which a kernel that calls
    ``dls_ik_step`` takes.

    Limits (n,): ``lower``, ``upper`` (rad) and ``velocity`` (rad/s), by default the joints' own in the
    plant. ``damping`` λ (m), ``null_rate`` (1/s: the share of the way to ``q_start`` per second, on a
    chain of 7 only), ``tolerance`` (m and rad) and ``iterations`` (steps per tick): the module notes."""

    def __init__(self, plant: MultibodyPlant, B: Frame, E: Frame, q_start, X_ET: RigidTransform | None = None,
                 lower=None, upper=None, velocity=None, damping: float = 0.01, null_rate: float = 2.0,
                 tolerance: float = 1e-9, iterations: int = 4):
        chain = SerialChain(plant, B, E)
        n = chain.num_joints
        if n not in CHAIN_JOINTS:
            raise ValueError(f"the chain from {B.name()!r} to {E.name()!r} has {n} joints; the inverse kinematics "
                             f"takes {' or '.join(str(c) for c in CHAIN_JOINTS)}")
        self.joints = chain.joints
        own = [(j.position_lower_limits()[0], j.position_upper_limits()[0], j.velocity_upper_limits()[0])
               for j in self.joints]
        lower = _limits(lower, [row[0] for row in own], n, "lower")
        upper = _limits(upper, [row[1] for row in own], n, "upper")
        velocity = _limits(velocity, [row[2] for row in own], n, "velocity")
        if not (np.isfinite(lower).all() and np.isfinite(upper).all() and (lower < upper).all()):
            raise ValueError("the inverse kinematics needs finite joint limits, lower < upper; got "
                             f"lower {lower}, upper {upper}")
        if not (np.isfinite(velocity).all() and (velocity > 0).all()):
            raise ValueError(f"the inverse kinematics needs finite speed limits > 0 (rad/s); got {velocity}")
        if not (damping > 0 and null_rate >= 0 and tolerance > 0 and iterations >= 1):
            raise ValueError("damping and tolerance must be > 0, null_rate >= 0 and iterations >= 1")
        self.record, arrays = record_views(chain_ik_dtype(n))
        chain_record = chain.record[0]
        X_BE0 = RigidTransform(RotationMatrix(np.array(chain_record["M_R"])), chain_record["M_p"])
        X_BT0 = X_BE0 @ (X_ET or RigidTransform())
        arrays["axes"][:], arrays["points"][:] = chain_record["axes"], chain_record["points"]
        arrays["M_R"][:], arrays["M_p"][:] = X_BT0.rotation().matrix(), X_BT0.translation()
        arrays["lower"][:], arrays["upper"][:], arrays["velocity"][:] = lower, upper, velocity
        arrays["settings"][:] = damping, null_rate if n > 6 else 0.0, tolerance
        self.record["iterations"] = iterations
        self._arrays = arrays
        self.lower, self.upper, self.velocity = arrays["lower"], arrays["upper"], arrays["velocity"]
        self.settings, self.q_start = arrays["settings"], arrays["q_start"]
        self.set_start(q_start)

    @property
    def num_joints(self) -> int:
        return len(self.joints)

    def set_start(self, q_start) -> None:
        """The posture (n, rad, within the limits) the null space is drawn to."""
        q_start = np.asarray(q_start, dtype=float)
        if q_start.shape != self.q_start.shape or not ((q_start >= self.lower) & (q_start <= self.upper)).all():
            raise ValueError(f"q_start must be {self.num_joints} joint positions within the limits; got {q_start}")
        self.q_start[:] = q_start

    def __call__(self, pose: np.ndarray, q_last: np.ndarray, dt: float, command: np.ndarray) -> int:
        """The status bits (module notes); ``command`` (n, rad) written, from ``q_last`` (n, rad, within
        the limits) toward the desired pose vector ``pose`` of T (7: [p (m); w, x, y, z] in B) in ``dt`` (s)."""
        a = self._arrays
        return dls_ik_step(a["axes"], a["points"], a["M_R"], a["M_p"], self.lower, self.upper, self.velocity,
                           self.settings, int(self.record["iterations"][0]), float_array(pose), float_array(q_last),
                           self.q_start, float(dt), command, a["work"])


def _limits(given, own, n: int, name: str) -> np.ndarray:
    values = np.array(own if given is None else given, dtype=float)
    if values.shape != (n,):
        raise ValueError(f"{name} needs {n} values; got {values.shape}")
    return values


def _chain_ik_update(command, status, slewing, pose, period, ik):
    """``dls_ik_step`` from the last ``command`` (n, rad) toward ``pose`` over ``period`` (1, s), in place;
    ``status`` (2) [the pose reached this tick (1/0), ticks it was not so far], ``slewing`` (1). ``ik``:
    ``ChainIk.record``."""
    k = ik[0]
    result = dls_ik_step(k["axes"], k["points"], k["M_R"], k["M_p"], k["lower"], k["upper"], k["velocity"],
                         k["settings"], k["iterations"], pose, command, k["q_start"], period[0], command, k["work"])
    if result & (NON_FINITE | NOT_CONVERGED):
        status[0] = 0.0
        status[1] += 1.0
    else:
        status[0] = 1.0
    slewing[0] = 1.0 if result & SLEWING else 0.0


chain_ik_update = {n: compiled("void(float64[:], float64[:], float64[:], float64[:], float64[:], IK[:])",
                               IK=chain_ik_dtype(n))(_chain_ik_update) for n in CHAIN_JOINTS}
"""``_chain_ik_update`` compiled for each chain's record (``chain_ik_dtype``), by its number of joints."""


@compiled("void(float64[:], float64[:], float64[:], float64[:])")
def chain_ik_initialize(command, measured, lower, upper):
    """The command at the ``measured`` position (n, rad) within [``lower``, ``upper``], if it is finite."""
    total = 0.0
    for j in range(measured.shape[0]):
        total += measured[j]
    if not math.isfinite(total):
        return
    for j in range(command.shape[0]):
        command[j] = min(max(measured[j], lower[j]), upper[j])


class ChainInverseKinematics(TickSystem):
    """Desired pose → joint command of a 6- or 7-joint chain (``ChainIk``), every ``period`` s, never jumping:
    the ports of ``SlaveInverseKinematics``, for any arm.

    Input ``pose_desired`` (7): X_BE*, the desired pose of the chain's end frame E in its base B,
    [p (m); w, x, y, z]. Input ``position_measured`` (n, rad), optional: when connected (and finite), the
    command starts there at initialization, clipped to the joint limits; else at ``ik.q_start``.

    Outputs, all discrete state (no direct feedthrough):
    ``position_commanded`` (n, rad): within the joint limits, each joint moving by at most its speed limit;
    ``status`` (2): [1 if this tick's steps reached the pose (within the tolerance; the command may still be
    slewing toward it) else 0, ticks they did not];
    ``slewing`` (1): 1 if the speed limits held the command back this tick.
    """

    def __init__(self, ik: ChainIk, period: float):
        if not (np.isfinite(period) and period > 0):
            raise ValueError(f"period must be finite and > 0 (s); got {period}")
        super().__init__(period)
        n = ik.num_joints
        self.DeclareTickInput("pose_desired", POSE_SIZE)
        self.DeclareTickInput("position_measured", n, np.full(n, np.nan))
        self.DeclareTickState("command", ik.q_start)
        self.DeclareTickState("status", [1.0, 0.0])
        self.DeclareTickState("slewing", [0.0])
        self.DeclareTickInitialization(chain_ik_initialize, "next:command", "in:position_measured", ik.lower,
                                       ik.upper)
        self.DeclareTickUpdate(chain_ik_update[n], "next:command", "next:status", "next:slewing", "in:pose_desired",
                               np.array([period]), ik.record)
        self.DeclareTickOutput("position_commanded", "x:command")
        self.DeclareTickOutput("status", "x:status")
        self.DeclareTickOutput("slewing", "x:slewing")
