"""A joint-state driver's LCM messages (the Phantom's ``heft_haptic_state``, the arm's
``lcmt_iiwa_status``) → the newest state the controller may use.

Every message is checked (``message_checks``): its structure, then whether it comes
from the channel's one source (``message_order``), then its values; what fails is
counted, never raised.
"""

from __future__ import annotations

import math

import numpy as np
from drake import lcmt_iiwa_status

from heft.systems.slave_kinematics import NUM_JOINTS  # the Phantom has as many (master_kinematics)

from heft.hardware_interface.fixed_layout import FixedLayout
from heft.hardware_interface.lcmtypes import heft_haptic_state
from heft.hardware_interface.message_checks import JointRange, Rejections
from heft.hardware_interface.message_order import LATE_TOLERANCE, SourceClock


class JointStateFields:
    """Where a joint-state type carries (utime, num_joints, position, velocity, error, buttons): the
    fields named ``position`` and ``velocity``, and ``error`` / ``buttons`` if it has them (else
    False / 0); read off a decoded message or, for a message of the type's ``layout`` (6 joints), off
    its unpacked values."""

    def __init__(self, lcm_type, position: str, velocity: str, error: str | None = None,
                 buttons: str | None = None):
        self.lcm_type = lcm_type
        self.layout = FixedLayout(lcm_type, num_joints=NUM_JOINTS)
        self._names = (position, velocity, error, buttons)
        self._at = tuple(None if name is None else self.layout.field(name)
                         for name in ("utime", "num_joints", position, velocity, error, buttons))

    def of_message(self, msg) -> tuple:
        position, velocity, error, buttons = self._names
        return (msg.utime, msg.num_joints, getattr(msg, position), getattr(msg, velocity),
                False if error is None else getattr(msg, error), 0 if buttons is None else getattr(msg, buttons))

    def of_values(self, values: tuple) -> tuple:
        utime, num_joints, position, velocity, error, buttons = self._at
        return (values[utime], values[num_joints], values[position], values[velocity],
                False if error is None else values[error], 0 if buttons is None else values[buttons])


HAPTIC_STATE = JointStateFields(heft_haptic_state, "position", "velocity", "error", "buttons")
IIWA_STATUS = JointStateFields(lcmt_iiwa_status, "joint_position_measured", "joint_velocity_estimated")
"""The arm driver's status carries no error flag and no buttons."""


class JointStateReader:
    """Takes one driver's payloads and holds its newest accepted state.

    ``fields`` says where its type carries the state (``HAPTIC_STATE``, ``IIWA_STATUS``): a
    six-joint message is unpacked by its layout, anything else decoded by the generated decoder
    (which then tells a wrong joint count from garbage); ``joint_range`` is what the device can report; a source
    silent for ``silence`` s gives way to the next (``SourceClock``). After ``take``:
    ``position``, ``velocity`` (rad, rad/s; updated in place), ``buttons``, ``t_good`` (the
    station time, s, of the last accepted message; −inf before the first), ``utime`` (its
    stamp, µs on the driver's clock; 0 before the first), ``rejections`` and ``clock``."""

    def __init__(self, fields: JointStateFields, joint_range: JointRange, silence: float):
        self._fields, self._range = fields, joint_range
        self.position, self.velocity = np.zeros(NUM_JOINTS), np.zeros(NUM_JOINTS)
        self.buttons = 0
        self.t_good = -math.inf
        self.utime = 0
        self.rejections = Rejections()
        self.clock = SourceClock(silence)
        self._position = [0.0] * NUM_JOINTS  # the last accepted position, for the continuity check
        self._stamp = 0.0

    def take(self, payloads, now: float) -> None:
        """Checks ``payloads`` (bytes, oldest first) read at station time ``now`` (s), in order."""
        for payload in payloads:
            reason = self._rejection(payload, now)
            if reason is not None:
                self.rejections.add(reason)

    def _rejection(self, payload: bytes, now: float) -> str | None:
        """Accepts ``payload`` and returns None, or returns why it is rejected."""
        fields = self._fields
        values = fields.layout.unpack(payload)
        if values is not None:
            utime, num_joints, position, velocity, error, buttons = fields.of_values(values)
        else:
            try:
                utime, num_joints, position, velocity, error, buttons = fields.of_message(
                    fields.lcm_type.decode(payload))
            except Exception:  # whatever a malformed payload makes the generated decoder raise
                return "undecodable"
        if num_joints != NUM_JOINTS or len(position) != NUM_JOINTS or len(velocity) != NUM_JOINTS:
            return "joint_count"
        stamp, clock = utime * 1e-6, self.clock
        reason = clock.rejection(stamp, now)
        if reason is not None:
            return reason
        if not math.isfinite(sum(position) + sum(velocity)):
            return "non_finite"
        if error:
            return "driver_error"
        if not self._range.contains(position, velocity):
            return "out_of_range"
        # The joints may have moved for as long as the stamps say, but not longer than the station
        # saw pass (a publisher leading the driver's clock gains no time to jump by).
        elapsed = min(stamp - self._stamp, clock.since_last(now) + LATE_TOLERANCE)
        if not clock.starts_source(now) and not self._range.continuous(self._position, position, elapsed):
            clock.foreign(stamp, now)
            return "discontinuous"
        clock.accept(stamp, now)
        self._stamp, self.t_good, self.buttons, self.utime = stamp, now, buttons, utime
        self._position[:] = position
        self.position[:] = position
        self.velocity[:] = velocity
        return None
