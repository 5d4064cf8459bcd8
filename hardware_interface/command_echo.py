"""How late the arm stepped on our commands, from its status's echo of the command it steps on.

The controller answers the arm's status of one step with a command its next step should take.
When the loop pauses, or its command reaches the driver after the step, the arm steps on an
older one and holds its setpoint: in fast strokes that rings a compliant tool mount
(docs/hardware.md, "The grasp on hardware"). ``lcmt_iiwa_status.joint_position_commanded`` says which
command the arm stepped on; ``CommandEcho`` remembers the last ``SENT_KEEP`` commands sent with
the status each answered, finds the echoed one (the newest equal to it: an echo is a copy) and
measures its lag: the steps between the status it answered and the status that echoes it, less
the one of a command on time. A driver whose echo matches none of them (one that filters its
commands, or echoes none) leaves the lag unmeasured, and says so by its count.
"""

from __future__ import annotations

import numpy as np

from heft.systems.compiled import compiled

SENT_KEEP = 64
"""Commands remembered: an echo can be found while at most this many were sent after it (32 ms at 2 kHz)."""


@compiled("int64(float64[:, :], int64[:], int64, float64[:])")
def echoed_status_utime(sent, answered, count, commanded) -> int:
    """The utime (µs, the driver's) of the status that the newest of the last ``count`` commands sent
    (ring ``sent`` (K, n) rad, ``answered`` (K,) the utimes of the statuses they answered) equal to
    ``commanded`` (n, rad) answered; −1 if none of the last K is."""
    keep = sent.shape[0]
    for back in range(min(count, keep)):
        row = (count - 1 - back) % keep
        same = True
        for j in range(sent.shape[1]):
            if sent[row, j] != commanded[j]:
                same = False
                break
        if same:
            return answered[row]
    return -1


@compiled("void(float64[:, :], int64[:], int64[:], float64[:], int64)")
def remember_sent(sent, answered, count, position, answered_utime) -> None:
    """The command ``position`` (n, rad), sent in answer to the status stamped ``answered_utime`` (µs), as the
    newest of ring ``sent`` (K, n) and ``answered`` (K,), of which ``count`` (1) have been sent."""
    row = count[0] % sent.shape[0]
    for j in range(position.shape[0]):
        sent[row, j] = position[j]
    answered[row] = answered_utime
    count[0] += 1


class CommandEcho:
    """The lag of the commands the arm stepped on (module docstring), for an arm of ``num_joints`` joints stepping
    every ``step`` s. After each ``heard``: ``lag`` (steps; −1 unmeasured), and over the run ``statuses``
    (heard after a command was sent), ``late`` (lag ≥ 1), ``unmeasured`` (since the first echo found: the
    status before it echoes what the driver held before the first command), ``max_lag`` and
    ``max_lag_at`` (s after the first status heard after a command, on the driver's clock). A status
    stamped at or before the last (a restarted driver) starts it afresh: the commands sent before answered
    another clock."""

    def __init__(self, step: float, num_joints: int):
        self._step_us = step * 1e6
        self._sent, self._answered = np.zeros((SENT_KEEP, num_joints)), np.zeros(SENT_KEEP, np.int64)
        self._count = np.zeros(1, np.int64)  # commands sent since the driver's clock last started
        self._last_utime, self._first_utime, self._matched = None, None, False
        self.lag, self.statuses, self.late, self.unmeasured, self.max_lag, self.max_lag_at = -1, 0, 0, 0, 0, 0.0

    def sent(self, position: np.ndarray, answered_utime: int) -> None:
        """A command ``position`` (n, rad) sent in answer to the status stamped ``answered_utime`` (µs)."""
        remember_sent(self._sent, self._answered, self._count, position, answered_utime)

    def heard(self, utime: int, commanded: np.ndarray) -> None:
        """A new status stamped ``utime`` (µs) echoing ``commanded`` (n, rad, float64)."""
        if self._last_utime is not None and utime <= self._last_utime:
            self._count[0], self._matched, self._first_utime = 0, False, None
        self._last_utime = utime
        count = int(self._count[0])
        if not count:
            return
        if self._first_utime is None:
            self._first_utime = utime
        answered = echoed_status_utime(self._sent, self._answered, count, commanded)
        if answered < 0 or utime <= answered:
            self.lag = -1
            if self._matched:
                self.statuses += 1
                self.unmeasured += 1
            return
        self._matched = True
        self.statuses += 1
        self.lag = round((utime - answered) / self._step_us) - 1
        if self.lag > 0:
            self.late += 1
            if self.lag > self.max_lag:
                self.max_lag, self.max_lag_at = self.lag, (utime - self._first_utime) * 1e-6

    def summary(self) -> dict:
        """The counts (JSON-serialisable)."""
        return {"statuses": self.statuses, "late": self.late, "unmeasured": self.unmeasured, "max_lag": self.max_lag,
                "max_lag_at": self.max_lag_at}
