"""FeedbackMapping: the operator feels what the environment does to the tool (sign),
scaling, clamping that keeps the direction, τ_M = J_Mᵀ·w against virtual work by
finite differences, and safe handling of non-finite inputs."""

import dataclasses

import numpy as np
import pytest
from pydrake.common.yaml import yaml_load_typed
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from scipy.spatial.transform import Rotation

from heft.diagrams.models import model_path
from heft.systems.controller.feedback_mapping import FeedbackMapping, FeedbackMappingParams
from heft.diagrams.plants import MakeMasterPlant
from heft.systems.controller.master_kinematics import MasterKinematics

URDF = model_path("phantom_premium_6dof.urdf")
UP = np.array([0.0, 0.0, 1.0])
G = 9.81
# The sensor frame S tilted arbitrarily in R.
R_RS = Rotation.from_rotvec([0.7, -1.9, 0.4])
POSE_RS = np.concatenate(([0.5, 0.1, 0.8], R_RS.as_quat(scalar_first=True)))


def sensor_on_load(f_R=np.zeros(3), tau_R=np.zeros(3)) -> np.ndarray:
    """[f; τ] in S of a sensor-on-load wrench given in R."""
    return np.concatenate((R_RS.inv().apply(f_R), R_RS.inv().apply(tau_R)))


@pytest.fixture(scope="module")
def loop():
    """q_M → MasterKinematics → jacobian → FeedbackMapping, built once; inputs exported."""
    builder = DiagramBuilder()
    kinematics = builder.AddSystem(MasterKinematics(MakeMasterPlant()))
    mapping = builder.AddSystem(FeedbackMapping())
    builder.Connect(kinematics.GetOutputPort("jacobian"), mapping.GetInputPort("jacobian"))
    builder.ExportInput(kinematics.get_input_port(), "q_M")
    for name in ("wrench_S", "pose_RS"):
        builder.ExportInput(mapping.GetInputPort(name), name)
    for name in ("wrench_E", "torque", "fault"):
        builder.ExportOutput(mapping.GetOutputPort(name), name)
    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    diagram.GetInputPort("q_M").FixValue(context, np.zeros(6))
    diagram.GetInputPort("wrench_S").FixValue(context, np.zeros(6))
    diagram.GetInputPort("pose_RS").FixValue(context, POSE_RS)
    simulator.AdvanceTo(0.01)
    return diagram, context


def evaluate(loop, wrench_S, q=np.zeros(6), pose_RS=POSE_RS):
    diagram, context = loop
    diagram.GetInputPort("q_M").FixValue(context, q)
    diagram.GetInputPort("wrench_S").FixValue(context, wrench_S)
    diagram.GetInputPort("pose_RS").FixValue(context, pose_RS)
    return {name: diagram.GetOutputPort(name).Eval(context) for name in ("wrench_E", "torque", "fault")}


def test_contact_pushing_the_tool_up_pushes_the_stylus_up(loop):
    """The plate pushes the tool up with 30 N: in equilibrium the sensor pulls the load
    down with 30 N (the contact part of f′); the stylus must be pushed up."""
    out = evaluate(loop, sensor_on_load(f_R=-30.0 * UP))
    np.testing.assert_allclose(out["wrench_E"][:3], 30.0 / 17.5 * UP, atol=1e-12)
    assert out["fault"][0] == 0.0


def test_the_loads_weight_pulls_the_stylus_down(loop):
    """At rest the sensor holds the 3.13 kg tool up: f′ = +m·g up; the operator feels the weight."""
    out = evaluate(loop, sensor_on_load(f_R=3.13 * G * UP))
    np.testing.assert_allclose(out["wrench_E"][:3], -3.13 * G / 17.5 * UP, atol=1e-12)


def test_a_twist_on_the_tool_twists_the_stylus_the_same_way(loop):
    """The environment turns the tool about +z_R with 1 N·m: the sensor resists with −1 N·m."""
    out = evaluate(loop, sensor_on_load(tau_R=-1.0 * UP))
    np.testing.assert_allclose(out["wrench_E"][3:], UP / 17.5, atol=1e-12)


