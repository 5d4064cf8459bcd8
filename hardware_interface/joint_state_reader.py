"""A joint-state driver's LCM messages (the haptic master's ``heft_haptic_state``, the arm's
``lcmt_iiwa_status``) → the newest state the controller may use.

Every message is checked (``message_checks``): its structure, then whether it comes
from the channel's one source (``message_order``), then its values; what fails is
counted, never raised. A message of the device's joint count (the master's six, the
arm's six or seven) is read in place by one kernel (``joint_state_rejection``); anything
else by the generated decoder, which tells a wrong joint count from garbage.
"""

from __future__ import annotations

import math

import numpy as np
from drake import lcmt_iiwa_status

from heft.systems.compiled import compiled
from heft.systems.controller.master_kinematics import NUM_JOINTS as MASTER_JOINTS

from heft.hardware_interface.fixed_layout import PAYLOAD, FixedLayout, of_layout, wire_double, wire_int
from heft.hardware_interface.lcmtypes import heft_haptic_state
from heft.hardware_interface.message_checks import (ACCEPT, DISCONTINUOUS, DRIVER_ERROR, JOINT_COUNT, NON_FINITE,
                                                    OUT_OF_RANGE, UNDECODABLE, JointRange, Rejections,
                                                    joints_continuous, joints_within)
from heft.hardware_interface.message_order import (LATE_TOLERANCE, SourceClock, clock_accept, clock_foreign,
                                                   clock_rejection, clock_since_last, clock_starts_source)

NOT_OF_LAYOUT = -2
"""``joint_state_rejection``'s code for a payload it cannot read: not a message of the type and joint count."""
# Where a type carries the state (``JointStateFields.at``): the message's size, then the byte offsets of
# utime, num_joints, the positions, the velocities, the error flag, the buttons and the commanded
# positions (−1: none).
SIZE, UTIME, COUNT, POSITION, VELOCITY, ERROR, BUTTONS, COMMANDED = range(8)
# The reader's memory: the last accepted stamp (s, the driver's clock), its buttons and its utime (µs).
STAMP, BUTTON_BITS, STAMP_UTIME = range(3)


class JointStateFields:
    """Where a joint-state type carries (utime, num_joints, position, velocity, error, buttons,
    commanded) for a device of ``num_joints`` joints: the fields named ``position`` and ``velocity``, and
    ``error`` / ``buttons`` / ``commanded`` (the command the driver steps on) if it has them (else False / 0 /
    none). ``at`` holds their byte offsets in a message of ``num_joints`` joints (``SIZE`` … ``COMMANDED``)."""

    def __init__(self, lcm_type, num_joints: int, position: str, velocity: str, error: str | None = None,
                 buttons: str | None = None, commanded: str | None = None):
        self.lcm_type, self.num_joints = lcm_type, num_joints
        layout = FixedLayout(lcm_type, num_joints=num_joints)
        self.fingerprint = layout.fingerprint
        self.at = np.array([layout.size] + [-1 if name is None else layout.offset(name) for name in
                                            ("utime", "num_joints", position, velocity, error, buttons,
                                             commanded)],
                           dtype=np.int64)
        self._position, self._velocity = position, velocity

    def joint_count(self, msg) -> bool:
        """Whether a decoded message ``msg`` has the device's joints."""
        n = self.num_joints
        return msg.num_joints == n and len(getattr(msg, self._position)) == n and len(getattr(msg, self._velocity)) == n


HAPTIC_STATE = JointStateFields(heft_haptic_state, MASTER_JOINTS, "position", "velocity", "error", "buttons")


def iiwa_status(num_joints: int) -> JointStateFields:
    """The arm driver's status for an arm of ``num_joints`` joints: it carries no error flag and no buttons, and
    echoes the command it steps on."""
    return JointStateFields(lcmt_iiwa_status, num_joints, "joint_position_measured", "joint_velocity_estimated",
                            commanded="joint_position_commanded")


