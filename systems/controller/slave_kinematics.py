"""Motion of the wrist sensor frame S from the slave's joint state (Fig. 4: q_S, q̇_S → R_WS, ω_S)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from pydrake.multibody.plant import MultibodyPlant

from heft.systems.load_dynamics import GRAVITY_W
from heft.systems.pose_vectors import POSE_SIZE, pose_into
from heft.systems.compiled import compiled
from heft.systems.serial_chain import CHAIN_JOINTS, GRAVITY, SerialChain, chain_dtype, chain_kinematics
from heft.systems.tick_system import TickSystem


def position_size(n: int) -> int:
    """The size of the chain at q_S for ``n`` joints: [X_RS (7); g_S (3); R_RS (9, row-major); the rows of J
    for ω in R (3 × n, row-major)]."""
    return POSE_SIZE + 3 + 9 + 3 * n


def _slave_position_into(out, position, chain):
    """The chain at q_S = ``position`` (n, rad) into ``out`` (``position_size(n)``)."""
    n = position.shape[0]
    c = chain[0]
    motion, R, J = c["motion"], c["R"], c["J"]
    chain_kinematics(c["axes"], c["points"], c["M_R"], c["M_p"], position, c["zeros"], c["zeros"], c["gravity_B"],
                     R, c["p"], J, motion, c["work"])
    pose_into(R, c["p"], out[:POSE_SIZE])
    for i in range(3):
        out[POSE_SIZE + i] = motion[GRAVITY.start + i]
        for k in range(3):
            out[POSE_SIZE + 3 + 3 * i + k] = R[i, k]
        for k in range(n):
            out[POSE_SIZE + 12 + n * i + k] = J[3 + i, k]


slave_position_into = {n: compiled("void(float64[:], float64[:], CHAIN[:])", CHAIN=chain_dtype(n))(
    _slave_position_into) for n in CHAIN_JOINTS}
"""``_slave_position_into`` compiled for each chain's record, by its number of joints."""


@compiled("void(float64[:], float64[:], float64[:])")
def slave_omega_into(out, at_position, velocity):
    """ω_S = R_RSᵀ·J_ω·q̇_S (3, rad/s) into ``out``, from ``slave_position_into``'s ``at_position``."""
    n = velocity.shape[0]
    jacobian = POSE_SIZE + 12
    wx = wy = wz = 0.0
    for k in range(n):
        wx += at_position[jacobian + k] * velocity[k]
        wy += at_position[jacobian + n + k] * velocity[k]
        wz += at_position[jacobian + 2 * n + k] * velocity[k]
    for k in range(3):
        out[k] = at_position[POSE_SIZE + 3 + k] * wx + at_position[POSE_SIZE + 6 + k] * wy + \
            at_position[POSE_SIZE + 9 + k] * wz


class SlaveKinematics(TickSystem):
    """Inputs ``position`` q_S (n, rad) and ``velocity`` q̇_S (n, rad/s) of the arm's n joints → outputs

    ``pose_RS`` (7): X_RS, the sensor frame S in the slave base R, [p (m); w, x, y, z];
    ``omega_S`` (3): ω_RS expressed in S (rad/s), S's angular velocity (R is fixed);
    ``gravity_S`` (3): the gravity vector expressed in S (m/s²).

    ``model`` is a finalized MultibodyPlant of arm + sensor + load (e.g. built with
    diagrams.plants.AddSlave), or a function returning one. ``base_frame`` and
    ``sensor_frame`` name R and S in it; the joints are those between them (``CHAIN_JOINTS``).
    ``gravity_R`` is gravity expressed in R (m/s²). Direct feedthrough:
    pose_RS and gravity_S from ``position``, omega_S from both inputs (zero velocity when unconnected).
    """

    def __init__(self, model: MultibodyPlant | Callable[[], MultibodyPlant], base_frame: str = "rx90_base",
                 sensor_frame: str = "S", gravity_R=GRAVITY_W):
        super().__init__(None)
        plant = model if isinstance(model, MultibodyPlant) else model()
        if not plant.is_finalized():
            raise ValueError("SlaveKinematics needs a finalized plant")
        R, S = plant.GetFrameByName(base_frame), plant.GetFrameByName(sensor_frame)
        self._chain = SerialChain(plant, R, S, np.asarray(gravity_R, dtype=float).reshape(3))
        n = self._chain.num_joints
        if n not in CHAIN_JOINTS:
            raise ValueError(f"the chain from '{base_frame}' to '{sensor_frame}' has {n} joints; SlaveKinematics "
                             f"takes {' or '.join(str(c) for c in CHAIN_JOINTS)}")
        self.DeclareTickInput("position", n)
        self.DeclareTickInput("velocity", n, np.zeros(n))
        self.DeclareTickCalc("at_position", position_size(n), slave_position_into[n], "calc:at_position",
                             "in:position", self._chain.record)
        self.DeclareTickCalc("omega", 3, slave_omega_into, "calc:omega", "calc:at_position", "in:velocity")
        self.DeclareTickOutput("pose_RS", "calc:at_position", 0, POSE_SIZE)
        self.DeclareTickOutput("omega_S", "calc:omega")
        self.DeclareTickOutput("gravity_S", "calc:at_position", POSE_SIZE, POSE_SIZE + 3)
