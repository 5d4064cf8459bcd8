"""The 3-D scene's poses from a run's joint angles: the sensor S in the arm's base R from
``slave_q`` and the stylus E in the master's base B from ``master_q``, by the kinematics the
controller uses (``SerialChain``), as pose vectors [p (m); w, x, y, z] under the keys
``analysis.topics.SCENE_KEYS`` (``pose_RS``, ``pose_BE``)."""

from __future__ import annotations

import numpy as np

from heft.diagrams.master_params import DEFAULT_MASTER
from heft.diagrams.plants import MakeArmPlant, MakeMasterPlant, Robot
from heft.systems.controller.master_kinematics import BASE_FRAME, STYLUS_FRAME
from heft.systems.pose_vectors import POSE_SIZE, pose_into
from heft.systems.serial_chain import SerialChain


class ScenePoses:
    """``update(slave_q, master_q)`` writes ``pose_RS`` and ``pose_BE`` (NaN where the angles are not
    finite) for the arm ``robot`` (``plants.Robot``: a bundled arm's name or a custom arm's ``ArmParams``) and
    the haptic ``master`` (``master_params.BUNDLED_MASTERS``)."""

    def __init__(self, robot: Robot, master: str = DEFAULT_MASTER):
        arm, S = MakeArmPlant(robot)
        master = MakeMasterPlant(master)
        self._slave = SerialChain(arm, arm.world_frame(), S)  # the arm's base R is welded at W
        self._master = SerialChain(master, master.GetFrameByName(BASE_FRAME), master.GetFrameByName(STYLUS_FRAME))
        self.pose_RS, self.pose_BE = np.full(POSE_SIZE, np.nan), np.full(POSE_SIZE, np.nan)

    def update(self, slave_q, master_q) -> None:
        for chain, q, pose in ((self._slave, slave_q, self.pose_RS), (self._master, master_q, self.pose_BE)):
            q = np.asarray(q, dtype=float)
            if np.isfinite(q).all():
                chain.update(q)
                pose_into(chain.R, chain.p, pose)
            else:
                pose[:] = np.nan


def with_scene_poses(arrays: dict, robot: Robot, master: str = DEFAULT_MASTER) -> dict:
    """``arrays`` with ``pose_RS`` and ``pose_BE`` (N, 7) added, if it has ``slave_q`` and ``master_q``."""
    if "slave_q" not in arrays or "master_q" not in arrays:
        return arrays
    poses = ScenePoses(robot, master)
    pose_RS, pose_BE = [], []
    for slave_q, master_q in zip(arrays["slave_q"], arrays["master_q"], strict=True):
        poses.update(slave_q, master_q)
        pose_RS.append(poses.pose_RS.copy())
        pose_BE.append(poses.pose_BE.copy())
    return {**arrays, "pose_RS": np.array(pose_RS).reshape(-1, POSE_SIZE),
            "pose_BE": np.array(pose_BE).reshape(-1, POSE_SIZE)}
