"""Kinematics by Drake's MultibodyPlant calls: the independent reference that tests hold heft's closed-form
kinematics (``SerialChain``), the rendered stylus forces and the sensor's motion to."""

import numpy as np
from pydrake.multibody.tree import JacobianWrtVariable

from heft.systems.drake_conventions import swap_halves
from heft.systems.load_dynamics import GRAVITY_W


def stylus_jacobian(plant, plant_context, B, E) -> np.ndarray:
    """The 6×6 J with [v_E; ω_E] = J·q̇ (E's origin measured and expressed in B; m/s, rad/s) at the
    positions in ``plant_context``: Drake's spatial-velocity Jacobian [ω; v] with its blocks swapped."""
    J_wv = plant.CalcJacobianSpatialVelocity(plant_context, JacobianWrtVariable.kV, E, np.zeros(3), B, B)
    return swap_halves(J_wv, axis=0)


def pose_and_jacobian(plant, plant_context, B, E, q):
    """(X_BE, J) at joint angles q (rad); sets q in ``plant_context``."""
    plant.SetPositions(plant_context, q)
    return plant.CalcRelativeTransform(plant_context, B, E), stylus_jacobian(plant, plant_context, B, E)


class SensorMotion:
    """The motion of the frame S of an arm ``plant`` (base frame R) from its joints sampled every ``period`` s:
    ``at(q, q̇)`` (rad, rad/s) is (a, α, ω, g) in S (m/s², rad/s², rad/s, m/s²), a and α the backward difference of
    S's spatial velocity in R, so None at the first sample."""

    def __init__(self, plant, R, S, period: float):
        self._plant, self._R, self._S, self._period = plant, R, S, period
        self._context, self._previous = plant.CreateDefaultContext(), None

    def at(self, q, v):
        plant, context, R, S = self._plant, self._context, self._R, self._S
        plant.SetPositions(context, q)
        plant.SetVelocities(context, v)
        R_SR = plant.CalcRelativeTransform(context, R, S).rotation().inverse()
        V_RS = S.CalcSpatialVelocity(context, R, R)
        velocity = np.concatenate((V_RS.translational(), V_RS.rotational()))  # of S in R, in R
        previous, self._previous = self._previous, velocity
        if previous is None:
            return None
        rates = (velocity - previous) / self._period
        return R_SR @ rates[:3], R_SR @ rates[3:], R_SR @ velocity[3:], R_SR @ np.array(GRAVITY_W)
