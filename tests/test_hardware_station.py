"""Hardware station over real LCM (memq://), the test playing the three drivers on an
explicit clock: no slave command before the slave is known and nothing moves before
every channel is fresh; a stale channel or a stalled controller faults within the
timeout of wall time, forces ramp back without a jump; slave commands are rate
limited by measured time and latched at a fault; the clutch button; FT sign flip."""

import dataclasses
import math
import time

import lcm
import numpy as np
import pytest
from drake import lcmt_iiwa_command, lcmt_iiwa_status

from heft.diagrams.device_limits import device_limits
from heft.diagrams.scenario import resolve_scenario
from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.hardware_station import (
    CLUTCH_BUTTON,
    STALLED_BIT,
    HardwareStation,
    HardwareStationParams,
    rate_limit_into,
)
from heft.hardware_interface.lcm_mailbox import LcmMailbox, pump
from heft.hardware_interface.gripper_state_reader import GRASP, RELEASE
from heft.hardware_interface.lcmtypes import (heft_ft_sample, heft_gripper_state, heft_haptic_command,
                                              heft_haptic_state, heft_station_status)
from heft.hardware_interface.message_order import CONFLICT_CLEAR, CONFLICT_COUNT, PROBATION, SILENCE_PER_TIMEOUT
from heft.hardware_interface.hardware_station_params import WatchdogParams
from heft.hardware_interface.watchdog import watchdog_step

PERIOD = 0.0005
PARAMS = HardwareStationParams()
TIMEOUT = PARAMS.watchdog.timeout
RAMP_STEP = PERIOD / PARAMS.watchdog.ramp_time
LIMITS = device_limits(resolve_scenario("fig6"))
MAX_STEP = LIMITS.slave_velocity * PERIOD
CHANNELS = LcmChannels()
Q_MASTER = np.array([0.1, -0.2, 0.3, 0.0, 0.5, -0.1])
Q_SLAVE = np.array([0.0, -0.5, 1.2, 0.0, 0.8, 0.3])
TORQUE = np.array([0.1, -0.2, 0.05, 0.01, -0.02, 0.03])
RAW = np.array([1.0, -2.0, 3.0, 0.1, -0.2, 0.3])
ACCEL = np.array([0.5, 0.0, -9.81, 0.01, 0.02, -0.03])
ALL = ("master", "slave", "ft")


class Rig:
    """The station on a fresh memq:// bus; the test plays the drivers and the controller's ticks."""

    def __init__(self, params=PARAMS, limits=LIMITS):
        self.bus = lcm.LCM("memq://")
        self.station = HardwareStation(self.bus, CHANNELS, limits, params)
        self.master_out = LcmMailbox(self.bus, CHANNELS.master_command.name, keep=100_000)
        self.slave_out = LcmMailbox(self.bus, CHANNELS.slave_command.name, keep=100_000)
        self.now, self.driver_start, self.counter = 0.0, 0.0, 0
        self.buttons = 0
        self.torques, self.enables, self.positions = [], [], []

    def publish(self, publish=ALL, q_slave=Q_SLAVE, wrench=RAW):
        utime = round(1e6 * (self.now - self.driver_start)) + 1
        if "master" in publish:
            msg = heft_haptic_state()
            msg.utime, msg.num_joints, msg.buttons = utime, 6, self.buttons
            msg.position, msg.velocity, msg.torque_applied = list(Q_MASTER), [0.0] * 6, [0.0] * 6
            self.bus.publish(CHANNELS.master_state.name, msg.encode())
        if "slave" in publish:
            self.bus.publish(CHANNELS.slave_status.name, iiwa_status(utime, q_slave))
        if "ft" in publish:
            self.counter += 1
            msg = heft_ft_sample()
            msg.utime, msg.sample_counter = utime, self.counter
            msg.wrench, msg.acceleration = list(wrench), list(ACCEL)
            self.bus.publish(CHANNELS.ft_sample.name, msg.encode())

    def tick(self, torque=TORQUE, position=Q_SLAVE + 0.5):
        self.station.receive(self.now)
        self.station.send(self.now, torque, position)
        pump(self.bus)
        for payload in self.master_out.take():
            msg = heft_haptic_command.decode(payload)
            self.torques.append(msg.torque)
            self.enables.append(msg.enable)
        self.positions.extend(lcmt_iiwa_command.decode(p).joint_position for p in self.slave_out.take())

    def run(self, duration, publish=ALL, q_slave=Q_SLAVE, period=PERIOD, **command):
        """Drivers and controller tick together every ``period`` s for ``duration`` s."""
        for _ in range(round(duration / period)):
            self.now += period
            self.publish(publish, q_slave)
            self.tick(**command)


