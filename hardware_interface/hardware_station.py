"""The hardware station: the lab's LCM channels, read and written once per controller tick.

``HardwareStation`` holds what the controller reads — the station quantities of
docs/design.md §3 (master and slave joint state, the wrist wrench and acceleration) plus
the clutch button — and gates what goes back. Every age, timeout and rate limit
is measured on the caller's clock (s, wall-clock, monotonic), never in ticks:

- ``receive(now)`` pumps LCM once, checks every message not checked yet
  (``message_checks``: what fails is counted per channel and reason, never
  raised, and never reaches the controller), keeps the newest accepted state of
  each channel and the gripper's grasps and releases (``gripper_events``), and
  runs the watchdog over the channels' ages, the controller's own
  tick spacing (a stalled controller is a fault too) and the channels' conflicts
  (a second publisher on a channel, ``message_order``, is a fault until it stops).
  The loop's waits between ticks (``idle``, ``wait_for_slave_status``) check each message as it
  arrives, at the station time of its arrival, so that a tick is left with little to check.
- ``send(now, torque, position)`` publishes (on the command bus) the master torque scaled by the
  watchdog's gain (zero and ``enable`` false while unhealthy or non-finite) and the
  slave command: none before the first slave status (there is nothing safe to
  command), the measured position until the station is first healthy, the measured
  position latched at a fault's onset while unhealthy, a restart from the measured
  position on recovery (a restarted arm driver may report another one:
  ``reanchored`` says so for that send), and every other change limited to the joint
  speed limits × the time since the last send.
"""

import math
import select
import time

import lcm
import numpy as np
from drake import lcmt_iiwa_command

from heft.systems.compiled import compiled, float_array, record_views
from heft.systems.controller.master_kinematics import NUM_JOINTS as MASTER_JOINTS
from heft.systems.serial_chain import CHAIN_JOINTS

from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.command_echo import CommandEcho
from heft.hardware_interface.fixed_layout import FixedLayout, put_wire_double, put_wire_int
from heft.hardware_interface.ft_receiver import FtSampleReader
from heft.hardware_interface.gripper_state_reader import GripperStateReader
from heft.hardware_interface.hardware_station_params import HardwareStationParams
from heft.hardware_interface.joint_state_reader import HAPTIC_STATE, JointStateReader, iiwa_status
from heft.hardware_interface.lcm_mailbox import LcmMailbox, pump
from heft.hardware_interface.lcmtypes import heft_haptic_command, heft_station_status
from heft.hardware_interface.message_checks import REASONS, DeviceLimits, JointRange
from heft.hardware_interface.message_order import (LAST_ACCEPT, SILENCE_PER_TIMEOUT, clock_conflict,
                                                   clock_on_probation, clock_since_last)
from heft.hardware_interface.watchdog import watchdog_step

WATCHED_CHANNELS = ("master_state", "slave_status", "ft_sample")
"""Channels the watchdog watches; channel i is bit i of the fault bitmask (stale), bit 3 a
stalled controller, bit 4 + i channel i's source in doubt (a second publisher, or a new
source on probation: ``message_order``)."""
STALLED_BIT = 1 << len(WATCHED_CHANNELS)
CHECKED_CHANNELS = (*WATCHED_CHANNELS, "gripper_state")
"""Every channel read and checked: the watched ones and the gripper's, whose silence is no fault
(a lab without a gripper driver runs as before)."""
FT_KEEP = 64
"""FT samples kept between two ticks (8 kHz sensor, a 2 kHz controller late by several ticks)."""
JOINT_KEEP = 8
"""Joint states kept between two ticks: the driver's newest and what another publisher
interleaves with it, so that a second publisher is seen rather than hidden behind the last."""
_NO_FDS: list = []  # select()'s write and error sets: none
CLUTCH_BUTTON = 1
"""Bit of ``heft_haptic_state.buttons`` held while the operator couples master and slave."""


# The gate's memory: ever healthy, healthy at the last send, the last send set the command to the
# measured position (a start or a recovery).
EVER_HEALTHY, WAS_HEALTHY, REANCHORED = range(3)


