"""The controller on the hardware station against the stand-in lab, in one process over
memq://, both stepped on one explicit clock: start-up never moves the slave, motion
follows the operator only with the clutch held and only by the scaled stylus motion,
the master command stays within the device's limits under faults, and forces go off
within the watchdog timeout once the lab dies or the controller stalls."""

import lcm
import numpy as np
import pytest
from pydrake.multibody.plant import MultibodyPlant
from scipy.spatial.transform import Rotation

from heft.diagrams.scenario import Scenario, layered, overrides_text
from heft.diagrams.plants import AddArmWithSensor
from heft.diagrams.scenario import resolve_scenario
from heft.diagrams.running.simulation import true_load
from heft.diagrams.stations.stand_in import FaultInjection, StandIn
from heft.diagrams.running.hardware_teleop import HardwareTeleop, format_summary
from heft.diagrams.running.realtime import TickTimes, timing_summary
from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.hardware_station import HardwareStationParams
from heft.hardware_interface.lcmtypes import heft_load_command, heft_load_status, heft_teleop_state
from heft.diagrams.load_estimate import LoadEstimate
from heft.systems.accelerometer_reading import motion_from_reading
from heft.systems.load_dynamics import InertialParameters
from heft.systems.controller.offset_tracking import DONE, REFUSED_MOVING
from drake_reference import stylus_jacobian
from heft.diagrams.plants import MakeMasterPlant
from heft.systems.controller.master_kinematics import BASE_FRAME, STYLUS_FRAME

PERIOD = 0.0005
TIMEOUT = HardwareStationParams().watchdog.timeout
MAX_FORCE, MAX_TORQUE = 8.5, 0.188  # the Phantom Premium 1.5 6DoF's continuous limits (feedback defaults)


class Lab:
    """Stand-in and controller on one memq:// bus, ticking together every ``PERIOD`` s."""

    def __init__(self, scenario: Scenario, faults=None, clutch_at=np.inf, load=None,
                 controller_scenario: Scenario | None = None, state_every_tick: bool = True):
        bus = self.bus = lcm.LCM("memq://")
        self.stand_in = StandIn(scenario, bus, LcmChannels(), faults or FaultInjection(), clutch_at=clutch_at)
        self.teleop = HardwareTeleop(controller_scenario or scenario, load or true_load(scenario)[0], bus,
                                     LcmChannels(), state_every_tick=state_every_tick)
        self.now = 0.0
        self.commands, self.torques, self.master_q, self.gains, self.stylus_wrenches = [], [], [], [], []

    def run(self, duration, controller=True):
        for _ in range(round(duration / PERIOD)):
            self.now += PERIOD
            self.stand_in.step(self.now)  # a dead lab publishes nothing
            if controller:
                self.teleop.tick(self.now, PERIOD)
                station = self.teleop.station
                self.torques.append(station.torque_sent.copy())
                self.commands.append(None if station.position_sent is None else station.position_sent.copy())
                self.master_q.append(station.master_position.copy())
                self.gains.append(station.gain)
                controller = self.teleop.controller
                self.stylus_wrenches.append(station.gain * controller.applied_wrench if controller.started
                                            else np.zeros(6))


def sensor_pose(q, robot: str = "rx90"):
    """X_RS of the bundled ``robot``'s sensor frame at joint angles q, from Drake's own plant."""
    plant = MultibodyPlant(0.0)
    chain, _, S = AddArmWithSensor(plant, robot)
    plant.Finalize()
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, q)
    return plant.CalcRelativeTransform(context, chain.base, S)


def sensor_position(q, robot: str = "rx90") -> np.ndarray:
    """p_RS (m) of the bundled ``robot``'s sensor frame at joint angles q."""
    return sensor_pose(q, robot).translation()


def stylus_position(q) -> np.ndarray:
    plant = MakeMasterPlant()
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, q)
    return plant.CalcRelativeTransform(context, plant.GetFrameByName(BASE_FRAME),
                                       plant.GetFrameByName(STYLUS_FRAME)).translation()


def test_start_up_never_moves_the_slave():
    """The operator moves the stylus but never presses the clutch: the slave is commanded
    exactly where it is measured, from the first command on."""
    lab = Lab(resolve_scenario("fig6"))
    lab.run(1.0)
    commands = np.array([c for c in lab.commands if c is not None])
    assert len(commands) > 1500 and lab.teleop.first_healthy is not None
    measured = lab.teleop.station.slave_position  # the encoders' reading, quantised
    np.testing.assert_allclose(commands, np.repeat(measured[None], len(commands), axis=0), atol=1e-12)
    q_start = np.array(resolve_scenario("fig6").slave_initial_q)
    np.testing.assert_allclose(lab.stand_in.slave_position, q_start, atol=1e-5)
    assert np.ptp(np.array(lab.master_q), axis=0).max() > 0.01, "the operator should have moved the stylus"


