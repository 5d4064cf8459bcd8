"""`heft identify --hardware`: the excitation on the real arm over LCM, then Sec. IV's estimators.

``HardwareIdentification.tick`` is one tick of the real-time loop
(``diagrams.running.realtime``): the hardware station receives, the
``ExcitationCommander`` (it waits for healthy hardware, moves slowly to the
excitation's start, settles, excites, holds) commands the slave, the master
gets zero torque, and every tick of the excitation phase is recorded with its
time into the excitation. ``recording`` resamples those ticks onto the
controller rate's uniform grid — exactly the excitation's whole periods — for
the same estimators as in simulation. There is no truth on hardware: the report
gives each method's estimate, its standard deviations, the residual RMS of the
wrench model per axis, and the spread between methods. A live view (``--view``) is fed
each tick's row (``HardwareIdentification.row``) and, once estimated, the estimate
(``show_estimate``).
"""

from __future__ import annotations

import contextlib
import logging
import math
import time

import lcm
import numpy as np

from heft.analysis.topics import TOPIC_BY_NAME
from heft.diagrams.device_limits import device_limits
from heft.diagrams.identify import Recording
from heft.diagrams.running.lcm_recording import LcmTrafficRecorder
from heft.diagrams.running.realtime import (LOOP_PRIORITY, HardwareRunFailed, StopOnSignal, claim_realtime,
                                            format_timing, keep_cpu_for_loop, run_realtime, timing_summary)
from heft.diagrams.scenario import Scenario
from heft.systems.controller.master_kinematics import NUM_JOINTS as MASTER_JOINTS
from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.hardware_station import (
    WATCHED_CHANNELS,
    HardwareStation,
    HardwareStationParams,
)
from heft.hardware_interface.lcm_mailbox import open_buses
from heft.hardware_interface.message_checks import DeviceLimits
from heft.systems.identification.excitation_commander import ExcitationCommander, Phase


say = logging.getLogger(__name__)
"""What this module reports, which `heft` shows (-v, -q)."""


class IdentificationAborted(HardwareRunFailed):
    """The hardware run could not give a usable recording (no hardware, a fault, incomplete)."""


WAIT_LIMIT = 10.0
"""Seconds to wait for healthy hardware before giving up."""
ESTIMATE_TOPICS = ("/estimate/phi", "/estimate/offsets")
"""The live view's topics of the estimate (``show_estimate``), advertised with the rows'."""


class HardwareIdentification:
    """The excitation ``trajectory`` (``duration`` s) on the lab at ``bus`` (module docstring),
    ticked at most once per ``period`` s (the real-time loop's grid).

    ``tick(now, dt)`` returns True once the commander is done or aborted; it raises
    ``IdentificationAborted`` if the hardware is not healthy within ``WAIT_LIMIT`` s. ``taps``: live
    views (``diagrams.live_view``, opened here; closed by their owner) fed ``row`` each tick, from
    ``start``."""

    def __init__(self, trajectory, duration: float, period: float, bus: lcm.LCM, channels: LcmChannels,
                 limits: DeviceLimits, params: HardwareStationParams | None = None,
                 command_bus: lcm.LCM | None = None, taps=()):
        self.station = station = HardwareStation(bus, channels, limits, params, command_bus)
        self.commander = commander = ExcitationCommander(trajectory, duration, limits.slave_velocity)
        self._zero = np.zeros(MASTER_JOINTS)  # the master's torque
        self.now = 0.0
        """The last tick's time (s)."""
        self.epoch = time.time()
        """Wall-clock s since the Unix epoch at the loop's time 0 (``start``)."""
        self._excitation = np.zeros(3)
        self.row = {"wrench_measured": station.wrench, "slave_q": station.slave_position,
                    "slave_v": station.slave_velocity, "slave_q_commanded": commander.command,
                    "master_q": station.master_position, "master_v": station.master_velocity,
                    "excitation": self._excitation}
        """A tick's row for a live view, by ``analysis.run_log``'s names, read in place: the measured wrench (at S
        in S), the joints and the arm's command, and ``excitation`` [phase, time into it (s), share played]
        (``analysis.topics``' ``/identify/excitation``)."""
        self._widths = {key: np.size(value) for key, value in self.row.items()}
        self.taps = list(taps)
        for tap in self.taps:
            tap.open(self._widths, topics=ESTIMATE_TOPICS)
        # Per excitation tick: time into the excitation (s), wrench (6), acceleration (6), q_S (n).
        self._rows = np.empty((int(duration / period) + 2, 13 + station.num_joints))
        self._count = 0
        self.abort_reason = None

    def start(self) -> None:
        """The loop's time 0 is now: ``epoch``, from which the taps' messages are timed."""
        self.epoch = time.time()
        for tap in self.taps:  # the same keys: only the time origin moves
            tap.open(self._widths, t0_ns=round(self.epoch * 1e9), topics=ESTIMATE_TOPICS)

    def tick(self, now: float, dt: float) -> bool:
        self.now = now
        station, commander = self.station, self.commander
        station.receive(now)
        commander.step(now, station.healthy, station.slave_position)
        station.send(now, self._zero, commander.command)
        station.publish_status(now)
        phase = commander.phase
        if self.taps:
            excitation, time_into = self._excitation, commander.excitation_time
            excitation[0], excitation[1] = phase, time_into
            excitation[2] = 0.0 if math.isnan(time_into) else min(max(time_into / commander.duration, 0.0), 1.0)
            for tap in self.taps:
                tap.publish(now, self.row)
        if phase == Phase.EXCITING:
            row = self._rows[self._count]  # one row per grid point at most: the buffer holds them all
            row[0] = commander.excitation_time
            row[1:7], row[7:13], row[13:] = station.wrench, station.acceleration, station.slave_position
            self._count += 1
        elif phase == Phase.WAITING and now > WAIT_LIMIT:
            raise IdentificationAborted(f"no healthy hardware within {WAIT_LIMIT:g} s: are the drivers (or "
                                        "`heft stand-in`) running on this LCM URL?")
        elif phase == Phase.ABORTED and self.abort_reason is None:
            ages = ", ".join(f"{name} {1e3 * age:.1f} ms" for name, age in zip(WATCHED_CHANNELS, station.ages))
            self.abort_reason = (f"the hardware faulted at t = {now:.3f} s, {commander.excitation_time:.3f} s into "
                                 f"the excitation (watchdog fault bits {station.fault}; channel ages {ages})")
        return phase in (Phase.DONE, Phase.ABORTED)

    def recording(self, period: float) -> Recording:
        """The excitation's ticks resampled (linearly) onto t = 0, period, … < duration; raises
        ``IdentificationAborted`` if the run faulted or did not complete. Ticks are never further
        apart than the watchdog's timeout: a longer stall is a fault that aborts the run."""
        if self.abort_reason is not None:
            raise IdentificationAborted(f"{self.abort_reason}: no estimate. Check the drivers' timing (or the "
                                        "LCM log) and run again")
        rows = self._rows[:self._count]
        duration = self.commander.duration
        samples = int(round(duration / period))
        if self.commander.phase != Phase.DONE or rows.shape[0] < 2:
            raise IdentificationAborted(f"the excitation did not complete ({rows.shape[0]} ticks recorded)")
        t = np.arange(samples) * period
        resampled = np.column_stack([np.interp(t, rows[:, 0], rows[:, i]) for i in range(1, rows.shape[1])])
        return Recording(t=t, wrench=resampled[:, :6], accel_measured=resampled[:, 6:12], q=resampled[:, 12:])


