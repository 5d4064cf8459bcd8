"""The teleoperation controller on the lab's LCM channels, in real time.

``HardwareTeleop.tick`` is one controller tick on the wall clock: the hardware
station receives (one LCM pump, the newest message of every channel), the
controller Diagram steps (``TeleopController``: Fig. 4's blocks as its ``TickProgram``),
and the station sends in the same tick, so a sensor sample reaches the master's command
in the tick it arrives.

Start-up and recovery never move the slave: the controller starts only when the
station is healthy (every channel fresh, so the slave's measured position is
known) and starts again on every recovery, from the slave's measured pose with
the clutch disengaged; motion follows the stylus only while the operator holds
the clutch button, anchored on the slave's measured pose at the press. Load
commands (``heft load``: re-zero, offset tracking, a new tool's estimate, a grasp
or release) and the gripper driver's grasps and releases are served after each
tick's send (``hardware_interface.load_commands``), through the Diagram's inputs.
What the controller computed goes out beside the commands while it steps (``hardware_interface.teleop_state``):
each tick when the run is recorded, else at ``STATE_RATE``.

``run_hardware_teleop`` runs it for a while (``diagrams.running.realtime``) and returns
what the run saw: faults and recoveries, the master command's largest stylus
force and torque, the largest slave command step, message rates and timing.
"""

from __future__ import annotations

import collections
import contextlib
import logging
import math
import sys
import time
from collections.abc import Sequence

import lcm
import numpy as np

from heft.analysis.topics import ESTIMATOR_PRIOR, ESTIMATOR_STATE
from heft.diagrams.device_limits import device_limits
from heft.diagrams.live_view import McapRecorder
from heft.diagrams.running.lcm_recording import LcmTrafficRecorder
from heft.diagrams.running.realtime import (LOOP_PRIORITY, StopOnSignal, claim_realtime, format_timing,
                                            keep_cpu_for_loop, run_realtime, timing_summary)
from heft.diagrams.scenario import Scenario
from heft.diagrams.load_estimate import LoadEstimate
from heft.diagrams.plants import arm_name, slave_arm
from heft.diagrams.teleop import FeedbackBlock
from heft.diagrams.teleop_controller import TeleopController
from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.command_echo import SENT_KEEP
from heft.hardware_interface.hardware_station import WATCHED_CHANNELS, HardwareStation, HardwareStationParams
from heft.hardware_interface.lcm_mailbox import open_buses
from heft.hardware_interface.load_commands import LoadCommandServer
from heft.hardware_interface.teleop_state import TeleopStatePublisher
from heft.systems.compiled import compiled
from heft.systems.load_dynamics import wrench_norms

say = logging.getLogger(__name__)
"""What a run says (``heft -q`` quiets it): under the ``heft`` logger the command line configures."""
STATE_RATE = 100.0
"""Hz at which ``heft_teleop_state`` goes out while a run is not recorded."""
PHI_SAMPLE_PERIOD = 0.01
"""s between the samples of φ̂ a run's summary keeps while the estimator learns online."""
MAX_PHI_SAMPLES = 60_000
"""The samples of φ̂ a summary keeps at most: the first 10 minutes (a long run grows nothing further)."""


