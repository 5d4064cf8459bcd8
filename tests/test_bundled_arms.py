"""The bundled UR5e and LBR iiwa 14 (diagrams/models/ur5e.urdf, iiwa14.urdf) against their published
numbers: Drake parses them, the flange's pose is the published DH tables' product (typed in again
here, standard DH), the masses sum to the arms' weights, the limits are the data sheets'."""

from __future__ import annotations

import importlib.util
import logging
import sys
from functools import cache
from pathlib import Path

import numpy as np
import pytest
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant

MODELS = Path(__file__).resolve().parents[1] / "diagrams" / "models"
H = np.pi / 2


def _load_module(name: str, path: Path):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # dataclasses look their module up here
    spec.loader.exec_module(module)
    return module


make = _load_module("heft_make_arm_models", MODELS / "make_arm_models.py")

# Standard DH rows (d, a, α), θ = q: UR's table for the UR5e; the iiwa 14's link lengths
# 360 / 420 / 400 / 126 mm with its alternating twists.
DH = {
    "ur5e": [(0.1625, 0, H), (0, -0.425, 0), (0, -0.3922, 0), (0.1333, 0, H), (0.0997, 0, -H), (0.0996, 0, 0)],
    "iiwa14": [(0.36, 0, -H), (0, 0, H), (0.42, 0, H), (0, 0, -H), (0.40, 0, -H), (0, 0, H), (0.126, 0, 0)],
}
WEIGHTS = {"ur5e": 20.6, "iiwa14": 29.9}  # kg, the data sheets'


def _sdh(theta, d, a, alpha):
    """Standard DH link transform Rz(θ) Tz(d) Tx(a) Rx(α)."""
    ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
    return np.array([[ct, -st * ca, st * sa, a * ct], [st, ct * ca, -ct * sa, a * st], [0, sa, ca, d], [0, 0, 0, 1]])


def _dh_fk(rows, q):
    T = np.eye(4)
    for (d, a, alpha), qi in zip(rows, q):
        T = T @ _sdh(qi, d, a, alpha)
    return T


@cache
def _plant(arm: str):
    plant = MultibodyPlant(time_step=0.0)
    Parser(plant).AddModels(str(MODELS / f"{arm}.urdf"))
    plant.Finalize()
    return plant, plant.CreateDefaultContext()


def _joints(arm: str):
    plant, _ = _plant(arm)
    return [plant.GetJointByName(f"joint{i + 1}") for i in range(len(DH[arm]))]


@pytest.mark.parametrize("arm", ["ur5e", "iiwa14"])
def test_the_files_are_what_the_script_writes(arm):
    assert (MODELS / f"{arm}.urdf").read_text() == make.urdf(make.ARMS[f"{arm}.urdf"]())


@pytest.mark.parametrize("arm", ["ur5e", "iiwa14"])
def test_parses_without_warnings_as_a_chain_from_base_to_flange(arm, caplog):
    with caplog.at_level(logging.DEBUG, logger="drake"):
        plant = MultibodyPlant(time_step=0.0)
        Parser(plant).AddModels(str(MODELS / f"{arm}.urdf"))
    assert [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING] == []
    joints = _joints(arm)
    assert all(j.type_name() == "revolute" for j in joints)
    assert joints[0].parent_body().name() == f"{arm}_base" and joints[-1].child_body().name() == "flange"
    for before, after in zip(joints, joints[1:]):
        assert after.parent_body().index() == before.child_body().index()
    plant, _ = _plant(arm)
    assert [plant.GetJointActuatorByName(f"{j.name()}_motor").joint().name() for j in joints] == [
        j.name() for j in joints]


@pytest.mark.parametrize("arm", ["ur5e", "iiwa14"])
def test_forward_kinematics_is_the_dh_product(arm):
    plant, context = _plant(arm)
    joints = _joints(arm)
    rng = np.random.default_rng(11)
    n = len(joints)
    postures = [np.zeros(n), np.full(n, 0.5), np.array([(-1) ** i * 1.2 for i in range(n)])]
    postures += [rng.uniform(-np.pi, np.pi, n) for _ in range(10)]
    for q in postures:
        for joint, angle in zip(joints, q):
            joint.set_angle(context, angle)
        X = plant.CalcRelativeTransform(context, plant.GetFrameByName(f"{arm}_base"), plant.GetFrameByName("flange"))
        np.testing.assert_allclose(X.GetAsMatrix4(), _dh_fk(DH[arm], q), atol=1e-12)


