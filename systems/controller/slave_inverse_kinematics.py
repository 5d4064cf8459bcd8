"""The slave's inverse kinematics as a sampled block (Fig. 4: X_RT* → q̄_S)."""

from __future__ import annotations

import math

import numpy as np
from pydrake.math import RigidTransform

from heft.systems.compiled import compiled, record_views
from heft.systems.pose_vectors import POSE_SIZE, rotation_into
from heft.systems.controller.rx_inverse_kinematics import (NON_FINITE, UNREACHABLE, WORK_ROWS, RxKinematics,
                                                          nearest_solution)
from heft.systems.tick_system import TickSystem

NUM_JOINTS = 6
"""The RX's joints."""

SLEWING = 1 << 12
"""``ik_step``'s status bit: the speed limits held the command back from the solution."""

# ``ik_step``'s scratch rows beyond ``nearest_solution``'s: R_RT, R_RF (3 rows each), p_RF, the solution.
_R_RT, _R_RF, _P_RF, _SOLUTION = WORK_ROWS, WORK_ROWS + 3, WORK_ROWS + 6, WORK_ROWS + 7
STEP_WORK_ROWS = WORK_ROWS + 8


@compiled("boolean(float64[:], float64[:, :], float64[:], float64[:, :], float64[:, :], float64[:])")
def flange_target(pose, R_TF, p_TF, R_RT, R_RF, p_RF):
    """Writes (R_RF, p_RF (m)) of the flange for the desired tool pose vector ``pose`` (X_RT*), the
    flange F sitting at (R_TF, p_TF) in the tool frame T, and R_RT; False if ``pose`` is not a pose
    (``rotation_into``)."""
    if not rotation_into(pose, R_RT):
        return False
    for r in range(3):
        for c in range(3):
            R_RF[r, c] = R_RT[r, 0] * R_TF[0, c] + R_RT[r, 1] * R_TF[1, c] + R_RT[r, 2] * R_TF[2, c]
        p_RF[r] = pose[r] + (R_RT[r, 0] * p_TF[0] + R_RT[r, 1] * p_TF[1] + R_RT[r, 2] * p_TF[2])
    return True


@compiled("int64(float64[:], float64[:], float64[:], float64[:], float64, float64[:], float64[:, :], float64[:], "
          "float64[:], float64, float64[:], float64[:, :])")
def ik_step(dh, lower, upper, velocity, band, pose, R_TF, p_TF, q_last, dt, command, work):
    """One tick: writes into ``command`` (6, rad) the last command ``q_last`` moved toward the IK
    solution nearest it (``nearest_solution``) for the desired tool pose ``pose`` (X_RT*, the flange
    at (R_TF, p_TF) in T), each joint by at most velocity × dt (rad/s × s; a dt that is NaN or negative
    moves none). Unreachable or not a
    pose: command = q_last. Returns ``nearest_solution``'s status, with ``SLEWING`` when a speed
    limit held a joint back. The arm: ``dh``, ``lower``, ``upper``, ``velocity``, ``band`` as in
    ``RxKinematics``; ``work`` (``STEP_WORK_ROWS``, 6): scratch. command may be q_last itself."""
    R_RF, p_RF, solution = work[_R_RF:_R_RF + 3, 0:3], work[_P_RF, 0:3], work[_SOLUTION]
    if flange_target(pose, R_TF, p_TF, work[_R_RT:_R_RT + 3, 0:3], R_RF, p_RF):
        status = nearest_solution(dh, lower, upper, band, R_RF, p_RF, q_last, solution, work)
    else:
        status = NON_FINITE
    if status & UNREACHABLE:
        for j in range(6):
            command[j] = q_last[j]
        return status
    if not dt >= 0.0:  # NaN or negative: no time to move in
        dt = 0.0
    for j in range(6):
        step, limit = solution[j] - q_last[j], velocity[j] * dt
        limited = min(max(step, -limit), limit)
        if limited != step:
            status |= SLEWING
        command[j] = q_last[j] + limited
    return status


class IkStep:
    """``ik_step`` for one arm and tool frame, its scratch preallocated: a call allocates nothing.
    Its arguments besides the pose, the commands and dt live in ``record`` (``IK_STEP``), which a
    kernel that calls ``ik_step`` takes.

    ``X_TF``: the flange F in the tool frame T."""

    def __init__(self, kinematics: RxKinematics, X_TF: RigidTransform):
        self.record, self._arrays = record_views(IK_STEP)
        arrays = self._arrays
        arrays["dh"][:], arrays["lower"][:], arrays["upper"][:] = kinematics.dh, kinematics.lower, kinematics.upper
        arrays["velocity"][:] = kinematics.velocity
        self.record["band"] = kinematics.wrist_band
        self._band = float(kinematics.wrist_band)
        arrays["R_TF"][:], arrays["p_TF"][:] = X_TF.rotation().matrix(), X_TF.translation()

    def __call__(self, pose: np.ndarray, q_last: np.ndarray, dt: float, command: np.ndarray) -> int:
        """``ik_step``'s status; ``command`` (6, rad) written, from ``q_last`` (6, rad) toward the desired
        tool pose vector ``pose`` (7, X_RT*) over ``dt`` s. The arrays: float64, writeable (``float_array``)."""
        a = self._arrays
        return ik_step(a["dh"], a["lower"], a["upper"], a["velocity"], self._band, pose,
                       a["R_TF"], a["p_TF"], q_last, dt, command, a["work"])


