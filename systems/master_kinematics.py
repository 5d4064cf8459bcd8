"""Forward kinematics and Jacobian of the master (Fig. 4: q_M → ᴮT_E and J_M).

B is the master base (the plant's ``phantom_base`` frame), E the stylus frame
(``stylus``). The Jacobian's rows are [v_E; ω_E] — translational first, the
order of heft's wrenches [f; τ] (DESIGN §4) — so that τ_M = J_Mᵀ·[f; τ] for a
wrench applied at E's origin, expressed in B.
"""

from __future__ import annotations

import numpy as np
from pydrake.math import RigidTransform
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import Frame, JacobianWrtVariable
from pydrake.systems.framework import Context, LeafSystem

from heft.systems.drake_conventions import swap_halves
from heft.systems.pose_vectors import POSE_SIZE, pose_vector
from heft.systems.scratch_context import declare_plant_scratch

NUM_JOINTS = 6
JACOBIAN_SIZE = 6 * NUM_JOINTS
BASE_FRAME = "phantom_base"
STYLUS_FRAME = "stylus"


def stylus_jacobian(plant: MultibodyPlant, plant_context: Context, B: Frame, E: Frame) -> np.ndarray:
    """The 6×6 J with [v_E; ω_E] = J·q̇ (E's origin measured and expressed in B; m/s, rad/s)
    at the positions in ``plant_context``. For revolute joints q̇ = v, so J is Drake's
    spatial-velocity Jacobian [ω; v] with its two 3-row blocks swapped."""
    J_wv = plant.CalcJacobianSpatialVelocity(plant_context, JacobianWrtVariable.kV, E, np.zeros(3), B, B)
    return swap_halves(J_wv, axis=0)


def pose_and_jacobian(plant: MultibodyPlant, plant_context: Context, B: Frame, E: Frame,
                      q) -> tuple[RigidTransform, np.ndarray]:
    """(X_BE, J) at joint angles q (rad); sets q in ``plant_context``."""
    plant.SetPositions(plant_context, q)
    return plant.CalcRelativeTransform(plant_context, B, E), stylus_jacobian(plant, plant_context, B, E)


class MasterKinematics(LeafSystem):
    """Input ``position`` q_M (6, rad) → outputs ``pose_BE`` (7: [p_BE (m); quaternion
    w, x, y, z]) and ``jacobian`` (36: J_M row-major, rows [v_E; ω_E] in B, columns q̇_M).

    ``plant`` is a finalized MultibodyPlant holding the frames ``phantom_base`` (B) and
    ``stylus`` (E) and exactly 6 positions (``diagrams.plants.MakeMasterPlant``, or the
    station's master plant).

    ``period`` None: outputs are computed from the input (direct feedthrough from
    ``position`` only). ``period`` T > 0: q_M is sampled at initialization and every T
    (offset 0) and both outputs are discrete state (no direct feedthrough), as a
    sampled haptic loop would hold them.
    """

    def __init__(self, plant: MultibodyPlant, period: float | None = None):
        super().__init__()
        if not plant.is_finalized():
            raise ValueError("MasterKinematics needs a finalized plant")
        if plant.num_positions() != NUM_JOINTS or plant.num_velocities() != NUM_JOINTS:
            raise ValueError(f"MasterKinematics needs a plant with {NUM_JOINTS} positions and velocities; got "
                             f"{plant.num_positions()} and {plant.num_velocities()}")
        if period is not None and not (np.isfinite(period) and period > 0):
            raise ValueError(f"period must be None or finite and > 0; got {period}")
        self._plant = plant
        self._B = plant.GetFrameByName(BASE_FRAME)
        self._E = plant.GetFrameByName(STYLUS_FRAME)
        self._position = self.DeclareVectorInputPort("position", NUM_JOINTS)
        self._scratch = declare_plant_scratch(self, plant)
        if period is None:
            inputs = {self._position.ticket()}
            self.DeclareVectorOutputPort("pose_BE", POSE_SIZE, self._calc_pose, prerequisites_of_calc=inputs)
            self.DeclareVectorOutputPort("jacobian", JACOBIAN_SIZE, self._calc_jacobian,
                                         prerequisites_of_calc=inputs)
        else:
            X_BE, J = pose_and_jacobian(plant, plant.CreateDefaultContext(), self._B, self._E,
                                        plant.GetDefaultPositions())
            self._pose_state = self.DeclareDiscreteState(pose_vector(X_BE))
            self._jacobian_state = self.DeclareDiscreteState(J.ravel())
            self.DeclareInitializationDiscreteUpdateEvent(self._sample)
            self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._sample)
            self.DeclareStateOutputPort("pose_BE", self._pose_state)
            self.DeclareStateOutputPort("jacobian", self._jacobian_state)

    def _scratch_at_input(self, context) -> Context:
        """The scratch plant context, with q_M from the input port."""
        scratch = self._scratch(context)
        self._plant.SetPositions(scratch, self._position.Eval(context))
        return scratch

    def _calc_pose(self, context, output):
        scratch = self._scratch_at_input(context)
        output.SetFromVector(pose_vector(self._plant.CalcRelativeTransform(scratch, self._B, self._E)))

    def _calc_jacobian(self, context, output):
        output.SetFromVector(stylus_jacobian(self._plant, self._scratch_at_input(context), self._B, self._E).ravel())

    def _sample(self, context, discrete_state):
        scratch = self._scratch(context)
        X_BE, J = pose_and_jacobian(self._plant, scratch, self._B, self._E, self._position.Eval(context))
        discrete_state.set_value(self._pose_state, pose_vector(X_BE))
        discrete_state.set_value(self._jacobian_state, J.ravel())