class JointStateReader:
    """Takes one driver's payloads and holds its newest accepted state.

    ``fields`` says where its type carries the state and for how many joints (``HAPTIC_STATE``,
    ``iiwa_status(n)``);
    ``joint_range`` is what the device can report; a source silent for ``silence`` s gives way to
    the next (``SourceClock``). After ``take``: ``position``, ``velocity`` (rad, rad/s; updated in
    place), ``buttons``, ``t_good`` (the station time, s, of the last accepted message; −inf before
    the first), ``utime`` (its stamp, µs on the driver's clock; 0 before the first), ``commanded``
    (rad: the command the driver says it stepped on, where its type carries one, else zeros; not
    checked, as the station only compares it with the commands it sent: ``command_echo``),
    ``rejections`` and ``clock``."""

    def __init__(self, fields: JointStateFields, joint_range: JointRange, silence: float):
        self._fields = fields
        n = fields.num_joints
        if any(len(limits) != n for limits in (joint_range.lower, joint_range.upper, joint_range.velocity)):
            raise ValueError(f"the joint range of a {n}-joint {fields.lcm_type.__name__} needs {n} limits per joint "
                             f"field; got {len(joint_range.lower)}")
        self.position, self.velocity, self.commanded = np.zeros(n), np.zeros(n), np.zeros(n)
        self.rejections = Rejections()
        self.clock = SourceClock(silence)
        self._memory = np.zeros(3)
        self._arguments = (fields.fingerprint, fields.at, self.clock.state, self._memory, joint_range.lower,
                           joint_range.upper, joint_range.velocity, joint_range.speed, self.position, self.velocity,
                           self.commanded, np.zeros(2 * n), self.rejections.by_code)

    @property
    def t_good(self) -> float:
        return self.clock.last_accept

    @property
    def buttons(self) -> int:
        return int(self._memory[BUTTON_BITS])

    @property
    def utime(self) -> int:
        return int(self._memory[STAMP_UTIME])

    def take(self, payloads, now: float) -> None:
        """Checks ``payloads`` (bytes, oldest first) read at station time ``now`` (s), in order."""
        for payload in payloads:
            if joint_state_rejection(payload, now, *self._arguments) == NOT_OF_LAYOUT:
                self._take_decoded(payload, now)

    def _take_decoded(self, payload: bytes, now: float) -> None:
        """Checks a payload that is not a message of the type and joint count, by the generated decoder."""
        fields = self._fields
        try:
            msg = fields.lcm_type.decode(payload)
        except Exception:  # whatever a malformed payload makes the generated decoder raise
            self.rejections.by_code[UNDECODABLE] += 1
            return
        if not fields.joint_count(msg):
            self.rejections.by_code[JOINT_COUNT] += 1
            return
        joint_state_rejection(msg.encode(), now, *self._arguments)  # its joints: now of the layout


@compiled(f"int64({PAYLOAD}, float64, int64[:], float64[:], float64[:], float64[:], float64[:], float64[:], "
          "float64[:], float64[:], float64[:], float64[:], float64[:])")
def _rejection(payload, now, at, clock, memory, lower, upper, max_velocity, speed, position, velocity, commanded,
               scratch) -> int:
    """``joint_state_rejection`` of a payload of the layout, uncounted."""
    n = position.shape[0]
    if wire_int(payload, at[COUNT], 4) != n:
        return JOINT_COUNT
    utime = wire_int(payload, at[UTIME], 8)
    stamp = utime * 1e-6
    code = clock_rejection(clock, stamp, now)
    if code != ACCEPT:
        return code
    q, v = scratch[:n], scratch[n:]
    total = 0.0
    for j in range(n):
        q[j] = wire_double(payload, at[POSITION] + 8 * j)
        v[j] = wire_double(payload, at[VELOCITY] + 8 * j)
        total += q[j] + v[j]
    if not math.isfinite(total):
        return NON_FINITE
    if at[ERROR] >= 0 and payload[at[ERROR]] != 0:
        return DRIVER_ERROR
    if not joints_within(q, v, lower, upper, max_velocity):
        return OUT_OF_RANGE
    # The joints may have moved for as long as the stamps say, but not longer than the station
    # saw pass (a publisher leading the driver's clock gains no time to jump by).
    elapsed = min(stamp - memory[STAMP], clock_since_last(clock, now) + LATE_TOLERANCE)
    if not clock_starts_source(clock, now) and not joints_continuous(position, q, speed, elapsed):
        clock_foreign(clock, stamp, now)
        return DISCONTINUOUS
    clock_accept(clock, stamp, now)
    memory[STAMP], memory[STAMP_UTIME] = stamp, utime
    memory[BUTTON_BITS] = wire_int(payload, at[BUTTONS], 4) if at[BUTTONS] >= 0 else 0
    for j in range(n):
        position[j] = q[j]
        velocity[j] = v[j]
    if at[COMMANDED] >= 0:
        for j in range(n):
            commanded[j] = wire_double(payload, at[COMMANDED] + 8 * j)
    return ACCEPT


@compiled(f"int64({PAYLOAD}, float64, {PAYLOAD}, int64[:], float64[:], float64[:], float64[:], float64[:], "
          "float64[:], float64[:], float64[:], float64[:], float64[:], float64[:], int64[:])")
def joint_state_rejection(payload, now, fingerprint, at, clock, memory, lower, upper, max_velocity, speed, position,
                          velocity, commanded, scratch, rejected) -> int:
    """Checks one payload read at station time ``now`` (s), in place: accepted, it becomes the
    reader's state (``position``, ``velocity``, ``commanded``, ``memory``); rejected, its reason is counted in
    ``rejected`` (per code). Returns ``ACCEPT``, the reason's code, or ``NOT_OF_LAYOUT`` (nothing
    counted). ``fingerprint`` and ``at`` are the type's (``JointStateFields``), ``clock`` the
    source's (``message_order``), the limits a ``JointRange``'s, each of the device's n joints (as ``position``,
    ``velocity``, ``commanded``); ``scratch``: 2n floats."""
    if not of_layout(payload, fingerprint, at[SIZE]):
        return NOT_OF_LAYOUT
    code = _rejection(payload, now, at, clock, memory, lower, upper, max_velocity, speed, position, velocity,
                      commanded, scratch)
    if code != ACCEPT:
        rejected[code] += 1
    return code
