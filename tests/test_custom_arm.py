"""A lab's own arm as the slave (``robot: custom`` with an ``arm`` section): a 7-joint URDF written in a layout
heft did not choose (tests/foreign_arm.py: the Panda's kinematics in franka_description's names, no
transmissions, S turned on the flange) is read from the scenario's folder, simulated, read by the
controller's kinematics as Drake poses it and driven through the chain inverse kinematics; a URDF lacking
what heft needs is refused in one line by ``heft``; in simulation heft identifies the paper's tool on it and
eliminates fig6's non-contact force (slow)."""

from __future__ import annotations

import numpy as np
import pytest
from pydrake.math import RigidTransform, RollPitchYaw

from heft.diagrams.cli import main
from heft.diagrams.load_estimate import LoadEstimate
from heft.diagrams.plants import MakeSlavePlant, slave_arm
from heft.diagrams.scenario import load_scenario, resolve_scenario
from heft.diagrams.stations.sim_station import MakeSimStation
from heft.diagrams.teleop import MakeTeleopController
from heft.diagrams.urdf_arm import ArmRefused
from heft.systems.controller.chain_inverse_kinematics import ChainInverseKinematics
from heft.systems.pose_vectors import rigid_transform

from foreign_arm import START, custom_scenario_text, panda_urdf

PERIOD = 0.0005  # s


def _lab(tmp_path, drop="", extra=""):
    """A lab folder: the arm's URDF in arms/, the scenario (fig6's motion on the arm) beside it, naming it
    relative to itself."""
    (tmp_path / "arms").mkdir(exist_ok=True)
    (tmp_path / "arms" / "panda.urdf").write_text(panda_urdf(drop))
    operator = resolve_scenario("fig6").operator
    text = custom_scenario_text("arms/panda.urdf", extra + "experiment: fig6\nenvironment: {kind: none}\n"
                                f"operator: {{stiffness: {operator.stiffness}, damping: {operator.damping}, "
                                f"amplitude: {operator.amplitude}, frequency: {operator.frequency}}}\n")
    path = tmp_path / "lab.yaml"
    path.write_text(text)
    return path


def test_the_urdf_is_taken_from_the_scenarios_folder_and_s_sits_at_x_fs(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path.parent)  # not the scenario's folder
    scenario = load_scenario(_lab(tmp_path))
    assert scenario.arm.urdf == str(tmp_path / "arms" / "panda.urdf")
    plant, parts = MakeSlavePlant(scenario)
    assert [j.name() for j in parts.chain.joints] == [f"panda_joint{i}" for i in range(1, 8)]
    assert [a.joint().name() for a in parts.chain.actuators] == [j.name() for j in parts.chain.joints]
    context = plant.CreateDefaultContext()
    X_FS = plant.CalcRelativeTransform(context, plant.GetFrameByName("panda_link8"), parts.S)
    assert X_FS.IsNearlyEqualTo(RigidTransform(RollPitchYaw(0, 0, -np.pi / 4), [0, 0, 0.0175]), 1e-12)
    plant.SetPositions(context, START)
    X_RS = parts.S.CalcPoseInWorld(context)
    np.testing.assert_allclose(X_RS.translation(), [0.5515, 0.0, 0.4126], atol=1e-4)
    np.testing.assert_allclose(X_RS.rotation().matrix(), np.diag([1.0, -1.0, -1.0]), atol=1e-4)


def test_the_controller_reads_and_drives_the_arm_as_drake_poses_it(tmp_path):
    scenario = load_scenario(_lab(tmp_path))
    controller = MakeTeleopController(scenario.controller, LoadEstimate(np.zeros(10), np.zeros(6)),
                                      slave_arm(scenario), PERIOD, scenario.slave_initial_q,
                                      accelerometer=scenario.accelerometer.convention())
    assert isinstance(controller.GetSubsystemByName("slave_ik"), ChainInverseKinematics)
    kinematics = controller.GetSubsystemByName("slave_kinematics")
    context = kinematics.CreateDefaultContext()
    plant, parts = MakeSlavePlant(scenario)
    reference = plant.CreateDefaultContext()
    rng = np.random.default_rng(5)
    for _ in range(20):
        q = rng.uniform(parts.chain.lower, parts.chain.upper)
        kinematics.GetInputPort("position").FixValue(context, q)
        plant.SetPositions(reference, q)
        X = plant.CalcRelativeTransform(reference, parts.chain.base, parts.S)
        np.testing.assert_allclose(rigid_transform(kinematics.GetOutputPort("pose_RS").Eval(context)).GetAsMatrix4(),
                                   X.GetAsMatrix4(), atol=1e-12)
    station = MakeSimStation(scenario)
    assert station.GetInputPort("slave.position_commanded").size() == 7


@pytest.mark.parametrize("drop, words", [("inertial", ["panda_link4", "panda_joint4", "<inertial>"]),
                                         ("limit", ["panda_joint3", "no velocity"])])
def test_a_urdf_lacking_what_heft_needs_is_refused_in_one_line(tmp_path, capsys, drop, words):
    path = _lab(tmp_path, drop)
    with pytest.raises(ArmRefused):
        MakeSlavePlant(load_scenario(path))
    assert main(["simulate", str(path), "--sigma", "0", "--duration", "0.1", "--out", str(tmp_path / "out")]) == 2
    lines = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert len(lines) == 1 and "Traceback" not in lines[0] and str(tmp_path / "arms" / "panda.urdf") in lines[0]
    for word in words:
        assert word in lines[0], lines[0]


def test_a_custom_arm_needs_its_section_and_its_start(tmp_path):
    with pytest.raises(ValueError, match="'arm.urdf' must name a URDF file"):
        resolve_scenario("fig6", "{robot: custom}")
    path = _lab(tmp_path)
    path.write_text(path.read_text().replace(f"slave_initial_q: {START}\n", ""))
    with pytest.raises(ValueError, match="'slave_initial_q' needs the custom arm's start posture"):
        load_scenario(path)
    with pytest.raises(ValueError, match="'arm' describes a custom arm"):
        resolve_scenario("fig6", "{arm: {urdf: a.urdf, base: b, flange: f}}")


@pytest.mark.slow
def test_fig6_on_the_arm_identifies_the_tool_and_eliminates_its_non_contact_force(tmp_path):
    """As ``heft simulate lab.yaml --sigma 0`` with the lab's motion scale of 1 (the Panda's joints are slower
    than the RX90's): the paper's tool identified within 1 g, 1 mm and 1 % of I_S, and at most 2 % of the
    non-contact peak fed back."""
    from heft.analysis.experiment_metrics import experiment_metrics
    from heft.diagrams.identify import identify
    from heft.diagrams.load_estimate import read_load_estimate
    from heft.diagrams.running.sim_identification import simulated_recorder
    from heft.diagrams.running.simulation import run_teleop, with_sigma
    scenario = load_scenario(_lab(tmp_path, extra="controller: {motion: {translation_scale: 1.0}}\n"))
    metrics = identify(scenario, tmp_path / "identify", simulated_recorder(scenario))
    error = metrics["errors"]["tls"]
    assert error["mass_kg"] < 1e-3 and error["com_m"] < 1e-3 and error["inertia_relative"] < 0.01
    run = run_teleop(with_sigma(scenario, 0.0), read_load_estimate(tmp_path / "identify" / "estimate.yaml"),
                     quiet=True)
    result = experiment_metrics("fig6", {0.0: run}, scenario.controller.feedback.force_scale)
    assert result["noncontact_peak_N"] > 40 and result["residual_ratio"] <= 0.02
