"""Which incoming messages come from a channel's one driver, and in order.

Each driver stamps its messages with a clock of its own; heft follows, per
channel, that clock's offset from the station's: d = stamp − now (s, ``now`` the
station time of the tick that reads the message). Of the driver's messages d
changes only by the jitter of delivery and of the ticks; a message whose d is
off by more than ``CLOCK_TOLERANCE`` cannot come from the same clock.

- A message stamped at or before the last accepted one, by at most
  ``LATE_TOLERANCE``, is a duplicate or a late UDP packet: out of order, dropped.
- A message off the source's clock while the source is alive (its last accepted
  message no older than its silence), or stamped further behind its newest, is
  foreign: stamped ahead of or behind its source, rejected. So is one that its
  reader finds discontinuous with the source's last (a joint jumping faster than
  the device moves, a sample counter going back).
- Once the source has been silent for longer than the watchdog allows
  (``SILENCE_PER_TIMEOUT`` times its timeout: the forces are off by then), the
  next message is taken: the source resuming on its clock, or a new source (a
  restarted driver stamps from its own zero again). A new source after the first
  is on probation for ``PROBATION``: the station stays unhealthy, so that another
  publisher shows before the controller restarts from what the new one reports.
- Foreign messages that recur (``CONFLICT_COUNT`` within ``CONFLICT_WINDOW``) mean
  a second publisher on the channel, a conflict that lasts until none has come
  for ``CONFLICT_CLEAR``: the station treats it as a fault (``HardwareStation``).
"""

from __future__ import annotations

import math

import numpy as np

from heft.hardware_interface.message_checks import ACCEPT, OUT_OF_ORDER, REASONS, STAMPED_AHEAD, STAMPED_BEHIND
from heft.systems.compiled import compiled

CLOCK_TOLERANCE = 1.0
"""How far (s) a message's clock offset may stray from its source's: more than the stalls of a
loaded machine on either side (a driver starved of CPU for a few tenths of a second, then
publishing its backlog, stamps that far ahead of where it left off); less than the clocks of two
processes started by hand differ. Publishers closer than that show as late or discontinuous."""
LATE_TOLERANCE = 0.005
"""How far (s) behind the source's newest stamp a UDP packet may arrive late; one further behind
is another clock's (a publisher leading the driver's clock by less than ``CLOCK_TOLERANCE``
makes every message of the driver look older than its own)."""
SILENCE_PER_TIMEOUT = 2.5
"""A source silent this many watchdog timeouts gives way to the next clock heard (50 ms at the
default 20 ms): later than the watchdog's cut, so a new source always meets a restarting controller."""
PROBATION = 0.5
"""s a new source (after the first) keeps the station unhealthy: a second publisher shows first."""
CONFLICT_COUNT = 3
"""Foreign messages within ``CONFLICT_WINDOW`` that make a conflict: one corrupted datagram does not."""
CONFLICT_WINDOW = 1.0
"""s."""
CONFLICT_CLEAR = 0.5
"""A conflict ends this long (s) after the last foreign message."""

ON_CLOCK, LATE, AHEAD, BEHIND = range(4)
"""What ``clock_check`` says of a stamp: the source's (or the first of a new one), a duplicate or
late packet of it, foreign stamped ahead, foreign stamped behind."""

# Layout of a clock's state: the source's offset (s), the last foreign message's offset (s; NaN
# before any), new sources after the first, the last accepted stamp and station time (s), the end
# of probation (s), the silence that ends a source (s), the last foreign message's time (s), the
# next slot of the ring of the last ``CONFLICT_COUNT`` foreign messages' times (s), then the ring.
(OFFSET, FOREIGN_OFFSET, RESTARTS, LAST_STAMP, LAST_ACCEPT, PROBATION_UNTIL, SILENCE, LAST_FOREIGN, FOREIGN_NEXT,
 FOREIGN_TIMES) = range(10)
CLOCK_SIZE = FOREIGN_TIMES + CONFLICT_COUNT


def initial_clock(silence: float) -> np.ndarray:
    """The state of a clock that has heard no source yet, which gives way to another after
    ``silence`` s without a message."""
    clock = np.full(CLOCK_SIZE, -math.inf)
    clock[OFFSET] = clock[FOREIGN_OFFSET] = math.nan
    clock[RESTARTS] = clock[FOREIGN_NEXT] = 0.0
    clock[SILENCE] = silence
    return clock


@compiled("boolean(float64[:], float64)")
def clock_starts_source(clock, now) -> bool:
    """True if a message accepted at ``now`` (s) would start a new source (the last one is silent)."""
    return now - clock[LAST_ACCEPT] > clock[SILENCE]


@compiled("float64(float64[:], float64)")
def clock_since_last(clock, now) -> float:
    """s of the station's clock since the source's last accepted message (inf before the first)."""
    return now - clock[LAST_ACCEPT]


