"""heft's robot and load models (diagrams/models) against independent references:
the cited DH tables, the Phantom's closed-form kinematics, the datasheet limits,
and the tool/gripper inertias composed part by part with Drake's own
SpatialInertia algebra (not the numpy composition the files were made with)."""

from __future__ import annotations

import importlib.util
import logging
import sys
import xml.etree.ElementTree as ET
from functools import cache
from pathlib import Path

import numpy as np
import pytest
from pydrake.math import RigidTransform
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph, MultibodyPlant
from pydrake.multibody.tree import BodyIndex, JointActuatorIndex, RotationalInertia, SpatialInertia
from pydrake.systems.framework import DiagramBuilder

MODELS = Path(__file__).resolve().parents[1] / "diagrams" / "models"


def _load_module(name: str, path: Path):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # dataclasses look their module up here
    spec.loader.exec_module(module)
    return module


models = _load_module("heft_models_under_test", MODELS / "__init__.py")
mti = _load_module("heft_make_tool_inertia", MODELS / "make_tool_inertia.py")

ARM_FILES = ("rx90.urdf", "rx60.urdf", "phantom_premium_6dof.urdf")
LOAD_FILES = ("jr3_sensor.urdf", "tool.urdf", "gripper_object.urdf")
ALL_FILES = ARM_FILES + LOAD_FILES


@cache
def _plant(name: str):
    """(plant, plant context) with ``name`` parsed; geometry registered with a SceneGraph."""
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlantSceneGraph(builder, time_step=0.0)
    Parser(plant).AddModels(models.model_path(name))
    plant.Finalize()
    return plant, plant.CreateDefaultContext()


def _body_inertia(name: str, body: str) -> SpatialInertia:
    """Spatial inertia of ``body`` about its frame origin, in its frame, as parsed by Drake."""
    plant, _ = _plant(name)
    return plant.GetBodyByName(body).default_spatial_inertia()


# ---------------------------------------------------------------- model_path


def test_model_path_finds_every_model_and_names_them_when_missing():
    for name in ALL_FILES:
        path = Path(models.model_path(name))
        assert path.is_absolute() and path.is_file()
    with pytest.raises(FileNotFoundError) as error:
        models.model_path("ur5.urdf")
    assert all(name in str(error.value) for name in ALL_FILES)


# ---------------------------------------------------------------- structure


@pytest.mark.parametrize("name, base, last", [("rx90.urdf", "rx90_base", "flange"),
                                              ("rx60.urdf", "rx60_base", "flange"),
                                              ("phantom_premium_6dof.urdf", "phantom_base", "stylus")])
def test_arm_has_six_actuated_revolute_joints_in_a_chain(name, base, last):
    plant, _ = _plant(name)
    revolute = [plant.GetJointByName(f"joint{i}") for i in range(1, 7)]
    assert all(j.type_name() == "revolute" for j in revolute)
    assert plant.num_actuators() == 6
    for i in range(6):
        actuator = plant.get_joint_actuator(JointActuatorIndex(i))
        joint = actuator.joint()
        assert actuator.name() == f"{joint.name()}_motor"
        assert actuator.effort_limit() > 0
    # joint1 hangs off the base, joint6 carries the last link; the chain is unbranched.
    assert revolute[0].parent_body().name() == base
    assert revolute[5].child_body().name() == last
    for j_prev, j_next in zip(revolute, revolute[1:]):
        assert j_next.parent_body().index() == j_prev.child_body().index()
    # Only the base floats until the builder welds it: 6 revolute dof + 7 of a free body.
    assert plant.num_positions() == 6 + 7


