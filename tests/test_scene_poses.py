"""The 3-D scene's poses (live view, MCAP, export) on any arm and master: S in the arm's base and E in the master's,
as Drake's own plants put them, for bundled arms, a custom arm from its URDF and each bundled master."""

import numpy as np
import pytest
from pydrake.math import RigidTransform

from heft.diagrams.plants import MakeArmPlant, MakeMasterPlant, slave_arm
from heft.diagrams.scenario import load_scenario
from heft.diagrams.scene_poses import ScenePoses
from heft.systems.controller.master_kinematics import BASE_FRAME, STYLUS_FRAME

from foreign_arm import START, custom_scenario_text, panda_urdf


def pose(X: RigidTransform) -> np.ndarray:
    q = X.rotation().ToQuaternion()
    return np.concatenate((X.translation(), [q.w(), q.x(), q.y(), q.z()]))


def same_pose(a, b) -> None:
    np.testing.assert_allclose(a[:3], b[:3], atol=1e-12)
    np.testing.assert_allclose(a[3:] * np.sign(a[3] or 1.0), b[3:] * np.sign(b[3] or 1.0), atol=1e-12)


def custom_arm(tmp_path):
    (tmp_path / "panda.urdf").write_text(panda_urdf())
    path = tmp_path / "lab.yaml"
    path.write_text(custom_scenario_text("panda.urdf", "experiment: fig6\n"))
    return slave_arm(load_scenario(path))


@pytest.mark.parametrize("arm", ["rx90", "ur5e", "iiwa14", "custom"])
def test_the_scene_poses_s_and_e_as_drakes_plants_do(arm, tmp_path):
    robot = custom_arm(tmp_path) if arm == "custom" else arm
    plant, S = MakeArmPlant(robot)
    master = MakeMasterPlant()
    rng = np.random.default_rng(5)
    q_S = (np.array(START) if arm == "custom" else np.zeros(plant.num_positions())) + rng.uniform(
        -0.3, 0.3, plant.num_positions())
    q_M = rng.uniform(-0.3, 0.3, master.num_positions())
    scene = ScenePoses(robot)
    scene.update(q_S, q_M)
    context, master_context = plant.CreateDefaultContext(), master.CreateDefaultContext()
    plant.SetPositions(context, q_S)
    master.SetPositions(master_context, q_M)
    same_pose(scene.pose_RS, pose(S.CalcPoseInWorld(context)))
    same_pose(scene.pose_BE, pose(master.GetFrameByName(STYLUS_FRAME).CalcPose(
        master_context, master.GetFrameByName(BASE_FRAME))))
    scene.update(np.full(plant.num_positions(), np.nan), q_M)
    assert np.isnan(scene.pose_RS).all() and np.isfinite(scene.pose_BE).all()


@pytest.mark.parametrize("master", ["phantom_premium_6dof", "touch"])
def test_the_scene_poses_the_stylus_of_the_scenarios_master(master):
    plant = MakeMasterPlant(master)
    q_M = np.random.default_rng(6).uniform(-0.3, 0.3, plant.num_positions())
    scene = ScenePoses("rx90", master)
    scene.update(np.zeros(6), q_M)
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, q_M)
    E, B = plant.GetFrameByName(STYLUS_FRAME), plant.GetFrameByName(BASE_FRAME)
    same_pose(scene.pose_BE, pose(E.CalcPose(context, B)))
