"""The slave's position command for an identification run on the real arm.

On hardware the excitation (Eqs. 9–10) cannot simply start: the arm is wherever
it was left. ``excitation_command`` is the whole schedule as a function of the
time since the station first became healthy: a quintic move from the latched
measured position to the trajectory's start (slow enough for every joint's
speed limit), a settling pause, the excitation, then a hold at its end.
``ExcitationCommander`` wraps it: it waits for the hardware to be healthy,
latches the measured position, and reports the phase so a recording can keep
exactly the excitation's samples. If the station turns unhealthy after it
started, the run is marked aborted and the command freezes (the hardware
station's gate then holds the arm where it is).
"""

import enum
import math

import numpy as np
from pydrake.systems.framework import BasicVector, LeafSystem

from .excitation import FourierTrajectory


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


class ExcitationCommander(LeafSystem):
    """Inputs ``position_measured`` (n, rad) and ``healthy`` (1, > 0.5 healthy); outputs
    ``position_commanded`` (n, rad) and ``phase`` (1, a ``Phase``), both state updated
    every ``period`` s (offset 0), so there is no direct feedthrough.

    Until the first healthy tick the command is the measured position. That tick
    latches it and starts the schedule of ``excitation_command`` with the approach
    time of ``approach_time`` (``speed_fraction`` of ``velocity_limits``, at least
    ``minimum_approach`` s).
    """

    def __init__(self, trajectory: FourierTrajectory, duration: float, velocity_limits, period: float,
                 settle: float = 1.0, speed_fraction: float = 0.2, minimum_approach: float = 1.0):
        super().__init__()
        if not (math.isfinite(duration) and duration > 0):
            raise ValueError(f"duration must be finite and > 0 (s); got {duration}")
        n = len(trajectory.q0)
        if len(velocity_limits) != n:
            raise ValueError(f"velocity_limits needs one entry (rad/s) per joint ({n}); got {len(velocity_limits)}")
        self._trajectory, self._duration, self._settle = trajectory, duration, settle
        self._limits = np.asarray(velocity_limits, dtype=float)
        self._speed_fraction, self._minimum_approach = speed_fraction, minimum_approach
        self._measured = self.DeclareVectorInputPort("position_measured", n)
        self._healthy = self.DeclareVectorInputPort("healthy", 1)
        self._command = self.DeclareDiscreteState(n)
        self._phase = self.DeclareDiscreteState(1)
        # Start time (s), approach duration (s), latched position (n, rad).
        self._start = self.DeclareDiscreteState(BasicVector(np.concatenate(([math.nan, math.nan], np.zeros(n)))))
        self.DeclareStateOutputPort("position_commanded", self._command)
        self.DeclareStateOutputPort("phase", self._phase)
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)

    def _update(self, context, discrete_state):
        phase = Phase(int(context.get_discrete_state(self._phase).GetAtIndex(0)))
        if phase in (Phase.DONE, Phase.ABORTED):
            return
        healthy = self._healthy.Eval(context)[0] > 0.5
        start = discrete_state.get_mutable_vector(self._start).get_mutable_value()
        if phase == Phase.WAITING:
            measured = self._measured.Eval(context)
            if not healthy:
                discrete_state.get_mutable_vector(self._command).SetFromVector(measured)
                return
            start[0] = context.get_time()
            start[1] = approach_time(measured, self._trajectory.position(0.0), self._limits,
                                     self._speed_fraction, self._minimum_approach)
            start[2:] = measured
        elif not healthy:
            discrete_state.get_mutable_vector(self._phase).SetAtIndex(0, float(Phase.ABORTED))
            return
        command, phase = excitation_command(context.get_time() - start[0], start[2:], self._trajectory, start[1],
                                            self._settle, self._duration)
        discrete_state.get_mutable_vector(self._command).SetFromVector(command)
        discrete_state.get_mutable_vector(self._phase).SetAtIndex(0, float(phase))