def test_load_files_hold_unjoined_bodies_and_the_sensor_frame():
    def bodies(name, instance):
        plant, _ = _plant(name)
        return {plant.get_body(b).name() for b in plant.GetBodyIndices(plant.GetModelInstanceByName(instance))}

    assert bodies("jr3_sensor.urdf", "jr3_sensor") == {"jr3_sensor"}
    assert bodies("tool.urdf", "tool") == {"tool"}
    assert bodies("gripper_object.urdf", "gripper_object") == {"gripper", "object"}
    for name in LOAD_FILES:
        assert _plant(name)[0].num_actuators() == 0
        # Nothing is joined in the files: the builder welds.
        assert not ET.parse(models.model_path(name)).getroot().findall("joint")
    # Only the sensor file has S; the loads are welded to it.
    assert not _plant("tool.urdf")[0].HasFrameNamed("S")
    assert not _plant("gripper_object.urdf")[0].HasFrameNamed("S")
    S = _plant("jr3_sensor.urdf")[0].GetFrameByName("S")
    assert S.body().name() == "jr3_sensor"
    # S at the sensor's centre, 17.5 mm from the robot-side face (JR3 85 mm x 35 mm).
    assert S.GetFixedPoseInBodyFrame().IsExactlyEqualTo(RigidTransform([0.0, 0.0, 0.0175]))
    assert _body_inertia("jr3_sensor.urdf", "jr3_sensor").get_com()[2] == pytest.approx(0.0175)


@pytest.mark.parametrize("name", ALL_FILES)
def test_every_model_parses_without_warnings(name, caplog):
    # pydrake forwards Drake's log to Python's "drake" logger. (Drake warns, e.g., once per joint
    # with a URDF friction value, which the plant ignores.)
    with caplog.at_level(logging.DEBUG, logger="drake"):
        plant = MultibodyPlant(time_step=0.0)  # kept in a name: the Parser does not keep it alive
        Parser(plant).AddModels(models.model_path(name))
    assert [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING] == []


@pytest.mark.parametrize("name", ALL_FILES)
def test_every_spatial_inertia_is_physically_valid(name):
    plant, _ = _plant(name)
    for i in range(1, plant.num_bodies()):  # 0 is the world
        body = plant.get_body(BodyIndex(i))
        M = body.default_spatial_inertia()
        assert M.get_mass() > 0, body.name()
        assert M.IsPhysicallyValid(), body.name()


# ---------------------------------------------------------------- RX90 / RX60 kinematics


def _mdh(alpha, a, theta, d):
    """Craig's modified DH link transform Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i) Tz(d_i)."""
    Rx = np.array([[1, 0, 0, 0], [0, np.cos(alpha), -np.sin(alpha), 0], [0, np.sin(alpha), np.cos(alpha), 0],
                   [0, 0, 0, 1]])
    Tx = np.eye(4)
    Tx[0, 3] = a
    Rz = np.array([[np.cos(theta), -np.sin(theta), 0, 0], [np.sin(theta), np.cos(theta), 0, 0], [0, 0, 1, 0],
                   [0, 0, 0, 1]])
    Tz = np.eye(4)
    Tz[2, 3] = d
    return Rx @ Tx @ Rz @ Tz


H = np.pi / 2
# (alpha_{i-1}, a_{i-1}, theta offset, d_i) — the tables cited in SOURCES.md, typed in again here.
DH_TABLES = {
    "rx90.urdf": [(0, 0, 0, 0.420), (-H, 0, -H, 0), (0, 0.450, -H, 0), (-H, 0, 0, 0.450), (H, 0, 0, 0),
                  (-H, 0, np.pi, 0.085)],
    "rx60.urdf": [(0, 0, 0, 0.341), (-H, 0, -H, 0), (0, 0.290, -H, 0.049), (-H, 0, 0, 0.310), (H, 0, 0, 0),
                  (-H, 0, np.pi, 0.065)],
}
BASES = {"rx90.urdf": "rx90_base", "rx60.urdf": "rx60_base"}


def _dh_fk(table, q):
    T = np.eye(4)
    for (alpha, a, offset, d), qi in zip(table, q):
        T = T @ _mdh(alpha, a, qi + offset, d)
    return T


def _drake_X(name, q, frame_a, frame_b) -> RigidTransform:
    """X_AB from Drake with joint{i} at q[i-1]."""
    plant, context = _plant(name)
    for i in range(6):
        plant.GetJointByName(f"joint{i + 1}").set_angle(context, q[i])
    return plant.CalcRelativeTransform(context, plant.GetFrameByName(frame_a), plant.GetFrameByName(frame_b))