@compiled("int64(float64[:], float64, float64)")
def clock_check(clock, stamp, now) -> int:
    """``ON_CLOCK``, ``LATE``, ``AHEAD`` or ``BEHIND`` for a message stamped ``stamp`` (s, the driver's
    clock) read at ``now`` (s, the station's)."""
    if clock_starts_source(clock, now):
        return ON_CLOCK
    drift = (stamp - now) - clock[OFFSET]
    if drift > CLOCK_TOLERANCE:
        return AHEAD
    if drift < -CLOCK_TOLERANCE or stamp < clock[LAST_STAMP] - LATE_TOLERANCE:
        return BEHIND
    return ON_CLOCK if stamp > clock[LAST_STAMP] else LATE


@compiled("void(float64[:], float64, float64)")
def clock_accept(clock, stamp, now) -> None:
    """Takes a message stamped ``stamp`` at ``now`` as the source's newest: after a silence, of
    the same source resuming (on its clock, newer) or of a new one."""
    if clock_starts_source(clock, now) and math.isfinite(clock[LAST_ACCEPT]) and not (
            stamp > clock[LAST_STAMP] and abs(stamp - now - clock[OFFSET]) <= CLOCK_TOLERANCE):
        clock[RESTARTS] += 1.0
        clock[PROBATION_UNTIL] = now + PROBATION
    clock[OFFSET] = stamp - now
    clock[LAST_STAMP], clock[LAST_ACCEPT] = stamp, now


@compiled("void(float64[:], float64, float64)")
def clock_foreign(clock, stamp, now) -> None:
    """Counts a foreign message stamped ``stamp``, read at ``now``, towards a conflict."""
    clock[FOREIGN_OFFSET] = stamp - now
    clock[LAST_FOREIGN] = now
    slot = int(clock[FOREIGN_NEXT])
    clock[FOREIGN_TIMES + slot] = now
    clock[FOREIGN_NEXT] = (slot + 1) % CONFLICT_COUNT


@compiled("int64(float64[:], float64, float64)")
def clock_rejection(clock, stamp, now) -> int:
    """``ACCEPT`` for a stamp ``clock_check`` accepts; otherwise the code of the reason a reader
    rejects its message for (``message_checks``): out of order, or stamped ahead of or behind
    the source (foreign: counted towards a conflict)."""
    order = clock_check(clock, stamp, now)
    if order == ON_CLOCK:
        return ACCEPT
    if order == LATE:
        return OUT_OF_ORDER
    clock_foreign(clock, stamp, now)
    return STAMPED_AHEAD if order == AHEAD else STAMPED_BEHIND


@compiled("boolean(float64[:], float64)")
def clock_conflict(clock, now) -> bool:
    """True while a second publisher is on the channel (module docstring)."""
    if now - clock[LAST_FOREIGN] > CONFLICT_CLEAR:
        return False
    oldest = clock[FOREIGN_TIMES]
    for i in range(1, CONFLICT_COUNT):
        oldest = min(oldest, clock[FOREIGN_TIMES + i])
    return clock[LAST_FOREIGN] - oldest <= CONFLICT_WINDOW


@compiled("boolean(float64[:], float64)")
def clock_on_probation(clock, now) -> bool:
    """True while a new source (after the first) is on probation."""
    return now < clock[PROBATION_UNTIL]


class SourceClock:
    """The clock of one channel's source (module docstring), which gives way to another after
    ``silence`` s without a message: its ``state`` (for the readers' kernels, which call the
    functions above on it) and, for a reader in Python, ``rejection(stamp, now)``: the reason to
    reject a message for, if any (counting a foreign one), and ``accept(stamp, now)`` for one it
    then accepts. ``conflict(now)`` tells whether a second publisher is on the channel;
    ``restarts`` counts the new sources after the first, ``offset`` is the source's clock
    offset (s), ``foreign_offset`` the last foreign message's (NaN before any), ``last_accept``
    when its last message was accepted."""

    def __init__(self, silence: float):
        self.state = initial_clock(silence)

    @property
    def offset(self) -> float:
        return float(self.state[OFFSET])

    @property
    def foreign_offset(self) -> float:
        return float(self.state[FOREIGN_OFFSET])

    @property
    def restarts(self) -> int:
        return int(self.state[RESTARTS])

    @property
    def last_accept(self) -> float:
        """The station time (s) of the source's last accepted message (−inf before the first)."""
        return float(self.state[LAST_ACCEPT])

    def rejection(self, stamp: float, now: float) -> str | None:
        """None for a stamp ``clock_check`` accepts; otherwise the reason (``message_checks.REASONS``)."""
        code = clock_rejection(self.state, stamp, now)
        return None if code == ACCEPT else REASONS[code]

    def accept(self, stamp: float, now: float) -> None:
        clock_accept(self.state, stamp, now)

    def conflict(self, now: float) -> bool:
        return clock_conflict(self.state, now)