def test_the_summary_says_when_the_controller_was_first_healthy():
    """In seconds with a fixed number of decimals, however early (a lab already publishing makes
    the first tick healthy), or "never"; that first tick is the controller's one start from the
    measured position, though no command came before it."""
    lab = Lab(resolve_scenario("fig6"))
    lab.run(0.05)
    summary = {**lab.teleop.summary(0.05), "duration": 0.05, "rate_hz": 2000.0,
               "timing": timing_summary(TickTimes(np.full(3, 1e-4), np.full(3, 1e-4), np.zeros(3), 0, 0.05, 5e-4))}
    first = summary["first_healthy"]
    assert first is not None and first < 0.01
    assert summary["slave_reanchors"]["count"] == 1 and summary["faults"] == [], summary["slave_reanchors"]
    assert f"(first at {first:.4f} s)" in format_summary(summary, "memq://")
    assert "healthy in 0 (never)" in format_summary({**summary, "healthy_ticks": 0, "first_healthy": None}, "memq://")
    lag = summary["arm_command_lag"]  # one clock: the arm steps on each answer, its status echoes it
    assert lag["statuses"] > 50 and (lag["late"], lag["unmeasured"]) == (0, 0), lag
    assert f"late at 0 of {lag['statuses']} statuses read" in format_summary(summary, "memq://")
    late = {**summary, "arm_command_lag": {**lag, "late": 3, "max_lag": 8, "max_lag_at": 3.73, "unmeasured": 2}}
    assert (f"late at 3 of {lag['statuses'] - 2} statuses read (the newest each tick; stepped on an older command "
            "than the answer to the status before), by up to 8 step(s) (3.7300 s after its first status); 2 echoed "
            "none") in format_summary(late, "memq://")


@pytest.mark.parametrize("sigma", [0.0, 0.2])
def test_a_tool_hanging_still_is_weighed_once(sigma):
    """Hanging still, the stand-in's accelerometer reports what a real one does (9.81 m/s²
    pointing up in the world, R = W here), and the controller counts gravity once: the
    stylus feels σ times the tool's weight scaled by k_f, pointing down; nothing at σ = 0
    (counted twice, σ = 0 would render the full weight upwards)."""
    scenario = resolve_scenario("fig6", overrides_text({
        "operator.amplitude": [0.0, 0.0, 0.0], "ft_sensor.white_noise": False, "accelerometer.white_noise": False,
        "controller.force.sigma": sigma}))
    load = true_load(scenario)[0]
    lab = Lab(scenario, load=load)
    lab.run(0.5)
    reading = lab.teleop.station.acceleration
    R_RS = sensor_pose(lab.stand_in.slave_position).rotation().matrix()
    np.testing.assert_allclose(R_RS @ reading[:3], [0.0, 0.0, 9.81], atol=0.2)  # biases ≤ 0.15 m/s²
    settled = np.array(lab.stylus_wrenches[-200:]).mean(axis=0)
    expected = -sigma * load.phi[0] * 9.81 * scenario.controller.feedback.force_scale
    assert abs(expected) < MAX_FORCE  # not clamped: the test sees the law
    np.testing.assert_allclose(settled[:3], [0.0, 0.0, expected], atol=0.05)


def still_lab(load_of, clutch_at=np.inf, amplitude=0.0, overrides=None, controller_overrides=None):
    """fig6 with σ = 0, no white noise nor accelerometer bias, the operator's hand at rest (or
    moving by ``amplitude`` m), the controller given ``load_of(true load)`` and no offset
    tracking, then changed by ``overrides`` (a dict of dotted fields; the controller's by
    ``controller_overrides`` besides); answers on the load status channel are kept."""
    scenario = resolve_scenario("fig6", overrides_text({
        "operator.amplitude": [0.0, 0.0, amplitude], "ft_sensor.white_noise": False, "accelerometer.white_noise": False,
        # the accelerometer's bias would weigh m·b on the force (0.4 N): not this test's subject
        "accelerometer.offsets": False, "controller.force.sigma": 0.0, "controller.offsets.tracking": False}))
    if overrides:
        scenario = layered(scenario, overrides_text(overrides))
    true = true_load(scenario)[0]
    controller_scenario = layered(scenario, overrides_text(controller_overrides)) if controller_overrides else None
    lab = Lab(scenario, load=load_of(true), clutch_at=clutch_at, controller_scenario=controller_scenario)
    lab.answers = []
    lab.bus.subscribe(LcmChannels().load_status.name,
                      lambda _, payload: lab.answers.append(heft_load_status.decode(payload)))
    return lab, true, scenario


