"""Motion of the wrist sensor frame S from the slave's joint state (Fig. 4: q_S, q̇_S → R_WS, ω_S)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import LeafSystem

from heft.systems.load_dynamics import GRAVITY_W
from heft.systems.pose_vectors import POSE_SIZE, pose_into
from heft.systems.serial_chain import GRAVITY, OMEGA, SerialChain

NUM_JOINTS = 6


class SlaveKinematics(LeafSystem):
    """Inputs ``position`` q_S (6, rad) and ``velocity`` q̇_S (6, rad/s) → outputs

    ``pose_RS`` (7): X_RS, the sensor frame S in the slave base R, [p (m); w, x, y, z];
    ``omega_S`` (3): ω_RS expressed in S (rad/s), S's angular velocity (R is fixed);
    ``gravity_S`` (3): the gravity vector expressed in S (m/s²).

    ``model`` is a finalized MultibodyPlant of arm + sensor + load (e.g. built with
    diagrams.plants.AddSlave), or a function returning one. ``base_frame`` and
    ``sensor_frame`` name R and S in it; the joints are those of R's model instance.
    ``gravity_R`` is gravity expressed in R (m/s²). Direct feedthrough: pose_RS and
    gravity_S from ``position``, omega_S from both inputs.
    """

    def __init__(self, model: MultibodyPlant | Callable[[], MultibodyPlant], base_frame: str = "rx90_base",
                 sensor_frame: str = "S", gravity_R=GRAVITY_W):
        super().__init__()
        plant = model if isinstance(model, MultibodyPlant) else model()
        if not plant.is_finalized():
            raise ValueError("SlaveKinematics needs a finalized plant")
        R, S = plant.GetFrameByName(base_frame), plant.GetFrameByName(sensor_frame)
        arm = R.model_instance()
        if plant.num_positions(arm) != NUM_JOINTS or plant.num_velocities(arm) != NUM_JOINTS:
            raise ValueError(f"the model instance of '{base_frame}' must have {NUM_JOINTS} positions and velocities")
        self._chain = SerialChain(plant, R, S, np.asarray(gravity_R, dtype=float).reshape(3))
        self._position = self.DeclareVectorInputPort("position", NUM_JOINTS)
        self._velocity = self.DeclareVectorInputPort("velocity", NUM_JOINTS)
        position = {self._position.ticket()}
        self.DeclareVectorOutputPort("pose_RS", POSE_SIZE, self._calc_pose, prerequisites_of_calc=position)
        self.DeclareVectorOutputPort("omega_S", 3, self._calc_omega,
                                     prerequisites_of_calc=position | {self._velocity.ticket()})
        self.DeclareVectorOutputPort("gravity_S", 3, self._calc_gravity, prerequisites_of_calc=position)

    def _calc_pose(self, context, output):
        chain = self._chain
        chain.update(self._position.Eval(context))
        pose = output.get_mutable_value()
        pose_into(chain.R, chain.p, pose)

    def _calc_omega(self, context, output):
        chain = self._chain
        chain.update(self._position.Eval(context), self._velocity.Eval(context))
        output.SetFromVector(chain.motion[OMEGA])

    def _calc_gravity(self, context, output):
        chain = self._chain
        chain.update(self._position.Eval(context))
        output.SetFromVector(chain.motion[GRAVITY])
