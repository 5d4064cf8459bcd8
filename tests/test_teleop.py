"""The closed bilateral loop: wiring, and the physics the operator feels."""

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from heft.diagrams.scenario import Scenario
from heft.diagrams.stations.sim_station import MakeSimStation
from heft.diagrams.scenario import IDEAL_STATION, NOISE_OFF, layered, overrides_text, resolve_scenario
from heft.diagrams.running.simulation import run_teleop, with_sigma
from heft.diagrams.load_estimate import LoadEstimate
from heft.diagrams.teleop import STATION_INPUTS_DRIVEN, STATION_OUTPUTS_READ, MakeTeleopController
from heft.diagrams.teleop_simulation import MakeTeleopSimulation
from heft.systems.accelerometer_reading import AT_S


def true_load(scenario: Scenario) -> LoadEstimate:
    station = MakeSimStation(scenario)
    phi = station.GetOutputPort("truth.phi").Eval(station.CreateDefaultContext())
    offsets = np.array(scenario.ft_sensor.initial_offsets) if scenario.ft_sensor.noise else np.zeros(6)
    return LoadEstimate(phi=np.array(phi), offsets=offsets)


def quiet_scenario(overrides: dict | None = None) -> Scenario:
    """The ideal station (``IDEAL_STATION``), noise-free sensors, free space, a hand at rest; then
    ``overrides`` (dotted fields) laid over it."""
    quiet = layered(Scenario(), overrides_text({**NOISE_OFF, **IDEAL_STATION, "environment.kind": "none",
                                                "operator.amplitude": [0.0, 0.0, 0.0]}))
    return layered(quiet, overrides_text(overrides)) if overrides else quiet


def test_controller_ports_are_the_station_ports_and_it_adds_no_feedthrough():
    scenario = quiet_scenario()
    controller = MakeTeleopController(scenario.controller, true_load(scenario), "rx90",
                                      scenario.controller_period, scenario.slave_initial_q,
                                      accelerometer=AT_S)
    inputs = {controller.get_input_port(i).get_name() for i in range(controller.num_input_ports())}
    outputs = {controller.get_output_port(i).get_name() for i in range(controller.num_output_ports())}
    assert set(STATION_OUTPUTS_READ) <= inputs and set(STATION_INPUTS_DRIVEN) <= outputs
    for name_in in STATION_OUTPUTS_READ:
        for name_out in STATION_INPUTS_DRIVEN:
            assert not controller.HasDirectFeedthrough(controller.GetInputPort(name_in).get_index(),
                                                       controller.GetOutputPort(name_out).get_index())


@pytest.mark.parametrize("sigma, includes_gravity", [(1.0, True), (0.5, True), (0.0, True), (0.0, False)])
def test_operator_feels_sigma_times_the_weight_at_rest(sigma, includes_gravity):
    """Holding still, the master renders the load's weight scaled by σ and by the force
    scale k_f: f_z = −σ·m·g·k_f (down), the apparent mass of Sec. V in statics; gravity is
    counted once whether the accelerometer reports specific force or the driver removes it."""
    scenario = quiet_scenario({"accelerometer.includes_gravity": includes_gravity,
                               # a firm grip settles fast
                               "operator.stiffness": 2000.0, "operator.damping": 40.0, "duration": 0.5})
    run = run_teleop(with_sigma(scenario, sigma), true_load(scenario))
    k_f = scenario.controller.feedback.force_scale
    expected = -sigma * 3.13 * 9.81 * k_f
    settled = run["master_force"][-200:].mean(axis=0)  # the last 0.1 s
    assert settled[2] == pytest.approx(expected, abs=0.01)
    np.testing.assert_allclose(settled[:2], 0.0, atol=0.01)
    assert run["ik_status"][:, 0].min() == 1.0


