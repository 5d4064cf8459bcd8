"""SlaveKinematics: the sensor frame's pose, angular velocity and gravity against
Drake's own kinematics of the station's arm + JR3 + load, and against our closed form."""

import numpy as np
import pytest
from pydrake.math import RigidTransform, RotationMatrix, RollPitchYaw
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import JacobianWrtVariable, SpatialInertia

from heft.diagrams.scenario import Scenario, layered, overrides_text
from heft.diagrams.plants import AddSlave
from heft.systems.pose_vectors import rigid_transform
from heft.systems.controller.rx_inverse_kinematics import RxKinematics
from heft.systems.controller.slave_kinematics import SlaveKinematics

GRAVITY_W = np.array([0.0, 0.0, -9.81])


def slave_plant(robot="rx90", load="tool", extra_free_body=False):
    """A finalized plant of arm + JR3 + load (and optionally a free body, which adds positions)."""
    scenario = layered(Scenario(), overrides_text({"robot": robot, "load.kind": load}))
    plant = MultibodyPlant(0.0)
    AddSlave(plant, scenario)
    if extra_free_body:
        plant.AddRigidBody("floater", plant.AddModelInstance("floater"), SpatialInertia.SolidSphereWithMass(1.0, 0.1))
    plant.mutable_gravity_field().set_gravity_vector(GRAVITY_W)
    plant.Finalize()
    return plant


class Check:
    """A SlaveKinematics and an independent plant of the same model to compare with."""

    def __init__(self, robot="rx90", **kwargs):
        self.robot = robot
        self.plant = slave_plant(robot, **kwargs)
        self.system = SlaveKinematics(lambda: slave_plant(robot, **kwargs), base_frame=f"{robot}_base")
        self.context = self.system.CreateDefaultContext()
        self.reference = self.plant.CreateDefaultContext()
        self.R = self.plant.GetFrameByName(f"{robot}_base")
        self.S = self.plant.GetFrameByName("S")
        self.arm = self.R.model_instance()

    def evaluate(self, q, v):
        """The system's outputs, and the reference plant set to the same state."""
        self.system.GetInputPort("position").FixValue(self.context, q)
        self.system.GetInputPort("velocity").FixValue(self.context, v)
        self.plant.SetPositions(self.reference, self.arm, q)
        self.plant.SetVelocities(self.reference, self.arm, v)
        return {name: self.system.GetOutputPort(name).Eval(self.context).copy()
                for name in ("pose_RS", "omega_S", "gravity_S")}


@pytest.fixture(scope="module")
def rx90():
    return Check()


def random_states(kin, count, seed):
    rng = np.random.default_rng(seed)
    return [(rng.uniform(kin.lower, kin.upper), rng.uniform(-kin.velocity, kin.velocity)) for _ in range(count)]


def test_pose_is_drakes_relative_transform_and_our_closed_form(rx90):
    kin = RxKinematics.rx90()
    X_FS = rx90.plant.CalcRelativeTransform(rx90.reference, rx90.plant.GetFrameByName("flange"), rx90.S)
    for q, v in random_states(kin, 50, seed=1):
        X_RS = rigid_transform(rx90.evaluate(q, v)["pose_RS"])
        X_drake = rx90.plant.CalcRelativeTransform(rx90.reference, rx90.R, rx90.S)
        R_RF, p_RF = kin.forward(q)
        X_closed_form = RigidTransform(RotationMatrix(R_RF), p_RF) @ X_FS
        np.testing.assert_allclose(X_RS.GetAsMatrix4(), X_drake.GetAsMatrix4(), atol=1e-12)
        np.testing.assert_allclose(X_RS.GetAsMatrix4(), X_closed_form.GetAsMatrix4(), atol=1e-12)


