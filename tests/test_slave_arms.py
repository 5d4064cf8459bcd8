"""The bundled UR5e and LBR iiwa 14 as the slave: a scenario names them (and brings their start posture,
servo gains and motion scale), the station simulates them with the JR3, the mount and the load, the
controller reads their kinematics and commands them through the chain inverse kinematics, each against
Drake's own kinematics of the same plant; in simulation heft identifies the paper's tool on them and
eliminates fig6's non-contact force (slow)."""

from __future__ import annotations

import numpy as np
import pytest
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.analysis import Simulator

from heft.diagrams.arm_params import BUNDLED_ARMS, SERVO_FREQUENCY
from heft.diagrams.plants import AddArmWithSensor, MakeSlavePlant
from heft.diagrams.scenario import Scenario, layered, resolve_scenario
from heft.diagrams.stations.sim_station import MakeSimStation
from heft.diagrams.stations.slave_servo import slave_servo_gains
from heft.diagrams.teleop import MakeTeleopController
from heft.diagrams.load_estimate import LoadEstimate
from heft.systems.controller.chain_inverse_kinematics import ChainIk, ChainInverseKinematics
from heft.systems.controller.slave_inverse_kinematics import SlaveInverseKinematics
from heft.systems.pose_vectors import pose_vector

ARMS = ("ur5e", "iiwa14")
PERIOD = 0.0005  # s, the controller's


def test_a_robot_laid_over_a_scenario_brings_its_own_start_and_gains_unless_stated():
    fig6 = resolve_scenario("fig6")
    for arm in ARMS:
        on_arm = layered(fig6, f"{{robot: {arm}}}")
        assert on_arm.slave_initial_q == list(BUNDLED_ARMS[arm].start)
        assert on_arm.slave_servo_stiffness == []  # rings at SERVO_FREQUENCY
        assert on_arm.controller.motion.translation_scale == BUNDLED_ARMS[arm].translation_scale
        stated = layered(fig6, f"{{robot: {arm}, controller: {{motion: {{translation_scale: 1.5}}}}}}")
        assert stated.controller.motion.translation_scale == 1.5
    back = layered(layered(fig6, "{robot: iiwa14}"), "{robot: rx90}")
    assert back.slave_initial_q == fig6.slave_initial_q and back.slave_servo_stiffness == fig6.slave_servo_stiffness
    assert layered(fig6, "{duration: 1}").controller.motion.translation_scale == 2.0  # no robot: nothing changes
    with pytest.raises(ValueError, match="'slave_initial_q' needs 7 joint angles"):
        layered(fig6, "{robot: iiwa14, slave_initial_q: [0, 0, 0, 0, 0, 0]}")
    with pytest.raises(ValueError, match="'robot' must be one of rx90, rx60, ur5e, iiwa14, custom"):
        layered(fig6, "{robot: ur10}")


def test_a_start_posture_outside_the_limits_is_refused_naming_the_joint():
    scenario = layered(Scenario(), "{robot: iiwa14, slave_initial_q: [0, 0, 0, -2.2, 0, 0, 0]}")
    with pytest.raises(ValueError, match=r"joint 4 at -2.2 outside \[-2.0944, 2.0944\]"):
        MakeSlavePlant(scenario)


@pytest.mark.parametrize("arm", ARMS)
def test_the_start_holds_S_where_the_rx90s_start_does(arm):
    """The bundled experiments' environment (fig8's sheet) is placed for the RX90's start: every arm's puts S
    at the same pose."""
    def X_RS(scenario):
        plant, parts = MakeSlavePlant(scenario)
        context = plant.CreateDefaultContext()
        plant.SetPositions(context, scenario.slave_initial_q)
        return parts.S.CalcPoseInWorld(context)
    reference = X_RS(Scenario())
    X = X_RS(layered(Scenario(), f"{{robot: {arm}}}"))
    assert np.abs(X.translation() - reference.translation()).max() < 2e-3
    assert np.abs(X.rotation().matrix() - reference.rotation().matrix()).max() < 5e-3


@pytest.mark.parametrize("arm", ARMS)
def test_the_servo_rings_at_its_frequency_and_the_station_has_a_port_per_joint(arm):
    scenario = layered(resolve_scenario("fig6"), f"{{robot: {arm}}}")
    kp, kd, M = slave_servo_gains(scenario)
    np.testing.assert_allclose(np.sqrt(kp / np.diag(M)) / (2 * np.pi), SERVO_FREQUENCY, rtol=1e-12)
    n = len(BUNDLED_ARMS[arm].start)
    station = MakeSimStation(scenario)
    for name in ("slave.position_commanded",):
        assert station.GetInputPort(name).size() == n
    for name in ("slave.position_measured", "slave.velocity_estimated", "truth.slave_position"):
        assert station.GetOutputPort(name).size() == n


