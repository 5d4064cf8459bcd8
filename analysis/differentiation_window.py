"""The differentiation window a recording leaves to estimate (``differentiation: {window: estimate}``, the
default): of a grid of windows, the one with which V·φ̂ agrees best with the measured wrench.

The window of the Savitzky–Golay filter through which ω and α come from the orientation trades the motion it
smooths away against the noise its derivative lifts; which wins depends on the motion, the stream's rate and
its resolution, all in the recording. The cost is the clock offsets' (``clock_offsets.residual_cost``: Σ
var(f − V·φ̂)/Σ var(f) over the forces plus the same over the torques), the clock offsets held, on the samples
out of contact (``clock_offsets.contact_free``); the wrench as measured, not through the kernel (the clock
offsets' search compares like with like for a given window; here the window is what is judged). The grid:
``GRID_POINTS`` windows evenly spaced in log from the shortest the stream allows (order + 2 samples) to
``LONGEST`` s (at most a quarter of the time the streams share), each a whole odd number of samples.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from heft.analysis.clock_offsets import MIN_FREE, contact_free, residual_cost, residuals, wrench_snapshot
from heft.analysis.recording import with_differentiation_window
from heft.analysis.recording_merge import RecordingSource
from heft.systems.identification.rotation_sampling import window_samples

GRID_POINTS = 16
LONGEST = 0.2
"""s: the longest window tried (four times the 50 ms that suits 100 Hz poses)."""


@dataclasses.dataclass
class WindowFit:
    """The window found (``window``, s) and the cost at each window tried (``windows`` s, ``costs``), from the
    ``stream`` differentiated; ``default_cost`` the cost at the window in use before (``default``, s)."""
    window: float
    windows: list
    costs: list
    stream: str
    default: float
    default_cost: float

    def how(self) -> str:
        """How the window was found, for the report."""
        return (f"window estimated: of {len(self.windows)} from {1e3 * self.windows[0]:.3g} to "
                f"{1e3 * self.windows[-1]:.3g} ms the one with which V·φ̂ agrees best with the wrench (cost "
                f"{min(self.costs):.3g}, {self.default_cost:.3g} at {1e3 * self.default:.3g} ms)")

    def summary(self) -> dict:
        return {"window_s": self.window, "how": "estimated", "stream": self.stream, "cost_min": float(min(self.costs)),
                "default_s": self.default, "cost_at_default": self.default_cost,
                "windows_s": self.windows, "costs": self.costs}


def estimate_differentiation_window(source: RecordingSource, phi, offsets: dict,
                                    window: tuple[float, float] | None = None, max_samples: int = 20000,
                                    sensor_offsets=None) -> WindowFit:
    """The differentiation window (module docstring) with the clock ``offsets`` (s, every stream's) and φ̂
    ``phi``; ``window``: (start, duration) s of wrench time (default: the first 60 s the streams share), at
    most ``max_samples`` wrench rows of it. ``sensor_offsets`` (6,), on the load's sign, if known: contact
    is then judged against them."""
    recording = source.recording
    order = recording.differentiation.order
    stream = "angular_velocity" if "angular_velocity" in source.files else "orientation"
    period = source.period(stream)
    lo, hi = source.common_interval(offsets)
    shortest = window_samples(period, 0.0, order) * period
    longest = max(shortest, min(LONGEST, 0.25 * (hi - lo)))
    counts = sorted({window_samples(period, w, order) for w in np.geomspace(shortest, longest, GRID_POINTS)})
    windows = [n * period for n in counts]
    half = 0.5 * windows[-1]
    t, wrench, data, _ = wrench_snapshot(source, lo + half, hi - half, window, offsets, half, max_samples,
                                         "estimate the differentiation window")
    keep = contact_free(t, residuals(recording, t, wrench, data, offsets, phi), windows[-1], sensor_offsets)
    if keep.sum() < MIN_FREE * len(t):
        keep = None

    def cost(value):
        return residual_cost(with_differentiation_window(recording, value), t, wrench, data, offsets, phi, keep)

    costs = [cost(w) for w in windows]
    default = recording.differentiation.seconds
    return WindowFit(float(windows[int(np.argmin(costs))]), windows, costs, stream, default, cost(default))
