"""A one-line progress bar on stderr (silent when stderr is not a terminal)."""

import sys
import time


class ProgressBar:
    """``update(done)`` with done in [0, total]; ``close()`` ends the line."""

    def __init__(self, total: float, label: str, width: int = 30, stream=sys.stderr):
        self.total, self.label, self.width, self.stream = total, label, width, stream
        self.start = time.perf_counter()
        self._live = stream.isatty()

    def update(self, done: float):
        if not self._live:
            return
        fraction = min(max(done / self.total, 0.0), 1.0) if self.total > 0 else 1.0
        filled = int(round(fraction * self.width))
        elapsed = time.perf_counter() - self.start
        self.stream.write(f"\r{self.label} [{'#' * filled}{'.' * (self.width - filled)}] "
                          f"{fraction:4.0%} {elapsed:5.1f} s")
        self.stream.flush()

    def close(self):
        if self._live:
            self.update(self.total)
            self.stream.write("\n")
            self.stream.flush()