@compiled("Tuple((boolean, float64, int64, int64))(float64, float64, float64, float64, float64, float64[:], "
          "float64[:], float64[:], float64[:])")
def station_health(now, spacing, gain, timeout, ramp_time, master_clock, slave_clock, ft_clock, ages):
    """(healthy, gain, fault, conflicts) at ``now`` (s), ``spacing`` s after the last tick, the gain
    before it ``gain``: ``ages`` (s, per ``WATCHED_CHANNELS``: since its source's last accepted message)
    written, the channels' conflicts (bit i: a second publisher on channel i) and the watchdog's verdict
    (``watchdog_step``: stale, stalled, or a source in doubt), from the clocks of ``WATCHED_CHANNELS``
    (``message_order``)."""
    conflicts = doubts = 0
    for i, clock in enumerate((master_clock, slave_clock, ft_clock)):
        ages[i] = clock_since_last(clock, now)
        if clock_conflict(clock, now):
            conflicts |= 1 << i
        if clock_on_probation(clock, now):
            doubts |= 1 << i
    healthy, gain, fault = watchdog_step(ages, gain, timeout, spacing / ramp_time, spacing > timeout,
                                         conflicts | doubts)
    return healthy, gain, fault, conflicts


@compiled("void(float64[:], float64[:], float64[:], float64)")
def rate_limit_into(command, target, speed_limits, dt) -> None:
    """``command`` (rad) moved toward ``target`` by at most ``speed_limits`` × ``dt`` per joint (rad/s, s)."""
    for j in range(command.shape[0]):
        step = speed_limits[j] * dt
        command[j] += min(max(target[j] - command[j], -step), step)


@compiled("boolean(boolean, float64, float64[:], float64[:])")
def gate_torque_into(healthy, gain, torque, torque_sent) -> bool:
    """The master torque ``send`` publishes (module docstring) into ``torque_sent`` (N·m): the
    controller's ``torque`` times the watchdog's ``gain``, zero unless ``healthy`` and finite.
    Returns whether the master's forces are enabled."""
    total = 0.0
    for j in range(torque.shape[0]):
        total += torque[j]
    enable = healthy and math.isfinite(total)
    for j in range(torque.shape[0]):
        torque_sent[j] = gain * torque[j] if enable else 0.0
    return enable


@compiled("void(boolean, float64[:], boolean, float64[:], float64, float64[:], float64[:], float64[:], float64[:])")
def gate_position_into(healthy, position, has_position, measured, dt, speed_limits, gate, command, hold) -> None:
    """The slave command ``send`` publishes (module docstring) into ``command`` (rad): from ``position``
    (if ``has_position``), the ``measured`` position and the ``hold`` latched at a fault, moved at most
    ``speed_limits`` (rad/s) × ``dt`` (s); ``gate`` (``EVER_HEALTHY`` …) advanced."""
    ever, was = gate[EVER_HEALTHY] > 0.5, gate[WAS_HEALTHY] > 0.5
    gate[REANCHORED] = not ever or (healthy and not was)
    if not ever:
        command[:] = measured
        hold[:] = measured
    elif healthy:
        if not was:
            command[:] = measured
        if has_position:
            total = 0.0
            for j in range(position.shape[0]):
                total += position[j]
            if math.isfinite(total):
                rate_limit_into(command, position, speed_limits, dt)
    else:
        if was:
            hold[:] = measured
        rate_limit_into(command, hold, speed_limits, dt)
    gate[EVER_HEALTHY] = ever or healthy
    gate[WAS_HEALTHY] = healthy


@compiled("void(uint8[:], int64[:], int64, int64, float64[:], boolean)")
def encode_master_command(buffer, at, utime, master_utime, torque, enable) -> None:
    """Writes a ``heft_haptic_command``'s values into ``buffer`` (its ``MASTER_COMMAND_FIELDS`` at ``at``)."""
    put_wire_int(buffer, at[0], 8, utime)
    put_wire_int(buffer, at[1], 8, master_utime)
    for j in range(torque.shape[0]):
        put_wire_double(buffer, at[2] + 8 * j, torque[j])
    put_wire_int(buffer, at[3], 1, 1 if enable else 0)


