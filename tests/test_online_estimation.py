"""The controller Diagram with the load learned online (``controller.estimator.mode: online``), stepped as its
program against Drake's stepping of the same Diagram, and the grasp's split (Eq. 14).

The recorded readings move the slave so that S swings and turns; the wrench is the load's own by Eq. 5 (from
S's motion in Drake's arm model, φ 3 % heavier than the estimate the controller starts from), with a contact
spell, a re-zero at rest, a new load, a grasp and a release, a new estimate, tracking turned off, the clutch
released, stale readings, a NaN sample and stretches of too little excitation, so that every block's
branches run and the gate opens and closes for each of its reasons. Every output agrees at every tick,
exactly."""

import numpy as np
import pytest

from heft.diagrams.load_estimate import LoadEstimate
from heft.diagrams.plants import MakeArmPlant
from heft.diagrams.running.simulation import true_load
from heft.diagrams.scenario import Scenario, layered, overrides_text, resolve_scenario
from heft.diagrams.teleop import MakeTeleopController
from heft.diagrams.teleop_controller import TeleopController
from heft.systems.accelerometer_reading import AT_S
from heft.systems.load_dynamics import GRAVITY_W, regressor
from heft.systems.controller.load_model import SPLIT
from heft.systems.controller.offset_tracking import COLLECTING, DONE, ESTIMATE_SIZE
from heft.systems.tick_program import TickProgram

from controller_inputs import PERIOD, drake_run, program_run
from drake_reference import SensorMotion

TICKS = 1700
CONTACT = range(520, 620)   # 6 N on the load, judged: the learning window has closed
REST = range(250, 450)      # the slave still: too little excitation once the prefilter forgets the swing
REZERO_TICK = 300           # a re-zero at rest (its window 0.05 s)
CLUTCH_RELEASED = range(460, 500)
HELD = range(700, 850)      # the gripper holds an object: a grasp, then a release
RESET_TICK = 950            # a new load: the window reopens
ESTIMATE_TICK = 1050        # a new tool's estimate
STALE = range(1100, 1105)   # readings older than max_input_age
FAULT_TICK = 1200           # a NaN wrench: the gate holds 2/prefilter s
TRACKING_OFF_TICK = 1500


def online_scenario() -> Scenario:
    return layered(Scenario(), overrides_text({
        "controller.motion.translation_scale": 2.0, "controller.force.sigma": 0.0,
        "controller.estimator.mode": "online",
        "controller.estimator.learning_window": 0.15,  # 300 ticks, so that contact is judged within the sequence
        "controller.estimator.new_load_wait": 0.02,  # 40 ticks after the start and each new load
        "controller.offsets.rezero_window": 0.05}))


def load_sequence(scenario: Scenario, phi_true, offsets) -> list[dict]:
    """Station readings: the slave swinging, its wrench ``offsets`` + V·``phi_true`` (+ contact) from
    S's motion in Drake's arm model (a and α by backward differences of its spatial velocity in R,
    then in S), the accelerometer's reading a − g at ``accelerometer.position``."""
    plant, S = MakeArmPlant(scenario.robot)
    motion = SensorMotion(plant, plant.world_frame(), S, PERIOD)
    p_SA = np.array(scenario.accelerometer.position)
    q0, qM = np.array(scenario.slave_initial_q), np.array(scenario.master_initial_q)
    amplitude = np.array([0.1, 0.08, 0.1, 0.15, 0.1, 0.2])
    w = 2 * np.pi * np.array([1.1, 1.7, 1.3, 2.3, 1.9, 2.9])
    sequence, rng = [], np.random.default_rng(3)
    new_estimate = np.concatenate(([1.0], 1.002 * phi_true, offsets + 0.01))  # a new tool's, at ESTIMATE_TICK
    for k in range(TICKS + 1):
        t = k * PERIOD
        envelope = 0.0 if k in REST else 1.0
        q = q0 + envelope * amplitude * np.sin(w * t)
        v = envelope * amplitude * w * np.cos(w * t)
        sample = motion.at(q, v)
        if sample is None:
            continue
        a, alpha, omega, g = sample
        a_A = a + np.cross(alpha, p_SA) + np.cross(omega, np.cross(omega, p_SA))
        noise = rng.normal(0, [0.1, 0.1, 0.1, 0.005, 0.005, 0.005])  # the default sensor model's
        wrench = offsets + regressor(a, alpha, omega, g) @ phi_true + noise
        if k - 1 in CONTACT:
            wrench = wrench + np.array([0.0, 0.0, 6.0, 0.0, 0.3, 0.0])
        if k - 1 == FAULT_TICK:
            wrench = np.full(6, np.nan)
        sequence.append({
            "master.position_measured": qM + 0.1 * np.sin(3 * t),
            "master.velocity_estimated": 0.3 * np.cos(3 * t) * np.ones(6),
            "slave.position_measured": q, "slave.velocity_estimated": v,
            "ft.wrench_measured": wrench,
            "ft.acceleration_measured": np.concatenate((a_A - g, alpha)),
            "clutch": np.array([0.0 if k - 1 in CLUTCH_RELEASED else 1.0]),
            "rezero": np.array([float(k - 1 >= REZERO_TICK)]),
            "tracking": np.array([0.0 if k - 1 >= TRACKING_OFF_TICK else 1.0]),
            "estimator_reset": np.array([float(k - 1 >= RESET_TICK)]),
            "holding": np.array([1.0 if k - 1 in HELD else 0.0]),
            "estimate": new_estimate if k - 1 >= ESTIMATE_TICK else np.zeros(ESTIMATE_SIZE),
            "input_age": np.array([0.006 if k - 1 in STALE else 0.001]),
        })
    return sequence



