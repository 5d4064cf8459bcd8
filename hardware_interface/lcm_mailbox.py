"""The payloads that arrived on one LCM channel since a receiver last looked.

A python-lcm handler only appends the raw payload (bounded to the ``keep``
newest), so no sample is lost to a queue that keeps the oldest and nothing is
decoded that the receiver does not read. LCM's own queue per subscription
(30 messages by default) discards the *newest* once full; the mailbox widens it
to ``LCM_QUEUE`` so that a late pump still finds them. ``pump`` handles
everything pending without blocking, once per controller tick; ``open_buses``
opens the two URLs of ``LcmChannels``.
"""

from __future__ import annotations

import lcm

from heft.hardware_interface.channels import LcmChannels


LCM_QUEUE = 1000
"""Messages LCM holds per subscription between two pumps: 125 ms of FT samples at 8 kHz,
0.5 s of a 2 kHz channel (with LCM's default of 30, a process paused for 15 ms lost commands)."""


class LcmMailbox:
    """Subscribes to ``channel`` on ``bus``; ``take()`` returns the payloads (bytes, oldest
    first, at most ``keep``) that arrived since the last ``take()``; ``count`` counts all,
    ``pushed_out`` those that newer ones pushed out unread."""

    def __init__(self, bus: lcm.LCM, channel: str, keep: int = 1):
        if keep < 1:
            raise ValueError(f"keep must be >= 1; got {keep}")
        self.channel, self.count, self.pushed_out = channel, 0, 0
        self._keep, self._pending = keep, []
        bus.subscribe(channel, self._on_message).set_queue_capacity(LCM_QUEUE)

    def _on_message(self, _channel: str, payload: bytes) -> None:
        self.count += 1
        self._pending.append(payload)
        if len(self._pending) > self._keep:
            del self._pending[0]
            self.pushed_out += 1

    def take(self) -> list[bytes]:
        """The payloads since the last call, oldest first (empty if none)."""
        pending, self._pending = self._pending, []
        return pending


def pump(bus: lcm.LCM) -> int:
    """Handles every message already waiting on ``bus`` without blocking; returns how many. A
    failed wait (python-lcm's OSError: a signal interrupting it, such as the Ctrl-C that stops a
    run) ends this pump, not the caller: the next one tries again, and a bus that stays broken
    leaves its channels stale, which the watchdog answers."""
    handled = 0
    try:
        while bus.handle_timeout(0) > 0:
            handled += 1
    except OSError:
        pass
    return handled


def open_buses(channels: LcmChannels) -> tuple[lcm.LCM, lcm.LCM]:
    """(bus on ``channels.lcm_url``, bus on its command URL): one object when both URLs are the
    same (``memq://`` is one process's own bus)."""
    command_url = channels.command_lcm_url()
    bus = _opened(channels.lcm_url, "--lcm-url")
    return bus, (bus if command_url == channels.lcm_url else _opened(command_url, "--command-url"))


def _opened(url: str, option: str) -> lcm.LCM:
    """``lcm.LCM(url)``, or a ValueError that names the URL and the option that set it."""
    try:
        return lcm.LCM(url)
    except RuntimeError as error:
        raise ValueError(f"cannot open the LCM URL {url!r} ({error}): give {option} as udpm://GROUP:PORT?ttl=0 "
                         "(a port up to 65534 for --lcm-url, whose command URL is one port up) or memq://") from None