def test_R_RB_maps_slave_directions_to_master_directions():
    """R_RB = yaw 90°: the master's +x is the slave's +y. A push along +y_R on the tool
    pushes the stylus along +x_B."""
    mapping = FeedbackMapping(FeedbackMappingParams(force_scale=1.0, torque_scale=1.0), R_RB=[0, 0, np.pi / 2])
    context = mapping.CreateDefaultContext()
    mapping.GetInputPort("wrench_S").FixValue(context, sensor_on_load(f_R=[0, -2.0, 0], tau_R=[0, -0.1, 0]))
    mapping.GetInputPort("pose_RS").FixValue(context, POSE_RS)
    mapping.GetInputPort("jacobian").FixValue(context, np.eye(6).ravel())
    np.testing.assert_allclose(mapping.GetOutputPort("wrench_E").Eval(context), [2.0, 0, 0, 0.1, 0, 0],
                               atol=1e-12)


def test_scaling_is_per_part():
    mapping = FeedbackMapping(FeedbackMappingParams(force_scale=0.1, torque_scale=0.02), R_RB=[0.2, 0.5, -1.0])
    context = mapping.CreateDefaultContext()
    rng = np.random.default_rng(1)
    f_R, tau_R = rng.normal(size=3) * 20, rng.normal(size=3)
    mapping.GetInputPort("wrench_S").FixValue(context, sensor_on_load(f_R, tau_R))
    mapping.GetInputPort("pose_RS").FixValue(context, POSE_RS)
    mapping.GetInputPort("jacobian").FixValue(context, np.eye(6).ravel())
    R_BR = Rotation.from_euler("xyz", [0.2, 0.5, -1.0]).inv()
    np.testing.assert_allclose(mapping.GetOutputPort("wrench_E").Eval(context),
                               np.concatenate((-0.1 * R_BR.apply(f_R), -0.02 * R_BR.apply(tau_R))), atol=1e-12)


def test_clamping_keeps_the_direction(loop):
    rng = np.random.default_rng(2)
    f_R, tau_R = rng.normal(size=3), rng.normal(size=3)
    f_R *= 1000.0 / np.linalg.norm(f_R)   # 57 N at the master: over 8.5 N
    tau_R *= 1.0 / np.linalg.norm(tau_R)  # 0.057 N·m at the master: under 0.188 N·m
    out = evaluate(loop, sensor_on_load(f_R, tau_R))
    f, tau = out["wrench_E"][:3], out["wrench_E"][3:]
    assert np.linalg.norm(f) == pytest.approx(8.5, rel=1e-12)
    np.testing.assert_allclose(f / 8.5, -f_R / 1000.0, atol=1e-12)
    np.testing.assert_allclose(tau, -tau_R / 17.5, atol=1e-12)
    out = evaluate(loop, sensor_on_load(f_R / 1000.0, 100 * tau_R))
    assert np.linalg.norm(out["wrench_E"][3:]) == pytest.approx(0.188, rel=1e-12)
    np.testing.assert_allclose(out["wrench_E"][3:] / 0.188, -tau_R, atol=1e-12)
    np.testing.assert_allclose(out["wrench_E"][:3], -f_R / 1000.0 / 17.5, atol=1e-12)


def test_joint_torque_is_the_virtual_work_of_the_rendered_wrench(loop):
    """τ_i = ∂W/∂q_i with δW = f·δp_E + τ·δθ_E, by central differences on a separately
    built plant: this checks J_M (rows [v; ω]) and the transpose together."""
    plant = MultibodyPlant(time_step=0.0)
    Parser(plant).AddModels(URDF)
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("phantom_base"))
    plant.Finalize()
    plant_context = plant.CreateDefaultContext()
    B, E = plant.GetFrameByName("phantom_base"), plant.GetFrameByName("stylus")

    def X_BE(q):
        plant.SetPositions(plant_context, q)
        return plant.CalcRelativeTransform(plant_context, B, E)

    rng = np.random.default_rng(3)
    h = 1e-6
    for _ in range(10):
        q = rng.uniform(plant.GetPositionLowerLimits(), plant.GetPositionUpperLimits())
        out = evaluate(loop, sensor_on_load(rng.normal(size=3) * 40, rng.normal(size=3)), q)
        f, tau = out["wrench_E"][:3], out["wrench_E"][3:]
        expected = np.zeros(6)
        for i in range(6):
            dq = np.zeros(6)
            dq[i] = h
            plus, minus = X_BE(q + dq), X_BE(q - dq)
            dtheta = Rotation.from_matrix((plus.rotation() @ minus.rotation().inverse()).matrix()).as_rotvec()
            expected[i] = (f @ (plus.translation() - minus.translation()) + tau @ dtheta) / (2 * h)
        np.testing.assert_allclose(out["torque"], expected, atol=1e-7)