class HardwareTeleop:
    """The controller closed around ``HardwareStation``, hearing ``bus`` and publishing on
    ``command_bus`` (default ``bus``; module docstring).

    ``tick(now, dt)`` runs one tick at ``now`` (s, monotonic) ``dt`` s after the last, nominally the
    scenario's ``controller_period``; ``summary(elapsed)`` reports the
    run so far; ``heft_teleop_state`` goes out while the controller steps, each tick if ``state_every_tick`` (a
    recording: the analyses need every tick), else at ``STATE_RATE`` (its encoding and publish cost a tick
    tens of µs). ``feedback_blocks``: a lab's own
    blocks on the feedback path (``MakeTeleopController``); ``taps``: the live view and MCAP recorders
    (``diagrams.live_view``, opened here) that take each tick's row (``rows``) off the loop's CPU, and as events
    the station's status (``/faults``), the load commands heard and their answers (``/load/…``)."""

    def __init__(self, scenario: Scenario, load: LoadEstimate, bus: lcm.LCM, channels: LcmChannels,
                 params: HardwareStationParams | None = None, command_bus: lcm.LCM | None = None,
                 feedback_blocks: Sequence[FeedbackBlock] = (), taps: Sequence = (), state_every_tick: bool = False):
        estimator = scenario.controller.estimator
        slowest = max(WATCHED_CHANNELS, key=lambda name: 1.0 / getattr(channels, name).rate)
        period = 1.0 / getattr(channels, slowest).rate
        if estimator.mode == "online" and not estimator.max_input_age > 2.0 * period:
            raise ValueError(f"controller.estimator.max_input_age ({1e3 * estimator.max_input_age:g} ms) must exceed "
                             f"twice the period of the slowest channel the station watches ({slowest} at "
                             f"{getattr(channels, slowest).rate:g} Hz: {1e3 * period:g} ms), or the online estimator "
                             f"would refuse the ticks of a healthy stream; set it to {2.5e3 * period:g} ms or more")
        # The controller's models first (about a second): the station's subscriptions then
        # start receiving only when the loop is about to pump them.
        limits = device_limits(scenario)
        self.controller = TeleopController(
            scenario.controller, load, slave_arm(scenario), scenario.controller_period,
            accelerometer=scenario.accelerometer.convention(), slave_initial_q=scenario.slave_initial_q,
            feedback_blocks=feedback_blocks, master=scenario.master,
            station=lambda: HardwareStation(bus, channels, limits, params, command_bus))
        self.station = self.controller.station.station
        self.load_commands = LoadCommandServer(bus, channels, self.controller, limits.wrench_full_scale, command_bus)
        self.state = TeleopStatePublisher(bus if command_bus is None else command_bus, channels)
        self._state_every_tick, self._next_state = state_every_tick, 0.0
        self.taps, self._row, self._scalars = list(taps), *tick_row(self)
        widths = {key: np.size(value) for key, value in self._row.items()}
        for tap in self.taps:  # the estimator's state, whence φ̂'s uncertainty, to the live view only
            tap.open({key: width for key, width in widths.items()
                      if not (tap.every_row and key in (ESTIMATOR_STATE, ESTIMATOR_PRIOR))})
        if self.taps:
            self.load_commands.on_message = lambda topic, message: self._event(topic, message.encode())
        self.starts = 0
        """Controller starts so far (the first healthy tick and each recovery)."""
        self._channel_names = [getattr(channels, name).name for name in WATCHED_CHANNELS]
        self._zero = np.zeros(self.station.num_joints)
        self.now = 0.0
        """The last tick's time (s)."""
        self._was_healthy = False
        self.ticks = self.healthy_ticks = 0
        self.first_healthy = None
        self.faults = []
        self._peaks = np.zeros(PEAKS_SIZE)
        # The last slave command sent (NaN before the first).
        self._last_position = np.full(self.station.num_joints, np.nan)
        self.reanchors = 0
        self.master_commands = self.slave_commands = 0
        self.conflicts = []
        self._conflicts = 0
        self.phi_history = []
        """(time (s), φ̂ in use (10)) every ``PHI_SAMPLE_PERIOD`` s while the estimator learns online (the
        first ``MAX_PHI_SAMPLES``)."""
        self._next_phi_sample = 0.0
        self.status = None
        """Called with a status line (``status_line``) each ``STATUS_PERIOD`` s, if set."""
        self._next_status, self._ticks_at_status = STATUS_PERIOD, 0

    def tick(self, now: float, dt: float) -> None:
        self.now = now
        station, controller = self.station, self.controller
        healthy = controller.tick(now, dt)
        if healthy and not self._was_healthy:
            self.starts += 1
        if healthy and (self._state_every_tick or now >= self._next_state):
            self._next_state = now + 1.0 / STATE_RATE
            self.state.publish(round((station.epoch + now) * 1e6), controller.hold, self.starts, station.stamps,
                               controller, station.gain)
        if self.taps:
            self._scalars[:] = controller.hold, station.gain, self.starts
            for tap in self.taps:
                tap.publish(now, self._row)
        utime = round((station.epoch + now) * 1e6)
        for event in station.gripper_events:
            self.load_commands.gripper(utime, event)
        self.load_commands.serve(utime, healthy, station.acceleration)
        status = station.publish_status(now)
        if status is not None and self.taps:
            self._event("/faults", status)
        self._observe(now, healthy)
        self._was_healthy = healthy
        if self.status is not None and now >= self._next_status:
            self._status(now)

    def _event(self, topic: str, payload: bytes) -> None:
        """The LCM message ``payload`` on the event topic ``topic`` (``analysis.topics.EVENT_TOPICS``) to every tap,
        at this tick."""
        for tap in self.taps:
            tap.event(topic, payload, self.now)

    def _observe(self, now: float, healthy: bool) -> None:
        station = self.station
        self.ticks += 1
        self.master_commands += 1
        if healthy:
            self.healthy_ticks += 1
            if self.first_healthy is None:
                self.first_healthy = now
            if self.faults and self.faults[-1]["recovered"] is None and not self._was_healthy:
                self.faults[-1]["recovered"] = now
        elif self._was_healthy:
            self.faults.append({"onset": now, "fault_bits": station.fault,
                                "ages_ms": [round(1e3 * float(a), 3) for a in station.ages], "recovered": None})
        if station.conflicts != self._conflicts:
            self._observe_conflicts(now)
        estimator = self.controller.estimator
        if estimator is not None and now >= self._next_phi_sample and len(self.phi_history) < MAX_PHI_SAMPLES:
            self._next_phi_sample = now + PHI_SAMPLE_PERIOD
            self.phi_history.append((now, self.controller.phi.tolist()))
        position = station.position_sent
        if position is not None:
            self.slave_commands += 1
            if station.reanchored and station.healthy:  # a start (the first healthy tick, a recovery)
                self.reanchors += 1
        command_peaks(self._peaks, station.torque_sent, self.controller.applied_wrench, station.gain, healthy,
                      self._zero if position is None else position, position is not None, station.reanchored,
                      self._last_position)

    def _status(self, now: float) -> None:
        self.status(status_line({"t": now, "rate_hz": (self.ticks - self._ticks_at_status) / STATUS_PERIOD,
                                 "healthy": self.station.healthy, "fault": self.station.fault,
                                 "stylus_force_peak": self.stylus_force_peak, "mass": float(self.controller.phi[0]),
                                 "faults": len(self.faults)}))
        self._next_status, self._ticks_at_status = now + STATUS_PERIOD, self.ticks

    @property
    def torque_finite(self) -> bool:
        """Every master torque sent so far was finite."""
        return not self._peaks[TORQUE_NOT_FINITE]

    @property
    def torque_peak(self) -> float:
        """The largest master joint torque sent while healthy (N·m)."""
        return float(self._peaks[TORQUE_PEAK])

    @property
    def stylus_force_peak(self) -> float:
        """The largest force the sent torques render on the hand (N): the gain times the wrench applied."""
        return float(self._peaks[STYLUS_FORCE_PEAK])

    @property
    def stylus_torque_peak(self) -> float:
        """The largest torque the sent torques render on the hand (N·m)."""
        return float(self._peaks[STYLUS_TORQUE_PEAK])

    @property
    def max_slave_step(self) -> float:
        """The largest change of a slave joint's command between two sends (rad), holds and starts aside."""
        return float(self._peaks[SLAVE_STEP])

    @property
    def max_reanchor_step(self) -> float:
        """The largest change of a slave joint's command when it was set to the measured position (rad)."""
        return float(self._peaks[REANCHOR_STEP])

    def _observe_conflicts(self, now: float) -> None:
        """Opens an entry of ``conflicts`` for each channel whose second publisher was just found,
        closes it when that channel's conflict has ended."""
        station, clocks = self.station, list(self.station.clocks.values())
        for i in range(len(WATCHED_CHANNELS)):
            bit = 1 << i
            if station.conflicts & bit and not self._conflicts & bit:
                clock = clocks[i]
                self.conflicts.append({"channel": self._channel_names[i], "onset": now, "ended": None,
                                       "source_clock_offset_s": clock.offset,
                                       "other_clock_offset_s": clock.foreign_offset})
            elif self._conflicts & bit and not station.conflicts & bit:
                for conflict in reversed(self.conflicts):
                    if conflict["channel"] == self._channel_names[i]:
                        conflict["ended"] = now
                        break
        self._conflicts = station.conflicts

    def summary(self, elapsed: float) -> dict:
        """The run so far (JSON-serialisable; times in s on the loop's clock, rates per wall second)."""
        station = self.station
        return {
            "slave_joints": station.num_joints,
            "ticks": self.ticks,
            "healthy_ticks": self.healthy_ticks,
            "first_healthy": self.first_healthy,
            "faults": self.faults,
            "final_healthy": station.healthy,
            "final_fault_bits": station.fault,
            "final_ages_ms": {name: (round(1e3 * age, 3) if math.isfinite(age) else None)
                              for name, age in zip(WATCHED_CHANNELS, station.ages)},
            "master_torque_finite": self.torque_finite,
            "master_torque_peak": self.torque_peak,
            "stylus_force_peak": self.stylus_force_peak,
            "stylus_torque_peak": self.stylus_torque_peak,
            "max_slave_command_step": self.max_slave_step,
            "arm_command_lag": station.command_echo.summary(),
            "slave_reanchors": {"count": self.reanchors, "max_step": self.max_reanchor_step},
            "rejected": station.rejections,
            "unread": station.unread,
            "driver_restarts": {name: clock.restarts for name, clock in station.clocks.items()},
            "second_publishers": self.conflicts,
            "sent_hz": {"master_command": self.master_commands / elapsed,
                        "slave_command": self.slave_commands / elapsed},
            "received_hz": {name: count / elapsed for name, count in station.received.items()},
            "load_events": [message for _, message in self.load_commands.events],
            "offsets_final": self.controller.offsets.tolist(),
            "estimator": self._estimator_summary(),
        }

    def _estimator_summary(self) -> dict:
        """φ̂ and the grasp's split at the end; online, since the last new load the samples taken and
        skipped and the ticks refused for stale readings, and ``phi_history``."""
        controller = self.controller
        estimator = controller.estimator
        gripper = controller.phi_gripper
        summary = {"mode": "fixed" if estimator is None else "online", "phi_final": controller.phi.tolist(),
                   "holding": controller.holding, "phi_gripper": None if gripper is None else gripper.tolist()}
        if estimator is not None:
            summary |= {"samples_since_new_load": estimator.num_samples, "skipped": estimator.num_skipped,
                        "stale_since_new_load": estimator.num_stale, "phi_history": self.phi_history}
        return summary


