"""The gripper driver's LCM messages (``heft_gripper_state``) → grasps and releases.

Checked as the other channels are (``message_checks``): the structure, then whether
the message comes from the channel's one source (``message_order``), then its values;
what fails is counted per reason, never raised. Of the accepted messages only the
changes matter: HOLDING while not holding is a grasp, OPEN while holding a release
(CLOSING changes nothing: the fingers move, the load does not change yet).
The first state heard sets where the gripper is without an event (a controller started
while the gripper holds something takes the estimate it was given as the whole load).
The channel is not watched: a lab without a gripper driver runs as before.
"""

from __future__ import annotations

import math

from heft.hardware_interface.lcmtypes import heft_gripper_state
from heft.hardware_interface.message_checks import Rejections
from heft.hardware_interface.message_order import SourceClock

GRASP, RELEASE = "grasp", "release"
"""The events ``GripperStateReader.take`` returns."""
STATES = (heft_gripper_state.OPEN, heft_gripper_state.CLOSING, heft_gripper_state.HOLDING)
MAX_WIDTH = 1.0
"""m: the widest finger opening a driver may report (a wrist gripper opens a few centimetres to
a few decimetres); beyond it, or negative, a message is out of range."""


class GripperStateReader:
    """Takes ``heft_gripper_state`` payloads; a source silent for ``silence`` s gives way to the
    next (``SourceClock``). ``state`` is the last accepted state (None before the first),
    ``holding`` whether an object is held by the last grasp or release (or the first state),
    ``t_good`` its station time (s; −inf before the first), ``rejections`` and ``clock`` as the
    other readers'."""

    def __init__(self, silence: float):
        self.state = None
        self.holding = False
        self.rejections = Rejections()
        self.clock = SourceClock(silence)
        self._events = []

    @property
    def t_good(self) -> float:
        return self.clock.last_accept

    def take(self, payloads, now: float) -> list[str]:
        """Checks ``payloads`` (bytes, oldest first) read at station time ``now`` (s), in order; returns
        the grasps and releases among them (``GRASP``, ``RELEASE``; usually none, an empty list)."""
        events = self._events
        events.clear()
        for payload in payloads:
            reason = self._rejection(payload, now)
            if reason is not None:
                self.rejections.add(reason)
        return events

    def _rejection(self, payload: bytes, now: float) -> str | None:
        try:
            msg = heft_gripper_state.decode(payload)
        except Exception:  # whatever a malformed payload makes the generated decoder raise
            return "undecodable"
        stamp, clock = msg.utime * 1e-6, self.clock
        reason = clock.rejection(stamp, now)
        if reason is not None:
            return reason
        if not math.isfinite(msg.width):
            return "non_finite"
        if msg.error:
            return "driver_error"
        if msg.state not in STATES or not 0.0 <= msg.width <= MAX_WIDTH:
            return "out_of_range"
        clock.accept(stamp, now)
        holding = self.holding
        if msg.state == heft_gripper_state.HOLDING:
            holding = True
        elif msg.state == heft_gripper_state.OPEN:
            holding = False  # CLOSING changes nothing: the fingers move, the load does not change yet
        if self.state is not None and holding != self.holding:
            self._events.append(GRASP if holding else RELEASE)
        self.state, self.holding = msg.state, holding
        return None