def test_watchdog_core():
    assert watchdog_step(np.array([np.inf, 0.0, np.nan]), 0.7, 0.02, 0.1, False, 0) == (False, 0.0, 0b101)
    assert watchdog_step(np.zeros(3), 0.95, 0.02, 0.1, False, 0) == (True, 1.0, 0)
    assert watchdog_step(np.zeros(3), 0.5, 0.02, 0.1, True, 0) == (False, 0.0, 0b1000)
    assert watchdog_step(np.zeros(3), 0.5, 0.02, 0.1, False, 0b010) == (False, 0.0, 0b100000)
    with pytest.raises(ValueError, match="timeout"):
        WatchdogParams(timeout=0.0).validate()


def test_rate_limit_moves_at_most_the_step():
    command = np.zeros(3)
    rate_limit_into(command, np.array([1.0, -0.01, 0.5]), np.full(3, 0.2), 0.5)
    np.testing.assert_allclose(command, [0.1, -0.01, 0.1])


def test_an_arm_of_another_joint_count_is_refused_by_name():
    five = dataclasses.replace(LIMITS, slave_lower=LIMITS.slave_lower[:5], slave_upper=LIMITS.slave_upper[:5],
                               slave_velocity=LIMITS.slave_velocity[:5])
    with pytest.raises(ValueError, match="an arm of 6 or 7 joints; the limits given are of 5"):
        HardwareStation(lcm.LCM("memq://"), CHANNELS, five, PARAMS)


def test_no_slave_command_before_the_slave_is_known():
    rig = Rig()
    rig.run(0.05, publish=("master", "ft"))
    assert rig.positions == [], "a slave command before any slave status"
    assert not any(rig.enables) and not np.any(rig.torques)
    rig.run(0.002)  # the slave reports: commands start, at its measured position
    assert rig.positions and np.allclose(rig.positions[0], Q_SLAVE)


def test_torque_ramps_in_and_slave_is_rate_limited():
    rig = Rig()
    rig.run(0.3)
    torques, positions = np.array(rig.torques), np.array(rig.positions)
    ratio = torques[:, 0] / TORQUE[0]
    assert ratio[0] == 0.0 and ratio[-1] == pytest.approx(1.0)
    assert np.diff(ratio).max() <= RAMP_STEP + 1e-12  # ramp in 0.2 s of the clock, no jump
    steps = np.abs(np.diff(positions, axis=0))
    assert np.all(steps <= MAX_STEP + 1e-12)
    np.testing.assert_allclose(positions[-1], Q_SLAVE + 0.5)


def test_slew_follows_measured_time_not_ticks():
    """A controller ticking at 1 kHz moves the slave command twice as far per tick as at 2 kHz."""
    rig = Rig()
    rig.run(0.05, period=0.001)
    steps = np.abs(np.diff(np.array(rig.positions), axis=0))
    np.testing.assert_allclose(steps.max(axis=0), 2 * MAX_STEP, rtol=1e-9)