def tick_row(teleop: HardwareTeleop) -> tuple[dict, np.ndarray]:
    """(row, scalars): the arrays a tick's row holds for the live view and the MCAP recorder, by
    ``analysis.run_log``'s names, as views of the station's and the controller's own arrays (built once, read
    in place each tick), and ``scalars`` [hold (s), gain, starts] for the loop to set. With the estimator
    online, the row holds its state and prior covariance too (``analysis.topics.ESTIMATOR_STATE``): the
    view's worker derives φ̂'s standard deviations from them (a copy of 997 numbers at the view's rate; the
    recorder, whose rows are ``heft export``'s of the same run, takes neither)."""
    station, controller = teleop.station, teleop.controller
    scalars = np.zeros(3)
    row = {"wrench_measured": station.wrench, "accel_measured": station.acceleration,
           "wrench_contact": controller.wrench_contact, "wrench_noncontact": controller.wrench_noncontact,
           "wrench_feedback": controller.wrench_feedback, "master_force": controller.master_wrench,
           "master_force_applied": controller.applied_wrench, "phi_hat": controller.phi,
           "offsets_hat": controller.offsets, "passivity_energy": controller.energy,
           "passivity_damping": controller.damping, "master_q": station.master_position,
           "master_v": station.master_velocity, "master_torque": station.torque_sent,
           "slave_q": station.slave_position, "slave_v": station.slave_velocity,
           "slave_q_commanded": controller._position, "pose_RS_desired": controller.pose_RS_desired,
           "pose_RS": controller.pose_RS, "pose_BE": controller.pose_BE, "scales": controller.scales,
           "ik_status": controller.ik_status, "hold": scalars[0:1], "gain": scalars[1:2], "starts": scalars[2:3]}
    if controller.estimator is not None:
        row[ESTIMATOR_STATE] = controller.program.block_state("phi_hat", "state")  # RlsLoadEstimator's, in place
        row[ESTIMATOR_PRIOR] = np.array([controller.estimator.params.prior_covariance])
    return row, scalars