def send(lab, action, phi=(0.0,) * 10, offsets=(0.0,) * 6):
    command = heft_load_command()
    command.utime, command.action, command.phi, command.offsets = round(lab.now * 1e6) + 1, action, phi, offsets
    lab.bus.publish(LcmChannels().load_command.name, command.encode())


def stylus_force(lab) -> float:
    return float(np.linalg.norm(np.array(lab.stylus_wrenches[-100:]).mean(axis=0)[:3]))


def test_a_new_tool_estimate_takes_effect_without_a_restart():
    """The controller starts with φ̂ = 0, so σ = 0 still renders the whole weight; a new estimate
    sent over LCM makes it vanish within the tick, and the answer says so."""
    lab, true, scenario = still_lab(lambda true: LoadEstimate(phi=np.zeros(10), offsets=true.offsets))
    lab.run(0.3)
    weight = true.phi[0] * 9.81 * scenario.controller.feedback.force_scale
    assert stylus_force(lab) == pytest.approx(weight, rel=0.01)
    send(lab, heft_load_command.NEW_ESTIMATE, true.phi.tolist(), true.offsets.tolist())
    lab.run(0.1)
    assert stylus_force(lab) < 0.01 * weight
    assert [a.accepted for a in lab.answers] == [True] and "new estimate in use" in lab.answers[0].message
    np.testing.assert_allclose(lab.answers[0].phi, true.phi)
    assert lab.teleop.station.healthy and len(lab.teleop.faults) == 0


def test_rezero_over_lcm_measures_the_offsets_and_refuses_while_moving():
    """Offsets 3 N off on f_z: the operator feels 3 N·k_f at rest; a re-zero sent over LCM measures
    them (to the sensor's own offsets) and the force goes; asked while the slave moves, it is refused."""
    wrong = np.array([0.0, 0.0, 3.0, 0.0, 0.0, 0.0])
    lab, true, scenario = still_lab(lambda true: LoadEstimate(phi=true.phi, offsets=true.offsets + wrong))
    lab.run(0.3)
    assert stylus_force(lab) == pytest.approx(3.0 * scenario.controller.feedback.force_scale, rel=0.02)
    send(lab, heft_load_command.REZERO)
    lab.run(0.7)
    assert [a.accepted for a in lab.answers] == [True, True]
    assert lab.answers[-1].rezero_status == DONE
    # To the sensor's resolution (one JR3 count is 12 mN, 0.7 mN·m) and its offsets' wander.
    np.testing.assert_allclose(lab.answers[-1].offsets, lab.stand_in.offsets, atol=0.02)
    assert stylus_force(lab) < 0.03 * 3.0 * scenario.controller.feedback.force_scale

    moving, _, _ = still_lab(lambda true: true, clutch_at=0.0, amplitude=0.05)
    moving.run(0.4)
    for _ in range(2):  # each request is answered twice, the second time with its outcome
        send(moving, heft_load_command.REZERO)
        moving.run(0.3)
    assert [a.accepted for a in moving.answers] == [True, False, True, False]
    assert moving.answers[-1].rezero_status == REFUSED_MOVING and "hold it still" in moving.answers[-1].message
    assert moving.answers[1].command_utime == moving.answers[0].command_utime != moving.answers[3].command_utime


