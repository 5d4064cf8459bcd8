"""The latest raw message on one LCM channel, for receivers that sample it.

Drake's ``LcmSubscriberSystem`` with a Python message type decodes every
arriving message and deep-copies it in abstract state; with the wrist sensor
at 8 kHz that alone costs more than a 2 kHz controller tick. An ``LcmMailbox``
only keeps the newest payload and counts arrivals; the handler runs inside
``HandleSubscriptions`` (pumped by the diagram's ``LcmInterfaceSystem``). A
receiver decodes at most one payload per tick and keeps the arrival count it
last took in its own discrete state, so clones of a Context stay independent
(the mailbox, like ``LcmSubscriberSystem``'s own buffer, belongs to the system).
"""

from pydrake.lcm import DrakeLcmInterface


class LcmMailbox:
    """Subscribes to ``channel`` on ``lcm``; ``count`` messages have arrived, the last
    one is ``payload`` (bytes; empty before the first)."""

    def __init__(self, lcm: DrakeLcmInterface, channel: str):
        self.channel = channel
        self.count = 0
        self.payload = b""
        lcm.Subscribe(channel=channel, handler=self._on_message)

    def _on_message(self, payload: bytes):
        self.payload = payload
        self.count += 1

    def newer_than(self, seen: float) -> bytes | None:
        """The latest payload if more than ``seen`` messages have arrived, else None."""
        return self.payload if self.count > seen else None