@pytest.mark.parametrize("arm", ARMS)
def test_the_controller_commands_the_arm_through_the_chain_ik(arm):
    scenario = layered(resolve_scenario("fig6"), f"{{robot: {arm}}}")
    controller = MakeTeleopController(scenario.controller, LoadEstimate(np.zeros(10), np.zeros(6)), arm, PERIOD,
                                      scenario.slave_initial_q, accelerometer=scenario.accelerometer.convention())
    ik = controller.GetSubsystemByName("slave_ik")
    assert isinstance(ik, ChainInverseKinematics)
    n = len(BUNDLED_ARMS[arm].start)
    assert controller.GetInputPort("slave.position_measured").size() == n
    assert controller.GetOutputPort("slave.position_commanded").size() == n
    rx = MakeTeleopController(scenario.controller, LoadEstimate(np.zeros(10), np.zeros(6)), "rx90", PERIOD,
                              Scenario().slave_initial_q, accelerometer=scenario.accelerometer.convention())
    assert isinstance(rx.GetSubsystemByName("slave_ik"), SlaveInverseKinematics)  # the RX keeps its closed form


@pytest.mark.parametrize("arm", ARMS)
def test_the_ik_block_follows_a_path_of_S_as_drake_poses_it(arm):
    """The block's commands, put through Drake's kinematics of arm + JR3, reach S's path: poses Drake computed
    along a sine of 2.5 Hz in joint space, each a tick on."""
    plant = MultibodyPlant(time_step=0.0)
    chain, _, S = AddArmWithSensor(plant, arm)
    plant.Finalize()
    context = plant.CreateDefaultContext()
    q0 = np.array(BUNDLED_ARMS[arm].start)
    block = ChainInverseKinematics(ChainIk(plant, chain.base, S, q0), PERIOD)
    simulator = Simulator(block)
    block_context = simulator.get_mutable_context()
    block.GetInputPort("position_measured").FixValue(block_context, q0)
    block.GetInputPort("pose_desired").FixValue(block_context, np.full(7, np.nan))
    simulator.Initialize()
    direction = np.random.default_rng(3).normal(size=len(q0)) * 0.02  # within the speed limits
    worst = 0.0
    for k in range(1, 400):
        q = q0 + direction * np.sin(2 * np.pi * 2.5 * k * PERIOD)
        plant.SetPositions(context, q)
        X_RS = plant.CalcRelativeTransform(context, chain.base, S)
        block.GetInputPort("pose_desired").FixValue(block_context, pose_vector(X_RS))
        simulator.AdvanceTo((k + 0.5) * PERIOD)  # the tick at k·PERIOD
        plant.SetPositions(context, block.GetOutputPort("position_commanded").Eval(block_context))
        reached = plant.CalcRelativeTransform(context, chain.base, S)
        worst = max(worst, np.abs(reached.translation() - X_RS.translation()).max(),
                    np.abs(reached.rotation().matrix() - X_RS.rotation().matrix()).max())
        assert block.GetOutputPort("status").Eval(block_context)[0] == 1.0
        assert block.GetOutputPort("slewing").Eval(block_context)[0] == 0.0
    assert worst < 1e-9


@pytest.mark.slow
@pytest.mark.parametrize("arm", ARMS)
def test_fig6_on_the_arm_identifies_the_tool_and_eliminates_its_non_contact_force(arm, tmp_path):
    """As ``heft simulate fig6 --sigma 0 --set '{robot: ARM}'``: the paper's tool identified in simulation
    within 1 g, 1 mm and 1 % of I_S of the plant's truth, then fig6 with σ = 0 leaves at most 2 % of the
    non-contact peak (the plant's truth) fed back."""
    from heft.analysis.experiment_metrics import experiment_metrics
    from heft.diagrams.identify import identify
    from heft.diagrams.load_estimate import read_load_estimate
    from heft.diagrams.running.sim_identification import simulated_recorder
    from heft.diagrams.running.simulation import run_teleop, with_sigma
    scenario = layered(resolve_scenario("fig6"), f"{{robot: {arm}}}")
    metrics = identify(scenario, tmp_path, simulated_recorder(scenario))
    error = metrics["errors"]["tls"]
    assert error["mass_kg"] < 1e-3 and error["com_m"] < 1e-3 and error["inertia_relative"] < 0.01
    load = read_load_estimate(tmp_path / "estimate.yaml")
    run = run_teleop(with_sigma(scenario, 0.0), load, quiet=True)
    assert np.abs(np.diff(run["slave_q"], axis=0)).max() > 0  # the arm moved
    result = experiment_metrics("fig6", {0.0: run}, scenario.controller.feedback.force_scale)
    assert result["noncontact_peak_N"] > 40 and result["residual_ratio"] <= 0.02