@pytest.mark.parametrize("stale", ["master", "slave", "ft"])
def test_stale_channel_cuts_forces_within_the_timeout_then_ramps_back(stale):
    rig = Rig()
    rig.run(0.3)
    last_message = rig.now
    before = len(rig.torques)
    rig.run(0.1, publish=tuple(c for c in ALL if c != stale))
    off = next(i for i, e in enumerate(rig.enables[before:]) if not e)
    assert TIMEOUT - 1e-9 <= (off + 1) * PERIOD <= TIMEOUT + PERIOD + 1e-9  # the first tick with age > timeout
    assert not np.any(rig.torques[before + off:])
    # The slave command heads for the position measured at the fault's onset, within the speed
    # limits (this test's arm never followed its commands; a real one is there already).
    held = np.array(rig.positions[before + off - 1:])
    steps = np.diff(held, axis=0)
    assert np.all(np.abs(steps) <= MAX_STEP + 1e-12)
    assert np.all(steps * (Q_SLAVE - held[:-1]) >= 0) and np.any(steps)
    assert rig.now - last_message > TIMEOUT
    rig.run(0.3)
    ratio = np.array(rig.torques)[before + off:, 0] / TORQUE[0]
    assert np.diff(ratio).max() <= RAMP_STEP + 1e-12 and ratio[-1] == pytest.approx(1.0)


def test_stalled_controller_is_a_fault_in_wall_time():
    """The controller itself stops ticking for 30 ms (the drivers keep publishing): its next
    tick sees the stall, sends no force and ramps back in from zero."""
    rig = Rig()
    rig.run(0.3)
    for _ in range(60):  # 30 ms of driver traffic, no controller tick
        rig.now += PERIOD
        rig.publish()
    before = len(rig.torques)
    rig.tick()
    assert rig.station.fault == STALLED_BIT and not rig.enables[before] and not any(rig.torques[before])
    rig.run(0.01)
    ratio = np.array(rig.torques)[before:, 0] / TORQUE[0]
    assert ratio[-1] == pytest.approx(20 * RAMP_STEP)


def test_restarted_drivers_recover_without_a_jump():
    """Every driver dies for longer than a source may be silent and comes back with its clock
    and counter from zero, the arm elsewhere: each channel has a new source, on probation
    before the station is healthy again; then the slave command restarts from the new measured
    position, moves within the speed limits, and the master torque ramps in from zero to full."""
    rig = Rig()
    rig.run(0.6)
    rig.now += SILENCE_PER_TIMEOUT * TIMEOUT + PERIOD
    rig.tick()
    rig.driver_start, rig.counter = rig.now, 0
    q_elsewhere = Q_SLAVE + 0.2
    before, back = len(rig.positions), rig.now
    rig.run(PROBATION + 0.3, q_slave=q_elsewhere)
    assert {name: clock.restarts for name, clock in rig.station.clocks.items()} == {
        **dict.fromkeys(("master_state", "slave_status", "ft_sample"), 1), "gripper_state": 0}  # no gripper here
    enabled = [i for i, enable in enumerate(rig.enables[before:]) if enable]
    assert enabled and PROBATION <= enabled[0] * PERIOD <= PROBATION + 2 * PERIOD, back
    positions = np.array(rig.positions[before:])
    restart = next(i for i, q in enumerate(positions) if np.all(np.abs(q - q_elsewhere) <= MAX_STEP + 1e-12))
    assert restart == enabled[0]
    assert np.all(np.abs(np.diff(positions[restart:], axis=0)) <= MAX_STEP + 1e-12)
    ratio = np.array(rig.torques[before:])[:, 0] / TORQUE[0]
    assert ratio[restart] <= RAMP_STEP + 1e-12 and np.diff(ratio).max() <= RAMP_STEP + 1e-12
    assert ratio[-1] == pytest.approx(1.0) and rig.station.conflicts == 0


def test_non_finite_commands_never_published():
    rig = Rig()
    rig.run(0.3)
    before = len(rig.torques)
    rig.run(0.01, torque=np.full(6, np.nan), position=np.full(6, np.inf))
    assert np.all(np.isfinite(rig.torques)) and np.all(np.isfinite(rig.positions))
    assert not any(rig.enables[before:]) and not np.any(rig.torques[before:])