IK_STEP = np.dtype([("dh", float, 5), ("lower", float, NUM_JOINTS), ("upper", float, NUM_JOINTS),
                    ("velocity", float, NUM_JOINTS), ("band", float), ("R_TF", float, (3, 3)), ("p_TF", float, 3),
                    ("work", float, (STEP_WORK_ROWS, 6))])
"""``IkStep.record``: ``ik_step``'s arguments for one arm (``RxKinematics``' ``dh``, ``lower``, ``upper``,
``velocity`` and ``wrist_band`` as ``band``) and tool frame (``R_TF``, ``p_TF``), and its scratch ``work``."""


@compiled("void(float64[:], float64[:], float64[:], float64[:], float64[:], IK[:])", IK=IK_STEP)
def ik_update(command, status, slewing, pose, period, ik):
    """``ik_step`` from the last ``command`` (6, rad) toward ``pose`` over ``period`` (1, s), in place;
    ``status`` (2) [reachable, ticks rejected so far], ``slewing`` (1)."""
    k = ik[0]
    result = ik_step(k["dh"], k["lower"], k["upper"], k["velocity"], k["band"], pose, k["R_TF"], k["p_TF"], command,
                     period[0], command, k["work"])
    if result & UNREACHABLE:
        status[0] = 0.0
        status[1] += 1.0
    else:
        status[0] = 1.0
    slewing[0] = 1.0 if result & SLEWING else 0.0


@compiled("void(float64[:], float64[:], IK[:])", IK=IK_STEP)
def ik_initialize(command, measured, ik):
    """The command at the ``measured`` position (6, rad) within the joint limits, if it is finite."""
    total = 0.0
    for j in range(measured.shape[0]):
        total += measured[j]
    if not math.isfinite(total):
        return
    k = ik[0]
    for j in range(command.shape[0]):
        command[j] = min(max(measured[j], k["lower"][j]), k["upper"][j])


class SlaveInverseKinematics(TickSystem):
    """Desired tool pose → joint command, every ``period`` s, never jumping.

    Input ``pose_desired`` (7): X_RT*, the desired pose of tool frame T in the slave base R,
    [p (m); w, x, y, z]. T sits at ``X_FT`` in the flange F (e.g. the tool tip, or S).
    Input ``position_measured`` (6, rad), optional: when connected (and finite), the command
    starts there at initialization, clipped to the joint limits; else at ``q_initial``.

    Every tick the nearest IK branch to the last command is taken (``ik_step``)
    and the command moves toward it by at most velocity limit × period per joint. An
    unreachable or non-finite pose leaves the command where it is.

    Outputs, all discrete state (no direct feedthrough):
    ``position_commanded`` (6, rad): q̄_S, always within the joint limits.
    ``status`` (2): [1 if this tick's pose was reachable else 0, ticks rejected so far].
    ``slewing`` (1): 1 if the speed limits held the command back from the solution this tick.
    """

    def __init__(self, kinematics: RxKinematics, X_FT: RigidTransform, q_initial, period: float):
        q_initial = np.asarray(q_initial, dtype=float)
        if q_initial.shape != (NUM_JOINTS,) or not kinematics.within_limits(q_initial):
            raise ValueError(f"q_initial must be 6 joint angles within the limits; got {q_initial}")
        if not (np.isfinite(period) and period > 0):
            raise ValueError(f"period must be finite and > 0 (s); got {period}")
        super().__init__(period)
        self._ik_step = IkStep(kinematics, X_FT.inverse())
        self.DeclareTickInput("pose_desired", POSE_SIZE)
        self.DeclareTickInput("position_measured", NUM_JOINTS, np.full(NUM_JOINTS, np.nan))
        self.DeclareTickState("command", q_initial)
        self.DeclareTickState("status", [1.0, 0.0])
        self.DeclareTickState("slewing", [0.0])
        self.DeclareTickInitialization(ik_initialize, "next:command", "in:position_measured", self._ik_step.record)
        self.DeclareTickUpdate(ik_update, "next:command", "next:status", "next:slewing", "in:pose_desired",
                               np.array([period]), self._ik_step.record)
        self.DeclareTickOutput("position_commanded", "x:command")
        self.DeclareTickOutput("status", "x:status")
        self.DeclareTickOutput("slewing", "x:slewing")