def status_line(summary_so_far: dict) -> str:
    """The line ``heft teleop --hardware`` writes to stderr each second (``STATUS_PERIOD``)."""
    return (f"teleop: {summary_so_far['t']:.0f} s, {summary_so_far['rate_hz']:.0f} Hz, "
            + ("healthy" if summary_so_far["healthy"] else f"FORCES OFF (fault bits {summary_so_far['fault']})")
            + f", stylus force peak {summary_so_far['stylus_force_peak']:.2f} N, "
            f"φ̂ mass {summary_so_far['mass']:.3f} kg, faults {summary_so_far['faults']}")


STATUS_PERIOD = 1.0
"""s between the status lines of a run."""


def format_command_lag(lag: dict) -> str:
    """The line of ``summary``'s "arm_command_lag" (``CommandEcho.summary``)."""
    if not lag["statuses"]:
        return "the arm's commands: no status echoed one of them"
    measured = lag["statuses"] - lag["unmeasured"]
    text = (f"the arm's commands, as its status echoes them: late at {lag['late']} of {measured} statuses read "
            "(the newest each tick; stepped on an older command than the answer to the status before)")
    if lag["late"]:
        text += f", by up to {lag['max_lag']} step(s) ({lag['max_lag_at']:.4f} s after its first status)"
    if lag["unmeasured"]:
        text += (f"; {lag['unmeasured']} echoed none of the last {SENT_KEEP} commands sent (not measured; if most: "
                 "a driver that filters its commands or echoes none)")
    return text


