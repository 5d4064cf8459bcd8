"""The load estimator in the one-computation-per-tick controller (``controller.estimator.mode: online``)
against the per-block Diagram's gate, prefilter and RLS, and the grasp on hardware (Eq. 14).

The sequence moves the slave so that S swings and turns; the wrench is the load's own by Eq. 5
(from S's motion in Drake's arm model, φ 3 % heavier than the estimate the controller starts
from), with a contact spell, a new load, a NaN sample and stretches of too little excitation, so
that the gate opens and closes for each of its reasons. Every signal, φ̂ among them, agrees at
every tick (the slave command one tick earlier, as without the estimator)."""

import numpy as np
import pytest

from heft.diagrams.plants import MakeArmPlant
from heft.diagrams.running.simulation import true_load
from heft.diagrams.load_estimate import LoadEstimate
from heft.diagrams.scenario import Scenario, layered, overrides_text, resolve_scenario
from heft.diagrams.teleop import MakeRealtimeTeleopController
from heft.systems.accelerometer_reading import AT_S
from heft.systems.load_dynamics import GRAVITY_W, regressor

from test_realtime_controller import COMPARED, PERIOD, assert_same_signal, run_both

TICKS = 1700
CONTACT = range(520, 620)   # 6 N on the load, judged: the learning window has closed
REST = range(250, 450)      # the slave still: too little excitation once the prefilter forgets the swing
RESET_TICK = 950            # a new load: the window reopens
FAULT_TICK = 1200           # a NaN wrench: the gate holds 2/prefilter s


def online_scenario() -> Scenario:
    return layered(Scenario(), overrides_text({
        "controller.motion.translation_scale": 2.0, "controller.force.sigma": 0.0,
        "controller.estimator.mode": "online",
        "controller.estimator.learning_window": 0.15,  # 300 ticks, so that contact is judged within the sequence
        "controller.estimator.new_load_wait": 0.02}))  # 40 ticks after the start and each new load


def load_sequence(scenario: Scenario, phi_true, offsets) -> list[dict]:
    """Station readings: the slave swinging, its wrench ``offsets`` + V·``phi_true`` (+ contact) from
    S's motion in Drake's arm model (a and α by backward differences of its spatial velocity in R,
    then in S), the accelerometer's reading a − g at ``accelerometer.position``."""
    plant, _ = MakeArmPlant(scenario.robot)
    context = plant.CreateDefaultContext()
    R, S = plant.GetFrameByName(f"{scenario.robot}_base"), plant.GetFrameByName("S")
    p_SA = np.array(scenario.accelerometer.position)
    q0, qM = np.array(scenario.slave_initial_q), np.array(scenario.master_initial_q)
    amplitude = np.array([0.1, 0.08, 0.1, 0.15, 0.1, 0.2])
    w = 2 * np.pi * np.array([1.1, 1.7, 1.3, 2.3, 1.9, 2.9])
    sequence, previous, rng = [], None, np.random.default_rng(3)
    for k in range(TICKS + 1):
        t = k * PERIOD
        envelope = 0.0 if k in REST else 1.0
        q = q0 + envelope * amplitude * np.sin(w * t)
        v = envelope * amplitude * w * np.cos(w * t)
        plant.SetPositions(context, q)
        plant.SetVelocities(context, v)
        R_SR = plant.CalcRelativeTransform(context, R, S).rotation().inverse()
        V_RS = S.CalcSpatialVelocity(context, R, R)
        velocity = np.concatenate((V_RS.translational(), V_RS.rotational()))  # of S in R, in R
        rates = np.zeros(6) if previous is None else (velocity - previous) / PERIOD
        previous = velocity
        if k == 0:
            continue
        a, alpha, omega = R_SR @ rates[:3], R_SR @ rates[3:], R_SR @ velocity[3:]
        g = R_SR @ np.array(GRAVITY_W)
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
            "clutch": np.array([1.0]),
            "rezero": np.array([0.0]),
            "estimator_reset": np.array([float(k - 1 >= RESET_TICK)]),
        })
    return sequence


@pytest.fixture(scope="module")
def online_runs():
    scenario = online_scenario()
    truth, _ = true_load(scenario)
    start = truth.phi.copy()
    start *= 0.97  # a 3 % lighter estimate: the estimator has something to learn
    load = type(truth)(phi=start, offsets=truth.offsets)
    return (*run_both(scenario, load, load_sequence(scenario, truth.phi, truth.offsets)), truth.phi)


@pytest.mark.parametrize("name", COMPARED)
def test_online_estimator_signals_equal_the_per_block_diagram(online_runs, name):
    blocks, steps, _, _ = online_runs
    assert_same_signal(blocks, steps, name)


def test_the_sequence_opens_and_closes_the_gate_for_each_reason(online_runs):
    """Guards the equality against a sequence that leaves the estimator idle or always on."""
    blocks, steps, fused, phi_true = online_runs
    enabled = np.array([s["enabled"] for s in steps])
    assert not enabled[:40].any() and not enabled[RESET_TICK:RESET_TICK + 40].any(), "new_load_wait"
    assert enabled[45:250].mean() > 0.9, "the gate should take the swinging samples"
    settled = REST.start + round(0.1 / PERIOD)  # the prefiltered swing (10 Hz) faded
    assert not enabled[settled:REST.stop].any(), "rest should not excite the regressor enough"
    assert not enabled[CONTACT.start + 2:CONTACT.stop].any(), "contact should close the gate"
    assert enabled[RESET_TICK:RESET_TICK + 100].any(), "a new load should reopen it"
    assert not enabled[FAULT_TICK:FAULT_TICK + 400].any(), "a fault should close it for 2/prefilter s"
    assert enabled[FAULT_TICK + 420:].any()
    phi = np.array([s["log.phi_hat"] for s in steps])
    assert abs(phi[-1, 0] - phi_true[0]) < abs(phi[0, 0] - phi_true[0]) / 2, "the mass should approach the truth"


