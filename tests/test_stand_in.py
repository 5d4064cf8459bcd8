"""The stand-in lab on an in-process memq:// bus, stepped with explicit times: the FT
sample against Drake's own statics and kinematics, the slave's setpoint following, the
master's motion and haptic safety, the channel rates, and every injected fault."""

import dataclasses
import json
import math
import os
import pickle
import subprocess
import sys

import lcm
import numpy as np
from scipy.signal import butter, lfilter, lfilter_zi
import pytest
from drake import lcmt_iiwa_command, lcmt_iiwa_status
from heft.diagrams.cli import main
from heft.diagrams.scenario import Scenario, layered, overrides_text, resolve_scenario
from heft.diagrams.plants import AddArmWithSensor, AddSlave
from heft.diagrams.stations.stand_in import (HAPTIC_WATCHDOG_S, FaultInjection, StandIn, _uniform, ft_samples_into,
                                             run_stand_in, stylus_force_at)
from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.ft_receiver import FtSampleReader
from heft.hardware_interface.lcm_mailbox import LcmMailbox, pump
from heft.hardware_interface.ft_messages import OFFSETS, decode_samples, pack_samples
from heft.hardware_interface.lcmtypes import heft_haptic_command, heft_haptic_state
from heft.systems.accelerometer_reading import motion_from_reading
from heft.systems.load_dynamics import noncontact_wrench
from heft.diagrams.plants import MakeMasterPlant
from heft.systems.controller.master_kinematics import BASE_FRAME, STYLUS_FRAME
from heft.systems.station.operator_hand import smooth_sine_offset
from heft.systems.serial_chain import SerialChain
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import JacobianWrtVariable

CHANNELS = LcmChannels()
NAMES = (CHANNELS.master_state.name, CHANNELS.slave_status.name, CHANNELS.ft_sample.name)
DECODERS = dict(zip(NAMES, (lambda payload: [heft_haptic_state.decode(payload)],
                            lambda payload: [lcmt_iiwa_status.decode(payload)], decode_samples)))
"""Channel name → the messages of one payload (an FT message holds several samples)."""
DELTA = np.array([0.1, -0.1, 0.1, 0.2, -0.2, 0.3])
G_W = np.array([0.0, 0.0, -9.81])  # m/s², gravity in the world (R = W)
"""A slave command step away from the start pose (rad)."""


def reader_of(scenario: Scenario) -> FtSampleReader:
    """The controller's reader of the scenario's sensor (its full scale; a source silent 50 ms gives way)."""
    return FtSampleReader(scenario.ft_sensor.full_scale + scenario.accelerometer.full_scale, 0.05)


def quiet_scenario(overrides: dict | None = None) -> Scenario:
    """Ideal wrist sensors (no disturbances, no filter), the load welded at S, the arm's true joint
    velocities and a still operator: what is published is the model's truth; then ``overrides``
    (dotted fields) laid over it."""
    quiet = layered(Scenario(), overrides_text({
        "operator.amplitude": [0.0, 0.0, 0.0], "load.mount.rigid": True, "slave_velocity_filter": 0.0,
        "ft_sensor.noise": False, "ft_sensor.lowpass_cutoff": 0.0,
        "accelerometer.noise": False, "accelerometer.lowpass_cutoff": 0.0}))
    return layered(quiet, overrides_text(overrides)) if overrides else quiet


class Lab:
    """A ``StandIn`` on memq:// with a listener on each published channel."""

    def __init__(self, scenario=None, faults=None, **kwargs):
        self.scenario = scenario or quiet_scenario()
        self.bus = lcm.LCM("memq://")
        self.stand_in = StandIn(self.scenario, self.bus, CHANNELS, faults, **kwargs)
        self._boxes = {name: LcmMailbox(self.bus, name, keep=10**6) for name in NAMES}
        self.payloads = {name: [] for name in NAMES}

    def run(self, until: float, dt: float = 0.001) -> bool:
        """Steps to ``until`` (s) every ``dt`` s and collects what was published; the last step's result."""
        now = self.stand_in.next_due
        while now < until + 1e-12:
            self.step(now)
            now += dt
        return self.step(until)

    def step(self, now: float) -> bool:
        alive = self.stand_in.step(now)
        pump(self.bus)
        for name, box in self._boxes.items():
            self.payloads[name] += box.take()
        return alive

    def messages(self, name: str) -> list:
        """What was published on channel ``name``, one message per sample (an FT message's split)."""
        return [msg for payload in self.payloads[name] for msg in DECODERS[name](payload)]

    def command_slave(self, q, num_joints: int = 6):
        msg = lcmt_iiwa_command()
        msg.num_joints, msg.joint_position = num_joints, list(q)
        self.bus.publish(CHANNELS.slave_command.name, msg.encode())

    def command_master(self, torque, enable: bool = True, master_utime: int = 0):
        msg = heft_haptic_command()
        msg.num_joints, msg.torque, msg.enable = len(torque), list(torque), enable
        msg.master_utime = master_utime
        self.bus.publish(CHANNELS.master_command.name, msg.encode())


class SlavePlant:
    """Drake's own plant of arm, sensor and load (``AddSlave``), for independent references."""

    def __init__(self, scenario: Scenario):
        self.plant = MultibodyPlant(time_step=0.0)
        self.parts = AddSlave(self.plant, scenario)
        self.plant.Finalize()
        self.context = self.plant.CreateDefaultContext()

    def set_state(self, q, v=np.zeros(6)):
        self.plant.SetPositions(self.context, q)
        self.plant.SetVelocities(self.context, v)

    def R_WS(self) -> np.ndarray:
        return self.X_WS().rotation().matrix()

    def X_WS(self):
        return self.plant.CalcRelativeTransform(self.context, self.plant.world_frame(), self.parts.S)

    def velocity_of_S(self, p_SA=np.zeros(3)):
        """(ω_WS, v_WA) in W (rad/s, m/s) of the point A fixed at ``p_SA`` in S (m; S's origin)."""
        V = self.parts.S.CalcSpatialVelocityInWorld(self.context).Shift(self.R_WS() @ p_SA)
        return V.rotational(), V.translational()