def test_a_rezero_measures_the_accelerometers_bias_too():
    """The lab's IMU is mounted at an angle, reports in g and has a bias of 0.08 g the controller does not
    know: at rest it takes S to accelerate by that much, which an object grasped would turn into a force
    (Δm·b; here, with the true load and offsets given, the stylus feels m·b). A re-zero measures the bias
    beside the offsets; afterwards S is at rest for the controller too, and that force is gone, without
    a jolt on the way."""
    mounting = {"accelerometer.R_SA": Rotation.from_rotvec([0.5, -0.9, 1.7]).as_matrix().tolist(),
                "accelerometer.unit": "g", "accelerometer.full_scale": [10.0, 10.0, 10.0, 1000.0, 1000.0, 1000.0]}
    bias = np.array([0.0, 0.08, -0.02])
    lab, true, scenario = still_lab(lambda true: true, overrides={**mounting, "accelerometer.bias": bias.tolist()},
                                    controller_overrides={"accelerometer.bias": [0.0, 0.0, 0.0]})

    def acceleration_of_S() -> np.ndarray:
        controller = lab.teleop.controller
        return motion_from_reading(np.empty(6), lab.teleop.station.acceleration, controller.gravity_S, np.zeros(3),
                                   controller.accelerometer)[:3]

    lab.run(0.3)
    assert np.linalg.norm(acceleration_of_S()) == pytest.approx(np.linalg.norm(bias) * 9.80665, rel=0.01)
    before = stylus_force(lab)  # m·b·k_f: the bias's force, as the controller knows the true load and offsets
    assert before == pytest.approx(true.phi[0] * np.linalg.norm(bias) * 9.80665
                                   * scenario.controller.feedback.force_scale, rel=0.05)
    ticks = len(lab.stylus_wrenches)
    send(lab, heft_load_command.REZERO)
    lab.run(0.7)
    assert [a.accepted for a in lab.answers] == [True, True] and lab.answers[-1].rezero_status == DONE
    assert "accelerometer bias [" in lab.answers[-1].message
    assert "] g and [0, 0, 0] rad/s^2 on its angular channels (was [0, 0, 0] and [0, 0, 0])" in lab.answers[-1].message
    count = 10.0 / scenario.accelerometer.counts_per_full_scale  # g: the reading is rounded to it
    np.testing.assert_allclose(lab.teleop.controller.accelerometer.bias, bias, rtol=0, atol=count / 2)
    assert np.linalg.norm(acceleration_of_S()) < 9.80665 * count
    assert stylus_force(lab) < 0.03 * before
    assert max(np.linalg.norm(np.array(lab.stylus_wrenches[ticks:])[:, :3], axis=1)) < 1.05 * before  # no jolt


def test_a_rezero_measures_the_angular_channels_bias():
    """The IMU's angular channels read 0.3 rad/s² and more at rest (the JR3's are noisy and biased): the
    controller takes that for S turning faster and faster, α × m·c of the load's static moment, a force
    the stylus feels. α is zero at rest, exactly, so a re-zero measures that bias too, and the force goes."""
    angular_bias = np.array([0.3, -0.2, 0.25])
    at_S = {"accelerometer.position": [0.0, 0.0, 0.0], "controller.feedback.force_scale": 1.0}  # α × m·c alone
    lab, true, scenario = still_lab(lambda true: true, overrides={**at_S, "accelerometer.angular_bias":
                                                                  angular_bias.tolist()},
                                    controller_overrides={"accelerometer.angular_bias": [0.0, 0.0, 0.0]})
    lab.run(0.3)
    count = scenario.accelerometer.full_scale[3] / scenario.accelerometer.counts_per_full_scale  # rad/s²
    before = stylus_force(lab)
    expected = np.linalg.norm(np.cross(angular_bias, true.phi[1:4]))
    assert before == pytest.approx(expected, rel=count / np.abs(angular_bias).min())  # the reading is rounded
    send(lab, heft_load_command.REZERO)
    lab.run(0.7)
    assert [a.accepted for a in lab.answers] == [True, True] and lab.answers[-1].rezero_status == DONE
    np.testing.assert_allclose(lab.teleop.controller.accelerometer.angular_bias, angular_bias, rtol=0, atol=count / 2)
    assert "rad/s^2 on its angular channels (was [0, 0, 0] and [0, 0, 0])" in lab.answers[-1].message
    force_count = scenario.ft_sensor.full_scale[0] / scenario.ft_sensor.counts_per_full_scale  # N: its rounding
    assert stylus_force(lab) < min(2 * force_count, 0.25 * before)