@pytest.mark.parametrize("bad", ["wrench_nan", "wrench_inf", "pose_nan", "pose_zero_quaternion"])
def test_bad_wrench_or_pose_gives_zero_and_fault(loop, bad):
    wrench = sensor_on_load(f_R=-30.0 * UP)
    pose = POSE_RS.copy()
    if bad == "wrench_nan":
        wrench[4] = np.nan
    elif bad == "wrench_inf":
        wrench[0] = np.inf
    elif bad == "pose_nan":
        pose[1] = np.nan
    else:
        pose[3:] = 0.0
    out = evaluate(loop, wrench, pose_RS=pose)
    np.testing.assert_array_equal(out["wrench_E"], np.zeros(6))
    np.testing.assert_array_equal(out["torque"], np.zeros(6))
    assert out["fault"][0] == 1.0
    assert evaluate(loop, sensor_on_load(f_R=-30.0 * UP))["fault"][0] == 0.0


def test_bad_jacobian_gives_zero_torque_and_fault():
    mapping = FeedbackMapping()
    context = mapping.CreateDefaultContext()
    mapping.GetInputPort("wrench_S").FixValue(context, sensor_on_load(f_R=-30.0 * UP))
    mapping.GetInputPort("pose_RS").FixValue(context, POSE_RS)
    jacobian = np.eye(6).ravel()
    jacobian[7] = np.nan
    mapping.GetInputPort("jacobian").FixValue(context, jacobian)
    np.testing.assert_array_equal(mapping.GetOutputPort("torque").Eval(context), np.zeros(6))
    assert mapping.GetOutputPort("fault").Eval(context)[0] == 1.0
    np.testing.assert_allclose(mapping.GetOutputPort("wrench_E").Eval(context)[:3], 30.0 / 17.5 * UP, atol=1e-12)


def test_direct_feedthrough():
    mapping = FeedbackMapping()
    index = {name: mapping.GetInputPort(name).get_index() for name in ("wrench_S", "pose_RS", "jacobian")}
    wrench_E, torque = mapping.GetOutputPort("wrench_E").get_index(), mapping.GetOutputPort("torque").get_index()
    assert mapping.HasDirectFeedthrough(index["wrench_S"], wrench_E)
    assert mapping.HasDirectFeedthrough(index["pose_RS"], wrench_E)
    assert not mapping.HasDirectFeedthrough(index["jacobian"], wrench_E)
    assert all(mapping.HasDirectFeedthrough(i, torque) for i in index.values())


def test_params_defaults_yaml_and_validation():
    defaults = FeedbackMappingParams()
    assert (defaults.force_scale, defaults.torque_scale) == (1 / 17.5, 1 / 17.5)
    assert (defaults.max_force, defaults.max_torque) == (8.5, 0.188)
    params = yaml_load_typed(schema=FeedbackMappingParams, data="{force_scale: 0.1, max_torque: 0.1}")
    assert params == FeedbackMappingParams(force_scale=0.1, max_torque=0.1)
    with pytest.raises(ValueError, match="force_scale"):
        FeedbackMapping(FeedbackMappingParams(force_scale=-0.1))
    with pytest.raises(ValueError, match="max_torque"):
        FeedbackMapping(FeedbackMappingParams(max_torque=0.0))


def test_R_RB_has_one_home_the_motion_scalings():
    """The rotation between the bases is set once, in ``controller.motion.R_RB``, and the feedback
    maps back through it: a scenario cannot give the feedback another one."""
    from heft.diagrams.scenario import Scenario, layered

    with pytest.raises(ValueError, match="unknown field 'controller.feedback.R_RB'"):
        layered(Scenario(), "{controller: {feedback: {R_RB: [0, 0, 1]}}}")
    assert "R_RB" not in {f.name for f in dataclasses.fields(FeedbackMappingParams)}
    assert layered(Scenario(), "{controller: {motion: {R_RB: [0, 0, 1]}}}").controller.motion.R_RB == [0, 0, 1]
