"""Recording a run's LCM traffic as a log that ``lcm-logplayer`` replays.

``LcmTrafficRecorder`` runs the ``lcm-logger`` of the installed ``lcm``
package as a separate process per LCM URL (the drivers' and the controller's:
``LcmChannels``) for the duration of a ``with`` block, so recording costs the
controller's process nothing, and at its end merges their logs into one, in
order of arrival. On memq:// there is no network to listen to; recording then
needs a real (udpm://) URL.
"""

from __future__ import annotations

import heapq
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

from heft.hardware_interface.channels import LcmChannels


def _lcm_logger() -> str:
    beside = Path(sys.executable).with_name("lcm-logger")
    found = str(beside) if beside.exists() else shutil.which("lcm-logger")
    if found is None:
        raise RuntimeError("lcm-logger not found: it comes with the `lcm` package (pip install lcm); "
                           "install heft's dependencies or run without recording")
    return found


def _group_alive(group: int) -> bool:
    try:
        os.killpg(group, 0)
    except ProcessLookupError:
        return False
    return True


LOGGER_NICENESS = 10
"""The logger's nice value (lower CPU priority than the controller and the drivers)."""

LOGGER_RECEIVE_BUFFER = 4 * 1024 * 1024
"""Bytes of socket receive buffer a logger asks for (LCM's ``recv_buf_size``; Linux grants at most
``net.core.rmem_max``): at its lower priority a logger waits for the CPU, and the kernel drops what
arrives meanwhile beyond the buffer (about 200 datagrams at the common default of 208 KiB). In a
6 s two-process run here the default's kernel drops were 98 datagrams, this one's none."""

SYNC_CHANNEL = "HEFT_RECORDER_SYNC"
"""Messages on this channel, published at the start until the log holds one, prove the logger listens."""


class LcmTrafficRecorder:
    """``with LcmTrafficRecorder(channels, path):`` records every channel on both of ``channels``'
    URLs to ``path`` (one LCM event log, overwritten, events in the order the loggers received
    them). Raises if a logger cannot start. The block starts only once every logger has written
    a ``SYNC_CHANNEL`` message, so nothing after it is missed."""

    def __init__(self, channels: LcmChannels, path):
        urls = list(dict.fromkeys((channels.lcm_url, channels.command_lcm_url())))
        for url in urls:
            if url.startswith("memq"):
                raise ValueError(f"cannot record {url}: memq:// stays inside one process; use a udpm:// URL")
        self.path = Path(path)
        # One logger per URL; with two, each writes a part that __exit__ merges into path.
        self._parts = ([self.path] if len(urls) == 1 else
                       [self.path.with_name(f".{self.path.name}.{i}") for i in range(len(urls))])
        self._urls, self._processes = urls, []

    def __enter__(self) -> LcmTrafficRecorder:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        try:
            for url, part in zip(self._urls, self._parts):
                self._processes.append(_start_logger(url, part))
        except BaseException:
            self._stop()
            raise
        return self

    def __exit__(self, *exc):
        self._stop()
        if len(self._parts) > 1:
            _merge(self._parts, self.path)
        return False

    def _stop(self) -> None:
        for process in self._processes:
            _stop_logger(process)
        self._processes = []


def logger_url(url: str) -> str:
    """``url`` with ``LOGGER_RECEIVE_BUFFER`` asked for, unless it asks for a buffer itself."""
    if not url.startswith("udpm://") or "recv_buf_size=" in url:
        return url
    return f"{url}{'&' if '?' in url else '?'}recv_buf_size={LOGGER_RECEIVE_BUFFER}"


def _start_logger(url: str, path: Path) -> subprocess.Popen:
    """An ``lcm-logger`` recording ``url`` to ``path``, once it has written a ``SYNC_CHANNEL`` message."""
    process = subprocess.Popen([_lcm_logger(), "--quiet", "--force", f"--lcm-url={logger_url(url)}",
                                "--flush-interval=50", str(path)], stdout=subprocess.DEVNULL,
                               stderr=subprocess.PIPE,
                               start_new_session=True)  # its own group: the pip entry point forks
    # Recording yields the CPU to the loop and the drivers: on a 2-core machine a logger at equal
    # priority made the drivers miss the watchdog's 20 ms.
    os.setpriority(os.PRIO_PGRP, process.pid, LOGGER_NICENESS)
    import lcm

    bus = lcm.LCM(url)
    deadline = time.monotonic() + 5.0
    while not (path.exists() and path.stat().st_size > 0):
        if process.poll() is not None:
            raise RuntimeError(f"lcm-logger exited at start: {process.stderr.read().decode().strip()}")
        if time.monotonic() > deadline:
            _stop_logger(process)
            raise RuntimeError(f"lcm-logger wrote nothing to {path} within 5 s: is {url} reachable?")
        bus.publish(SYNC_CHANNEL, b"")
        time.sleep(0.01)
    return process


def _stop_logger(process: subprocess.Popen) -> None:
    if process.poll() is None:
        group = os.getpgid(process.pid)
        os.killpg(group, signal.SIGINT)  # lcm-logger flushes and closes on SIGINT
        deadline = time.monotonic() + 5.0
        while _group_alive(group) and time.monotonic() < deadline:  # the logger itself, not only its wrapper
            time.sleep(0.01)
        if _group_alive(group):
            os.killpg(group, signal.SIGKILL)
        process.wait()


def _merge(parts, path: Path) -> None:
    """The events of the logs ``parts`` into one log at ``path`` by receive time (µs); removes the parts."""
    import lcm

    logs = [lcm.EventLog(str(part), "r") for part in parts]
    merged = lcm.EventLog(str(path), "w", overwrite=True)
    # Generators, not the logs: heapq.merge re-iterates the last one left, and a log's iter() rewinds it.
    for event in heapq.merge(*((event for event in log) for log in logs), key=lambda event: event.timestamp):
        merged.write_event(event.timestamp, event.channel, event.data)
    merged.close()
    for log, part in zip(logs, parts):
        log.close()
        part.unlink()
