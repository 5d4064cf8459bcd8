"""Gravity feed-forward of a robot's own controller, from its model of arm + payload."""

from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import LeafSystem

from heft.systems.scratch_context import declare_plant_scratch


class GravityCompensation(LeafSystem):
    """Input ``position`` q (rad) → output ``torque`` = −τ_g(q) (N·m), the joint torques
    that hold ``plant`` (a finalized model that this system keeps) still against gravity."""

    def __init__(self, plant: MultibodyPlant):
        super().__init__()
        if not plant.is_finalized():
            raise ValueError("GravityCompensation needs a finalized plant")
        self._plant = plant
        n = plant.num_positions()
        self._position = self.DeclareVectorInputPort("position", n)
        self._scratch = declare_plant_scratch(self, plant)
        self.DeclareVectorOutputPort("torque", n, self._calc, prerequisites_of_calc={
            self._position.ticket()})

    def _calc(self, context, output):
        scratch = self._scratch(context)
        self._plant.SetPositions(scratch, self._position.Eval(context))
        output.SetFromVector(-self._plant.CalcGravityGeneralizedForces(scratch))