@pytest.fixture(scope="module")
def online_runs():
    scenario = online_scenario()
    truth, _ = true_load(scenario)
    load = LoadEstimate(phi=0.97 * truth.phi, offsets=truth.offsets)  # 3 % light: something to learn
    sequence = load_sequence(scenario, truth.phi, truth.offsets)

    def make():
        return MakeTeleopController(scenario.controller, load, scenario.robot, PERIOD, scenario.slave_initial_q,
                                    accelerometer=scenario.accelerometer.convention())

    def gate(k, program):
        return {"enabled": program.calculation("estimator_gate", "enable")[0] > 0.5,
                "split": program.block_state("grasp", "state")[SPLIT] > 0.5}

    return drake_run(make(), sequence), program_run(TickProgram(make()), sequence, gate), truth.phi


def test_the_program_steps_the_online_diagram_exactly(online_runs):
    drake, program, _ = online_runs
    for k, (tick, reference) in enumerate(zip(program, drake, strict=True)):
        for name, value in reference.items():
            np.testing.assert_array_equal(tick[name], value, err_msg=f"{name} at tick {k}")


def test_the_sequence_runs_every_feature(online_runs):
    """Guards the equality against a sequence that leaves the estimator idle or always on, or a load command
    untaken."""
    _, ticks, phi_true = online_runs
    enabled = np.array([tick["enabled"] for tick in ticks])
    assert not enabled[:40].any() and not enabled[RESET_TICK + 1:RESET_TICK + 40].any(), "new_load_wait"
    assert enabled[45:250].mean() > 0.9, "the gate should take the swinging samples"
    settled = REST.start + round(0.1 / PERIOD)  # the prefiltered swing (10 Hz) faded
    assert not enabled[settled:REST.stop].any(), "rest should not excite the regressor enough"
    assert not enabled[CONTACT.start + 2:CONTACT.stop].any(), "contact should close the gate"
    assert enabled[RESET_TICK:RESET_TICK + 100].any(), "a new load should reopen it"
    assert not enabled[STALE.start + 1:STALE.stop].any(), "stale readings should close it"
    assert not enabled[FAULT_TICK + 1:FAULT_TICK + 400].any(), "a fault should close it for 2/prefilter s"
    assert enabled[FAULT_TICK + 420:].any()
    phi = np.array([tick["log.phi_hat"] for tick in ticks])
    assert abs(phi[RESET_TICK, 0] - phi_true[0]) < abs(phi[0, 0] - phi_true[0]) / 2, "the mass should be learned"
    status = np.array([tick["log.rezero_status"][0] for tick in ticks])
    assert status[REZERO_TICK + 1] == COLLECTING and status[REST.stop - 1] == DONE, "the re-zero"
    offsets = np.array([tick["log.offsets"] for tick in ticks])
    taken = np.flatnonzero(np.abs(offsets[ESTIMATE_TICK:] - offsets[ESTIMATE_TICK - 1]).max(axis=1) > 0.005)[0]
    np.testing.assert_allclose(offsets[ESTIMATE_TICK + taken], offsets[0] + 0.01, err_msg="the new estimate's offsets")
    assert np.abs(phi[ESTIMATE_TICK + taken] - 1.002 * phi_true).max() < 1e-9, "φ̂ restarts from it in that tick"
    assert np.abs(phi[ESTIMATE_TICK + taken - 1] - 1.002 * phi_true).max() > 1e-4, "and not before"
    assert np.ptp(offsets[TRACKING_OFF_TICK + 1:], axis=0).max() == 0, "tracking off holds the offsets"
    split = np.array([tick["split"] for tick in ticks])
    assert not split[HELD.start - 1] and split[HELD.start + 1] and not split[HELD.stop + 2], "grasp, release"
    released = HELD.stop + np.flatnonzero(~split[HELD.stop:])[0]
    np.testing.assert_array_equal(phi[released], phi[HELD.start], err_msg="φ̂ back to φ_gr")
    desired = np.array([tick["log.pose_RS_desired"] for tick in ticks])
    np.testing.assert_array_equal(desired[CLUTCH_RELEASED.start + 1:CLUTCH_RELEASED.stop],
                                  np.repeat(desired[CLUTCH_RELEASED.start:CLUTCH_RELEASED.start + 1],
                                            len(CLUTCH_RELEASED) - 1, axis=0))


