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

ACCEPTED, OUT_OF_ORDER, AHEAD, BEHIND = range(4)
"""What ``SourceClock.check`` says of a stamp."""


class SourceClock:
    """The clock of one channel's source (module docstring), which gives way to another after
    ``silence`` s without a message.

    ``check(stamp, now)`` classifies a message's stamp without changing anything;
    ``rejection(stamp, now)`` gives a reader the reason to reject it for, if any (counting a
    foreign one). A reader that then accepts the message calls ``accept(stamp, now)``, one that
    finds it foreign for another reason (a jump, a counter going back) calls
    ``foreign(stamp, now)``. ``conflict(now)`` tells whether a second publisher is on the
    channel, ``on_probation(now)`` whether a new source is still on probation;
    ``restarts`` counts the new sources after the first, ``offset`` is the source's clock
    offset (s), ``foreign_offset`` the last foreign message's (NaN before any)."""

    def __init__(self, silence: float):
        self._silence = silence
        self.offset = math.nan
        self.foreign_offset = math.nan
        self.restarts = 0
        self._last_stamp = -math.inf
        self._last_accept = -math.inf
        self._probation_until = -math.inf
        self._foreign_times = [-math.inf] * CONFLICT_COUNT  # ring of the last foreign messages' times
        self._foreign_next = 0
        self._last_foreign = -math.inf

    def check(self, stamp: float, now: float) -> int:
        """ACCEPTED (from the source, or the first of a new one), OUT_OF_ORDER, AHEAD or BEHIND
        (foreign) for a message stamped ``stamp`` (s, the driver's clock) read at ``now`` (s, the
        station's)."""
        if self.starts_source(now):
            return ACCEPTED
        drift = (stamp - now) - self.offset
        if drift > CLOCK_TOLERANCE:
            return AHEAD
        if drift < -CLOCK_TOLERANCE or stamp < self._last_stamp - LATE_TOLERANCE:
            return BEHIND
        return ACCEPTED if stamp > self._last_stamp else OUT_OF_ORDER

    def rejection(self, stamp: float, now: float) -> str | None:
        """None for a stamp ``check`` accepts; otherwise the reason a reader rejects its message
        for: "out_of_order", or "stamped_ahead" / "stamped_behind" (foreign: counted towards a
        conflict, ``foreign``)."""
        order = self.check(stamp, now)
        if order == ACCEPTED:
            return None
        if order == OUT_OF_ORDER:
            return "out_of_order"
        self.foreign(stamp, now)
        return "stamped_ahead" if order == AHEAD else "stamped_behind"

    def starts_source(self, now: float) -> bool:
        """True if a message accepted at ``now`` would start a new source (the last one is silent)."""
        return now - self._last_accept > self._silence

    def since_last(self, now: float) -> float:
        """s of the station's clock since the source's last accepted message (inf before the first)."""
        return now - self._last_accept

    def accept(self, stamp: float, now: float) -> None:
        """Takes a message stamped ``stamp`` at ``now`` as the source's newest: after a silence, of
        the same source resuming (on its clock, newer) or of a new one."""
        if self.starts_source(now) and math.isfinite(self._last_accept) and not (
                stamp > self._last_stamp and abs(stamp - now - self.offset) <= CLOCK_TOLERANCE):
            self.restarts += 1
            self._probation_until = now + PROBATION
        self.offset = stamp - now
        self._last_stamp, self._last_accept = stamp, now

    def foreign(self, stamp: float, now: float) -> None:
        """Counts a foreign message stamped ``stamp``, read at ``now``, towards a conflict."""
        self.foreign_offset = stamp - now
        self._last_foreign = now
        self._foreign_times[self._foreign_next] = now
        self._foreign_next = (self._foreign_next + 1) % CONFLICT_COUNT

    def conflict(self, now: float) -> bool:
        """True while a second publisher is on the channel (module docstring)."""
        if now - self._last_foreign > CONFLICT_CLEAR:
            return False
        return self._last_foreign - min(self._foreign_times) <= CONFLICT_WINDOW

    def on_probation(self, now: float) -> bool:
        """True while a new source (after the first) is on probation."""
        return now < self._probation_until