def test_grasp_splits_the_load_and_release_returns_to_the_gripper():
    """A grasp keeps φ̂ as φ_gr and learns the rest as the object's, fed back scaled by η (Eq. 14:
    f′ = γ·c + σ·V·φ_gr + η·V·(φ̂ − φ_gr)); a release returns to φ_gr. Refused with the reason
    when it cannot apply."""
    scenario = layered(resolve_scenario("grasp"), overrides_text({
        "controller.force.eta": 0.5, "controller.force.sigma": 0.0, "controller.force.slew_rate": 1e6}))
    truth, phi_gripper = true_load(scenario)
    gripper = LoadEstimate(phi=phi_gripper, offsets=truth.offsets)  # identified alone, before the grasp
    fused = MakeRealtimeTeleopController(scenario.controller, gripper, scenario.robot, PERIOD, accelerometer=AT_S)
    fused.start(scenario.slave_initial_q)
    with pytest.raises(ValueError, match="holds nothing"):
        fused.release()
    fused.grasp()
    with pytest.raises(ValueError, match="already holds"):
        fused.grasp()
    np.testing.assert_array_equal(fused.phi_gripper, gripper.phi)
    assert fused.holding
    # Suppose the estimator has learned an object: φ̂ = φ_gr + φ_obj (held: no sample excites it at rest).
    phi_object = np.array([0.5, 0.0, 0.0, -0.03, 0.002, 0, 0, 0.002, 0, 0.001])
    fused.phi[:] = gripper.phi + phi_object
    q = np.array(scenario.slave_initial_q)
    plant, _ = MakeArmPlant(scenario.robot)
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, q)
    g_S = plant.CalcRelativeTransform(context, plant.GetFrameByName(f"{scenario.robot}_base"),
                                      plant.GetFrameByName("S")).rotation().inverse() @ np.array(GRAVITY_W)
    V = regressor(np.zeros(3), np.zeros(3), np.zeros(3), g_S)  # at rest
    measured = gripper.offsets + V @ (gripper.phi + phi_object)  # the sensor's wrench on the held load
    at_rest = np.concatenate((-g_S, np.zeros(3)))  # the accelerometer's reading a − g at rest
    fused.step(PERIOD, scenario.master_initial_q, np.zeros(6), q, np.zeros(6), measured, at_rest, False)
    assert fused.estimator.since_reset == pytest.approx(PERIOD)  # the grasp opened the learning window
    np.testing.assert_allclose(fused.phi, gripper.phi + phi_object)  # at rest nothing is learned
    np.testing.assert_allclose(fused.wrench_contact, 0.0, atol=1e-9)
    # σ = 0, γ = 1: the gripper's weight eliminated, half the object's fed back.
    np.testing.assert_allclose(fused.wrench_feedback, 0.5 * V @ phi_object, atol=1e-9)
    assert abs(fused.wrench_feedback[2]) > 1.0  # the object's weight is there to see
    fused.release()
    assert not fused.holding and fused.phi_gripper is None
    np.testing.assert_allclose(fused.phi, gripper.phi)


def test_grasp_is_refused_with_the_estimate_fixed():
    scenario = Scenario()
    gripper, _ = true_load(scenario)
    fused = MakeRealtimeTeleopController(scenario.controller, gripper, scenario.robot, PERIOD, accelerometer=AT_S)
    with pytest.raises(ValueError, match="estimator: {mode: online}"):
        fused.grasp()


def test_stale_readings_spoil_the_sample_as_a_fault_does():
    """A tick whose readings are older than ``max_input_age`` (a stalled lab) is not learned from, nor the
    2/prefilter s after it (the arm jerks and the load rings when the lab catches up); the ticks are
    counted since the last new load."""
    from heft.systems.contact_threshold import ContactThresholdParams
    from heft.systems.load_estimation_params import LoadEstimationParams
    from heft.systems.online_estimator import OnlineLoadEstimator

    params = LoadEstimationParams(mode="online", max_input_age=0.005)
    truth, _ = true_load(Scenario())
    estimator = OnlineLoadEstimator(params, ContactThresholdParams(), truth.phi, PERIOD)
    acceleration, omega, gravity = np.array([3.0, 0.0, 0.0, 0.0, 2.0, 0.0]), np.array([0.0, 0.5, 0.0]), np.zeros(3)
    gravity[2] = -9.81
    wrench = regressor(acceleration[:3], acceleration[3:], omega, gravity) @ truth.phi
    hold = round(2.0 / params.prefilter / PERIOD)  # ticks

    def tick(age):
        estimator.step(PERIOD, np.zeros(6), wrench, acceleration, omega, gravity, False, age)
        return estimator.enabled

    assert [tick(0.0) for _ in range(10)][-1], "a steady, excited stream is learned from"
    assert not tick(0.0051), "readings older than max_input_age"
    assert estimator.num_stale == 1
    assert not any(tick(0.0) for _ in range(hold - 2)), "nor for 2/prefilter s after"
    assert [tick(0.005) for _ in range(5)][-1], "max_input_age itself is fresh enough, and the gate reopens"
    estimator.new_load()
    tick(0.0)
    assert estimator.num_stale == 0, "counted since the last new load"
    with pytest.raises(ValueError, match="max_input_age must be > 0"):
        LoadEstimationParams(mode="online", max_input_age=float("nan")).validate()
