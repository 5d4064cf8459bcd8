"""The slave's inverse kinematics as a sampled block (Fig. 4: X_RT* → q̄_S)."""

from __future__ import annotations

import numpy as np
from pydrake.math import RigidTransform
from pydrake.systems.framework import EventStatus, LeafSystem

from heft.systems.pose_vectors import POSE_SIZE, rotation_matrix
from heft.systems.rx_inverse_kinematics import RxKinematics
from heft.systems.slave_kinematics import NUM_JOINTS



def flange_target(pose, R_TF: np.ndarray, p_TF: np.ndarray):
    """(R_RF, p_RF (m)) of the flange for the desired tool pose vector ``pose`` (X_RT*), the
    flange F sitting at (R_TF, p_TF) in the tool frame T; None if ``pose`` is not a pose
    (non-finite, or a zero quaternion)."""
    R_RT = rotation_matrix(pose)
    if R_RT is None:
        return None
    return R_RT @ R_TF, pose[:3] + R_RT @ p_TF


def ik_step(kinematics: RxKinematics, target, q_last: np.ndarray, max_step: np.ndarray):
    """One tick: (command (6, rad), reachable, slewing) from the last command toward the nearest
    IK solution for ``target`` (``flange_target``'s (R_RF, p_RF), or None), each joint moving at
    most ``max_step`` (rad: speed limit × dt). Unreachable or None: the command stays."""
    result = None if target is None else kinematics.solve_nearest(*target, q_last)
    if result is None or not result.reachable:
        return q_last, False, False
    step = result.q - q_last
    limited = np.minimum(np.maximum(step, -max_step), max_step)  # np.clip's wrapper costs 1 µs more
    return q_last + limited, True, bool((limited != step).any())


class SlaveInverseKinematics(LeafSystem):
    """Desired tool pose → joint command, every ``period`` s, never jumping.

    Input ``pose_desired`` (7): X_RT*, the desired pose of tool frame T in the slave base R,
    [p (m); w, x, y, z]. T sits at ``X_FT`` in the flange F (e.g. the tool tip, or S).
    Input ``position_measured`` (6, rad), optional: when connected (and finite), the command
    starts there at initialization, clipped to the joint limits; else at ``q_initial``.

    Every tick the nearest IK branch to the last command is taken (RxKinematics.solve_nearest)
    and the command moves toward it by at most velocity limit × period per joint. An
    unreachable or non-finite pose leaves the command where it is.

    Outputs, all discrete state (no direct feedthrough):
    ``position_commanded`` (6, rad): q̄_S, always within the joint limits.
    ``status`` (2): [1 if this tick's pose was reachable else 0, ticks rejected so far].
    ``slewing`` (1): 1 if the speed limits held the command back from the solution this tick.
    """

    def __init__(self, kinematics: RxKinematics, X_FT: RigidTransform, q_initial, period: float):
        super().__init__()
        q_initial = np.asarray(q_initial, dtype=float)
        if q_initial.shape != (NUM_JOINTS,) or not kinematics.within_limits(q_initial):
            raise ValueError(f"q_initial must be 6 joint angles within the limits; got {q_initial}")
        if not (np.isfinite(period) and period > 0):
            raise ValueError(f"period must be finite and > 0 (s); got {period}")
        self._kinematics = kinematics
        X_TF = X_FT.inverse()
        self._R_TF, self._p_TF = X_TF.rotation().matrix(), X_TF.translation()
        self._max_step = kinematics.velocity * period  # rad per tick
        self._pose = self.DeclareVectorInputPort("pose_desired", POSE_SIZE)
        self._measured = self.DeclareVectorInputPort("position_measured", NUM_JOINTS)
        self._command = self.DeclareDiscreteState(q_initial)
        self._status = self.DeclareDiscreteState(np.array([1.0, 0.0]))
        self._slewing = self.DeclareDiscreteState(np.zeros(1))
        self.DeclareInitializationDiscreteUpdateEvent(self._initialize)
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)
        self.DeclareStateOutputPort("position_commanded", self._command)
        self.DeclareStateOutputPort("status", self._status)
        self.DeclareStateOutputPort("slewing", self._slewing)

    def _initialize(self, context, discrete_state) -> EventStatus:
        if not self._measured.HasValue(context):
            return EventStatus.DidNothing()
        q_measured = self._measured.Eval(context)
        if not np.isfinite(q_measured).all():
            return EventStatus.DidNothing()
        discrete_state.set_value(self._command, np.clip(q_measured, self._kinematics.lower, self._kinematics.upper))
        return EventStatus.Succeeded()

    def _update(self, context, discrete_state) -> EventStatus:
        q_last = context.get_discrete_state(self._command).get_value()
        rejected = context.get_discrete_state(self._status).get_value()[1]
        target = flange_target(self._pose.Eval(context), self._R_TF, self._p_TF)
        command, reachable, slewing = ik_step(self._kinematics, target, q_last, self._max_step)
        discrete_state.set_value(self._command, command)
        discrete_state.set_value(self._status, [1.0, rejected] if reachable else [0.0, rejected + 1])
        discrete_state.set_value(self._slewing, [float(slewing)])
        return EventStatus.Succeeded()