def _random_q(name, rng):
    lower, upper, _, _ = _limits(name)
    return rng.uniform(lower, upper)


@pytest.mark.parametrize("name", ["rx90.urdf", "rx60.urdf"])
def test_arm_forward_kinematics_equals_the_dh_table(name):
    rng = np.random.default_rng(7)
    for _ in range(20):
        q = _random_q(name, rng)
        X = _drake_X(name, q, BASES[name], "flange").GetAsMatrix4()
        np.testing.assert_allclose(X, _dh_fk(DH_TABLES[name], q), atol=1e-9)


def test_rx90_zero_pose_and_reach():
    # q = 0: the arm straight up, flange 0.420 + 0.450 + 0.450 + 0.085 = 1.405 m above R, F parallel to R.
    X = _drake_X("rx90.urdf", np.zeros(6), "rx90_base", "flange")
    assert X.IsNearlyEqualTo(RigidTransform([0.0, 0.0, 1.405]), 1e-12)
    # Laid forward (J2 = +90°): the flange face reaches 0.985 m from the J2 axis (datasheet reach).
    X = _drake_X("rx90.urdf", [0, np.pi / 2, 0, 0, 0, 0], "rx90_base", "flange")
    np.testing.assert_allclose(X.translation(), [0.985, 0.0, 0.420], atol=1e-12)
    np.testing.assert_allclose(X.rotation().col(2), [1.0, 0.0, 0.0], atol=1e-12)


def _limits(name):
    plant, _ = _plant(name)
    joints = [plant.GetJointByName(f"joint{i}") for i in range(1, 7)]
    lower = np.array([j.position_lower_limits()[0] for j in joints])
    upper = np.array([j.position_upper_limits()[0] for j in joints])
    velocity = np.array([j.velocity_upper_limits()[0] for j in joints])
    effort = np.array([plant.GetJointActuatorByName(f"joint{i}_motor").effort_limit() for i in range(1, 7)])
    return lower, upper, velocity, effort


def test_rx90_limits_match_the_datasheet():
    lower, upper, velocity, effort = _limits("rx90.urdf")
    np.testing.assert_allclose(np.rad2deg(lower), [-160, -137.5, -142.5, -270, -105, -270], rtol=0, atol=1e-9)
    np.testing.assert_allclose(np.rad2deg(upper), [160, 137.5, 142.5, 270, 120, 270], rtol=0, atol=1e-9)
    np.testing.assert_allclose(np.rad2deg(velocity), [236, 200, 286, 401, 320, 580], rtol=0, atol=1e-9)
    np.testing.assert_array_equal(effort, mti.arm_effort_estimate(mti.RX90))


def test_rx60_limits_match_their_source():
    lower, upper, velocity, _ = _limits("rx60.urdf")
    np.testing.assert_allclose(upper, [2.7925, 2.2253, 2.3474, np.deg2rad(270), 2.1031, np.deg2rad(270)], atol=1e-9)
    np.testing.assert_allclose(lower, [-2.7925, -2.2253, -2.3474, -np.deg2rad(270), -1.9111, -np.deg2rad(270)],
                               atol=1e-9)
    np.testing.assert_allclose(velocity, [5.0, 5.0, 5.5, 7.1, 5.5, 12.2], atol=1e-9)


@pytest.mark.parametrize("name, arm", [("rx90.urdf", "RX90"), ("rx60.urdf", "RX60")])
def test_arm_link_inertias_are_the_scripts(name, arm):
    spec = getattr(mti, arm)
    prefix = spec.name
    names = [f"{prefix}_base"] + [f"{prefix}_link{i}" for i in range(1, 6)] + ["flange"]
    total = 0.0
    for body, (mass, com, inertia) in zip(names, mti.arm_link_inertias(spec)):
        expected = SpatialInertia.MakeFromCentralInertia(mass, com, _rotational(inertia))
        np.testing.assert_allclose(_body_inertia(name, body).CopyToFullMatrix6(), expected.CopyToFullMatrix6(),
                                   rtol=1e-8, atol=1e-12)
        total += _body_inertia(name, body).get_mass()
    assert total == pytest.approx(spec.total_mass, rel=1e-8)


