"""The master's kinematics by Drake's MultibodyPlant calls: the independent reference that tests hold
heft's closed-form kinematics (``SerialChain``) and the rendered stylus forces to."""

import numpy as np
from pydrake.multibody.tree import JacobianWrtVariable

from heft.systems.drake_conventions import swap_halves


def stylus_jacobian(plant, plant_context, B, E) -> np.ndarray:
    """The 6×6 J with [v_E; ω_E] = J·q̇ (E's origin measured and expressed in B; m/s, rad/s) at the
    positions in ``plant_context``: Drake's spatial-velocity Jacobian [ω; v] with its blocks swapped."""
    J_wv = plant.CalcJacobianSpatialVelocity(plant_context, JacobianWrtVariable.kV, E, np.zeros(3), B, B)
    return swap_halves(J_wv, axis=0)


def pose_and_jacobian(plant, plant_context, B, E, q):
    """(X_BE, J) at joint angles q (rad); sets q in ``plant_context``."""
    plant.SetPositions(plant_context, q)
    return plant.CalcRelativeTransform(plant_context, B, E), stylus_jacobian(plant, plant_context, B, E)