# --- the wrist sensor ------------------------------------------------------------------------

def test_still_tool_weighs_on_the_sensor_as_drake_says():
    """Still arm: the FT round trip (sensor sign flipped back, offsets removed) is the 3.13 kg
    tool held against gravity, f = −m·g in S and τ = p_SC × f, from Drake's own model; the
    accelerometer reads 9.81 m/s² upwards."""
    scenario = quiet_scenario({"ft_sensor.noise": True,  # offsets only
                               "ft_sensor.white_noise": False, "ft_sensor.drift": False,
                               "ft_sensor.quantization": False})
    lab = Lab(scenario)
    lab.run(0.05)
    samples = lab.payloads[CHANNELS.ft_sample.name]
    reader = reader_of(scenario)
    reader.take(samples, 0.05)
    np.testing.assert_allclose(lab.stand_in.offsets, scenario.ft_sensor.initial_offsets)

    slave = SlavePlant(scenario)
    slave.set_state(scenario.slave_initial_q)
    instance = [slave.parts.load_bodies[0].model_instance()]
    mass = slave.plant.CalcTotalMass(slave.context, instance)
    assert mass == pytest.approx(3.13)
    R_SW, p_WS = slave.R_WS().T, slave.X_WS().translation()
    p_SC = R_SW @ (slave.plant.CalcCenterOfMassPositionInWorld(slave.context, instance) - p_WS)
    f = R_SW @ np.array([0.0, 0.0, mass * 9.81])
    expected = np.concatenate((f, np.cross(p_SC, f)))
    np.testing.assert_allclose(reader.wrench - lab.stand_in.offsets, expected, atol=1e-9)
    # On the wire, the sensor's sign: the load pulls the sensor down.
    last = decode_samples(samples[-1])[-1]
    np.testing.assert_allclose(slave.R_WS() @ (np.array(last.wrench[:3]) + lab.stand_in.offsets[:3]),
                               [0.0, 0.0, -mass * 9.81], atol=1e-9)
    # The accelerometer reports specific force: one g, pointing up in the world.
    np.testing.assert_allclose(slave.R_WS() @ np.array(last.acceleration[:3]), [0.0, 0.0, 9.81], atol=1e-9)
    np.testing.assert_array_equal(last.acceleration[3:], np.zeros(3))
    np.testing.assert_allclose(lab.stand_in.phi_true[:4], np.concatenate(([mass], mass * p_SC)), atol=1e-12)


@pytest.fixture(scope="module")
def moving():
    """The slave commanded DELTA away at 0.1 s, run to 0.5 s (settled)."""
    lab = Lab()
    lab.run(0.1)
    lab.command_slave(np.asarray(lab.scenario.slave_initial_q) + DELTA)
    lab.run(0.5)
    return lab


def test_sensor_acceleration_is_the_derivative_of_the_velocity_of_S(moving):
    """The FT sample's accelerometer reading is d/dt of the spatial velocity of the accelerometer's
    point A in S (Drake, from the published joint state) minus gravity, expressed in S; checked by
    central differences."""
    statuses = moving.messages(CHANNELS.slave_status.name)
    ft = {m.utime: m for m in moving.messages(CHANNELS.ft_sample.name)}
    slave, period = SlavePlant(moving.scenario), 1.0 / CHANNELS.slave_status.rate
    p_SA = np.array(moving.scenario.accelerometer.position)
    assert np.linalg.norm(p_SA) > 0.01  # the default accelerometer is off S's origin

    def velocity(status):
        slave.set_state(status.joint_position_measured, status.joint_velocity_estimated)
        return slave.R_WS(), *slave.velocity_of_S(p_SA)

    errors, peak = [], 0.0
    for before, now, after in zip(statuses, statuses[1:], statuses[2:]):
        if now.utime < 102_000 or before.joint_position_ipo != before.joint_position_commanded:
            continue  # the filter's acceleration steps with its input: the command at 0.1 s, then the setpoint
            # that approaches it at the speed limits (joint_position_ipo) one status step at a time
        R_WS, _, _ = velocity(now)
        (_, w0, v0), (_, w1, v1) = velocity(before), velocity(after)
        expected = np.concatenate((R_WS.T @ ((v1 - v0) / (2 * period) - G_W), R_WS.T @ (w1 - w0) / (2 * period)))
        measured = np.array(ft[now.utime].acceleration)
        errors.append(np.abs(measured - expected).max())
        peak = max(peak, np.abs(measured).max())
    assert peak > 100.0  # it really moved
    assert max(errors) < 0.01 * peak


def test_the_sensors_filter_is_a_butterworth_on_the_published_samples(moving):
    """With the JR3's 500 Hz filter on, the same motion publishes the unfiltered samples through a
    second-order Butterworth at the 8 kHz sample rate (scipy's design and filter, started in steady
    state): the wrench and the accelerometer alike."""
    scenario = quiet_scenario({"ft_sensor.lowpass_cutoff": 500.0, "accelerometer.lowpass_cutoff": 500.0})
    lab = Lab(scenario)
    lab.run(0.1)
    lab.command_slave(np.asarray(lab.scenario.slave_initial_q) + DELTA)
    lab.run(0.5)
    b, a = butter(2, 500.0, fs=CHANNELS.ft_sample.rate)
    for field in ("wrench", "acceleration"):
        raw = np.array([getattr(m, field) for m in moving.messages(CHANNELS.ft_sample.name)])
        filtered = np.array([getattr(m, field) for m in lab.messages(CHANNELS.ft_sample.name)])
        expected, _ = lfilter(b, a, raw, axis=0, zi=lfilter_zi(b, a)[:, None] * raw[0])
        assert np.abs(filtered - raw).max() > 1.0  # the filter mattered in this motion
        np.testing.assert_allclose(filtered, expected, atol=1e-9 * np.abs(raw).max())