# ---------------------------------------------------------------- Phantom kinematics

L1, L2 = 0.215, 0.170  # Cavusoglu et al., Premium 1.5


def _phantom_gimbal_point(q1, q2, q3):
    """Closed form with the device's absolute distal angle theta3 = q2 + q3 (z up, x forward)."""
    theta3 = q2 + q3
    reach = L1 * np.cos(q2) + L2 * np.sin(theta3)
    return np.array([np.cos(q1) * reach, np.sin(q1) * reach, L1 * np.sin(q2) - L2 * np.cos(theta3)])


def test_phantom_stylus_position_matches_the_link_lengths():
    X = _drake_X("phantom_premium_6dof.urdf", np.zeros(6), "phantom_base", "stylus")
    np.testing.assert_allclose(X.translation(), [L1, 0.0, -L2], atol=1e-12)
    # E at q = 0: z along +x_B, y along +y_B, x along -z_B.
    np.testing.assert_allclose(X.rotation().matrix(), [[0, 0, 1], [0, 1, 0], [-1, 0, 0]], atol=1e-12)
    rng = np.random.default_rng(3)
    samples = [np.array([0.3, 0.0, 0.0, 0, 0, 0]), np.array([0.0, 0.4, -0.4, 0, 0, 0]),
               np.array([0.0, 0.0, 0.5, 1.0, -0.7, 2.0])]
    samples += [_random_q("phantom_premium_6dof.urdf", rng) for _ in range(10)]
    for q in samples:
        X = _drake_X("phantom_premium_6dof.urdf", q, "phantom_base", "stylus")
        # The gimbal axes intersect: the stylus origin does not depend on q4..q6.
        np.testing.assert_allclose(X.translation(), _phantom_gimbal_point(*q[:3]), atol=1e-12)


def test_phantom_limits_damping_and_efforts():
    lower, upper, _, effort = _limits("phantom_premium_6dof.urdf")
    assert np.all(lower < 0) and np.all(upper > 0)
    # Gimbal torques: CHAI3D's tabulated 0.188 N·m; arm joints: 8.5 N at the full arm length.
    np.testing.assert_allclose(effort[3:], 0.188)
    np.testing.assert_allclose(effort[:3], 3.27)
    root = ET.parse(models.model_path("phantom_premium_6dof.urdf")).getroot()
    for joint in root.findall("joint"):
        dynamics = joint.find("dynamics")
        # Damping only: the plant ignores URDF friction (its values are in SOURCES.md).
        assert float(dynamics.get("damping")) > 0 and dynamics.get("friction") is None
    plant, _ = _plant("phantom_premium_6dof.urdf")
    assert plant.GetJointByName("joint1").default_damping() == pytest.approx(5e-4)
    # Transmissions for all six joints, in the file itself.
    assert sorted(t.find("joint").get("name") for t in root.iter("transmission")) == [f"joint{i}" for i in range(1, 7)]


# ---------------------------------------------------------------- loads: composite inertias


def _rotational(I):
    return RotationalInertia(I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2])


def _drake_part(part) -> SpatialInertia:
    """A part's spatial inertia about its own centre, built by Drake's factories."""
    axis = {"x": [1.0, 0, 0], "y": [0, 1.0, 0], "z": [0, 0, 1.0]}[part.axis]
    if part.shape == "box":
        return (SpatialInertia.SolidBoxWithMass(part.mass_kg, *part.size) if part.mass_kg is not None
                else SpatialInertia.SolidBoxWithDensity(part.density, *part.size))
    if part.shape == "cylinder":
        return (SpatialInertia.SolidCylinderWithMass(part.mass_kg, *part.size, axis) if part.mass_kg is not None
                else SpatialInertia.SolidCylinderWithDensity(part.density, *part.size, axis))
    assert part.shape == "sphere"
    return SpatialInertia.SolidSphereWithDensity(part.density, part.size[0])