def test_clutch_button_and_ft_sign():
    rig = Rig()
    rig.run(0.01)
    assert not rig.station.clutch
    rig.buttons = CLUTCH_BUTTON | 0b100
    rig.run(0.001)
    assert rig.station.clutch
    np.testing.assert_array_equal(rig.station.wrench, -RAW)  # sensor-on-load = −(load-on-sensor)
    np.testing.assert_array_equal(rig.station.acceleration, ACCEL)


def test_every_ft_sample_since_the_last_tick_is_read_and_the_newest_kept():
    rig = Rig()
    rig.run(0.01)
    for k in range(4):  # an 8 kHz sensor: four samples per 2 kHz tick
        rig.now += PERIOD / 4
        rig.publish(("ft",), wrench=RAW * (k + 2))
    rig.tick()
    np.testing.assert_array_equal(rig.station.wrench, -5 * RAW)
    assert rig.station.received["ft_sample"] == 20 + 4 and not any(rig.station.rejections.values())


def test_what_arrived_before_the_loop_is_drained_and_its_newest_read_at_the_first_tick():
    rig = Rig()
    for k in range(50):  # the drivers publish while the run is set up
        rig.now += PERIOD
        rig.publish(wrench=RAW * (1.0 + 0.01 * k))
    assert rig.station.drain() == 150
    assert pump(rig.bus) == 0  # the first tick's pump finds no backlog
    rig.tick()
    assert rig.station.received == {"master_state": 50, "slave_status": 50, "ft_sample": 50, "gripper_state": 0}
    np.testing.assert_array_equal(rig.station.wrench, -RAW * 1.49)
    np.testing.assert_array_equal(rig.station.slave_position, Q_SLAVE)
    assert rig.station.healthy and not any(rig.station.rejections.values())


def test_between_ticks_the_station_checks_what_arrives_at_its_arrival():
    """``idle``, the loop's wait between ticks: once a ``receive`` has set the station's time, what the drivers
    publish meanwhile is checked as it arrives, at its arrival's station time (so that the next tick finds it
    as old as it is), and the tick has nothing left to pump; bad messages are counted there, as a tick counts
    them; the wait lasts its time."""
    rig = Rig()
    rig.run(0.01)
    rig.now += PERIOD
    rig.publish()
    before = time.perf_counter()
    rig.station.receive(rig.now)  # the tick that sets the station's time: perf_counter() − origin
    after = time.perf_counter()
    ticked = rig.now
    rig.now += PERIOD
    rig.publish(wrench=2 * RAW, q_slave=Q_SLAVE + 0.001)
    rig.bus.publish(CHANNELS.master_state.name, b"garbage")
    start = time.perf_counter()
    rig.station.idle(0.002)
    end = time.perf_counter()
    assert end - start >= 0.002
    assert rig.station.received == {"master_state": 23, "slave_status": 22, "ft_sample": 22, "gripper_state": 0}
    assert pump(rig.bus) == 0  # nothing left for the tick's pump
    np.testing.assert_array_equal(rig.station.wrench, -2 * RAW)
    np.testing.assert_array_equal(rig.station.slave_position, Q_SLAVE + 0.001)
    assert rig.station.rejections["master_state"] == {"undecodable": 1}
    rig.now += 0.01
    rig.station.receive(rig.now)
    # Checked during the wait: on the station's clock, between its start and its end (the origin known to
    # within the first receive's duration), so its age at this tick is what the test's clock gained over the
    # real wait (about 8 ms), not 0 as if this tick had checked it.
    youngest, oldest = rig.now - (end - before + ticked), rig.now - (start - after + ticked)
    assert all(youngest <= age <= oldest for age in rig.station.ages)
    assert rig.station.healthy