def test_a_mounting_stated_wrong_is_not_taken_for_a_bias():
    """The controller's scenario has the IMU turned half a turn about S's x from how it is mounted: at rest
    that reads as a "bias" of up to 2 g, which no IMU has. With the tool's 3 kg that also looks like contact
    (tens of newtons) and a re-zero is refused as such; with its gates opened wide here, the re-zero
    measures the offsets, keeps the bias and says to check the mounting."""
    mounting = {"accelerometer.R_SA": Rotation.from_rotvec([0.5, -0.9, 1.7]).as_matrix().tolist(),
                "accelerometer.unit": "g", "accelerometer.full_scale": [10.0, 10.0, 10.0, 1000.0, 1000.0, 1000.0]}
    wrong = (Rotation.from_rotvec([np.pi, 0.0, 0.0]) * Rotation.from_rotvec([0.5, -0.9, 1.7])).as_matrix().tolist()
    lab, _, _ = still_lab(lambda true: true, overrides=mounting, controller_overrides={
        "accelerometer.R_SA": wrong, "controller.offsets.rezero_force": 1e3, "controller.offsets.rezero_torque": 1e3})
    lab.run(0.3)
    send(lab, heft_load_command.REZERO)
    lab.run(0.7)
    assert [a.accepted for a in lab.answers] == [True, True] and lab.answers[-1].rezero_status == DONE
    assert "accelerometer bias kept at [0, 0, 0]" in lab.answers[-1].message
    assert "check the scenario's accelerometer.R_SA and unit" in lab.answers[-1].message
    assert lab.teleop.controller.accelerometer.bias == (0.0, 0.0, 0.0)


def test_a_malformed_load_command_is_answered_and_the_loop_goes_on():
    lab, _, _ = still_lab(lambda true: true)
    lab.run(0.2)
    command = heft_load_command()
    command.utime, command.action = 1, heft_load_command.REZERO
    lab.bus.publish(LcmChannels().load_command.name, command.encode()[:20])  # right type, cut short
    lab.run(0.1)
    assert [a.accepted for a in lab.answers] == [False] and "not a heft_load_command" in lab.answers[0].message
    assert lab.teleop.station.healthy and not lab.teleop.faults


@pytest.mark.parametrize(("phi_of", "offsets", "reason"), [
    (lambda phi: np.r_[-5.0, phi[1:]], np.zeros(6), "mass -5 kg is not positive"),
    (lambda phi: np.r_[1e12, phi[1:]], np.zeros(6), "weight 9.81e+12 N is beyond the sensor's range"),
    (lambda phi: np.r_[phi[:4], -phi[4:]], np.zeros(6), "no body has these inertial parameters"),
    (lambda phi: InertialParameters(10.0, np.array([0.23, 0.0, 0.05]), 0.01 * np.eye(3)).to_phi(), np.zeros(6),
     "static moment |m·c|·g = 23.09 N·m is beyond the sensor's range"),  # 10 kg, its COM 0.23 m off-axis
    (lambda phi: phi, np.array([0.0, 0.0, 500.0, 0.0, 0.0, 0.0]), "offsets beyond the sensor's range"),
])
def test_a_non_physical_estimate_over_lcm_is_refused_with_the_reason(phi_of, offsets, reason):
    """What `heft load --estimate` could be made to send, or another process could: refused with the
    reason, and the estimate in use stays."""
    lab, true, _ = still_lab(lambda true: true)
    lab.run(0.1)
    send(lab, heft_load_command.NEW_ESTIMATE, phi_of(true.phi).tolist(), offsets.tolist())
    lab.run(0.01)
    (answer,) = lab.answers
    assert not answer.accepted and reason in answer.message, answer.message
    np.testing.assert_array_equal(answer.phi, true.phi)
    np.testing.assert_array_equal(lab.teleop.controller.phi, true.phi)


@pytest.mark.parametrize("robot", ["rx90", "ur5e", "iiwa14"])
def test_with_the_clutch_held_the_slave_moves_by_the_scaled_stylus_motion(robot):
    """Each bundled arm, its status and commands in its own joints (6, or the iiwa's 7): held still where it is
    measured until the clutch is pressed, then S follows the stylus by the arm's motion scale."""
    scenario = resolve_scenario("fig6", f"{{robot: {robot}}}")
    lab = Lab(scenario, clutch_at=0.2)
    lab.run(1.2)
    joints = len(scenario.slave_initial_q)
    assert lab.teleop.station.num_joints == joints and lab.teleop.summary(1.2)["slave_joints"] == joints
    assert not any(lab.teleop.station.rejections.values()) and lab.stand_in.refused == {
        name: {} for name in (LcmChannels().master_command.name, LcmChannels().slave_command.name)}
    k_t = scenario.controller.motion.translation_scale
    engaged = round(0.2 / PERIOD)
    still = np.array([c for c in lab.commands[:engaged] if c is not None])
    # Still to well within an encoder count (6e-6 rad): the iiwa's iterative IK settles to 1e-9 where it stands.
    assert len(still) > 0.9 * engaged and np.ptp(still, axis=0).max() < 1e-9, "the slave moved before the clutch"
    q_S = [c for c in lab.commands[engaged:] if c is not None]
    assert all(len(q) == joints for q in q_S)
    stylus = np.array([stylus_position(q) for q in lab.master_q[engaged::50]])
    sensor = np.array([sensor_position(q, robot) for q in q_S[::50]])
    n = min(len(stylus), len(sensor))
    stylus_motion = np.linalg.norm(stylus[:n] - stylus[0], axis=1)
    sensor_motion = np.linalg.norm(sensor[:n] - sensor[0], axis=1)
    assert stylus_motion.max() > 0.005, "the operator should have moved the stylus"
    # The slave follows (speed limits and one tick of lag aside) and never goes further.
    assert sensor_motion.max() <= k_t * stylus_motion.max() + 1e-3
    assert sensor_motion.max() >= 0.8 * k_t * stylus_motion.max()


