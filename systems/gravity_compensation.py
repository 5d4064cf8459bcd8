"""Gravity feed-forward of a robot's own controller, from its model of arm + payload."""

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import LeafSystem, ValueProducer


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
        # The scratch plant context lives in the cache: every context of this system has its own.
        self._scratch = self.DeclareCacheEntry(
            "plant_context",
            ValueProducer(allocate=lambda: AbstractValue.Make(plant.CreateDefaultContext()),
                          calc=lambda context, value: None),
            prerequisites_of_calc={self.nothing_ticket()})
        self.DeclareVectorOutputPort("torque", n, self._calc, prerequisites_of_calc={
            self._position.ticket()})

    def _calc(self, context, output):
        scratch = self._scratch.get_mutable_cache_entry_value(context).GetMutableValueOrThrow()
        self._plant.SetPositions(scratch, self._position.Eval(context))
        output.SetFromVector(-self._plant.CalcGravityGeneralizedForces(scratch))