def test_slave_follows_the_scaled_master_motion():
    """The operator lifts the stylus by 2 cm; with translation scale 2 the sensor frame
    rises by 4 cm, and the eliminated feedback stays near zero throughout."""
    scenario = quiet_scenario({"operator.amplitude": [0.0, 0.0, 0.02], "operator.frequency": 1.0,
                               "operator.start_time": 0.0, "controller.motion.translation_scale": 2.0,
                               "duration": 0.6})  # past the top of the reference at 0.5 s
    diagram, log = MakeTeleopSimulation(with_sigma(scenario, 0.0), true_load(scenario))
    simulator = Simulator(diagram)
    simulator.Initialize()
    context = simulator.get_context()
    master = diagram.GetSubsystemByName("station").GetSubsystemByName("master_plant")
    station = diagram.GetSubsystemByName("station")
    slave = station.GetSubsystemByName("slave_plant")

    def heights():
        master_context = master.GetMyContextFromRoot(context)
        slave_context = slave.GetMyContextFromRoot(context)
        return (master.EvalBodyPoseInWorld(master_context, master.GetBodyByName("stylus")).translation()[2],
                slave.GetFrameByName("S").CalcPoseInWorld(slave_context).translation()[2])

    stylus0, sensor0 = heights()
    simulator.AdvanceTo(scenario.duration)
    stylus, sensor = heights()
    assert stylus - stylus0 > 0.015
    assert sensor - sensor0 == pytest.approx(2.0 * (stylus - stylus0), abs=0.004)  # lag of the slave servo
    feedback = log.arrays(context)["wrench_feedback"]
    assert np.abs(feedback[:, :3]).max() < 0.5


@pytest.mark.slow
@pytest.mark.parametrize("name", ["fig6", "fig8"])
def test_paper_experiments_with_the_true_load(name):
    """fig6: ≈100 N of non-contact force at the slave, eliminated to a few percent.
    fig8: after elimination the contact is detected within 30 ms of its onset; the second,
    shallower stroke (the paper's control) touches nothing, yet the measured force swings
    about as far as in the first, and after elimination it stays under the detection threshold."""
    from heft.analysis.experiment_metrics import DETECTION_THRESHOLD_N, experiment_metrics
    from heft.systems.station.operator_hand import stroke_windows
    scenario = resolve_scenario(name, overrides_text({"duration": 1.2} if name == "fig6" else {}))
    load = true_load(scenario)
    runs = {sigma: run_teleop(with_sigma(scenario, sigma), load) for sigma in (1.0, 0.0)}
    op = scenario.operator
    metrics = experiment_metrics(scenario.experiment, runs, scenario.controller.feedback.force_scale,
                                 stroke_windows(op.start_time, op.frequency, scenario.duration))
    if name == "fig6":
        assert metrics["noncontact_peak_N"] > 60
        assert metrics["residual_ratio"] < 0.05
    else:
        onset = metrics["contact_onset_s"]
        assert 0.15 < onset < 0.3
        assert abs(metrics["contact_detected_s_eliminated"] - onset) < 0.03
        assert metrics["false_alarm_raw"] or metrics["contact_detected_s_raw"] > onset + 0.03
        contact, control = metrics["strokes"]
        assert contact["contact_peak_N"] > DETECTION_THRESHOLD_N
        assert control["contact_peak_N"] == 0.0
        assert control["raw_swing_N"] > 0.75 * contact["raw_swing_N"]
        assert contact["eliminated_swing_N"] > DETECTION_THRESHOLD_N > control["eliminated_swing_N"]