def test_before_the_first_tick_the_wait_leaves_messages_unchecked():
    """Before a ``receive`` has set the station's time there is none to check a message at: the wait only
    handles what arrives into the mailboxes, and the first tick checks it."""
    rig = Rig()
    rig.now += PERIOD
    rig.publish()
    rig.station.idle(0.001)
    assert rig.station.received["slave_status"] == 1 and not rig.station.slave_known
    rig.tick()
    assert rig.station.slave_known
    np.testing.assert_array_equal(rig.station.slave_position, Q_SLAVE)


def test_the_wait_for_the_arms_status_sees_one_checked_as_it_arrived():
    rig = Rig()
    rig.run(0.01)
    assert not rig.station.wait_for_slave_status(0.002)  # none since the last tick
    rig.now += PERIOD
    rig.publish(("slave",), q_slave=Q_SLAVE + 0.001)
    start = time.perf_counter()
    assert rig.station.wait_for_slave_status(1.0)
    assert time.perf_counter() - start < 0.5
    np.testing.assert_array_equal(rig.station.slave_position, Q_SLAVE + 0.001)  # checked on arrival
    assert rig.station.wait_for_slave_status(1.0)  # and still, at once, until the next tick
    rig.tick()
    assert not rig.station.wait_for_slave_status(0.0)


def test_published_utime_is_wall_clock_and_names_the_master_state():
    """A command's utime is wall-clock time; its master_utime the stamp (the driver's clock) of the
    master state it was computed at: the newest accepted, not a later or a rejected one."""
    rig = Rig()
    rig.station.epoch = 1.7e9
    rig.run(0.002)
    rig.now += PERIOD
    used = round(1e6 * (rig.now - rig.driver_start)) + 1
    rig.publish(("master",))
    bus_copy = LcmMailbox(rig.bus, CHANNELS.master_command.name, keep=2)
    rig.tick()
    rig.bus.publish(CHANNELS.master_state.name, haptic_state(used + 500, np.full(6, 50.0)))  # beyond the limits
    rig.tick()
    pump(rig.bus)
    commands = [heft_haptic_command.decode(payload) for payload in bus_copy.take()]
    assert commands[-1].utime == round((1.7e9 + rig.now) * 1e6)
    assert [command.master_utime for command in commands] == [used, used]
    assert math.isfinite(rig.station.ages.max())


def iiwa_status(utime, position) -> bytes:
    """The arm driver's status of the joints at ``position`` (rad), as many as it has."""
    msg = lcmt_iiwa_status()
    msg.utime, msg.num_joints = utime, len(position)
    msg.joint_position_measured = list(position)
    for field in ("joint_velocity_estimated", "joint_position_commanded", "joint_position_ipo",
                  "joint_torque_measured", "joint_torque_commanded", "joint_torque_external"):
        setattr(msg, field, [0.0] * len(position))
    return msg.encode()


def haptic_state(utime, position, num_joints=6, velocity=None) -> bytes:
    msg = heft_haptic_state()
    msg.utime, msg.num_joints = utime, num_joints
    msg.position, msg.velocity = list(position), list(velocity if velocity is not None else [0.0] * num_joints)
    msg.torque_applied = [0.0] * num_joints
    return msg.encode()


def gripper_state(utime, state, width=0.05, error=False) -> bytes:
    msg = heft_gripper_state()
    msg.utime, msg.state, msg.width, msg.error = utime, state, width, error
    return msg.encode()


