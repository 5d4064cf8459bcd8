"""Progress of long work on stderr, with its ETA: a tqdm bar on a terminal, plain lines otherwise
(a log file, CI), silent under ``heft -q``."""

from __future__ import annotations

import io
import logging
import os
import sys
import time

from tqdm import tqdm

PLAIN_STEP = 0.1
"""Off a terminal, a line each time this share of the work is done (and one at the end)."""


class ProgressBar:
    """``update(done)`` with done in [0, total] (any unit: simulated s, samples, runs); ``close()`` ends it.
    ``stream``: default stderr as it is when made."""

    def __init__(self, total: float, label: str, stream=None, unit: str = ""):
        self.total, self.label, self.unit = float(total), label, unit
        self.stream = sys.stderr if stream is None else stream
        self.start = time.perf_counter()
        self._silent = not logging.getLogger("heft").isEnabledFor(logging.INFO)
        self._bar = None
        self._next_line = PLAIN_STEP
        self._done = 0.0
        if not self._silent and _is_terminal(self.stream):
            self._bar = tqdm(total=self.total, desc=label, file=self.stream, unit=unit or "it", leave=True,
                             bar_format="{desc}: {percentage:3.0f}%|{bar}| {n:.4g}/{total:.4g} "
                                        "[{elapsed}<{remaining}]")

    def update(self, done: float) -> None:
        self._done = min(max(float(done), 0.0), self.total)
        if self._silent:
            return
        if self._bar is not None:
            self._bar.n = self._done
            self._bar.refresh()
            return
        fraction = self._done / self.total if self.total > 0 else 1.0
        if fraction >= self._next_line and fraction < 1.0:
            self._line()
            self._next_line = (int(fraction / PLAIN_STEP) + 1) * PLAIN_STEP

    def close(self) -> None:
        if self._silent:
            return
        if self._bar is not None:
            self._bar.n = self.total
            self._bar.close()
            return
        self._done = self.total
        self._line()

    def _line(self) -> None:
        elapsed = time.perf_counter() - self.start
        fraction = self._done / self.total if self.total > 0 else 1.0
        remaining = elapsed * (1 - fraction) / fraction if fraction > 0 else float("nan")
        self.stream.write(f"{self.label}: {fraction:4.0%} ({self._done:.4g}/{self.total:.4g}{self.unit}) "
                          f"{tqdm.format_interval(elapsed)} elapsed, ETA {_interval(remaining)}\n")
        self.stream.flush()


def _is_terminal(stream) -> bool:
    """A terminal a bar can be drawn on: one of no width (a bare pseudo-terminal) gets plain lines."""
    if not (hasattr(stream, "isatty") and stream.isatty()):
        return False
    try:
        return os.get_terminal_size(stream.fileno()).columns > 0
    except (OSError, ValueError, AttributeError, io.UnsupportedOperation):
        return True


def _interval(seconds: float) -> str:
    return tqdm.format_interval(seconds) if seconds == seconds else "?"