TORQUE_NOT_FINITE, TORQUE_PEAK, STYLUS_FORCE_PEAK, STYLUS_TORQUE_PEAK, SLAVE_STEP, REANCHOR_STEP = range(6)
PEAKS_SIZE = 6
"""What ``command_peaks`` keeps of the commands sent: a non-finite master torque seen (1), then the peaks."""


@compiled("void(float64[:], float64[:], float64[:], float64, boolean, float64[:], boolean, boolean, float64[:])")
def command_peaks(peaks, torque_sent, applied_wrench, gain, healthy, position, has_position, reanchored,
                  last_position) -> None:
    """Updates ``peaks`` (``PEAKS_SIZE``) with one tick's commands: the master ``torque_sent`` (N·m) and,
    while ``healthy``, the wrench it renders on the hand (``gain`` × the controller's ``applied_wrench``);
    the slave command ``position`` (rad; if ``has_position``), whose largest joint change from
    ``last_position`` (NaN before the first; then set to it) counts as a move, or as a re-anchoring when
    the send set it to the measured position (``reanchored``)."""
    total, largest = 0.0, 0.0
    for j in range(torque_sent.shape[0]):
        total += torque_sent[j]
        largest = max(largest, abs(torque_sent[j]))
    if not math.isfinite(total):
        peaks[TORQUE_NOT_FINITE] = 1.0
    elif healthy:
        force, torque = wrench_norms(applied_wrench)
        peaks[TORQUE_PEAK] = max(peaks[TORQUE_PEAK], largest)
        peaks[STYLUS_FORCE_PEAK] = max(peaks[STYLUS_FORCE_PEAK], gain * force)
        peaks[STYLUS_TORQUE_PEAK] = max(peaks[STYLUS_TORQUE_PEAK], gain * torque)
    if not has_position:
        return
    step = 0.0
    for j in range(position.shape[0]):
        if not math.isnan(last_position[j]):
            step = max(step, abs(position[j] - last_position[j]))
        last_position[j] = position[j]
    slot = REANCHOR_STEP if reanchored else SLAVE_STEP
    peaks[slot] = max(peaks[slot], step)