@pytest.mark.parametrize("tracking", [True, False])
def test_offset_tracking_in_the_closed_loop_holds_the_residual_against_drift(tracking):
    """The sensor's offsets drift while the tool hangs still (time compressed a hundredfold: a
    warm-up of 0.5 N on f_z with a 3 s time constant, the tracker's 5 s and 0.02 N/s made
    0.05 s and 2 N/s). With tracking the eliminated wrench stays within the tracker's lag;
    without it, it follows the drift."""
    initial_offsets = quiet_scenario().ft_sensor.initial_offsets
    scenario = quiet_scenario({
        "ft_sensor.noise": True, "ft_sensor.white_noise": False, "ft_sensor.quantization": False,
        "ft_sensor.offset_random_walk": [0.0] * 6, "ft_sensor.drift_time_constant": 3.0,
        "ft_sensor.drifted_offsets": np.add(initial_offsets, [0, 0, 0.5, 0, 0, 0]).tolist(),
        "controller.offsets.tracking": tracking, "controller.offsets.time_constant": 0.05,
        "controller.offsets.max_force_rate": 2.0, "operator.stiffness": 2000.0, "operator.damping": 40.0,
        "duration": 1.5})
    run = run_teleop(with_sigma(scenario, 0.0), true_load(scenario), quiet=True)
    residual = run["wrench_contact"][200:, 2]  # f_z of the eliminated wrench, after the start
    drift = run["offsets_true"][-1, 2] - run["offsets_true"][0, 2]
    assert drift > 0.15  # the offsets really drifted
    if tracking:
        rate = 0.5 / 3.0  # the warm-up's fastest drift (N/s)
        assert np.abs(residual).max() < 1.5 * rate * scenario.controller.offsets.time_constant + 1e-3
        np.testing.assert_allclose(run["offsets_hat"][-1, 2], run["offsets_true"][-1, 2], atol=0.01)
    else:
        assert residual[-1] == pytest.approx(drift, abs=0.01)


def test_online_estimation_learns_the_load_in_the_loop():
    """Fig. 6 in the ideal station with the estimator in the loop (RLS, the controller knowing nothing of the tool at
    start): once the stylus moves (0.2 s) the mass settles within 2 % in well under the 1 s aimed
    for (Kubus 2008's RTLS needed about 1.5 s), and the eliminated wrench then stays within 2 % of
    the non-contact peak, as with the identified estimate."""
    scenario = resolve_scenario("fig6", overrides_text({**IDEAL_STATION, "controller.estimator.mode": "online",
                                                        "duration": 1.5}))
    true = true_load(scenario)
    log = run_teleop(with_sigma(scenario, 0.0), LoadEstimate(phi=np.zeros(10), offsets=true.offsets), quiet=True)
    error = np.abs(log["phi_hat"][:, 0] - true.phi[0]) / true.phi[0]
    settled = log["t"][np.flatnonzero(error > 0.02)[-1] + 1]
    print(f"mass within 2 % from {settled - scenario.operator.start_time:.3f} s after the motion starts")
    assert error[0] == 1.0 and settled - scenario.operator.start_time < 1.0
    late = log["t"] > 1.0
    peak = np.abs(log["wrench_noncontact_true"][:, :3]).max()
    assert np.abs(log["wrench_feedback"][late, :3]).max() < 0.02 * peak


@pytest.mark.parametrize("eta", [0.5])
def test_eq_14_after_a_grasp_with_the_estimator_in_the_loop(eta):
    """The grasp scenario in the ideal station with ideal sensors, φ_gr the gripper's: the estimator learns the object
    within 1.5 s of the grasp (mass within 2 %), and then the operator feels the contact plus η of
    the object's true non-contact wrench and nothing of the gripper's (σ = 0), to 1 % of its weight."""
    from heft.analysis.experiment_metrics import grasp_metrics
    from heft.diagrams.running.simulation import true_load as station_truth

    scenario = resolve_scenario("grasp", overrides_text({**NOISE_OFF, **IDEAL_STATION, "duration": 2.2,
                                                         "controller.force.eta": eta}))
    load, phi_gripper = station_truth(scenario)
    scenario = layered(scenario, overrides_text({"controller.force.phi_gripper": phi_gripper.tolist()}))
    gripper_only = LoadEstimate(phi=phi_gripper, offsets=load.offsets)
    metrics = grasp_metrics(run_teleop(with_sigma(scenario, 0.0), gripper_only, quiet=True), scenario.load.grasp_at)
    assert metrics["object_mass_settled_after_s"] < 1.5
    assert metrics["force_deviation_peak_of_weight"] < 0.01
