"""What a driver's message may carry to reach the controller, and the count of those refused.

Every message on the lab's channels is untrusted: another version of a type, a
corrupted datagram, a stray tool on the multicast group or a second driver may
send anything. The readers (``joint_state_reader``, ``ft_receiver``) reject a
message that fails to decode, has the wrong joint count, carries a non-finite
value or one no device could report (``DeviceLimits``), is flagged by its
driver, or does not come from the channel's one source (``message_order``).
Each rejection is counted per channel and reason (``Rejections``); none is fatal.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from heft.systems.compiled import compiled

REASONS = ("undecodable", "joint_count", "non_finite", "out_of_range", "stamped_ahead", "stamped_behind",
           "discontinuous", "out_of_order", "driver_error")
"""Why a message was rejected: it failed to decode; had another joint count; carried NaN or
inf; carried a value beyond ``DeviceLimits``; was stamped ahead of or behind its channel's
source (``message_order``); jumped from the source's last message faster than the device
moves, or its sample counter went back; was a duplicate or a late packet; its driver
flagged an error."""
(UNDECODABLE, JOINT_COUNT, NON_FINITE, OUT_OF_RANGE, STAMPED_AHEAD, STAMPED_BEHIND, DISCONTINUOUS, OUT_OF_ORDER,
 DRIVER_ERROR) = range(len(REASONS))
"""Each reason's code, as the readers' kernels return it: its place in ``REASONS``."""
ACCEPT = -1
"""The code of a message accepted."""

POSITION_MARGIN = 0.1
"""rad beyond a joint's limits that its encoder may still report (overshoot onto the stops)."""
VELOCITY_MARGIN = 1.5
"""Factor over a joint's speed limit that its velocity estimate may report (differentiated noise)."""
RANGE_MARGIN = 1.05
"""Factor over a sensor's full scale that its reading may report (a saturated axis reads full scale)."""
JUMP_MARGIN = 0.05
"""rad a joint may move between two messages beyond its speed limit × their stamps' distance
(encoder quantisation and the driver's stamp jitter)."""


@dataclasses.dataclass
class DeviceLimits:
    """What the lab's devices can report: joint limits (rad) and speed limits (rad/s) of the
    master and the slave, in their models' joint order, and the wrist sensor's full scale
    ([f; τ] in N, N·m; [a; α] in m/s², rad/s²). ``diagrams.device_limits`` reads them from
    the scenario's robot models and sensor parameters."""

    master_lower: np.ndarray
    master_upper: np.ndarray
    master_velocity: np.ndarray
    slave_lower: np.ndarray
    slave_upper: np.ndarray
    slave_velocity: np.ndarray
    wrench_full_scale: np.ndarray
    acceleration_full_scale: np.ndarray


class JointRange:
    """The positions and velocities one device's driver may report (``DeviceLimits`` widened by
    the margins above: ``lower``, ``upper`` in rad, ``velocity`` in rad/s; ``joints_within``), and
    how far its joints may move between two messages (``speed``, rad/s: ``joints_continuous``)."""

    def __init__(self, lower, upper, velocity):
        self.lower = np.asarray(lower, dtype=float) - POSITION_MARGIN
        self.upper = np.asarray(upper, dtype=float) + POSITION_MARGIN
        self.speed = np.array(velocity, dtype=float)
        self.velocity = VELOCITY_MARGIN * self.speed


@compiled("boolean(float64[:], float64[:], float64[:], float64[:], float64[:])")
def joints_within(position, velocity, lower, upper, max_velocity) -> bool:
    """True if every joint's position (rad) and velocity (rad/s) are ones the device can report:
    within [``lower``, ``upper``] and ±``max_velocity`` (a ``JointRange``'s)."""
    for j in range(position.shape[0]):
        if not (lower[j] <= position[j] <= upper[j] and -max_velocity[j] <= velocity[j] <= max_velocity[j]):
            return False
    return True


@compiled("boolean(float64[:], float64[:], float64[:], float64)")
def joints_continuous(previous, position, speed, dt) -> bool:
    """True if no joint moved from ``previous`` to ``position`` (rad) further than its ``speed`` limit
    (rad/s) allows over ``dt`` s, plus ``JUMP_MARGIN``."""
    for j in range(position.shape[0]):
        if abs(position[j] - previous[j]) > speed[j] * dt + JUMP_MARGIN:
            return False
    return True


class Rejections:
    """Rejected messages of one channel, per reason (``reasons``, default ``REASONS``): ``counts[reason]``, kept
    as ``by_code`` (per code, for the readers' kernels)."""

    def __init__(self, reasons: tuple[str, ...] = REASONS):
        self.reasons = reasons
        self.by_code = np.zeros(len(reasons), dtype=np.int64)

    def add(self, reason: str) -> None:
        self.by_code[self.reasons.index(reason)] += 1

    @property
    def counts(self) -> dict[str, int]:
        return dict(zip(self.reasons, self.by_code.tolist()))

    @property
    def total(self) -> int:
        return int(self.by_code.sum())

    def nonzero(self) -> dict[str, int]:
        """The reasons that occurred, with their counts."""
        return {reason: count for reason, count in self.counts.items() if count}