def test_a_lab_of_another_arm_never_reaches_the_controller():
    """An iiwa's lab (7 joints) on the channels of a controller for the RX90 (6): every status is rejected as
    of another joint count, counted and reported; the controller never starts, sends no slave command and no
    force, and runs on."""
    lab = Lab(resolve_scenario("fig6", "{robot: iiwa14}"), controller_scenario=resolve_scenario("fig6"))
    lab.run(0.1)
    summary = lab.teleop.summary(0.1)
    assert summary["rejected"]["slave_status"] == {"joint_count": 200} and summary["ticks"] == 200
    assert summary["healthy_ticks"] == 0 and summary["first_healthy"] is None
    assert all(c is None for c in lab.commands) and not np.any(lab.torques)
    assert "slave_status: 200 joint_count" in format_summary(
        {**summary, "duration": 0.1, "rate_hz": 2000.0, "epoch": 0.0,
         "timing": timing_summary(TickTimes(np.full(3, 1e-4), np.full(3, 1e-4), np.zeros(3), 0, 0.1, 5e-4))},
        "memq://")


def test_master_command_within_device_limits_under_faults():
    """σ = 1 and force scale 1: the tool's 31 N weight asks for more than the Phantom may render;
    with 5 % drops and 5 % NaN samples no command is non-finite or beyond its limits."""
    scenario = resolve_scenario("fig6", "{controller: {force: {sigma: 1.0},"
                                        " feedback: {force_scale: 1.0, torque_scale: 1.0}}}")
    lab = Lab(scenario, FaultInjection(drop_rate=0.05, nan_rate=0.05, seed=3), clutch_at=0.1)
    lab.run(1.0)
    assert np.all(np.isfinite(lab.torques)) and lab.teleop.torque_finite
    # The wrench on the hand each sent torque renders, τ_M = J_Mᵀ·[f; τ], with Drake's Jacobian.
    plant = MakeMasterPlant()
    context = plant.CreateDefaultContext()
    forces, torques = [], []
    for q, tau in zip(lab.master_q[::10], lab.torques[::10]):
        plant.SetPositions(context, q)
        wrench = np.linalg.solve(stylus_jacobian(plant, context, plant.GetFrameByName(BASE_FRAME),
                                                 plant.GetFrameByName(STYLUS_FRAME)).T, tau)
        forces.append(np.linalg.norm(wrench[:3]))
        torques.append(np.linalg.norm(wrench[3:]))
    assert max(forces) == pytest.approx(MAX_FORCE, rel=1e-6), "the clamp should be reached"
    assert max(torques) <= MAX_TORQUE * (1 + 1e-9)
    assert lab.teleop.stylus_force_peak == pytest.approx(max(forces), rel=1e-6)


def test_forces_off_within_the_timeout_once_the_lab_dies():
    lab = Lab(resolve_scenario("fig6"), FaultInjection(die_at_s=0.5))
    lab.run(0.6)  # the stand-in stops publishing at 0.5 s; the controller ticks on
    died = round(0.5 / PERIOD)
    torques = np.array(lab.torques)
    assert np.abs(torques[died - 10:died]).max() > 0, "forces should be on before the lab dies"
    off = died + np.flatnonzero(~np.abs(torques[died:]).any(axis=1))[0]
    assert (off - died) * PERIOD <= TIMEOUT + 2 * PERIOD
    assert not np.any(torques[off:])
    assert lab.teleop.faults and lab.teleop.faults[-1]["recovered"] is None