@compiled("void(uint8[:], int64[:], int64, float64[:])")
def encode_slave_command(buffer, at, utime, position) -> None:
    """Writes an ``lcmt_iiwa_command``'s values into ``buffer`` (its ``SLAVE_COMMAND_FIELDS`` at ``at``)."""
    put_wire_int(buffer, at[0], 8, utime)
    for j in range(position.shape[0]):
        put_wire_double(buffer, at[1] + 8 * j, position[j])


MASTER_COMMAND_FIELDS = ("utime", "master_utime", "torque", "enable")
SLAVE_COMMAND_FIELDS = ("utime", "joint_position")


def commands_dtype(n: int) -> np.dtype:
    """The record of what ``send`` keeps for an arm of ``n`` joints (``commands_into``): the two commands'
    messages (``master_command``, ``slave_command``: bytes of their layouts, ``FixedLayout.buffer``) and where their
    fields lie (``master_at``, ``slave_at``), the master torque sent (``torque_sent``, N·m), the slave command
    sent (``command``, rad) and the hold latched at a fault (``hold``, rad), the gate's memory (``gate``:
    ``EVER_HEALTHY`` …), the joints' ``speed_limits`` (rad/s), the time of the last send (``last_send``, s;
    NaN before the first) and the longest step a send may take (``timeout``, s: the watchdog's)."""
    master = FixedLayout(heft_haptic_command, num_joints=MASTER_JOINTS)
    slave = FixedLayout(lcmt_iiwa_command, num_joints=n, num_torques=0)
    return np.dtype([("master_command", np.uint8, master.size), ("master_at", np.int64, len(MASTER_COMMAND_FIELDS)),
                     ("slave_command", np.uint8, slave.size), ("slave_at", np.int64, len(SLAVE_COMMAND_FIELDS)),
                     ("torque_sent", float, MASTER_JOINTS), ("command", float, n), ("hold", float, n),
                     ("gate", float, 3), ("speed_limits", float, n), ("last_send", float), ("timeout", float)])


def _commands_into(commands, now, epoch, torque, position, has_position, healthy, gain, master_utime, measured,
                   slave_clock) -> bool:
    """``send``'s two commands at ``now`` (s; stamped ``epoch`` + ``now``, in µs) into ``commands``
    (``commands_dtype``): the master's from the controller's ``torque`` (``gate_torque_into``), naming the
    master state stamped ``master_utime`` (µs), and, once the arm's status has been heard (its source's
    ``slave_clock`` has accepted one: ``message_order``), the slave's from ``position`` (if ``has_position``) and
    the ``measured`` position (``gate_position_into``). Returns whether the slave's is to be sent."""
    c = commands[0]
    utime = round((epoch + now) * 1e6)
    dt = 0.0 if math.isnan(c["last_send"]) else min(now - c["last_send"], c["timeout"])
    c["last_send"] = now
    enable = gate_torque_into(healthy, gain, torque, c["torque_sent"])
    encode_master_command(c["master_command"], c["master_at"], utime, master_utime, c["torque_sent"], enable)
    if not math.isfinite(slave_clock[LAST_ACCEPT]):
        return False
    gate_position_into(healthy, position, has_position, measured, dt, c["speed_limits"], c["gate"], c["command"],
                       c["hold"])
    encode_slave_command(c["slave_command"], c["slave_at"], utime, c["command"])
    return True


commands_into = {n: compiled("boolean(COMMANDS[:], float64, float64, float64[:], float64[:], boolean, boolean, "
                             "float64, int64, float64[:], float64[:])", COMMANDS=commands_dtype(n))(_commands_into)
                 for n in CHAIN_JOINTS}
"""``_commands_into`` compiled for each arm's record, by its number of joints."""


# Per checked channel, the counts a status reports (``encode_station_status``'s ``counts``' columns).
RECEIVED, UNREAD, RESTARTS = range(3)