def test_known_postures():
    # UR5e at q = 0: stretched along −x at the shoulder's height; the wrist's offsets in y and z.
    plant, context = _plant("ur5e")
    for joint in _joints("ur5e"):
        joint.set_angle(context, 0.0)
    X = plant.CalcRelativeTransform(context, plant.GetFrameByName("ur5e_base"), plant.GetFrameByName("flange"))
    np.testing.assert_allclose(X.translation(), [-0.425 - 0.3922, -0.1333 - 0.0996, 0.1625 - 0.0997], atol=1e-12)
    # iiwa 14 at q = 0: straight up, 1.306 m, F parallel to R.
    plant, context = _plant("iiwa14")
    for joint in _joints("iiwa14"):
        joint.set_angle(context, 0.0)
    X = plant.CalcRelativeTransform(context, plant.GetFrameByName("iiwa14_base"), plant.GetFrameByName("flange"))
    np.testing.assert_allclose(X.GetAsMatrix4(), np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 1.306], [0, 0, 0, 1]]),
                               atol=1e-12)


@pytest.mark.parametrize("arm", ["ur5e", "iiwa14"])
def test_masses_sum_to_the_weight_and_every_inertia_is_physical(arm):
    plant, _ = _plant(arm)
    bodies = [plant.get_body(b) for b in plant.GetBodyIndices(plant.GetModelInstanceByName(arm))]
    assert sum(b.default_mass() for b in bodies) == pytest.approx(WEIGHTS[arm], abs=1e-12)
    for body in bodies:
        assert body.default_mass() > 0 and body.default_spatial_inertia().IsPhysicallyValid(), body.name()


def test_ur5e_link_masses_and_centres_of_mass_are_urs():
    # UR's table: links 1–6 and their COMs in UR's DH frame i (the flange is frame 6).
    plant, context = _plant("ur5e")
    masses = [3.761, 8.058, 2.846, 1.37, 1.3, 0.365]
    coms = [(0, -0.02561, 0.00193), (0.2125, 0, 0.11336), (0.15, 0, 0.0265), (0, -0.0018, 0.01634),
            (0, 0.0018, 0.01634), (0, 0, -0.001159)]
    joints = _joints("ur5e")
    q = np.array([0.3, -0.7, 1.1, -0.4, 0.9, 1.3])
    for joint, angle in zip(joints, q):
        joint.set_angle(context, angle)
    base = plant.GetFrameByName("ur5e_base")
    for i, joint in enumerate(joints):
        body = joint.child_body()
        assert body.default_mass() == pytest.approx(masses[i], abs=1e-12)
        p_RC = plant.CalcRelativeTransform(context, base, body.body_frame()) @ body.default_com()
        T = _dh_fk(DH["ur5e"][:i + 1], q[:i + 1])  # UR's DH frame i in R
        np.testing.assert_allclose(p_RC, T[:3, :3] @ coms[i] + T[:3, 3], atol=1e-12)


def _limits(arm):
    plant, _ = _plant(arm)
    joints = _joints(arm)
    return (np.array([j.position_lower_limits()[0] for j in joints]),
            np.array([j.position_upper_limits()[0] for j in joints]),
            np.array([j.velocity_upper_limits()[0] for j in joints]),
            np.array([plant.GetJointActuatorByName(f"{j.name()}_motor").effort_limit() for j in joints]))


def test_limits_are_the_data_sheets():
    lower, upper, velocity, effort = _limits("ur5e")
    np.testing.assert_allclose(np.degrees(upper), [360] * 6, atol=1e-12)
    np.testing.assert_allclose(lower, -upper)
    np.testing.assert_allclose(np.degrees(velocity), [180] * 6, atol=1e-12)
    np.testing.assert_array_equal(effort, [150, 150, 150, 28, 28, 28])
    lower, upper, velocity, effort = _limits("iiwa14")
    np.testing.assert_allclose(np.degrees(upper), [170, 120, 170, 120, 170, 120, 175], atol=1e-12)
    np.testing.assert_allclose(lower, -upper)
    np.testing.assert_allclose(np.degrees(velocity), [85, 85, 100, 75, 130, 135, 135], atol=1e-12)
    np.testing.assert_array_equal(effort, [320, 320, 176, 176, 110, 40, 40])