def show_estimate(view, record: dict) -> None:
    """Shows an estimate (``load_estimate.estimate_record``: φ̂ with its standard deviations, the offsets) on
    ``view``'s ``/estimate/phi`` and ``/estimate/offsets``, at the loop's clock now."""
    t = view.since_origin()
    rows = {"phi_hat": record["phi"], "phi_hat_std": record["std_phi"], "offsets_hat": record["offsets"]}
    for topic in ESTIMATE_TOPICS:
        view.event(topic, TOPIC_BY_NAME[topic].message(t, rows), t)


def record_on_hardware(scenario: Scenario, trajectory, duration: float, channels: LcmChannels, record=None,
                       params: HardwareStationParams | None = None, priority: int = LOOP_PRIORITY, view=None):
    """Runs ``HardwareIdentification`` on ``channels``' two URLs (``open_buses``) in real time at
    the controller rate (real-time ``priority``: ``claim_realtime``, as ``run_hardware_teleop``
    does) until the excitation is done (or aborted); returns (Recording, timing summary). ``view``: a
    ``diagrams.live_view.LiveView`` fed each tick, left open for the estimate (its owner closes it)."""
    period = scenario.controller_period
    budget = WAIT_LIMIT + 60.0 + duration  # waiting, the slow approach and settling, the excitation
    with contextlib.nullcontext() if record is None else LcmTrafficRecorder(channels, record):
        say.info(f"identify: {claim_realtime(priority)}")
        bus, command_bus = open_buses(channels)
        run = HardwareIdentification(trajectory, duration, period, bus, channels, device_limits(scenario), params,
                                     command_bus, taps=() if view is None else (view,))
        if priority:
            say.info(f"identify: {keep_cpu_for_loop()}")
        anchor, ticking = run.station.loop_anchor(1.0 / period, 0.0)
        say.info(f"identify: {ticking}")
        say.debug(f"identify: {run.station.drain()} messages arrived before the loop starts")
        run.start()
        with StopOnSignal() as stop:
            try:
                times = run_realtime(lambda now, dt: run.tick(now, dt) or stop.requested, period, budget,
                                     sleep=run.station.idle, anchor=anchor)
            finally:
                run.station.stop(run.now)
                run.station.publish_status(run.now, force=True)
        if stop.requested:
            raise HardwareRunFailed("stopped by a signal before the excitation completed; forces off, the arm held")
    return run.recording(period), timing_summary(times)


def hardware_recorder(scenario: Scenario, channels: LcmChannels, record=None,
                      params: HardwareStationParams | None = None, priority: int = LOOP_PRIORITY, view=None):
    """The ``record`` of ``identify`` on the hardware on ``channels`` (``record_on_hardware``, feeding ``view``);
    the extra metrics are the LCM URLs, the loop's timing and the traffic log's path."""
    def run(trajectory, duration: float):
        say.info(f"identify: excitation of {duration:g} s on {channels.lcm_url} (commands on "
                 f"{channels.command_lcm_url()}); the arm first moves slowly to its start")
        recording, timing = record_on_hardware(scenario, trajectory, duration, channels, record, params, priority,
                                               view)
        say.info(format_timing(timing))
        return recording, {"lcm_url": channels.lcm_url, "command_url": channels.command_lcm_url(), "timing": timing,
                           "lcm_log": None if record is None else str(record)}
    return run