def run_hardware_teleop(scenario: Scenario, load: LoadEstimate, duration: float, record=None,
                        priority: int = LOOP_PRIORITY, busy_wait: float = 0.0, view=None,
                        record_mcap=None) -> dict:
    """Runs ``HardwareTeleop`` on the scenario's lab (``scenario.lab``: the LCM channels' two URLs,
    ``open_buses``, and the station's watchdog) at its rate (``controller_period``) for
    ``duration`` s of wall time, with real-time ``priority`` (``claim_realtime``: after the
    recorder's loggers start, which keep normal scheduling, and before the buses open, so that
    LCM's receive thread shares it; then ``keep_cpu_for_loop`` moves that thread off the loop's
    CPU); returns its summary with ``timing`` (``timing_summary``), ``scheduling``, ``lcm_log``
    and ``epoch`` (wall-clock s since the Unix epoch at the loop's time 0). ``busy_wait``: the share of
    each period before a tick that the loop waits busy (``run_realtime``).
    SIGINT (Ctrl-C) or SIGTERM end the run early as its duration does: the station's
    last commands turn the forces off and hold the slave (``HardwareStation.stop``).
    ``record``: a path to record the LCM traffic to (``lcm-logger`` format), or None; ``view`` a
    ``diagrams.live_view.LiveView`` (not yet open) and ``record_mcap`` a path to write the run's rows to as
    MCAP (``McapRecorder``), each fed each tick off the loop's CPU. A status line goes to stderr each second."""
    say.info(f"teleop: {scenario.accelerometer.convention()}")
    say.info(f"teleop: {scenario.controller.force.mount_notch_summary()}")
    estimator = scenario.controller.estimator
    say.info("teleop: the controller Diagram (the blocks the simulation runs) steps each tick")
    say.info("teleop: load estimate " + (
        "fixed (`heft load --estimate` changes it)" if estimator.mode == "fixed" else
        f"learned online ({estimator.method}, forgetting {estimator.forgetting:g} per tick, prefilter "
        f"{estimator.prefilter:g} Hz, from readings at most {1e3 * estimator.max_input_age:g} ms old; "
        "`heft load --grasp`/`--release` or the gripper's driver split it into the "
        "gripper's and the object's, η of the object's fed back)"))
    channels, rate = scenario.lab.lcm, 1.0 / scenario.controller_period
    with contextlib.nullcontext() if record is None else LcmTrafficRecorder(channels, record):
        scheduling = claim_realtime(priority)
        say.info(f"teleop: {scheduling}")
        bus, command_bus = open_buses(channels)
        recorder = None if record_mcap is None else McapRecorder(record_mcap, slave_arm(scenario), scenario.master)
        taps = [tap for tap in (view, recorder) if tap is not None]
        teleop = HardwareTeleop(scenario, load, bus, channels, scenario.lab.station, command_bus, taps=taps,
                                state_every_tick=record is not None)
        teleop.status = lambda line: print(line, file=sys.stderr, flush=True)
        say.info(f"teleop: the slave is the {arm_name(slave_arm(scenario))}, {teleop.station.num_joints} joints on "
                 f"{channels.slave_status.name} and {channels.slave_command.name} (a status of another joint count "
                 f"is rejected); the master is the {scenario.master}")
        if priority:
            placement = keep_cpu_for_loop()
            scheduling += f"; {placement}"
            say.info(f"teleop: {placement}")
        if busy_wait:
            scheduling += f"; the last {busy_wait:g} of each period waited busy"
        anchor, ticking = teleop.station.loop_anchor(rate, busy_wait)
        scheduling += f"; {ticking}"
        say.info(f"teleop: {ticking}")
        say.debug(f"teleop: {teleop.station.drain()} messages arrived before the loop starts")
        teleop.station.epoch = time.time()
        with StopOnSignal() as stop:
            say.info("teleop: running (Ctrl-C stops with forces off and the slave held)")
            try:
                times = run_realtime(lambda now, dt: teleop.tick(now, dt) or stop.requested, 1.0 / rate, duration,
                                     sleep=teleop.station.idle, busy_wait=busy_wait, anchor=anchor)
                summary = teleop.summary(times.elapsed)
            finally:
                teleop.station.stop(teleop.now)
                teleop.station.publish_status(teleop.now, force=True)
                for tap in teleop.taps:
                    tap.close()
    return {"duration": times.elapsed, "rate_hz": rate, "epoch": teleop.station.epoch,
            "stopped_by_signal": stop.requested, **summary, "scheduling": scheduling,
            "lcm_log": None if record is None else str(record), "timing": timing_summary(times)}


