"""Forward kinematics and Jacobian of the master (Fig. 4: q_M → ᴮT_E and J_M).

B is the master base (the plant's ``phantom_base`` frame), E the stylus frame
(``stylus``). The Jacobian's rows are [v_E; ω_E] — translational first, the
order of heft's wrenches [f; τ] (docs/design.md §4) — so that τ_M = J_Mᵀ·[f; τ] for a
wrench applied at E's origin, expressed in B.
"""

from __future__ import annotations

import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import LeafSystem

from heft.systems.pose_vectors import POSE_SIZE, pose_into
from heft.systems.serial_chain import SerialChain

NUM_JOINTS = 6
JACOBIAN_SIZE = 6 * NUM_JOINTS
BASE_FRAME = "phantom_base"
STYLUS_FRAME = "stylus"


def master_pose(chain: SerialChain) -> np.ndarray:
    """The pose vector of E in B (``pose_vectors``) after ``chain.update``."""
    pose = np.empty(POSE_SIZE)
    pose_into(chain.R, chain.p, pose)
    return pose


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
        self._chain = chain = SerialChain(plant, plant.GetFrameByName(BASE_FRAME), plant.GetFrameByName(STYLUS_FRAME))
        self._position = self.DeclareVectorInputPort("position", NUM_JOINTS)
        if period is None:
            inputs = {self._position.ticket()}
            self.DeclareVectorOutputPort("pose_BE", POSE_SIZE, self._calc_pose, prerequisites_of_calc=inputs)
            self.DeclareVectorOutputPort("jacobian", JACOBIAN_SIZE, self._calc_jacobian,
                                         prerequisites_of_calc=inputs)
        else:
            chain.update(plant.GetDefaultPositions())
            self._pose_state = self.DeclareDiscreteState(master_pose(chain))
            self._jacobian_state = self.DeclareDiscreteState(chain.J.ravel())
            self.DeclareInitializationDiscreteUpdateEvent(self._sample)
            self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._sample)
            self.DeclareStateOutputPort("pose_BE", self._pose_state)
            self.DeclareStateOutputPort("jacobian", self._jacobian_state)

    def _chain_at_input(self, context) -> SerialChain:
        self._chain.update(self._position.Eval(context))
        return self._chain

    def _calc_pose(self, context, output):
        output.SetFromVector(master_pose(self._chain_at_input(context)))

    def _calc_jacobian(self, context, output):
        output.SetFromVector(self._chain_at_input(context).J.ravel())

    def _sample(self, context, discrete_state):
        chain = self._chain_at_input(context)
        discrete_state.set_value(self._pose_state, master_pose(chain))
        discrete_state.set_value(self._jacobian_state, chain.J.ravel())
