"""Which incoming messages come from a channel's one driver, and in order.

Each driver stamps its messages with a clock of its own; heft follows, per
channel, that clock's offset from the station's: d = stamp − now (s, ``now`` the
station time of the tick that reads the message). Of the driver's messages d
changes only by the jitter of delivery and of the ticks; a message whose d is
off by more than ``CLOCK_TOLERANCE`` cannot come from the same clock.

- A message stamped at or before the last accepted one is a duplicate or a late
  UDP packet: out of order, dropped.
- A message off the source's clock while the source is alive (its last accepted
  message no older than its silence) is foreign: stamped ahead of or behind
  its source, rejected. So is one that its reader finds discontinuous with the
  source's last (a joint jumping faster than the device moves, a sample counter
  going back).
- Once the source has been silent for longer than the watchdog allows
  (``SILENCE_PER_TIMEOUT`` times its timeout: the forces are off by then), the
  next message starts a new source: a restarted driver stamps from its own zero
  again, and the controller starts again from what it reports.
- Foreign messages that recur (``CONFLICT_COUNT`` within ``CONFLICT_WINDOW``) mean
  a second publisher on the channel, a conflict that lasts until none has come
  for ``CONFLICT_CLEAR``: the station treats it as a fault (``HardwareStation``).
"""

from __future__ import annotations

import math

CLOCK_TOLERANCE = 0.25
"""How far (s) a message's clock offset may stray from its source's: more than the stalls of a
loaded machine on either side (tens of ms), far less than the clocks of two processes differ."""
SILENCE_PER_TIMEOUT = 2.5
"""A source silent this many watchdog timeouts gives way to the next clock heard (50 ms at the
default 20 ms): later than the watchdog's cut, so a new source always meets a restarting controller."""
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

    ``check(stamp, now)`` classifies a message's stamp without changing anything; a reader
    that then accepts the message calls ``accept(stamp, now)``, one that finds it foreign
    calls ``foreign(now)``. ``conflict(now)`` tells whether a second publisher is on the
    channel; ``restarts`` counts the new sources after the first, ``offset`` is the source's
    clock offset (s), ``foreign_offset`` the last foreign message's (NaN before any)."""

    def __init__(self, silence: float):
        self._silence = silence
        self.offset = math.nan
        self.foreign_offset = math.nan
        self.restarts = 0
        self._last_stamp = -math.inf
        self._last_accept = -math.inf
        self._foreign_times = [-math.inf] * CONFLICT_COUNT  # ring of the last foreign messages' times
        self._foreign_next = 0

    def check(self, stamp: float, now: float) -> int:
        """ACCEPTED (from the source, or the first of a new one), OUT_OF_ORDER, AHEAD or BEHIND
        (off the source's clock) for a message stamped ``stamp`` (s, the driver's clock) read at
        ``now`` (s, the station's)."""
        if self.starts_source(now):
            return ACCEPTED
        drift = (stamp - now) - self.offset
        if drift > CLOCK_TOLERANCE:
            return AHEAD
        if drift < -CLOCK_TOLERANCE:
            return BEHIND
        return ACCEPTED if stamp > self._last_stamp else OUT_OF_ORDER

    def starts_source(self, now: float) -> bool:
        """True if a message accepted at ``now`` would start a new source (the last one is silent)."""
        return now - self._last_accept > self._silence

    def accept(self, stamp: float, now: float) -> None:
        """Takes a message stamped ``stamp`` at ``now`` as the source's newest."""
        if self.starts_source(now) and math.isfinite(self._last_accept):
            self.restarts += 1
        self.offset = stamp - now
        self._last_stamp, self._last_accept = stamp, now

    def foreign(self, stamp: float, now: float) -> None:
        """Counts a foreign message stamped ``stamp``, read at ``now``, towards a conflict."""
        self.foreign_offset = stamp - now
        self._foreign_times[self._foreign_next] = now
        self._foreign_next = (self._foreign_next + 1) % CONFLICT_COUNT

    def conflict(self, now: float) -> bool:
        """True while a second publisher is on the channel (module docstring)."""
        times = self._foreign_times
        newest, oldest = max(times), min(times)
        return now - newest <= CONFLICT_CLEAR and newest - oldest <= CONFLICT_WINDOW