def format_summary(summary: dict, lcm_url: str) -> str:
    """The summary as a few human lines; ``lcm_url`` is where the drivers publish."""
    faults = summary["faults"]
    fault_lines = "; ".join(
        f"at {f['onset']:.4f} s (bits {f['fault_bits']}, ages {f['ages_ms']} ms), "
        + ("not recovered" if f["recovered"] is None else f"recovered at {f['recovered']:.4f} s")
        for f in faults[:5]) + (f" … ({len(faults)} in all)" if len(faults) > 5 else "")
    first = ("never" if summary["first_healthy"] is None else f"first at {summary['first_healthy']:.4f} s")
    received = ", ".join(f"{name} {hz:.0f}" for name, hz in summary["received_hz"].items())
    sent = ", ".join(f"{name} {hz:.0f}" for name, hz in summary["sent_hz"].items())
    rejected = "; ".join(f"{name}: " + ", ".join(f"{count} {reason}" for reason, count in reasons.items())
                         for name, reasons in summary["rejected"].items() if reasons)
    reanchors = summary["slave_reanchors"]
    lines = [
        f"ran {summary['duration']:.3g} s at {summary['rate_hz']:g} Hz: {summary['ticks']} ticks, healthy in "
        f"{summary['healthy_ticks']} ({first}); faults: {fault_lines or 'none'}; "
        f"final: healthy {summary['final_healthy']}, fault bits {summary['final_fault_bits']}",
        f"messages per second: received {received}; sent {sent}",
        f"messages rejected (none reached the controller): {rejected or 'none'}; pushed out unread by newer "
        "ones: " + ", ".join(f"{name} {count}" for name, count in summary["unread"].items())
        + "; driver restarts: " + ", ".join(f"{name} {count}" for name, count in summary["driver_restarts"].items()),
        f"master command finite: {summary['master_torque_finite']}; peaks: {summary['master_torque_peak']:.3g} N·m "
        f"joint torque, {summary['stylus_force_peak']:.3g} N / {summary['stylus_torque_peak']:.3g} N·m on the "
        f"stylus; largest slave command step {summary['max_slave_command_step']:.3g} rad (besides "
        f"{reanchors['count']} start(s) from the measured position, up to {reanchors['max_step']:.3g} rad from the "
        "last command)",
        format_command_lag(summary["arm_command_lag"]),
        "load commands: " + ("; ".join(f"{count}× {event}" if count > 1 else event
                                       for event, count in collections.Counter(summary["load_events"]).items())
                             or "none"),
    ]
    for conflict in summary["second_publishers"]:
        ended = "still there at the end" if conflict["ended"] is None else f"gone at {conflict['ended']:.3f} s"
        lines.append(
            f"SECOND PUBLISHER on {conflict['channel']} from {conflict['onset']:.3f} s ({ended}): messages on a clock "
            f"{conflict['other_clock_offset_s'] - conflict['source_clock_offset_s']:+.3f} s off the driver's, or "
            "jumping back and forth; forces were off and the slave held meanwhile. Stop every other driver, "
            f"stand-in or replay publishing to {lcm_url}: `ss -uap` on each machine of the network lists the "
            "processes with a socket on its port, `lcm-logger` records who sends what")
    lines.append(format_timing(summary["timing"]))
    return "\n".join(lines)
