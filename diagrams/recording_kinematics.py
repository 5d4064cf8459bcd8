"""R_WS of a recorded arm from its joint angles, through heft's own model of it (``plants.MakeArmPlant``):
what a recording's orientation of kind ``joint_positions`` needs (``analysis.recording_merge``)."""

from __future__ import annotations

import numpy as np

from heft.diagrams.plants import MakeArmPlant


def joint_orientation(robot: str):
    """A function q (N, 6) rad → R_WS (N, 3, 3) for the arm ``robot`` (rx90 | rx60) with the JR3 on its
    flange, the arm's base frame taken as W (it stands level, docs/design.md §4)."""
    plant, S = MakeArmPlant(robot)
    context = plant.CreateDefaultContext()
    world = plant.world_frame()

    def orientation(q: np.ndarray) -> np.ndarray:
        out = np.empty((len(q), 3, 3))
        for k, angles in enumerate(q):
            plant.SetPositions(context, angles)
            out[k] = plant.CalcRelativeRotationMatrix(context, world, S).matrix()
        return out
    return orientation