def test_a_stalled_controller_cuts_forces_and_ramps_back():
    """The controller misses 40 ms of ticks while the lab keeps publishing: its next tick
    sends no force, then forces ramp back in from zero."""
    lab = Lab(resolve_scenario("fig6"))
    lab.run(0.5)
    lab.run(0.04, controller=False)
    before = len(lab.torques)
    lab.run(0.1)
    torques = np.abs(np.array(lab.torques[before:])).max(axis=1)
    assert torques[0] == 0.0 and lab.teleop.faults[-1]["fault_bits"] & 0b1000
    assert lab.teleop.faults[-1]["recovered"] is not None
    ramp = HardwareStationParams().watchdog.ramp_time
    gains = np.array(lab.gains[before:])
    np.testing.assert_allclose(gains, np.minimum(1.0, np.arange(len(gains)) * PERIOD / ramp), atol=1e-9)


def test_the_controller_is_designed_for_the_rate_the_loop_runs_at():
    """`--rate` lays the loop's period over the scenario's ``controller_period``, and the controller,
    its mount notch among it, is designed for that period (at 4 kHz a notch designed for the
    scenario's 2 kHz would sit at twice its frequency)."""
    import argparse

    from heft.diagrams.commands.options import scenario_from

    bus = lcm.LCM("memq://")
    load = true_load(Scenario())[0]
    assert HardwareTeleop(Scenario(), load, bus, LcmChannels()).controller.period == Scenario().controller_period
    scenario = scenario_from(argparse.Namespace(scenario="fig6", set=None, rate=4000.0))
    assert scenario.controller_period == 0.00025
    assert HardwareTeleop(scenario, load, bus, LcmChannels()).controller.period == 0.00025
    with pytest.raises(ValueError, match="--rate must be a positive number of Hz"):
        scenario_from(argparse.Namespace(scenario="fig6", set=None, rate=0.0))


def test_a_grasp_and_release_over_lcm_split_the_load_and_are_answered():
    """With the estimator online, `heft load --grasp` (and the gripper driver's HOLDING) keep φ̂ in
    use as the gripper's, open the estimator's learning window, and are answered twice: at once and
    with the object's verdict when the window ends (not learned, at rest: the gate takes no sample
    without excitation); a release returns to the gripper's φ. With the estimate fixed, or a second
    grasp, the answer refuses with the reason."""
    from heft.hardware_interface.lcmtypes import heft_gripper_state

    fixed, _, _ = still_lab(lambda true: true)
    fixed.run(0.05)
    send(fixed, heft_load_command.GRASP)
    fixed.run(0.01)
    assert [a.accepted for a in fixed.answers] == [False] and "mode: online" in fixed.answers[0].message

    online = {"controller.estimator.mode": "online", "controller.estimator.learning_window": 0.1}
    lab, true, scenario = still_lab(lambda true: true, overrides=online)
    lab.run(0.05)
    send(lab, heft_load_command.GRASP)
    lab.run(0.01)
    send(lab, heft_load_command.GRASP)
    lab.run(0.15)
    first, refused, learned = lab.answers
    assert first.accepted and "grasp: the gripper's φ kept (m = 3.13 kg)" in first.message, first.message
    assert not refused.accepted and "already holds" in refused.message
    assert learned.accepted and learned.command_utime == first.command_utime
    assert learned.message.startswith("object not learned over 0.1 s: no sample taken;"), learned.message
    assert "its whole weight is felt as contact" in learned.message
    np.testing.assert_array_equal(lab.teleop.controller.phi_gripper, true.phi)
    send(lab, heft_load_command.RELEASE)
    lab.run(0.01)
    assert lab.answers[-1].accepted and "released" in lab.answers[-1].message
    assert not lab.teleop.controller.holding

    # The gripper's driver says the same on its own channel.
    for k, state in enumerate((heft_gripper_state.OPEN, heft_gripper_state.CLOSING, heft_gripper_state.HOLDING)):
        msg = heft_gripper_state()
        msg.utime, msg.state, msg.width = 1000 * (k + 1), state, 0.05
        lab.bus.publish(LcmChannels().gripper_state.name, msg.encode())
        lab.run(0.005)
    assert lab.answers[-1].message.startswith("gripper driver: grasp:") and lab.answers[-1].command_utime == 0
    assert lab.teleop.controller.holding
    assert lab.teleop.summary(1.0)["load_events"][-1].startswith("gripper driver: grasp:")