def test_malformed_messages_are_counted_and_never_reach_the_controller():
    """Between the drivers' own messages, every kind of broken one on every channel, those that
    decode stamped on the drivers' clock (corrupted by the driver or the network, not another
    publisher): the station stays healthy, reads exactly the drivers' values, and counts each
    rejection by its reason."""
    rig = Rig()
    rig.run(0.05)
    ft = heft_ft_sample()
    ft.utime, ft.sample_counter, ft.wrench, ft.acceleration = 1, 1, list(RAW), list(ACCEL)
    lower, upper = LIMITS.master_lower, LIMITS.master_upper
    for _ in range(20):
        rig.now += PERIOD
        rig.publish()
        stamp = round(1e6 * (rig.now - rig.driver_start)) + 2  # just after the driver's own
        hostile = {
            CHANNELS.master_state.name: [
                b"\x07" * 40, haptic_state(stamp, Q_MASTER)[:-5], haptic_state(stamp, Q_MASTER[:3], num_joints=3),
                haptic_state(stamp, [np.nan] + [0.0] * 5), haptic_state(stamp, upper + 1.0),
                haptic_state(stamp, (lower + upper) / 2, velocity=[1e3] * 6)],
            CHANNELS.slave_status.name: [bytes(range(200)), b""],
            CHANNELS.ft_sample.name: [ft.encode()[:50], b"\xff" * 8],
            CHANNELS.gripper_state.name: [b"\x01" * 9, gripper_state(stamp, 7), gripper_state(stamp, OPEN, math.nan),
                                          gripper_state(stamp, OPEN, -0.01), gripper_state(stamp, HOLDING, error=True)],
        }
        for channel, payloads in hostile.items():
            for payload in payloads:
                rig.bus.publish(channel, payload)
        rig.tick()
        assert rig.station.healthy
        np.testing.assert_array_equal(rig.station.master_position, Q_MASTER)
        np.testing.assert_array_equal(rig.station.slave_position, Q_SLAVE)
        np.testing.assert_array_equal(rig.station.wrench, -RAW)
    assert rig.station.rejections == {
        "master_state": {"undecodable": 40, "joint_count": 20, "non_finite": 20, "out_of_range": 40},
        "slave_status": {"undecodable": 40},
        "ft_sample": {"undecodable": 40},
        "gripper_state": {"undecodable": 20, "out_of_range": 40, "non_finite": 20, "driver_error": 20},
    }
    assert rig.station.gripper_events == []
    assert rig.enables[-1] and rig.station.conflicts == 0
    # The same counts go out on the status channel, for a recording to keep.
    statuses = LcmMailbox(rig.bus, CHANNELS.station_status.name)
    rig.station.publish_status(rig.now, force=True)
    pump(rig.bus)
    status = heft_station_status.decode(statuses.take()[-1])
    assert status.healthy and list(status.channels) == ["master_state", "slave_status", "ft_sample", "gripper_state"]
    assert {channel: {reason: count for reason, count in zip(status.reasons, row) if count}
            for channel, row in zip(status.channels, status.rejected)} == rig.station.rejections
    assert list(status.received) == [rig.station.received[name] for name in status.channels]


IIWA = resolve_scenario("fig6", "{robot: iiwa14}")
Q_IIWA = np.array(IIWA.slave_initial_q)


def test_a_seven_joint_arm_is_read_and_commanded_in_its_joints_and_six_are_refused():
    """The station of an iiwa (its limits: 7 joints) reads the driver's 7-joint statuses and sends 7-joint
    commands; statuses of six joints between them, stamped on the driver's clock (an RX's driver on the
    same channel, a misconfigured one), are rejected as of another joint count, counted and reported, and
    never fatal: the station stays healthy on the driver's own."""
    rig = Rig(limits=device_limits(IIWA))
    assert rig.station.num_joints == 7
    rig.run(0.05, q_slave=Q_IIWA, position=Q_IIWA + 0.01)
    for _ in range(20):
        rig.now += PERIOD
        rig.publish(q_slave=Q_IIWA)
        stamp = round(1e6 * (rig.now - rig.driver_start)) + 2
        rig.bus.publish(CHANNELS.slave_status.name, iiwa_status(stamp, Q_SLAVE))
        rig.tick(position=Q_IIWA + 0.01)
        assert rig.station.healthy
        np.testing.assert_array_equal(rig.station.slave_position, Q_IIWA)
    assert rig.station.rejections["slave_status"] == {"joint_count": 20}
    assert rig.enables[-1] and rig.station.conflicts == 0
    assert {len(position) for position in rig.positions} == {7}
    np.testing.assert_allclose(rig.positions[-1], Q_IIWA + 0.01)


