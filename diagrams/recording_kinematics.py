"""R_WS of a recorded arm from its joint angles, through heft's own model of it (``plants.MakeArmPlant``):
what a recording's orientation of kind ``joint_positions`` needs (``analysis.recording_merge``)."""

from __future__ import annotations

import numpy as np
from pydrake.common.yaml import yaml_load_typed

from heft.analysis.recording import Recording
from heft.diagrams.arm_params import BUNDLED_ARMS, ArmParams
from heft.diagrams.plants import MakeArmPlant, Robot


def joint_orientation(robot: Robot):
    """A function q (N, n) rad → R_WS (N, 3, 3) for the arm ``robot`` (``plants.Robot``) with the JR3 on its
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
    orientation.num_joints = plant.num_positions()
    return orientation


def recording_joint_orientation(recording: Recording, robot: str, columns: list, field: str):
    """``joint_orientation`` of the arm a recording names in ``field`` (``robot``: a bundled arm, or ``custom``:
    the recording's ``arm`` section, its URDF relative to the recording), checked against its ``columns``
    (one per joint); a ValueError of one line naming the recording and the field otherwise."""
    if robot == "custom":
        try:
            arm = yaml_load_typed(schema=ArmParams, filename=recording.source, child_name="arm")
        except RuntimeError as error:
            raise ValueError(f"{recording.source}: arm: {' '.join(str(error).split())}") from None
        arm.urdf = str(arm.urdf_path(recording.folder))
        model = arm
    elif robot in BUNDLED_ARMS:
        model = robot
    else:
        raise ValueError(f"{recording.source}: {field}.robot must be one of {', '.join(BUNDLED_ARMS)} or custom "
                         f"(with the recording's arm section); got {robot!r}")
    orientation = joint_orientation(model)
    if len(columns) != orientation.num_joints:
        raise ValueError(f"{recording.source}: {field} names {len(columns)} joint columns; the {robot} arm has "
                         f"{orientation.num_joints} joints")
    return orientation
