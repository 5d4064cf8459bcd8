"""Forward kinematics and Jacobian of the master (Fig. 4: q_M → ᴮT_E and J_M).

B is the master base (the plant's ``phantom_base`` frame), E the stylus frame
(``stylus``). The Jacobian's rows are [v_E; ω_E] — translational first, the
order of heft's wrenches [f; τ] (docs/design.md §4) — so that τ_M = J_Mᵀ·[f; τ] for a
wrench applied at E's origin, expressed in B.
"""

from __future__ import annotations

import numpy as np
from pydrake.multibody.plant import MultibodyPlant

from heft.systems.compiled import compiled
from heft.systems.pose_vectors import POSE_SIZE, pose_into
from heft.systems.serial_chain import SerialChain, chain_dtype, chain_kinematics
from heft.systems.tick_system import TickSystem

NUM_JOINTS = 6
JACOBIAN_SIZE = 6 * NUM_JOINTS
BASE_FRAME = "phantom_base"
STYLUS_FRAME = "stylus"


def master_pose(chain: SerialChain) -> np.ndarray:
    """The pose vector of E in B (``pose_vectors``) after ``chain.update``."""
    pose = np.empty(POSE_SIZE)
    pose_into(chain.R, chain.p, pose)
    return pose


KINEMATICS_SIZE = POSE_SIZE + JACOBIAN_SIZE


@compiled("void(float64[:], float64[:], CHAIN[:])", CHAIN=chain_dtype(NUM_JOINTS))
def master_kinematics_into(out, position, chain):
    """[pose of E in B (7); J_M row-major (36)] at q_M = ``position`` (6, rad) into ``out`` (43)."""
    c = chain[0]
    chain_kinematics(c["axes"], c["points"], c["M_R"], c["M_p"], position, c["zeros"], c["zeros"], c["gravity_B"],
                     c["R"], c["p"], c["J"], c["motion"], c["work"])
    pose_into(c["R"], c["p"], out[:POSE_SIZE])
    J = c["J"]
    for r in range(6):
        for k in range(NUM_JOINTS):
            out[POSE_SIZE + r * NUM_JOINTS + k] = J[r, k]


@compiled("void(float64[:], float64[:], float64[:], CHAIN[:])", CHAIN=chain_dtype(NUM_JOINTS))
def master_sample(pose, jacobian, position, chain):
    """``master_kinematics_into`` held in the states ``pose`` (7) and ``jacobian`` (36)."""
    c = chain[0]
    chain_kinematics(c["axes"], c["points"], c["M_R"], c["M_p"], position, c["zeros"], c["zeros"], c["gravity_B"],
                     c["R"], c["p"], c["J"], c["motion"], c["work"])
    pose_into(c["R"], c["p"], pose)
    J = c["J"]
    for r in range(6):
        for k in range(NUM_JOINTS):
            jacobian[r * NUM_JOINTS + k] = J[r, k]


class MasterKinematics(TickSystem):
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
        if not plant.is_finalized():
            raise ValueError("MasterKinematics needs a finalized plant")
        if plant.num_positions() != NUM_JOINTS or plant.num_velocities() != NUM_JOINTS:
            raise ValueError(f"MasterKinematics needs a plant with {NUM_JOINTS} positions and velocities; got "
                             f"{plant.num_positions()} and {plant.num_velocities()}")
        if period is not None and not (np.isfinite(period) and period > 0):
            raise ValueError(f"period must be None or finite and > 0; got {period}")
        super().__init__(period)
        self._chain = chain = SerialChain(plant, plant.GetFrameByName(BASE_FRAME), plant.GetFrameByName(STYLUS_FRAME))
        self.DeclareTickInput("position", NUM_JOINTS)
        if period is None:
            self.DeclareTickCalc("kinematics", KINEMATICS_SIZE, master_kinematics_into, "calc:kinematics",
                                 "in:position", chain.record)
            self.DeclareTickOutput("pose_BE", "calc:kinematics", 0, POSE_SIZE)
            self.DeclareTickOutput("jacobian", "calc:kinematics", POSE_SIZE, KINEMATICS_SIZE)
        else:
            chain.update(plant.GetDefaultPositions())
            self.DeclareTickState("pose", master_pose(chain))
            self.DeclareTickState("jacobian", chain.J.ravel())
            args = ("next:pose", "next:jacobian", "in:position", chain.record)
            self.DeclareTickInitialization(master_sample, *args)
            self.DeclareTickUpdate(master_sample, *args)
            self.DeclareTickOutput("pose_BE", "x:pose")
            self.DeclareTickOutput("jacobian", "x:jacobian")
