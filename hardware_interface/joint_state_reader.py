"""A joint-state driver's LCM messages (the Phantom's ``heft_haptic_state``, the arm's
``lcmt_iiwa_status``) → the newest state the controller may use.

Every message is checked (``message_checks``): its structure, then whether it comes
from the channel's one source (``message_order``), then its values; what fails is
counted, never raised. A message of six joints is read in place by one kernel
(``joint_state_rejection``); anything else by the generated decoder, which tells a
wrong joint count from garbage.
"""

from __future__ import annotations

import math

import numpy as np
from drake import lcmt_iiwa_status

from heft.systems.compiled import compiled
from heft.systems.controller.slave_kinematics import NUM_JOINTS  # the Phantom has as many (master_kinematics)

from heft.hardware_interface.fixed_layout import PAYLOAD, FixedLayout, of_layout, wire_double, wire_int
from heft.hardware_interface.lcmtypes import heft_haptic_state
from heft.hardware_interface.message_checks import (ACCEPT, DISCONTINUOUS, DRIVER_ERROR, JOINT_COUNT, NON_FINITE,
                                                    OUT_OF_RANGE, UNDECODABLE, JointRange, Rejections,
                                                    joints_continuous, joints_within)
from heft.hardware_interface.message_order import (LATE_TOLERANCE, SourceClock, clock_accept, clock_foreign,
                                                   clock_rejection, clock_since_last, clock_starts_source)

NOT_OF_LAYOUT = -2
"""``joint_state_rejection``'s code for a payload it cannot read: not a six-joint message of the type."""
# Where a type carries the state (``JointStateFields.at``): the message's size, then the byte offsets of
# utime, num_joints, the positions, the velocities, the error flag, the buttons and the commanded
# positions (−1: none).
SIZE, UTIME, COUNT, POSITION, VELOCITY, ERROR, BUTTONS, COMMANDED = range(8)
# The reader's memory: the last accepted stamp (s, the driver's clock), its buttons and its utime (µs).
STAMP, BUTTON_BITS, STAMP_UTIME = range(3)


class JointStateFields:
    """Where a joint-state type carries (utime, num_joints, position, velocity, error, buttons,
    commanded): the fields named ``position`` and ``velocity``, and ``error`` / ``buttons`` /
    ``commanded`` (the command the driver steps on) if it has them (else False / 0 / none). ``at``
    holds their byte offsets in a message of six joints (``SIZE`` … ``COMMANDED``)."""

    def __init__(self, lcm_type, position: str, velocity: str, error: str | None = None,
                 buttons: str | None = None, commanded: str | None = None):
        self.lcm_type = lcm_type
        layout = FixedLayout(lcm_type, num_joints=NUM_JOINTS)
        self.fingerprint = layout.fingerprint
        self.at = np.array([layout.size] + [-1 if name is None else layout.offset(name) for name in
                                            ("utime", "num_joints", position, velocity, error, buttons,
                                             commanded)],
                           dtype=np.int64)
        self._position, self._velocity = position, velocity

    def joint_count(self, msg) -> bool:
        """Whether a decoded message ``msg`` has six joints."""
        return (msg.num_joints == NUM_JOINTS and len(getattr(msg, self._position)) == NUM_JOINTS
                and len(getattr(msg, self._velocity)) == NUM_JOINTS)


HAPTIC_STATE = JointStateFields(heft_haptic_state, "position", "velocity", "error", "buttons")
IIWA_STATUS = JointStateFields(lcmt_iiwa_status, "joint_position_measured", "joint_velocity_estimated",
                               commanded="joint_position_commanded")
"""The arm driver's status carries no error flag and no buttons; it echoes the command it steps on."""


class JointStateReader:
    """Takes one driver's payloads and holds its newest accepted state.

    ``fields`` says where its type carries the state (``HAPTIC_STATE``, ``IIWA_STATUS``);
    ``joint_range`` is what the device can report; a source silent for ``silence`` s gives way to
    the next (``SourceClock``). After ``take``: ``position``, ``velocity`` (rad, rad/s; updated in
    place), ``buttons``, ``t_good`` (the station time, s, of the last accepted message; −inf before
    the first), ``utime`` (its stamp, µs on the driver's clock; 0 before the first), ``commanded``
    (rad: the command the driver says it stepped on, where its type carries one, else zeros; not
    checked, as the station only compares it with the commands it sent: ``command_echo``),
    ``rejections`` and ``clock``."""

    def __init__(self, fields: JointStateFields, joint_range: JointRange, silence: float):
        self._fields = fields
        self.position, self.velocity, self.commanded = np.zeros(NUM_JOINTS), np.zeros(NUM_JOINTS), np.zeros(NUM_JOINTS)
        self.rejections = Rejections()
        self.clock = SourceClock(silence)
        self._memory = np.zeros(3)
        self._arguments = (fields.fingerprint, fields.at, self.clock.state, self._memory, joint_range.lower,
                           joint_range.upper, joint_range.velocity, joint_range.speed, self.position, self.velocity,
                           self.commanded, np.zeros(2 * NUM_JOINTS), self.rejections.by_code)

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
        """Checks a payload that is not a six-joint message of the type, by the generated decoder."""
        fields = self._fields
        try:
            msg = fields.lcm_type.decode(payload)
        except Exception:  # whatever a malformed payload makes the generated decoder raise
            self.rejections.by_code[UNDECODABLE] += 1
            return
        if not fields.joint_count(msg):
            self.rejections.by_code[JOINT_COUNT] += 1
            return
        joint_state_rejection(msg.encode(), now, *self._arguments)  # six joints: now of the layout


@compiled(f"int64({PAYLOAD}, float64, int64[:], float64[:], float64[:], float64[:], float64[:], float64[:], "
          "float64[:], float64[:], float64[:], float64[:], float64[:])")
def _rejection(payload, now, at, clock, memory, lower, upper, max_velocity, speed, position, velocity, commanded,
               scratch) -> int:
    """``joint_state_rejection`` of a payload of the layout, uncounted."""
    if wire_int(payload, at[COUNT], 4) != NUM_JOINTS:
        return JOINT_COUNT
    utime = wire_int(payload, at[UTIME], 8)
    stamp = utime * 1e-6
    code = clock_rejection(clock, stamp, now)
    if code != ACCEPT:
        return code
    q, v = scratch[:NUM_JOINTS], scratch[NUM_JOINTS:]
    total = 0.0
    for j in range(NUM_JOINTS):
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
    for j in range(NUM_JOINTS):
        position[j] = q[j]
        velocity[j] = v[j]
    if at[COMMANDED] >= 0:
        for j in range(NUM_JOINTS):
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
    source's (``message_order``), the limits a ``JointRange``'s; ``scratch``: 12 floats."""
    if not of_layout(payload, fingerprint, at[SIZE]):
        return NOT_OF_LAYOUT
    code = _rejection(payload, now, at, clock, memory, lower, upper, max_velocity, speed, position, velocity,
                      commanded, scratch)
    if code != ACCEPT:
        rejected[code] += 1
    return code