def _compose_about_origin(parts) -> SpatialInertia:
    total = SpatialInertia.Zero()
    for part in parts:
        total += _drake_part(part).Shift(-np.asarray(part.center, dtype=float))  # about the frame origin
    return total


def _compose_numpy(parts):
    """Parallel-axis theorem by hand, inertia about the frame origin."""
    m_total, first_moment, inertia = 0.0, np.zeros(3), np.zeros((3, 3))
    for part in parts:
        m = part.mass_kg if part.mass_kg is not None else part.density * part.volume
        c = np.asarray(part.center, dtype=float)
        if part.shape == "box":
            a, b, h = part.size
            Ic = m / 12 * np.diag([b * b + h * h, a * a + h * h, a * a + b * b])
        elif part.shape == "cylinder":
            r, length = part.size
            Ic = np.diag([m * (3 * r * r + length * length) / 12] * 2 + [m * r * r / 2])
        else:
            Ic = 0.4 * m * part.size[0] ** 2 * np.eye(3)
        m_total += m
        first_moment += m * c
        inertia += Ic + m * (c @ c * np.eye(3) - np.outer(c, c))
    return m_total, first_moment / m_total, inertia


def test_tool_weighs_3_13_kg_and_its_inertia_is_the_sum_of_its_parts():
    parts = mti.tool_parts()
    assert [p.name for p in parts] == ["adapter", "cuboid", "rod", "ball"]
    assert {p.name: p.density for p in parts} == {"adapter": 2700.0, "cuboid": 7850.0, "rod": 2700.0, "ball": 7850.0}
    M = _body_inertia("tool.urdf", "tool")
    assert M.get_mass() == pytest.approx(3.13, abs=1e-9)
    np.testing.assert_allclose(M.CopyToFullMatrix6(), _compose_about_origin(parts).CopyToFullMatrix6(),
                               rtol=1e-8, atol=1e-11)
    mass, com, I_origin = _compose_numpy(parts)
    assert mass == pytest.approx(3.13, abs=1e-12)
    np.testing.assert_allclose(M.get_com(), com, atol=1e-9)
    np.testing.assert_allclose(M.CalcRotationalInertia().CopyToFullMatrix3(), I_origin, rtol=1e-8, atol=1e-11)
    # Parts stack from the sensor's tool face (17.5 mm past S) without gaps.
    assert parts[0].center[2] - parts[0].size[1] / 2 == pytest.approx(0.0175)


def test_tool_tip_is_the_ball_centre_and_the_ball_collides():
    plant, _ = _plant("tool.urdf")
    tip = plant.GetFrameByName("tool_tip")
    assert tip.body().name() == "tool"
    ball = mti.tool_parts()[-1]
    np.testing.assert_allclose(tip.GetFixedPoseInBodyFrame().translation(), ball.center, atol=1e-9)
    assert tip.GetFixedPoseInBodyFrame().rotation().IsExactlyIdentity()
    tool = plant.GetBodyByName("tool")
    geometries = plant.GetCollisionGeometriesForBody(tool)
    assert len(geometries) == 1
    root = ET.parse(models.model_path("tool.urdf")).getroot()
    sphere = root.find("./link[@name='tool']/collision/geometry/sphere")
    assert float(sphere.get("radius")) == pytest.approx(ball.size[0])