OPEN, CLOSING, HOLDING = heft_gripper_state.OPEN, heft_gripper_state.CLOSING, heft_gripper_state.HOLDING


def test_the_grippers_grasps_and_releases_are_read_once_and_its_silence_is_no_fault():
    """The gripper driver's state changes become one event each: HOLDING after OPEN or CLOSING a
    grasp, OPEN after HOLDING a release; the first state heard sets where it is without one; a
    message stamped on another clock is rejected as foreign; the gripper going silent leaves the
    station healthy."""
    rig = Rig()
    rig.run(0.05)
    events = []

    def gripper(states, stamp_offset=0.0):
        for state in states:
            rig.now += PERIOD
            rig.publish()
            stamp = round(1e6 * (rig.now - rig.driver_start + stamp_offset)) + 1
            rig.bus.publish(CHANNELS.gripper_state.name, gripper_state(stamp, state))
            rig.tick()
            events.extend(rig.station.gripper_events)

    gripper([HOLDING])  # first heard: no event
    gripper([OPEN, OPEN, CLOSING, CLOSING, HOLDING, HOLDING, HOLDING])
    assert events == [RELEASE, GRASP]
    gripper([OPEN], stamp_offset=5.0)  # another clock's: foreign, no release
    assert events == [RELEASE, GRASP] and rig.station.rejections["gripper_state"] == {"stamped_ahead": 1}
    gripper([CLOSING, HOLDING, OPEN])  # CLOSING while holding changes nothing
    assert events == [RELEASE, GRASP, RELEASE]
    rig.run(0.2)  # the gripper silent, the others not
    assert rig.station.healthy and rig.enables[-1]


def test_a_second_publisher_is_a_fault_until_it_stops():
    """A stand-in left running beside the master's driver, on its own clock, publishes plausible
    states: within a few of its messages the station faults (forces off, the slave command held),
    none of its states is ever read, and the station recovers once it has been quiet for
    ``CONFLICT_CLEAR``."""
    rig = Rig()
    rig.run(0.3)
    elsewhere = Q_MASTER + 0.3
    before = len(rig.torques)
    for k in range(200):  # 100 ms
        rig.now += PERIOD
        rig.publish()
        if k % 4 == 0:  # 500 Hz, its clock started 7 s before the driver's
            rig.bus.publish(CHANNELS.master_state.name, haptic_state(round(1e6 * (rig.now + 7.0)), elsewhere))
        rig.tick()
        np.testing.assert_array_equal(rig.station.master_position, Q_MASTER)
    off = next(i for i, enable in enumerate(rig.enables[before:]) if not enable)
    assert off <= 4 * CONFLICT_COUNT, "the fault comes within a few of the other publisher's messages"
    assert rig.station.fault == 1 << 4 and rig.station.conflicts == 0b001
    assert not np.any(rig.torques[before + off:])
    assert rig.station.rejections["master_state"] == {"stamped_ahead": 50}
    held = np.array(rig.positions[before + off:])
    assert np.all(np.abs(np.diff(held, axis=0)) <= MAX_STEP + 1e-12)
    last_foreign = rig.now - (199 % 4) * PERIOD
    while not rig.station.healthy:
        rig.run(PERIOD)
    assert CONFLICT_CLEAR <= rig.now - last_foreign <= CONFLICT_CLEAR + 2 * PERIOD
    rig.run(0.25)
    assert rig.enables[-1] and rig.station.conflicts == 0


def test_a_second_publisher_on_the_same_clock_shows_as_jumps():
    """Another FT driver stamping on the same clock (two drivers on one sensor's time base) with
    its own counter: its samples go back and forth against the driver's and are rejected; the
    channel is in conflict."""
    rig = Rig()
    rig.run(0.1)
    for _ in range(40):
        rig.now += PERIOD
        rig.publish()
        msg = heft_ft_sample()
        msg.utime, msg.sample_counter = round(1e6 * rig.now) + 2, 5  # the driver's counter is past 200
        msg.wrench, msg.acceleration = list(5 * RAW), list(ACCEL)
        rig.bus.publish(CHANNELS.ft_sample.name, msg.encode())
        rig.tick()
        np.testing.assert_array_equal(rig.station.wrench, -RAW)
    assert rig.station.rejections["ft_sample"]["discontinuous"] >= 3
    assert rig.station.conflicts == 0b100 and not rig.station.healthy