def test_omega_is_the_jacobian_times_v_and_the_bodys_spatial_velocity(rx90):
    sensor_body = rx90.S.body()
    for q, v in random_states(RxKinematics.rx90(), 50, seed=2):
        omega_S = rx90.evaluate(q, v)["omega_S"]
        J_w = rx90.plant.CalcJacobianAngularVelocity(rx90.reference, JacobianWrtVariable.kV, rx90.S, rx90.R, rx90.S)
        np.testing.assert_allclose(omega_S, J_w @ v, atol=1e-12)
        R_SW = rx90.S.CalcPoseInWorld(rx90.reference).rotation().inverse()
        w_WB_W = rx90.plant.EvalBodySpatialVelocityInWorld(rx90.reference, sensor_body).rotational()
        np.testing.assert_allclose(omega_S, R_SW @ w_WB_W, atol=1e-12)


def test_gravity_is_the_plants_gravity_in_S(rx90):
    for q, v in random_states(RxKinematics.rx90(), 50, seed=3):
        g_S = rx90.evaluate(q, v)["gravity_S"]
        R_SW = rx90.S.CalcPoseInWorld(rx90.reference).rotation().inverse()
        np.testing.assert_allclose(g_S, R_SW @ rx90.plant.gravity_field().gravity_vector(), atol=1e-12)
        assert np.linalg.norm(g_S) == pytest.approx(9.81)


def test_gravity_of_a_tilted_base():
    """Base R mounted rolled by 0.3 rad in W: gravity in R is given, and rotates into S."""
    plant = slave_plant()
    R_WR = RotationMatrix(RollPitchYaw(0.3, 0.0, 0.0))
    system = SlaveKinematics(plant, gravity_R=R_WR.inverse() @ GRAVITY_W)
    context = system.CreateDefaultContext()
    q = np.array([0.3, 0.5, 1.8, 0.2, 0.84, 0.1])
    system.GetInputPort("position").FixValue(context, q)
    reference = plant.CreateDefaultContext()
    plant.SetPositions(reference, q)
    R_RS = plant.CalcRelativeRotationMatrix(reference, plant.GetFrameByName("rx90_base"), plant.GetFrameByName("S"))
    R_WS = R_WR @ R_RS
    np.testing.assert_allclose(system.GetOutputPort("gravity_S").Eval(context), R_WS.inverse() @ GRAVITY_W, atol=1e-12)


def test_rx60_with_gripper_and_a_plant_with_more_joints():
    """The arm's joints are found through the base frame's model instance, whatever else the plant holds."""
    check = Check("rx60", load="gripper_object", extra_free_body=True)
    assert check.plant.num_positions() == 6 + 7
    q, v = random_states(RxKinematics.rx60(), 1, seed=4)[0]
    outputs = check.evaluate(q, v)
    X_drake = check.plant.CalcRelativeTransform(check.reference, check.R, check.S)
    np.testing.assert_allclose(rigid_transform(outputs["pose_RS"]).GetAsMatrix4(), X_drake.GetAsMatrix4(), atol=1e-12)
    V_RS_S = check.S.CalcSpatialVelocity(check.reference, check.R, check.S)
    np.testing.assert_allclose(outputs["omega_S"], V_RS_S.rotational(), atol=1e-12)


def test_direct_feedthrough_is_only_where_the_math_needs_it(rx90):
    system = rx90.system
    position, velocity = (system.GetInputPort(name).get_index() for name in ("position", "velocity"))
    pose, omega, gravity = (system.GetOutputPort(name).get_index() for name in ("pose_RS", "omega_S", "gravity_S"))
    assert all(system.HasDirectFeedthrough(position, output) for output in (pose, omega, gravity))
    assert system.HasDirectFeedthrough(velocity, omega)
    assert not system.HasDirectFeedthrough(velocity, pose) and not system.HasDirectFeedthrough(velocity, gravity)


def test_unfinalized_plant_is_refused():
    with pytest.raises(ValueError, match="finalized"):
        SlaveKinematics(MultibodyPlant(0.0))