def test_gripper_and_object_inertias_and_their_sum():
    g_parts, o_parts = mti.gripper_parts(), mti.object_parts()
    Mg, Mo = _body_inertia("gripper_object.urdf", "gripper"), _body_inertia("gripper_object.urdf", "object")
    np.testing.assert_allclose(Mg.CopyToFullMatrix6(), _compose_about_origin(g_parts).CopyToFullMatrix6(),
                               rtol=1e-8, atol=1e-11)
    np.testing.assert_allclose(Mo.CopyToFullMatrix6(), _compose_about_origin(o_parts).CopyToFullMatrix6(),
                               rtol=1e-8, atol=1e-11)
    # Both frames sit at S, so the whole load about S is the plain sum (Eq. 14's split).
    mass, com, I_origin = _compose_numpy(g_parts + o_parts)
    total = SpatialInertia.Zero()
    total += Mg
    total += Mo
    assert total.get_mass() == pytest.approx(mass, rel=1e-8)
    np.testing.assert_allclose(total.get_com(), com, atol=1e-9)
    np.testing.assert_allclose(total.CalcRotationalInertia().CopyToFullMatrix3(), I_origin, rtol=1e-8, atol=1e-11)
    # The object sits where the gripper's grasp_center frame says, between the fingers.
    plant, _ = _plant("gripper_object.urdf")
    np.testing.assert_allclose(plant.GetFrameByName("grasp_center").GetFixedPoseInBodyFrame().translation(),
                               Mo.get_com(), atol=1e-9)
    fingers = [p for p in g_parts if p.name.startswith("finger")]
    gap = fingers[1].center[0] - fingers[0].center[0] - fingers[0].size[0]
    assert gap == pytest.approx(o_parts[0].size[0])


def test_script_agrees_with_drake_factories_for_single_solids():
    # The script's own primitive formulas against Drake's, about each solid's centre.
    solids = [mti.Solid("b", "box", (0.1, 0.2, 0.3), (0, 0, 0), density=7850.0),
              mti.Solid("cx", "cylinder", (0.05, 0.4), (0, 0, 0), density=2700.0, axis="x"),
              mti.Solid("cy", "cylinder", (0.05, 0.4), (0, 0, 0), density=2700.0, axis="y"),
              mti.Solid("cz", "cylinder", (0.05, 0.4), (0, 0, 0), density=2700.0, axis="z"),
              mti.Solid("s", "sphere", (0.03,), (0, 0, 0), density=7850.0)]
    for s in solids:
        np.testing.assert_allclose(s.central_inertia(),
                                   _drake_part(s).CalcRotationalInertia().CopyToFullMatrix3(), rtol=1e-12)


def test_phantom_link_inertias_are_the_scripts():
    for body, (mass, com, inertia) in mti.phantom_links().items():
        expected = SpatialInertia.MakeFromCentralInertia(mass, com, _rotational(inertia))
        np.testing.assert_allclose(_body_inertia("phantom_premium_6dof.urdf", body).CopyToFullMatrix6(),
                                   expected.CopyToFullMatrix6(), rtol=1e-8, atol=1e-12)


# ---------------------------------------------------------------- assembly, as the builder will weld it


def test_assembled_slave_holds_the_tool_and_the_sensor_feels_its_weight():
    """rx90 + jr3_sensor + tool welded with identities (flange→jr3_sensor, S→tool), held still by
    gravity-compensating torques: the weld reaction on the tool at S is exactly the tool's
    weight acting at its COM, and tool_tip sits where the DH table plus the offsets put it."""
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlantSceneGraph(builder, time_step=0.0)
    parser = Parser(plant)
    parser.AddModels(models.model_path("rx90.urdf"))
    parser.AddModels(models.model_path("jr3_sensor.urdf"))
    parser.AddModels(models.model_path("tool.urdf"))
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("rx90_base"))
    plant.WeldFrames(plant.GetFrameByName("flange"), plant.GetBodyByName("jr3_sensor").body_frame())
    weld = plant.WeldFrames(plant.GetFrameByName("S"), plant.GetBodyByName("tool").body_frame())
    plant.Finalize()
    assert plant.num_positions() == 6
    diagram = builder.Build()
    context = plant.GetMyMutableContextFromRoot(diagram.CreateDefaultContext())
    tool = _body_inertia("tool.urdf", "tool")
    m, c = tool.get_mass(), tool.get_com()
    g = plant.gravity_field().gravity_vector()
    B = plant.MakeActuationMatrix()
    for q in (np.zeros(6), np.array([0.3, 0.7, -0.4, 1.1, 1.2, -0.8])):
        plant.SetPositions(context, q)
        u = np.linalg.solve(B, -plant.CalcGravityGeneralizedForces(context))
        plant.get_actuation_input_port().FixValue(context, u)
        np.testing.assert_allclose(plant.get_generalized_acceleration_output_port().Eval(context), 0, atol=1e-9)
        F = plant.get_reaction_forces_output_port().Eval(context)[int(weld.index())]  # on tool, at S, in tool frame
        R_WT = plant.GetBodyByName("tool").EvalPoseInWorld(context).rotation()
        f_expected = -(R_WT.inverse() @ (m * g))  # the sensor holds the tool up
        np.testing.assert_allclose(F.translational(), f_expected, atol=1e-9)
        np.testing.assert_allclose(F.rotational(), np.cross(c, f_expected), atol=1e-9)
        # tool_tip in R from the DH table, then F→sensor face (identity), S (+17.5 mm), ball centre.
        X_RF = _dh_fk(DH_TABLES["rx90.urdf"], q)
        p_tip = X_RF @ np.append(np.array([0, 0, 0.0175]) + mti.tool_tip(), 1.0)
        X = plant.CalcRelativeTransform(context, plant.GetFrameByName("rx90_base"), plant.GetFrameByName("tool_tip"))
        np.testing.assert_allclose(X.translation(), p_tip[:3], atol=1e-9)