def test_moving_wrench_is_v_phi_on_the_held_kinematics(moving):
    """Each FT sample is V(a, α, ω, g)·φ_true with the kinematics of the latest slave status
    (ω and g from Drake's pose and velocity of S); between statuses they are held."""
    slave = SlavePlant(moving.scenario)
    statuses = {m.utime: m for m in moving.messages(CHANNELS.slave_status.name)}
    checked = 0
    ft_per_status = round(CHANNELS.ft_sample.rate / CHANNELS.slave_status.rate)
    for sample in moving.messages(CHANNELS.ft_sample.name):
        held = (sample.sample_counter // ft_per_status) * ft_per_status
        status = statuses.get(round(held / CHANNELS.ft_sample.rate * 1e6))
        if status is None:  # before the first status: the start pose, at rest
            continue
        slave.set_state(status.joint_position_measured, status.joint_velocity_estimated)
        R_SW = slave.R_WS().T
        omega = R_SW @ slave.velocity_of_S()[0]
        g = R_SW @ G_W
        a = motion_from_reading(np.empty(6), np.array(sample.acceleration), g, omega,
                                moving.scenario.accelerometer.convention())
        expected = noncontact_wrench(moving.stand_in.phi_true, a[:3], a[3:], omega, g)
        # Positions on the wire are encoder-quantised (2π/2²⁰ rad): ω and g agree to that.
        np.testing.assert_allclose(-np.array(sample.wrench), expected, atol=2e-3)
        checked += 1
    assert checked > 0.99 * 0.5 * CHANNELS.ft_sample.rate


# --- the slave ---------------------------------------------------------------------------------

def test_slave_holds_until_commanded_then_settles_on_the_setpoint(moving):
    q0 = np.asarray(moving.scenario.slave_initial_q)
    statuses = moving.messages(CHANNELS.slave_status.name)
    before = [m for m in statuses if m.utime <= 100_000]
    assert len(before) == 200
    for m in before:
        np.testing.assert_allclose(m.joint_position_measured, q0, atol=1e-5)  # encoder counts
        assert m.joint_position_measured == before[0].joint_position_measured
        np.testing.assert_array_equal(m.joint_velocity_estimated, np.zeros(6))
        np.testing.assert_array_equal(m.joint_position_commanded, q0)
    last = statuses[-1]
    assert last.num_joints == 6 and last.utime == 500_000
    np.testing.assert_allclose(last.joint_position_measured, q0 + DELTA, atol=1e-5)
    np.testing.assert_allclose(last.joint_velocity_estimated, 0.0, atol=1e-5)
    np.testing.assert_allclose(last.joint_position_commanded, q0 + DELTA)
    np.testing.assert_array_equal(last.joint_torque_measured, np.zeros(6))
    # The filter and each joint's servo are critically damped; the joints pulling on each other
    # overshoot the setpoint a little.
    travelled = np.array([m.joint_position_measured for m in statuses]) - q0
    assert (travelled / DELTA).max() < 1.1
    np.testing.assert_allclose(moving.stand_in.slave_position, q0 + DELTA, atol=1e-9)


def test_a_command_that_jumps_is_followed_within_the_speed_limits():
    """The arm's controller limits its joints' speed: a command 0.5 rad away (a stand-in that ran
    late, a re-anchored controller) is approached by the setpoint (``joint_position_ipo``) at the
    URDF's speed limits exactly; the joints behind the filter and the servo, pulling on each other,
    exceed them by less than a fifth."""
    lab = Lab()
    lab.run(0.02)
    lab.command_slave(np.asarray(lab.scenario.slave_initial_q) + 0.5)
    lab.run(0.5)
    statuses = lab.messages(CHANNELS.slave_status.name)
    setpoint_speed = np.abs(np.diff([m.joint_position_ipo for m in statuses], axis=0)) * CHANNELS.slave_status.rate
    velocities = np.abs([m.joint_velocity_estimated for m in statuses])
    plant = MultibodyPlant(0.0)
    AddArmWithSensor(plant, lab.scenario.robot)
    plant.Finalize()
    limits = plant.GetVelocityUpperLimits()
    np.testing.assert_allclose(setpoint_speed.max(axis=0), limits, rtol=1e-9)
    assert np.all(velocities < 1.2 * limits) and np.all(velocities.max(axis=0) > 0.9 * limits)


def test_malformed_slave_commands_keep_the_last_setpoint():
    lab = Lab()
    q0 = np.asarray(lab.scenario.slave_initial_q)
    lab.command_slave(q0 + DELTA)
    lab.step(0.01)
    lab.command_slave((q0 + 2 * DELTA)[:5], num_joints=5)
    lab.command_slave(np.full(6, np.nan))
    lab.bus.publish(CHANNELS.slave_command.name, b"not a command")
    lab.step(0.02)
    np.testing.assert_array_equal(lab.stand_in.slave_command, q0 + DELTA)
    assert lab.stand_in.received[CHANNELS.slave_command.name] == 4
    assert lab.stand_in.refused == {CHANNELS.master_command.name: {},
                                    CHANNELS.slave_command.name: {"joint_count": 1, "non_finite": 1, "undecodable": 1}}


def test_a_seven_joint_arm_reports_and_takes_seven_joints_only():
    """The scenario's iiwa: its driver publishes 7 joints, follows a 7-joint command and refuses one of six (an
    RX's controller on its channel), counting it by its reason."""
    lab = Lab(quiet_scenario({"robot": "iiwa14"}))
    q0 = np.asarray(lab.scenario.slave_initial_q)
    assert lab.stand_in.num_joints == len(q0) == 7
    step = np.append(DELTA, -0.1)
    lab.command_slave(q0 + step, num_joints=7)
    lab.step(0.01)
    lab.command_slave(q0[:6], num_joints=6)
    lab.run(0.5)
    statuses = lab.messages(CHANNELS.slave_status.name)
    assert {m.num_joints for m in statuses} == {7}
    np.testing.assert_allclose(statuses[-1].joint_position_measured, q0 + step, atol=1e-5)
    np.testing.assert_array_equal(lab.stand_in.slave_command, q0 + step)
    assert lab.stand_in.refused[CHANNELS.slave_command.name] == {"joint_count": 1}



def test_the_arm_counts_its_steps_that_take_two_commands_after_one_that_took_none():
    """One valid command a step is the controller in step with the arm; none, then two, is one count
    (the setpoint stalled, then jumped); a malformed command beside a valid one is not a second."""
    lab = Lab()
    q0, rate = np.asarray(lab.scenario.slave_initial_q), CHANNELS.slave_status.rate
    for k in range(1, 5):
        lab.command_slave(q0 + k * 1e-3)
        lab.step(k / rate)
    assert lab.stand_in.arm_steps_after_a_held_one == 0
    lab.step(5 / rate)  # no command: the arm holds
    lab.command_slave(q0 + 5e-3)
    lab.command_slave(q0 + 6e-3)
    lab.step(6 / rate)
    lab.command_slave(q0 + 7e-3)
    lab.bus.publish(CHANNELS.slave_command.name, b"not a command")
    lab.step(7 / rate)
    assert lab.stand_in.arm_steps_after_a_held_one == 1
    np.testing.assert_array_equal(lab.stand_in.slave_command, q0 + 7e-3)

# --- the master --------------------------------------------------------------------------------

def test_master_follows_the_operator_reference():
    """Still before ``operator.start_time``; then the stylus follows the reference offset to first
    order, and the published velocity integrates to the published position."""
    scenario = Scenario()
    lab = Lab(scenario)
    lab.run(0.7)
    states = lab.messages(CHANNELS.master_state.name)
    t = np.array([m.utime for m in states]) * 1e-6
    q = np.array([m.position for m in states])
    v = np.array([m.velocity for m in states])
    still = t < scenario.operator.start_time
    np.testing.assert_allclose(q[still], np.tile(scenario.master_initial_q, (still.sum(), 1)), atol=1e-4)
    np.testing.assert_array_equal(v[still], 0.0)
    integrated = q[0] + np.concatenate(([np.zeros(6)], np.cumsum((v[1:] + v[:-1]) / 2 * np.diff(t)[:, None], axis=0)))
    np.testing.assert_allclose(q, integrated, atol=2e-4)  # encoder counts plus the trapezoid's error

    plant = MakeMasterPlant()
    context = plant.CreateDefaultContext()
    B, E = plant.GetFrameByName(BASE_FRAME), plant.GetFrameByName(STYLUS_FRAME)

    def stylus(position):
        plant.SetPositions(context, position)
        return plant.CalcRelativeTransform(context, B, E).translation()

    op = scenario.operator
    offset, _ = smooth_sine_offset(t[-1], op.start_time, op.frequency, op.amplitude)
    assert np.linalg.norm(offset) > 0.5 * np.linalg.norm(op.amplitude)
    np.testing.assert_allclose(stylus(q[-1]) - stylus(q[0]), offset, atol=0.1 * np.linalg.norm(op.amplitude))


def test_the_driver_judges_the_rendered_force_at_the_state_a_command_names():
    """A torque clamped to 8.5 N at a position the driver published renders 8.5 N there, by
    Drake's Jacobian of the Phantom, while the stylus has moved on; the same torque computed 0.3 rad
    off (another publisher's position) renders another force; a command naming a state the driver
    never published is judged at the present position."""
    plant = MakeMasterPlant()
    context = plant.CreateDefaultContext()
    B, E = plant.GetFrameByName(BASE_FRAME), plant.GetFrameByName(STYLUS_FRAME)

    def jacobian(position):
        plant.SetPositions(context, position)
        return plant.CalcJacobianSpatialVelocity(context, JacobianWrtVariable.kV, E, np.zeros(3), B, B)  # [ω; v]

    def peak(offset: float, names_state: bool) -> tuple[float, float]:
        """The driver's judge of an 8.5 N torque computed ``offset`` rad off a 0.1 s old state, and
        that torque's force at the present position."""
        lab = Lab(scenario=Scenario())
        start = lab.scenario.operator.start_time
        lab.run(start + 0.3)
        state = [m for m in lab.messages(CHANNELS.master_state.name) if m.utime <= (start + 0.2) * 1e6][-1]
        torque = jacobian(np.asarray(state.position) + offset).T @ np.array([0, 0, 0, 0.0, 0.0, -8.5])
        lab.command_master(torque, master_utime=state.utime if names_state else 0)
        lab.step(start + 0.3)  # takes the command; the stylus stays where it is until the next step
        present = lab.stand_in.master_position
        assert np.abs(present - state.position).max() > 1e-3  # the stylus has moved on
        return lab.stand_in.stylus_force_peak, float(np.linalg.norm(np.linalg.solve(jacobian(present).T, torque)[3:]))

    at_state, _ = peak(0.0, names_state=True)
    elsewhere, _ = peak(0.3, names_state=True)
    unnamed, present = peak(0.0, names_state=False)
    assert at_state == pytest.approx(8.5, rel=1e-9) and abs(elsewhere - 8.5) > 0.1, (at_state, elsewhere)
    assert unnamed == pytest.approx(present, rel=1e-9) and abs(unnamed - 8.5) > 1e-3, (unnamed, present)


def test_haptic_driver_applies_only_valid_commands_and_times_out():
    lab = Lab()
    torque = [0.1, -0.2, 0.3, 0.01, -0.02, 0.03]
    lab.step(0.1)
    lab.command_master(torque)
    lab.step(0.1)
    np.testing.assert_array_equal(lab.stand_in.master_torque, torque)
    lab.run(0.1 + HAPTIC_WATCHDOG_S - 0.001)
    np.testing.assert_array_equal(lab.stand_in.master_torque, torque)
    lab.run(0.1 + HAPTIC_WATCHDOG_S + 0.001)
    np.testing.assert_array_equal(lab.stand_in.master_torque, np.zeros(6))
    states = lab.messages(CHANNELS.master_state.name)
    applied = [m for m in states if any(m.torque_applied)]
    assert applied and all(list(m.torque_applied) == torque for m in applied)
    assert applied[-1].utime < (0.1 + HAPTIC_WATCHDOG_S) * 1e6
    np.testing.assert_array_equal(states[-1].torque_applied, np.zeros(6))

    for bad in ((torque, False), ([math.nan] + torque[1:], True), (torque[:5], True)):
        lab.command_master(torque)
        lab.step(lab.stand_in.next_due)
        np.testing.assert_array_equal(lab.stand_in.master_torque, torque)
        lab.command_master(*bad)
        lab.step(lab.stand_in.next_due)
        np.testing.assert_array_equal(lab.stand_in.master_torque, np.zeros(6))
    lab.command_master([10.0, -10.0, 1.0, 1.0, -1.0, 0.1])  # beyond the amplifiers' limits
    lab.step(lab.stand_in.next_due)
    np.testing.assert_allclose(lab.stand_in.master_torque, [3.27, -3.27, 1.0, 0.188, -0.188, 0.1])
    assert lab.stand_in.received[CHANNELS.master_command.name] == 8
    # A disabled command is valid (no torque); the NaN and the five joints are refused, counted.
    assert lab.stand_in.refused[CHANNELS.master_command.name] == {"joint_count": 1, "non_finite": 1}



def touch_scenario(overrides: dict | None = None) -> Scenario:
    """``Scenario()`` with the Touch-type master (``master: touch``), then ``overrides``."""
    touch = resolve_scenario("fig6", "{master: touch}")
    return layered(touch, overrides_text(overrides)) if overrides else touch


def test_a_touch_driver_drives_its_three_motors_and_refuses_torque_on_its_wrist():
    """The Touch's driver applies torque on its three motors, clipped to their 0.88 N·m (its URDF's efforts), and
    refuses a command with torque on a wrist joint (no motor there) as "unactuated", its force off at once."""
    lab = Lab(touch_scenario())
    lab.step(0.1)
    torque = [0.1, -0.2, 0.3, 0.0, 0.0, 0.0]
    lab.command_master(torque)
    lab.step(lab.stand_in.next_due)
    np.testing.assert_array_equal(lab.stand_in.master_torque, torque)
    for wrist in (3, 4, 5):
        lab.command_master(torque)
        lab.step(lab.stand_in.next_due)
        np.testing.assert_array_equal(lab.stand_in.master_torque, torque)
        bad = list(torque)
        bad[wrist] = 1e-6
        lab.command_master(bad)
        lab.step(lab.stand_in.next_due)
        np.testing.assert_array_equal(lab.stand_in.master_torque, np.zeros(6))
    lab.command_master([2.0, -2.0, 0.5, 0.0, -0.0, 0.0])  # beyond the motors' limits; -0.0 is no torque
    lab.step(lab.stand_in.next_due)
    np.testing.assert_allclose(lab.stand_in.master_torque, [0.88, -0.88, 0.5, 0.0, 0.0, 0.0])
    lab.command_master([0.0, 0.0, 0.0, 0.3, 0.0, 0.0], enable=False)  # disabled, but torque on the wrist
    lab.step(lab.stand_in.next_due)
    np.testing.assert_array_equal(lab.stand_in.master_torque, np.zeros(6))
    assert lab.stand_in.refused[CHANNELS.master_command.name] == {"unactuated": 4}


def test_the_phantom_driver_takes_torque_on_its_wrist():
    """The Phantom Premium's six joints all have motors: a wrist torque is applied, nothing refused."""
    lab = Lab()
    lab.step(0.1)
    lab.command_master([0.0, 0.0, 0.0, 0.1, -0.1, 0.05])
    lab.step(lab.stand_in.next_due)
    np.testing.assert_array_equal(lab.stand_in.master_torque, [0.0, 0.0, 0.0, 0.1, -0.1, 0.05])
    assert lab.stand_in.refused[CHANNELS.master_command.name] == {}


def test_the_touch_driver_judges_the_force_by_the_touchs_own_jacobian():
    """A command rendering 3.3 N at the stylus of the Touch by Drake's Jacobian of the Touch (its wrist rows
    zero: the wrist's axes meet at E) is judged 3.3 N by the Touch's driver; the same torque on the Phantom's
    driver renders another force (another arm)."""
    plant = MakeMasterPlant("touch")
    context = plant.CreateDefaultContext()
    B, E = plant.GetFrameByName(BASE_FRAME), plant.GetFrameByName(STYLUS_FRAME)

    def peak(scenario) -> tuple[float, np.ndarray]:
        lab = Lab(scenario)
        start = lab.scenario.operator.start_time
        lab.run(start + 0.1)
        state = lab.messages(CHANNELS.master_state.name)[-1]
        plant.SetPositions(context, np.asarray(state.position))
        J = plant.CalcJacobianSpatialVelocity(context, JacobianWrtVariable.kV, E, np.zeros(3), B, B)  # [ω; v]
        torque = J.T @ np.array([0.0, 0.0, 0.0, 1.9, 0.0, -2.7])  # 3.3 N
        np.testing.assert_allclose(torque[3:], 0.0, atol=1e-12)
        torque[3:] = 0.0
        lab.command_master(torque, master_utime=state.utime)
        lab.step(start + 0.1)
        assert lab.stand_in.refused[CHANNELS.master_command.name] == {}
        return lab.stand_in.stylus_force_peak, torque

    touch, torque = peak(touch_scenario())
    assert touch == pytest.approx(np.hypot(1.9, 2.7), rel=1e-9) and np.abs(torque).max() < 0.88
    phantom, _ = peak(Scenario())
    assert abs(phantom - touch) > 0.1, (phantom, touch)


def test_the_device_limits_are_the_scenarios_masters(monkeypatch):
    """The station checks the master's states against the scenario's master's URDF (the Touch's limits happen to
    equal the Phantom's: the plant asked for is what tells)."""
    import heft.diagrams.device_limits as module

    asked = []
    monkeypatch.setattr(module, "MakeMasterPlant", lambda master: asked.append(master) or MakeMasterPlant(master))
    limits = module.device_limits(touch_scenario())
    touch = MakeMasterPlant("touch")
    assert asked == ["touch"]
    np.testing.assert_array_equal(limits.master_lower, touch.GetPositionLowerLimits())
    np.testing.assert_array_equal(limits.master_upper, touch.GetPositionUpperLimits())
    np.testing.assert_array_equal(limits.master_velocity, touch.GetVelocityUpperLimits())



def test_clutch_button_is_held_in_its_interval():
    lab = Lab(clutch_at=0.05, clutch_release_at=0.1)
    lab.run(0.15)
    for m in lab.messages(CHANNELS.master_state.name):
        assert m.buttons == (1 if 50_000 <= m.utime < 100_000 else 0), m.utime
    default = Lab()
    default.run(0.01)
    assert all(m.buttons == 1 for m in default.messages(CHANNELS.master_state.name))


# --- rates and stamps --------------------------------------------------------------------------

def test_counts_are_the_nominal_rates_also_when_stepped_late():
    lab = Lab(Scenario())
    assert lab.step(0.01)
    # FT: samples 1–3, then an arm step's 4 a message, sent when its newest is due.
    assert lab.stand_in.published == dict(zip(NAMES, (20, 20, 20)))
    lab.run(1.0, dt=0.0137)
    assert lab.stand_in.published == dict(zip(NAMES, (2000, 2000, 2000)))
    for name, rate, count in zip(NAMES, (2000, 2000, 8000), (2000, 2000, 7999)):  # sample 8000 opens a message
        utimes = [m.utime for m in lab.messages(name)]
        assert utimes == [round(k / rate * 1e6) for k in range(1, count + 1)]
    assert [m.sample_counter for m in lab.messages(NAMES[2])] == list(range(1, 8000))


def test_what_is_published_does_not_depend_on_how_the_lab_is_stepped():
    fine, coarse = Lab(Scenario()), Lab(Scenario())
    fine.run(0.05, dt=1 / 8000)
    coarse.step(0.05)
    assert fine.payloads == coarse.payloads


def test_a_late_lab_publishes_every_channel_in_time_order():
    """Stepped 50 ms late, the lab sends its backlog in the order of the messages' times (an FT
    message at its newest sample's), not one channel after another."""
    bus = lcm.LCM("memq://")
    lab = StandIn(Scenario(), bus, CHANNELS)
    stamps = []
    for name in NAMES:
        bus.subscribe(name, lambda _, payload, name=name: stamps.append(DECODERS[name](payload)[-1].utime))
    lab.step(0.05)
    pump(bus)
    assert len(stamps) == 3 * 100 and stamps == sorted(stamps)


# --- faults ------------------------------------------------------------------------------------

def test_uniform_is_uniform_and_fixed():
    u = np.array([_uniform(3, 1, k) for k in range(20000)])
    assert 0.0 <= u.min() and u.max() < 1.0 and abs(u.mean() - 0.5) < 0.01
    assert _uniform(3, 1, 5) == _uniform(3, 1, 5) != _uniform(4, 1, 5)


def _ft_counters(lab):
    return np.array([m.sample_counter for m in lab.messages(CHANNELS.ft_sample.name)])


def test_losses_come_in_bursts_and_repeat_with_the_seed():
    faults = FaultInjection(drop_rate=0.01, burst_loss_s=0.002, seed=7)
    runs = [Lab(faults=faults) for _ in range(2)] + [Lab(faults=dataclasses.replace(faults, seed=8))]
    for lab in runs:
        lab.step(2.0)
    assert runs[0].payloads == runs[1].payloads != runs[2].payloads
    for name in NAMES:  # 2000 messages a second each (FT: 4 samples a message); about 4 % lost
        assert 0.6 * 2.0 * 2000 < runs[0].stand_in.published[name] < 0.985 * 2.0 * 2000
    gaps = np.diff(_ft_counters(runs[0])) - 1
    assert gaps[gaps > 0].min() >= 0.002 * CHANNELS.ft_sample.rate  # whole bursts are lost


def test_nan_samples():
    lab = Lab(faults=FaultInjection(nan_rate=0.25, seed=3))
    lab.step(0.25)
    samples = lab.messages(CHANNELS.ft_sample.name)
    nan = np.array([np.isnan(m.wrench).all() for m in samples])
    assert len(samples) == 1999 and 0.2 < nan.mean() < 0.3  # sample 2000 opens the next message
    assert np.isfinite([m.acceleration for m in samples]).all()
    reader = reader_of(resolve_scenario("fig6"))
    reader.take([s.encode() for s in samples if np.isnan(s.wrench).all()][-1:], 0.25)
    assert reader.non_finite


def test_saturation_from_its_time_on():
    lab = Lab(faults=FaultInjection(saturate_at_s=0.05))
    lab.run(0.1)
    for m in lab.messages(CHANNELS.ft_sample.name):
        assert m.saturated == (0x3F if m.utime >= 50_000 else 0), m.utime


def test_death_stops_every_channel():
    lab = Lab(faults=FaultInjection(die_at_s=0.1))
    assert lab.step(0.05)
    assert not lab.step(0.2)
    assert lab.stand_in.published == dict(zip(NAMES, (199, 199, 200)))  # FT: samples 1–3, then 4 a message
    assert not lab.step(0.3)
    assert lab.stand_in.published == dict(zip(NAMES, (199, 199, 200)))  # FT: samples 1–3, then 4 a message
    assert max(m.utime for m in lab.messages(NAMES[2])) < 100_000


def test_reordered_messages_arrive_after_the_next_one():
    lab = Lab(faults=FaultInjection(reorder_rate=0.1, seed=5))
    lab.run(0.2)
    for name, rate, per_message in zip(NAMES, (2000, 2000, 8000), (1, 1, 4)):
        stamps = np.array([DECODERS[name](payload)[-1].utime for payload in lab.payloads[name]])  # newest sample's
        late = np.flatnonzero(np.diff(stamps) < 0)
        assert 0.05 * len(stamps) < len(late) < 0.15 * len(stamps)
        assert (np.diff(late) > 1).all()  # one message held at a time, swapped with the next
        utimes = [m.utime for m in lab.messages(name)]
        expected = [round(k / rate * 1e6) for k in range(1, round(0.2 * rate) + 1)]
        # Not yet sent: a message held back, and FT's samples of a message still filling (3).
        assert sorted(utimes) == expected[:len(utimes)] and len(expected) - len(utimes) <= 2 * per_message - 1


def test_added_delay_holds_ft_samples_back():
    lab = Lab(faults=FaultInjection(added_delay_s=0.005))
    for now in np.arange(0.001, 0.05, 0.001):
        lab.step(now)
        newest = {name: max([DECODERS[name](p)[-1].utime for p in lab.payloads[name]], default=0) for name in NAMES}
        assert newest[NAMES[1]] == round(now * 1e6)
        # An FT message goes out 5 ms after its newest sample (index 4k + 3) is due.
        assert newest[NAMES[2]] == max(0, round((4 * ((round((now - 0.005) * 8000) + 1) // 4) - 1) / 8000 * 1e6))
    samples = lab.messages(NAMES[2])
    assert [m.utime for m in samples] == [round(m.sample_counter / 8000 * 1e6) for m in samples]


# --- running it --------------------------------------------------------------------------------

def test_run_stand_in_on_a_fake_clock(fake_clock):
    clock = fake_clock
    summary = run_stand_in(quiet_scenario(), LcmChannels(lcm_url="memq://"), 0.05, clock=clock, sleep=clock.sleep)
    assert not summary["died"] and summary["duration_s"] == pytest.approx(0.05)
    assert summary["published"] == dict(zip(NAMES, (100, 100, 100)))  # FT: 4 samples a message
    for name in NAMES:
        assert summary["published_hz"][name] == pytest.approx(2000)
    assert summary["max_lateness_ms"] == pytest.approx(0.0, abs=1e-6)


def test_a_starved_stand_in_stops_when_asked(fake_clock):
    """A stand-in whose machine gives it a tenth of real time falls ever further behind; a stop
    request still ends it after one bounded step, not after its whole backlog."""
    clock, stops = fake_clock, []

    def stop():  # asked after each step, each of which took a second of wall time
        clock.t += 1.0
        stops.append(clock())
        return len(stops) == 20

    summary = run_stand_in(quiet_scenario(), LcmChannels(lcm_url="memq://"), 1000.0, clock=clock,
                           sleep=clock.sleep, stop=stop)
    assert len(stops) == 20 and not summary["died"]
    assert summary["duration_s"] == pytest.approx(20.0)
    assert summary["max_lateness_ms"] > 1e4  # it reports how far behind the wall clock it fell
    by_second = summary["lateness_ms_by_second"]  # and when: in the first second of its clock, the one it reached
    assert len(by_second) == 1000 and by_second[0] > 1e4 and not any(by_second[2:])
    assert summary["published"][NAMES[2]] <= 20 * 0.05 * 2000 + 1  # 20 steps of at most 50 ms each


def test_run_stand_in_returns_when_the_lab_dies(fake_clock):
    clock = fake_clock
    summary = run_stand_in(quiet_scenario(), LcmChannels(lcm_url="memq://"), 0.05, FaultInjection(die_at_s=0.02),
                           clock=clock, sleep=clock.sleep)
    assert summary["died"] and summary["published"] == dict(zip(NAMES, (39, 39, 40)))


def test_cli_writes_the_summary(tmp_path, capsys):
    assert main(["stand-in", "--lcm-url", "memq://", "--duration", "1", "--die-at", "0.02", "--seed", "3",
                 "--drop-rate", "0.1", "--reorder-rate", "0.1", "--rt-priority", "0", "--out", str(tmp_path)]) == 0
    summary = json.loads((tmp_path / "stand_in.json").read_text())
    assert summary["died"] and set(summary["published_hz"]) == set(NAMES)
    assert "died" in capsys.readouterr().out


@pytest.mark.parametrize(("field", "value"), [("drop_rate", -0.1), ("nan_rate", 1.5), ("reorder_rate", math.nan),
                                              ("burst_loss_s", -1.0), ("added_delay_s", math.inf),
                                              ("die_at_s", math.nan)])
def test_faults_out_of_range_are_refused_by_name(field, value):
    with pytest.raises(ValueError, match=field):
        StandIn(quiet_scenario(), lcm.LCM("memq://"), CHANNELS, FaultInjection(**{field: value}))



# --- the kernels ---------------------------------------------------------------------------------

def test_an_ft_message_is_the_pack_of_its_samples():
    """``ft_samples_into`` writes what ``pack_samples`` encodes from the samples' fields: utimes, counters,
    the wrench negated, the acceleration, each instrument's saturated axes as flag bits (all wrench axes
    from ``saturate_at`` on), no errors."""
    rng = np.random.default_rng(5)
    rate, first, count = 8000.0, 1237, 4
    wrench, acceleration = rng.normal(0.0, 50.0, (2, count, 6))
    wrench_saturated, acceleration_saturated = (rng.uniform(0, 1, (2, count, 6)) < 0.2).astype(float)
    ticks = range(first, first + count)
    flags = [int(wrench_saturated[k] @ (1 << np.arange(6)) + acceleration_saturated[k] @ (1 << np.arange(6, 12)))
             | (0x3F if tick / rate >= (first + 2) / rate else 0) for k, tick in enumerate(ticks)]
    expected = pack_samples([round(tick / rate * 1e6) for tick in ticks], ticks, (-wrench).ravel().tolist(),
                            acceleration.ravel().tolist(), flags, [False] * count)
    message = np.zeros(len(expected), dtype=np.uint8)
    message[:12] = np.frombuffer(expected[:12], dtype=np.uint8)  # fingerprint and count
    ft_samples_into(message, OFFSETS[count], first, rate, (first + 2) / rate, wrench, acceleration, wrench_saturated,
                    acceleration_saturated)
    assert message.tobytes() == expected


def test_the_stylus_force_solves_the_jacobian_transpose():
    """``stylus_force_at`` against numpy's solve of J_Mᵀ·[f; τ_E] = τ at random poses and torques."""
    rng = np.random.default_rng(6)
    plant = MakeMasterPlant()
    chain = SerialChain(plant, plant.GetFrameByName(BASE_FRAME), plant.GetFrameByName(STYLUS_FRAME))
    work = np.empty((6, 7))
    for _ in range(20):
        position, torque = rng.uniform(-1.0, 1.0, 6), rng.normal(0.0, 0.3, 6)
        force = stylus_force_at(chain.record, position, torque, work)
        chain.update(position)
        assert force == pytest.approx(np.linalg.norm(np.linalg.solve(chain.J.T, torque)[:3]), rel=1e-10)


_PLAIN_AND_COMPILED = r"""
import pickle, sys
import lcm
import numpy as np
from heft.diagrams.scenario import resolve_scenario
from heft.diagrams.stations.stand_in import FaultInjection, StandIn
from heft.diagrams.stations.stand_in_wrist import GraspTimes
from heft.hardware_interface.lcmtypes import heft_haptic_command, heft_haptic_state
from heft.systems import compiled

scenario = resolve_scenario("grasp")
channels = scenario.lab.lcm
bus = lcm.LCM("memq://")
payloads, states = [], []

def on_message(channel, payload):
    payloads.append((channel, payload))
    if channel == channels.master_state.name:
        states.append(heft_haptic_state.decode(payload).utime)

for channel in (channels.master_state, channels.slave_status, channels.ft_sample, channels.gripper_state):
    bus.subscribe(channel.name, on_message).set_queue_capacity(10**5)
faults = FaultInjection(drop_rate=0.05, nan_rate=0.05, saturate_at_s=0.05, seed=2)
lab = StandIn(scenario, bus, channels, faults, grasp=GraspTimes(0.02), record_truth=True)
command = heft_haptic_command()
command.num_joints, command.enable = 6, True
for k in range(1, 161):  # 80 ms: the grasp closes, the mount rings, commands name the states published
    lab.step(k * 5e-4)
    while bus.handle_timeout(0) > 0:
        pass
    if states:
        command.torque, command.master_utime = list(np.sin(np.arange(6) + k) * 0.2), states[-1]
        bus.publish(channels.master_command.name, command.encode())
with open(sys.argv[1], "wb") as out:
    pickle.dump({"pure_python": compiled.PURE_PYTHON, "payloads": payloads, "peak": lab.stylus_force_peak,
                 "truth": lab.truth.arrays(lab.ft_samples_due)}, out)
"""


def test_the_compiled_stand_in_publishes_what_its_plain_python_does(tmp_path):
    """The stand-in's kernels compiled and run as plain Python (``HEFT_PURE_PYTHON=1``), in a process
    each, on a grasp with faults and commands: the same messages, the same truth."""
    runs = []
    for pure_python in (True, False):
        path = tmp_path / f"{pure_python}.pickle"
        env = dict(os.environ, HEFT_PURE_PYTHON="1" if pure_python else "0")
        subprocess.run([sys.executable, "-c", _PLAIN_AND_COMPILED, str(path)], env=env, check=True, timeout=300)
        with open(path, "rb") as run:
            runs.append(pickle.load(run))
    plain, machine_code = runs
    assert plain["pure_python"] and not machine_code["pure_python"]
    assert len(plain["payloads"]) > 400 and plain["payloads"] == machine_code["payloads"]
    assert plain["peak"] > 0 and machine_code["peak"] == pytest.approx(plain["peak"], rel=1e-13)
    for name, expected in plain["truth"].items():
        np.testing.assert_allclose(machine_code["truth"][name], expected, rtol=1e-13, atol=1e-13, err_msg=name)