def test_one_sample_stamped_in_the_future_changes_nothing():
    """A single corrupted datagram stamped 10 s ahead: rejected, counted, and the driver's samples
    that follow are read as before: no fault."""
    rig = Rig()
    rig.run(0.1)
    before = len(rig.enables)
    rig.now += PERIOD
    rig.publish()
    msg = heft_ft_sample()
    msg.utime, msg.sample_counter = round(1e6 * (rig.now + 10.0)), 10**9
    msg.wrench, msg.acceleration = list(5 * RAW), list(ACCEL)
    rig.bus.publish(CHANNELS.ft_sample.name, msg.encode())  # newest: read first
    rig.tick()
    np.testing.assert_array_equal(rig.station.wrench, -RAW)
    rig.run(0.05)
    assert all(rig.enables[before:]) and rig.station.rejections["ft_sample"] == {"stamped_ahead": 1}


def test_a_publisher_just_ahead_of_the_drivers_clock_is_never_read():
    """Another publisher stamps 0.2 s ahead of the master driver (within the clock tolerance)
    with the stylus 0.3 rad elsewhere: the joints could not have moved so far in the time the
    station saw pass, so none of its states is read, and the channel is in conflict."""
    rig = Rig()
    rig.run(0.3)
    for _ in range(20):
        rig.now += PERIOD
        rig.publish()
        stamp = round(1e6 * (rig.now - rig.driver_start + 0.2))
        rig.bus.publish(CHANNELS.master_state.name, haptic_state(stamp, Q_MASTER + 0.3))
        rig.tick()
        np.testing.assert_array_equal(rig.station.master_position, Q_MASTER)
    assert rig.station.rejections["master_state"] == {"discontinuous": 20}
    assert rig.station.conflicts == 0b001 and not rig.station.healthy


def test_a_source_that_takes_over_a_silent_channel_is_on_probation():
    """The arm driver falls silent; another process's slave state, on its own clock and 0.4 rad
    elsewhere, becomes the channel's new source, but on probation: the station stays unhealthy,
    and when the driver speaks again the channel is in conflict. The slave command never heads
    for the other process's position."""
    rig = Rig()
    rig.run(0.3)
    rig.run(SILENCE_PER_TIMEOUT * TIMEOUT + PERIOD, publish=("master", "ft"))
    before = len(rig.positions)
    for k in range(600):  # 0.3 s; the driver back after 20 ms
        rig.now += PERIOD
        rig.publish() if k >= 40 else rig.publish(("master", "ft"))
        status = lcmt_iiwa_status()
        status.utime, status.num_joints = round(1e6 * (rig.now + 30.0)), 6
        status.joint_position_measured = list(Q_SLAVE + 0.4)
        for field in ("joint_velocity_estimated", "joint_position_commanded", "joint_position_ipo",
                      "joint_torque_measured", "joint_torque_commanded", "joint_torque_external"):
            setattr(status, field, [0.0] * 6)
        rig.bus.publish(CHANNELS.slave_status.name, status.encode())
        rig.tick()
        assert not rig.station.healthy
    assert rig.station.clocks["slave_status"].restarts == 1 and rig.station.conflicts == 0b010
    commands = np.array(rig.positions[before - 1:])
    steps = np.diff(commands, axis=0)
    assert np.all(np.abs(steps) <= MAX_STEP + 1e-12) and np.all(steps * (Q_SLAVE - commands[:-1]) >= 0)
    np.testing.assert_allclose(commands[-1], Q_SLAVE)  # held where the driver last reported the arm