@compiled("void(uint8[:], int64[:], int64, boolean, int64, float64, int64, int64[:, :], int64[:, :])")
def encode_station_status(buffer, at, utime, healthy, fault, gain, conflicts, counts, rejected) -> None:
    """Writes a ``heft_station_status``'s values into ``buffer`` (its ``STATUS_FIELDS`` at ``at``): per checked
    channel (rows of ``counts``, by ``RECEIVED``, ``UNREAD``, ``RESTARTS``; ``rejected`` per reason), a second
    publisher where bit i of ``conflicts`` is set."""
    put_wire_int(buffer, at[0], 8, utime)
    put_wire_int(buffer, at[1], 1, 1 if healthy else 0)
    put_wire_int(buffer, at[2], 4, fault)
    put_wire_double(buffer, at[3], gain)
    channels, reasons = rejected.shape
    for i in range(channels):
        put_wire_int(buffer, at[4] + 8 * i, 8, counts[i, RECEIVED])
        put_wire_int(buffer, at[5] + 8 * i, 8, counts[i, UNREAD])
        for k in range(reasons):
            put_wire_int(buffer, at[6] + 8 * (i * reasons + k), 8, rejected[i, k])
        put_wire_int(buffer, at[7] + 4 * i, 4, counts[i, RESTARTS])
        put_wire_int(buffer, at[8] + i, 1, (conflicts >> i) & 1)


STATUS_FIELDS = ("utime", "healthy", "fault", "gain", "received", "unread", "rejected", "restarts",
                 "second_publisher")