def test_grasp_splits_the_load_and_release_returns_to_the_gripper():
    """A grasp keeps φ̂ as φ_gr and learns the rest as the object's, fed back scaled by η (Eq. 14:
    f′ = γ·c + σ·V·φ_gr + η·V·(φ̂ − φ_gr)); a release returns to φ_gr. Refused with the reason
    when it cannot apply."""
    scenario = layered(resolve_scenario("grasp"), overrides_text({
        "controller.force.eta": 0.5, "controller.force.sigma": 0.0, "controller.force.slew_rate": 1e6,
        "controller.force.phi_gripper": None}))
    truth, phi_gripper = true_load(scenario)
    gripper = LoadEstimate(phi=phi_gripper, offsets=truth.offsets)  # identified alone, before the grasp
    controller = TeleopController(scenario.controller, gripper, scenario.robot, PERIOD, accelerometer=AT_S)
    controller.start(scenario.slave_initial_q)
    q = np.array(scenario.slave_initial_q)
    plant, _ = MakeArmPlant(scenario.robot)
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, q)
    g_S = plant.CalcRelativeTransform(context, plant.GetFrameByName(f"{scenario.robot}_base"),
                                      plant.GetFrameByName("S")).rotation().inverse() @ np.array(GRAVITY_W)
    V = regressor(np.zeros(3), np.zeros(3), np.zeros(3), g_S)  # at rest
    at_rest = np.concatenate((-g_S, np.zeros(3)))  # the accelerometer's reading a − g at rest
    phi_object = np.array([0.5, 0.0, 0.0, -0.03, 0.002, 0, 0, 0.002, 0, 0.001])

    def step(phi):
        controller.step(PERIOD, scenario.master_initial_q, np.zeros(6), q, np.zeros(6), gripper.offsets + V @ phi,
                        at_rest, False)

    with pytest.raises(ValueError, match="holds nothing"):
        controller.release()
    controller.grasp()
    with pytest.raises(ValueError, match="already holds"):
        controller.grasp()
    step(gripper.phi)  # the tick that takes the grasp up
    assert controller.holding and controller.grasps == 1
    np.testing.assert_array_equal(controller.phi_gripper, gripper.phi)
    # Suppose the estimator has learned an object: φ̂ = φ_gr + φ_obj (held: no sample excites it at rest).
    controller.phi[:] = gripper.phi + phi_object
    step(gripper.phi + phi_object)
    assert controller.estimator.since_reset == pytest.approx(PERIOD)  # the grasp opened the learning window
    np.testing.assert_allclose(controller.phi, gripper.phi + phi_object)  # at rest nothing is learned
    np.testing.assert_allclose(controller.wrench_contact, 0.0, atol=1e-9)
    # σ = 0, γ = 1: the gripper's weight eliminated, half the object's fed back.
    np.testing.assert_allclose(controller.wrench_feedback, 0.5 * V @ phi_object, atol=1e-9)
    assert abs(controller.wrench_feedback[2]) > 1.0  # the object's weight is there to see
    controller.release()
    step(gripper.phi + phi_object)  # the release is taken up: the split holds until φ̂ returns with it
    np.testing.assert_array_equal(controller.phi_gripper, gripper.phi)
    np.testing.assert_allclose(controller.phi, gripper.phi + phi_object)
    step(gripper.phi)  # the estimator restarts from φ_gr, and the split goes, in one tick
    assert not controller.holding and controller.phi_gripper is None
    np.testing.assert_allclose(controller.phi, gripper.phi)


def test_grasp_is_refused_with_the_estimate_fixed():
    scenario = Scenario()
    gripper, _ = true_load(scenario)
    controller = TeleopController(scenario.controller, gripper, scenario.robot, PERIOD, accelerometer=AT_S)
    with pytest.raises(ValueError, match="estimator: {mode: online}"):
        controller.grasp()
