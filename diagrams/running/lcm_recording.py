"""Recording a run's LCM traffic as a log that ``lcm-logplayer`` replays.

``LcmTrafficRecorder`` runs the ``lcm-logger`` of the installed ``lcm``
package as a separate process for the duration of a ``with`` block, so
recording costs the controller's process nothing. On memq:// there is no
network to listen to; recording then needs a real (udpm://) URL.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path


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

SYNC_CHANNEL = "HEFT_RECORDER_SYNC"
"""Messages on this channel, published at the start until the log holds one, prove the logger listens."""


class LcmTrafficRecorder:
    """``with LcmTrafficRecorder(url, path):`` records every channel on ``url`` to ``path``
    (an LCM event log; overwritten). Raises if the logger cannot start. The block starts
    only once the logger has written a ``SYNC_CHANNEL`` message, so nothing after it is missed."""

    def __init__(self, lcm_url: str, path):
        if lcm_url.startswith("memq"):
            raise ValueError(f"cannot record {lcm_url}: memq:// stays inside one process; use a udpm:// URL")
        self.lcm_url, self.path = lcm_url, Path(path)
        self._process = None

    def __enter__(self) -> LcmTrafficRecorder:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._process = subprocess.Popen([_lcm_logger(), "--quiet", "--force", f"--lcm-url={self.lcm_url}",
                                          "--flush-interval=50", str(self.path)],
                                         stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                         start_new_session=True)  # its own group: the pip entry point forks
        # Recording yields the CPU to the loop and the drivers: on a 2-core machine a logger at equal
        # priority made the drivers miss the watchdog's 20 ms.
        os.setpriority(os.PRIO_PGRP, self._process.pid, LOGGER_NICENESS)
        import lcm

        bus = lcm.LCM(self.lcm_url)
        deadline = time.monotonic() + 5.0
        while not (self.path.exists() and self.path.stat().st_size > 0):
            if self._process.poll() is not None:
                raise RuntimeError(f"lcm-logger exited at start: {self._process.stderr.read().decode().strip()}")
            if time.monotonic() > deadline:
                self.__exit__(None, None, None)
                raise RuntimeError(f"lcm-logger wrote nothing to {self.path} within 5 s: is {self.lcm_url} reachable?")
            bus.publish(SYNC_CHANNEL, b"")
            time.sleep(0.01)
        return self

    def __exit__(self, *exc):
        if self._process is not None and self._process.poll() is None:
            group = os.getpgid(self._process.pid)
            os.killpg(group, signal.SIGINT)  # lcm-logger flushes and closes on SIGINT
            deadline = time.monotonic() + 5.0
            while _group_alive(group) and time.monotonic() < deadline:  # the logger itself, not only its wrapper
                time.sleep(0.01)
            if _group_alive(group):
                os.killpg(group, signal.SIGKILL)
            self._process.wait()
        return False