def test_gripper_object_welds_to_the_bare_sensor():
    """rx90 + jr3_sensor + gripper_object welded as the builder does (flange→jr3_sensor, S→gripper,
    gripper→object, all identities): a valid assembly with only the arm's six dof, the object at
    grasp_center, and the weld at S carrying exactly the weight of gripper and object together."""
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlantSceneGraph(builder, time_step=0.0)
    parser = Parser(plant)
    parser.AddModels(models.model_path("rx90.urdf"))
    parser.AddModels(models.model_path("jr3_sensor.urdf"))
    parser.AddModels(models.model_path("gripper_object.urdf"))
    gripper, obj = plant.GetBodyByName("gripper"), plant.GetBodyByName("object")
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("rx90_base"))
    plant.WeldFrames(plant.GetFrameByName("flange"), plant.GetBodyByName("jr3_sensor").body_frame())
    weld = plant.WeldFrames(plant.GetFrameByName("S"), gripper.body_frame())
    plant.WeldFrames(gripper.body_frame(), obj.body_frame())
    plant.Finalize()
    assert plant.num_positions() == 6 and plant.num_velocities() == 6
    diagram = builder.Build()
    context = plant.GetMyMutableContextFromRoot(diagram.CreateDefaultContext())
    mass, com, _ = _compose_numpy(mti.gripper_parts() + mti.object_parts())
    g = plant.gravity_field().gravity_vector()
    B = plant.MakeActuationMatrix()
    S = plant.GetFrameByName("S")
    for q in (np.zeros(6), np.array([-0.5, 0.4, 0.9, -1.3, 0.6, 2.0])):
        plant.SetPositions(context, q)
        # The load about S, from the assembled plant, is the parts' composite.
        M = plant.CalcSpatialInertia(context, S, [gripper.index(), obj.index()])
        assert M.get_mass() == pytest.approx(mass, rel=1e-8) and M.IsPhysicallyValid()
        np.testing.assert_allclose(M.get_com(), com, atol=1e-9)
        # The object's centre sits at the gripper's grasp_center.
        p_obj = obj.EvalPoseInWorld(context).multiply(obj.default_com())
        p_grasp = plant.GetFrameByName("grasp_center").CalcPoseInWorld(context).translation()
        np.testing.assert_allclose(p_obj, p_grasp, atol=1e-9)
        u = np.linalg.solve(B, -plant.CalcGravityGeneralizedForces(context))
        plant.get_actuation_input_port().FixValue(context, u)
        np.testing.assert_allclose(plant.get_generalized_acceleration_output_port().Eval(context), 0, atol=1e-9)
        F = plant.get_reaction_forces_output_port().Eval(context)[int(weld.index())]  # on gripper, at S
        R_WG = gripper.EvalPoseInWorld(context).rotation()
        f_expected = -(R_WG.inverse() @ (mass * g))
        np.testing.assert_allclose(F.translational(), f_expected, atol=1e-9)
        np.testing.assert_allclose(F.rotational(), np.cross(com, f_expected), atol=1e-9)