def test_an_online_estimator_needs_a_max_input_age_beyond_the_slowest_channel():
    """A lab whose arm reports at 250 Hz: readings 4 ms old are its steady stream, so the estimator's
    age limit must be well above that; the controller says so at its start, with a value that works."""
    scenario = layered(resolve_scenario("grasp"), overrides_text({"controller.estimator.mode": "online",
                                                                  "lab.lcm.slave_status.rate": 250.0}))
    truth, _ = true_load(scenario)
    with pytest.raises(ValueError, match=r"max_input_age \(5 ms\).*slave_status at 250 Hz: 4 ms.*10 ms or more"):
        HardwareTeleop(scenario, truth, lcm.LCM("memq://"), scenario.lab.lcm)
    scenario = layered(scenario, overrides_text({"controller.estimator.max_input_age": 0.01}))
    HardwareTeleop(scenario, truth, lcm.LCM("memq://"), scenario.lab.lcm)


def test_an_unrecorded_run_publishes_its_state_at_the_state_rate():
    """Not recorded, the teleop state still goes out while the controller steps, at ``STATE_RATE``."""
    from heft.diagrams.running.hardware_teleop import STATE_RATE

    lab = Lab(resolve_scenario("fig6"), state_every_tick=False)
    states = []
    lab.bus.subscribe(LcmChannels().teleop_state.name,
                      lambda _, payload: states.append(heft_teleop_state.decode(payload)))
    lab.run(0.5)
    healthy_seconds = lab.teleop.healthy_ticks * PERIOD
    assert healthy_seconds > 0.2 and abs(len(states) - STATE_RATE * healthy_seconds) <= 2, len(states)


def test_a_recorded_run_publishes_its_state_every_healthy_tick():
    """The teleop state goes out each healthy tick, with the applied wrench the stylus peak is judged by; the
    start never moves the slave, the clutch held moves it, the forces stay within the Phantom's limits."""
    scenario = resolve_scenario("fig6")
    lab = Lab(scenario, clutch_at=0.2)
    states = []
    lab.bus.subscribe(LcmChannels().teleop_state.name,
                      lambda _, payload: states.append(heft_teleop_state.decode(payload)))
    lab.run(1.2)
    # One state a healthy tick (the last tick's not yet handled by the bus).
    assert lab.teleop.healthy_ticks - 1 <= len(states) <= lab.teleop.healthy_ticks
    applied = np.array([state.applied_wrench for state in states])
    assert np.linalg.norm(applied[:, :3], axis=1).max() == pytest.approx(lab.teleop.stylus_force_peak)
    engaged = round(0.2 / PERIOD)
    before = np.array([c for c in lab.commands[:engaged] if c is not None])
    assert len(before) > 300 and lab.teleop.first_healthy is not None and not lab.teleop.faults
    np.testing.assert_allclose(before, np.repeat(before[:1], len(before), axis=0), atol=1e-12)
    after = np.array([c for c in lab.commands[engaged:] if c is not None])
    assert np.abs(after - after[0]).max() > 0.02, "the operator should have moved the slave"
    peaks = np.array(lab.stylus_wrenches)
    assert np.linalg.norm(peaks[:, :3], axis=1).max() <= MAX_FORCE + 1e-9
    assert np.isfinite(np.array(lab.torques)).all()


def test_the_hardware_controller_drives_a_touchs_motors_only_within_its_force():
    """With ``master: touch`` the hardware controller computes the Touch's kinematics and torques: against the
    stand-in's Touch, the load's whole weight fed back (force scale 1), it sends no torque to the wrist (the
    driver refuses none), drives the motors, and the force on the hand reaches the Touch's 3.3 N and no more."""
    scenario = resolve_scenario("fig6", overrides_text({"master": "touch", "controller.feedback.force_scale": 1.0}))
    lab = Lab(scenario, clutch_at=0.2)
    lab.run(1.0)
    torques = np.array(lab.torques)
    assert lab.teleop.first_healthy is not None and not lab.teleop.faults
    assert not torques[:, 3:].any() and np.abs(torques[:, :3]).max() > 0.1
    assert lab.stand_in.refused[LcmChannels().master_command.name] == {}
    forces = np.linalg.norm(np.array(lab.stylus_wrenches)[:, :3], axis=1)
    assert forces.max() == pytest.approx(3.3) and lab.stand_in.stylus_force_peak <= 3.3 * (1 + 1e-9)
