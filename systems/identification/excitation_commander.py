"""The slave's position command for an identification run on the real arm.

On hardware the excitation (Eqs. 9–10) cannot simply start: the arm is wherever
it was left. ``excitation_command`` is the whole schedule as a function of the
time since the station first became healthy: a quintic move from the latched
measured position to the trajectory's start (slow enough for every joint's
speed limit), a settling pause, the excitation, then a hold at its end.
``ExcitationCommander`` steps it on the hardware's clock: it waits for the
hardware to be healthy, latches the measured position, and reports the phase
and the time into the excitation so a recording can keep exactly the
excitation's samples. If the station turns unhealthy after it started, the run
is marked aborted and the command freezes (the hardware station then holds the
arm where it is).
"""

import enum
import math

import numpy as np

from heft.systems.identification.excitation import FourierTrajectory


class Phase(enum.IntEnum):
    """What the commander is doing; the ``phase`` output carries the value."""

    WAITING = 0      # for the hardware to be healthy
    APPROACHING = 1  # quintic move to the excitation's start
    SETTLING = 2     # at rest at the start
    EXCITING = 3     # playing the trajectory
    DONE = 4         # holding the trajectory's end
    ABORTED = 5      # the hardware faulted after the start: command frozen


QUINTIC_PEAK_SPEED = 15.0 / 8.0
"""Peak speed of the rest-to-rest quintic 10s³ − 15s⁴ + 6s⁵ over Δq in time T, in units of Δq/T."""


def approach_time(q_from, q_to, velocity_limits, speed_fraction: float, minimum: float) -> float:
    """Duration (s) of the quintic move ``q_from`` → ``q_to`` (rad) whose peak joint speed is
    ``speed_fraction`` of ``velocity_limits`` (rad/s); at least ``minimum`` s."""
    distance = np.abs(np.asarray(q_to, dtype=float) - np.asarray(q_from, dtype=float))
    limits = speed_fraction * np.asarray(velocity_limits, dtype=float)
    return max(minimum, float(np.max(QUINTIC_PEAK_SPEED * distance / limits)))


def excitation_command(elapsed: float, q_latched, trajectory: FourierTrajectory, approach: float, settle: float,
                       duration: float) -> tuple[np.ndarray, Phase]:
    """(command (rad), phase) ``elapsed`` s after the start: quintic from ``q_latched`` to
    q(0) over ``approach`` s, q(0) for ``settle`` s, q(t) for ``duration`` s, then q(duration)."""
    if elapsed < approach:
        s = elapsed / approach
        blend = s * s * s * (10.0 - 15.0 * s + 6.0 * s * s)
        start = trajectory.position(0.0)
        return q_latched + blend * (start - q_latched), Phase.APPROACHING
    if elapsed < approach + settle:
        return trajectory.position(0.0), Phase.SETTLING
    t = elapsed - approach - settle
    if t < duration:
        return trajectory.position(t), Phase.EXCITING
    return trajectory.position(duration), Phase.DONE


class ExcitationCommander:
    """The schedule of ``excitation_command`` on the hardware station's clock.

    ``step(now, healthy, measured)`` once per tick (``now`` in s, monotonic; ``measured``
    q_S, n rad) updates ``command`` (n, rad) and ``phase``. Until the first healthy tick
    the command is the measured position; that tick latches it and starts the schedule
    with the approach time of ``approach_time`` (``speed_fraction`` of ``velocity_limits``,
    at least ``minimum_approach`` s). ``elapsed`` is the time since that start (s).
    """

    def __init__(self, trajectory: FourierTrajectory, duration: float, velocity_limits, settle: float = 1.0,
                 speed_fraction: float = 0.2, minimum_approach: float = 1.0):
        if not (math.isfinite(duration) and duration > 0):
            raise ValueError(f"duration must be finite and > 0 (s); got {duration}")
        n = len(trajectory.q0)
        if len(velocity_limits) != n:
            raise ValueError(f"velocity_limits needs one entry (rad/s) per joint ({n}); got {len(velocity_limits)}")
        self.trajectory, self.duration, self.settle = trajectory, duration, settle
        self._limits = np.asarray(velocity_limits, dtype=float)
        self._speed_fraction, self._minimum_approach = speed_fraction, minimum_approach
        self.phase = Phase.WAITING
        self.command = np.zeros(n)
        self.approach = math.nan
        self.elapsed = math.nan
        self._start, self._latched = math.nan, np.zeros(n)

    def step(self, now: float, healthy: bool, measured) -> None:
        if self.phase in (Phase.DONE, Phase.ABORTED):
            return
        if self.phase == Phase.WAITING:
            self.command[:] = measured
            if not healthy:
                return
            self._start = now
            self.approach = approach_time(measured, self.trajectory.position(0.0), self._limits,
                                          self._speed_fraction, self._minimum_approach)
            self._latched[:] = measured
        elif not healthy:
            self.phase = Phase.ABORTED
            return
        self.elapsed = now - self._start
        command, self.phase = excitation_command(self.elapsed, self._latched, self.trajectory, self.approach,
                                                 self.settle, self.duration)
        self.command[:] = command

    @property
    def excitation_time(self) -> float:
        """Time into the excitation (s): negative before it, past ``duration`` after it."""
        return self.elapsed - self.approach - self.settle