class HardwareStation:
    """The lab on ``bus`` (python-lcm, ``channels.lcm_url``), read by ``receive``, and on ``command_bus``
    (``channels.command_lcm_url()``; default ``bus``), written by ``send`` (module docstring);
    ``limits`` are what the devices can report and the slave's speed limits, one per joint: the slave's
    ``num_joints`` are as many as its limits (the scenario's arm, ``diagrams.device_limits``), and its
    status and commands carry that many (a status of another count is rejected as ``joint_count``).

    Readings after ``receive`` (arrays updated in place): ``master_position``,
    ``master_velocity`` (rad, rad/s), ``clutch`` (the clutch button held),
    ``slave_position``, ``slave_velocity`` (rad, rad/s), ``wrench`` ([f; τ] the sensor
    exerts on the load, at S, in S; N, N·m), ``acceleration`` (the accelerometer's
    reading as the sensor reports it: ``accelerometer_reading``); ``ages`` (s, per
    ``WATCHED_CHANNELS``), ``healthy``, ``gain``,
    ``fault`` (bitmask), ``slave_known`` (a slave status has arrived), ``rejections`` and
    ``conflicts`` per channel, ``gripper_events``.
    """

    def __init__(self, bus: lcm.LCM, channels: LcmChannels, limits: DeviceLimits,
                 params: HardwareStationParams | None = None, command_bus: lcm.LCM | None = None):
        params = params or HardwareStationParams()
        params.watchdog.validate()
        self._bus, self._channels, self._params = bus, channels, params
        self._command_bus = bus if command_bus is None else command_bus
        self._bus_fd = [bus.fileno()]
        self.num_joints = n = len(limits.slave_velocity)
        """The slave's joints (6 or 7)."""
        if n not in CHAIN_JOINTS:
            raise ValueError(f"the hardware station drives an arm of {' or '.join(map(str, CHAIN_JOINTS))} joints; "
                             f"the limits given are of {n}")
        self._mail = (LcmMailbox(bus, channels.master_state.name, keep=JOINT_KEEP),
                      LcmMailbox(bus, channels.slave_status.name, keep=JOINT_KEEP),
                      LcmMailbox(bus, channels.ft_sample.name, keep=FT_KEEP),
                      LcmMailbox(bus, channels.gripper_state.name, keep=JOINT_KEEP))
        silence = SILENCE_PER_TIMEOUT * params.watchdog.timeout
        self._master = JointStateReader(HAPTIC_STATE,
                                        JointRange(limits.master_lower, limits.master_upper, limits.master_velocity),
                                        silence)
        self._slave = JointStateReader(iiwa_status(n),
                                       JointRange(limits.slave_lower, limits.slave_upper, limits.slave_velocity),
                                       silence)
        self._ft = FtSampleReader(np.concatenate([limits.wrench_full_scale, limits.acceleration_full_scale]), silence)
        self._gripper = GripperStateReader(silence)
        self._readers = (self._master, self._slave, self._ft, self._gripper)
        self.command_echo = CommandEcho(1.0 / channels.slave_status.rate, n)
        """How late the arm stepped on the slave commands sent, from its status's echo (``command_echo``)."""
        self._echo_utime = 0
        self.gripper_events: list[str] = []
        """The grasps and releases (``gripper_state_reader``: GRASP, RELEASE) that the gripper's driver reported in
        the messages checked by the last ``receive`` and the wait before it."""
        self._gripper_pending: list[str] = []  # those checked since the last receive
        self._origin = None  # time.perf_counter() at station time 0 (s), learned at each receive
        self._statuses_received = 0  # the arm's statuses received by the last receive
        self._checked = 0  # the messages handled into the mailboxes by the last check
        self.conflicts = 0
        """Bit i set while channel i of ``WATCHED_CHANNELS`` has a second publisher."""
        self.master_position, self.master_velocity = self._master.position, self._master.velocity
        self.slave_position, self.slave_velocity = self._slave.position, self._slave.velocity
        self.wrench, self.acceleration = self._ft.wrench, self._ft.acceleration
        self.clutch = False
        self.ages = np.full(len(WATCHED_CHANNELS), math.inf)
        self.healthy, self.gain, self.fault = False, 0.0, (1 << len(WATCHED_CHANNELS)) - 1
        self._last_tick = None
        # What send keeps: the commands' messages, the gate's memory, the slave command, the hold, the last send.
        self._commands, commands = record_views(commands_dtype(n))
        self._commands_into = commands_into[n]
        commands["master_command"][:], commands["master_at"][:] = FixedLayout(
            heft_haptic_command, num_joints=MASTER_JOINTS).buffer(MASTER_COMMAND_FIELDS)
        commands["slave_command"][:], commands["slave_at"][:] = FixedLayout(
            lcmt_iiwa_command, num_joints=n, num_torques=0).buffer(SLAVE_COMMAND_FIELDS)
        commands["speed_limits"][:] = limits.slave_velocity
        self._commands["last_send"], self._commands["timeout"] = math.nan, params.watchdog.timeout
        self._master_command, self._slave_command = commands["master_command"], commands["slave_command"]
        self._gate, self._position = commands["gate"], commands["command"]
        self._slave_clock = self._slave.clock.state
        self._master_channel, self._slave_channel = channels.master_command.name, channels.slave_command.name
        self._no_position, self._no_torque = np.zeros(n), np.zeros(MASTER_JOINTS)
        checked = len(CHECKED_CHANNELS)
        self._status, self._status_at = FixedLayout(
            heft_station_status, strings={"channels": CHECKED_CHANNELS, "reasons": REASONS}, num_channels=checked,
            num_reasons=len(REASONS)).buffer(STATUS_FIELDS)
        self._status_counts = np.zeros((checked, 3), dtype=np.int64)
        self._status_rejected = np.zeros((checked, len(REASONS)), dtype=np.int64)
        self._next_status = 0.0
        self.torque_sent = commands["torque_sent"]
        """The master torque last published (N·m), zero while forces are off."""
        self.position_sent = None
        """The slave command last published (rad), None before the first."""
        self.epoch = 0.0
        """Wall-clock time (s since the Unix epoch) at station time 0: published utimes are epoch + now."""

    @property
    def stamps(self) -> tuple[int, int, int]:
        """The utimes (µs, each on its driver's clock) of the master state, slave status and FT
        sample in the readings (0 before a channel's first)."""
        return self._master.utime, self._slave.utime, self._ft.utime

    @property
    def slave_known(self) -> bool:
        return math.isfinite(self._slave.t_good)

    @property
    def received(self) -> dict[str, int]:
        """Messages received so far per checked channel (valid or not)."""
        return {name: mailbox.count for name, mailbox in zip(CHECKED_CHANNELS, self._mail)}

    @property
    def rejections(self) -> dict[str, dict[str, int]]:
        """Per checked channel, the messages rejected so far per reason (``message_checks.REASONS``)."""
        return {name: reader.rejections.nonzero() for name, reader in zip(CHECKED_CHANNELS, self._readers)}

    @property
    def unread(self) -> dict[str, int]:
        """Per checked channel, the messages pushed out of its mailbox by newer ones before they were
        checked (more arrived in one pump than it keeps: a stalled controller, or a flood)."""
        return {name: mailbox.pushed_out for name, mailbox in zip(CHECKED_CHANNELS, self._mail)}

    @property
    def clocks(self) -> dict:
        """Per checked channel, its source's ``SourceClock`` (offsets, restarts)."""
        return {name: reader.clock for name, reader in zip(CHECKED_CHANNELS, self._readers)}

    def wait_for_slave_status(self, seconds: float) -> bool:
        """Waits up to ``seconds`` (s) for the arm driver's status: True once one has arrived since the
        last ``receive`` (at once if one already has; valid or not), False if none did. The bus's messages
        are handled meanwhile as ``idle`` handles them: a loop anchored here (``run_realtime``'s ``anchor``)
        ticks as the arm's status arrives, so that each arm step receives one command."""
        return self._handle_until(time.perf_counter() + seconds, self._mail[1])

    def idle(self, seconds: float) -> None:
        """Waits ``seconds`` (s), handling the bus's messages as they arrive: the loop's wait between ticks
        (``run_realtime``'s ``sleep``). Once a ``receive`` has told the station its time, each message is
        checked as ``receive`` checks it, at the station time of its arrival (the loop's clock is
        ``time.perf_counter``'s, from the origin that ``receive`` learns), and the tick that follows has
        only the watchdog's judgement and what arrived last to check; before, it waits in its mailbox."""
        self._handle_until(time.perf_counter() + seconds)

    def _handle_until(self, deadline: float, mailbox: LcmMailbox | None = None) -> bool:
        """Handles the bus's messages as they arrive (``idle``) until ``deadline`` (s, ``time.perf_counter``):
        False then, or True as soon as ``mailbox`` (if given) has received a message since the last
        ``receive``."""
        while True:
            if pump(self._bus) and self._origin is not None:
                self._check(max(self._last_tick, time.perf_counter() - self._origin))
            if mailbox is not None and mailbox.count != self._statuses_received:
                return True
            left = deadline - time.perf_counter()
            if left <= 0.0:
                return False
            select.select(self._bus_fd, _NO_FDS, _NO_FDS, left)

    def loop_anchor(self, rate: float, busy_wait: float):
        """(``wait_for_slave_status`` or None, what the loop ticks on): a loop at ``rate`` (Hz) follows the
        arm's status where ``tick_on_slave_status`` asks and the loop runs at the status's nominal rate
        without a busy wait. Ticking on its own clock, a loop whose grid lay near the arm's step in phase
        had the arm take no command at one step and two at the next, which rang the load on its mount."""
        status = self._channels.slave_status
        if not self._params.tick_on_slave_status:
            return None, "ticks on its own clock (lab.station.tick_on_slave_status: false)"
        if busy_wait:
            return None, "ticks on its own clock (it waits busy before each tick)"
        if not math.isclose(rate, status.rate):
            return None, (f"ticks on its own clock ({rate:g} Hz, not the {status.rate:g} Hz of the arm's status on "
                          f"{status.name})")
        return self.wait_for_slave_status, f"ticks as the arm's status arrives ({status.name}, {status.rate:g} Hz)"

    def drain(self) -> int:
        """Handles every message waiting on the bus into the mailboxes (each keeps its newest), unchecked;
        returns how many. Called as a loop starts, so that its first tick does not handle all that arrived
        while the run was set up (a live view's worker starting, a recorder)."""
        return pump(self._bus)

    def receive(self, now: float) -> None:
        """Pumps LCM, checks every message not checked yet, updates the readings, ages and watchdog at ``now``
        (s)."""
        self._origin = time.perf_counter() - now
        pump(self._bus)
        self._check(now)
        self._statuses_received = self._mail[1].count
        events, pending = self.gripper_events, self._gripper_pending
        if events or pending:
            events.clear()
            events += pending
            pending.clear()
        master, slave, ft = self._master, self._slave, self._ft
        watchdog = self._params.watchdog
        spacing = 0.0 if self._last_tick is None else now - self._last_tick
        self._last_tick = now
        self.healthy, self.gain, self.fault, self.conflicts = station_health(
            now, spacing, self.gain, watchdog.timeout, watchdog.ramp_time, master.clock.state, slave.clock.state,
            ft.clock.state, self.ages)

    def _check(self, now: float) -> None:
        """Checks the messages handled since the last check, at station time ``now`` (s): each channel's newest
        accepted state, the clutch, the arm's echo of our command, the gripper's events."""
        mail, slave = self._mail, self._slave
        handled = mail[0].count + mail[1].count + mail[2].count + mail[3].count
        if handled == self._checked:
            return
        self._checked = handled
        self._master.take(mail[0].take(), now)
        self.clutch = bool(self._master.buttons & CLUTCH_BUTTON)
        slave.take(mail[1].take(), now)
        utime = slave.utime
        if utime != self._echo_utime:
            self._echo_utime = utime
            self.command_echo.heard(utime, slave.commanded)
        self._ft.take(mail[2].take(), now)
        self._gripper_pending += self._gripper.take(mail[3].take(), now)

    def publish_status(self, now: float, force: bool = False) -> bytes | None:
        """Publishes ``heft_station_status`` (health, per channel the messages received, unread,
        rejected per reason, restarts, second publishers) at ``now`` (s) if its channel's period
        has passed since the last, or if ``force``; returns the payload published, or None."""
        if not (force or now >= self._next_status):
            return None
        self._next_status = now + 1.0 / self._channels.station_status.rate
        counts, rejected = self._status_counts, self._status_rejected
        for i, (mailbox, reader) in enumerate(zip(self._mail, self._readers)):
            counts[i, RECEIVED], counts[i, UNREAD], counts[i, RESTARTS] = (mailbox.count, mailbox.pushed_out,
                                                                           reader.clock.restarts)
            rejected[i] = reader.rejections.by_code
        gripper_conflict = self._gripper.clock.conflict(now) << len(WATCHED_CHANNELS)
        encode_station_status(self._status, self._status_at, round((self.epoch + now) * 1e6), self.healthy,
                              self.fault, self.gain, self.conflicts | gripper_conflict, counts, rejected)
        payload = self._status.tobytes()
        self._command_bus.publish(self._channels.station_status.name, payload)
        return payload

    def stop(self, now: float) -> None:
        """The run's last commands at ``now`` (s): forces off, and the slave command one
        rate-limited step towards a hold (the position measured now, or at the fault's onset if
        the station is already unhealthy)."""
        self.healthy = False
        self.send(now, self._no_torque, None)

    @property
    def reanchored(self) -> bool:
        """The last send set the slave command to the measured position (a start or a recovery)."""
        return bool(self._gate[REANCHORED])

    def send(self, now: float, torque, position) -> None:
        """Publishes the gated master ``torque`` (6, N·m) and slave ``position`` (``num_joints``, rad, or None:
        no command from the controller) at ``now`` (s)."""
        has_position = position is not None
        slave = self._commands_into(self._commands, now, self.epoch, float_array(torque),
                                    float_array(position) if has_position else self._no_position, has_position,
                                    self.healthy, self.gain, self._master.utime, self.slave_position,
                                    self._slave_clock)
        bus = self._command_bus
        bus.publish(self._master_channel, self._master_command.tobytes())
        if slave:
            self.position_sent = self._position
            bus.publish(self._slave_channel, self._slave_command.tobytes())
            self.command_echo.sent(self._position, self._echo_utime)
