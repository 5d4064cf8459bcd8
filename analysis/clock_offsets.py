"""The clock offset of each stream against the wrench's: the shift that makes V·φ̂ agree best with
the measured wrench.

For a candidate offset the streams are merged onto the wrench's stamps (``recording_merge.merge``)
and the cost is Σ var(f − V·φ̂) / Σ var(f) over the three forces plus the same over the three
torques: the variance, so that the sensor's constant offsets (unknown while identifying) do not
matter; relative per group, so that forces and torques weigh alike; summed within a group, so that an
axis the motion hardly moves weighs little. (Per axis, var(f − V·φ̂)/var(f) of such an axis is its
noise over its noise, about 1 and fluctuating from offset to offset by far more than the moving
axes' costs change: in a horizontal swing of the paper's tool it put the minimum 1.75 ms off.)
Each stream's offset is found on a grid over ±``search`` s, refined on a grid 20 times finer
around the best and by a parabola through the finest grid's three best points.
Then the samples near contact (``contact_free``: as `heft compensate` finds it, wherever the recording
is quiet) are left out and the search runs again (with
several streams, two more rounds of one stream at a time). A φ̂ is needed: ``heft compensate`` takes
the estimate's, identification may alternate (identify with an offset, estimate the offset, …).

Like with like: α derived from the orientation is ω's Savitzky–Golay derivative, which is α seen
through a smoothing kernel as wide as the ``differentiation`` window; the wrench and the
accelerometer's rows are passed through the same kernel (``like_derived``) before the cost compares
them. Unsmoothed, the fit traded the accelerometer's timing against α's smoothing: in a fast swing (2 s
of fig7, the wrench at 700 Hz, the accelerometer at 250 Hz and 6 ms late) the offset came out
0.13 ms early, 0.02 ms with the kernel.

Whether the motion could tell (``observable``): the offset's standard error from the cost's
curvature at its minimum, σ² = J₀ / (n · ½J''), n the window's duration over the differentiation
window (the smoothed residual's independent stretches), must be at most ``OBSERVABLE_STD``, and the
minimum inside the search.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from heft.analysis.compensation import quiet_threshold
from heft.analysis.recording_merge import RecordingSource, StreamData, merge, rotation_terms
from heft.systems.identification.rotation_sampling import savitzky_golay

COARSE_STEPS = 25
"""Grid points on each side of the stated offset at the coarse stage."""
FINE_FACTOR = 20
"""The fine grid's step is the coarse one's over this."""
ROUNDS = 2
MIN_FREE = 0.05
"""The least share of the window's samples out of contact for the search to keep to them."""
OBSERVABLE_STD = 1e-4
"""s: the largest standard error of an offset the motion is said to tell (half the 0.2 ms aimed at)."""


@dataclasses.dataclass
class OffsetFit:
    """One stream's offset (s): the cost at the grid points (``offsets`` s, ``costs``), the offset's
    standard error ``std`` (s, inf where the cost has no minimum inside the search), and whether the
    window's motion could tell (``observable``, module docstring)."""
    offset: float
    offsets: list
    costs: list
    std: float
    observable: bool

    def why_not(self) -> str:
        """Why the offset is not observable, for the report."""
        if not np.isfinite(self.std):
            return "the cost has no minimum inside the search; the window holds too little motion"
        return (f"its standard error is {1e3 * self.std:.2g} ms (at most {1e3 * OBSERVABLE_STD:g} ms): too little "
                "motion, or a model that leaves too much of the wrench unexplained")

    def summary(self) -> dict:
        return {"offset_s": self.offset, "observable": self.observable,
                "std_s": self.std if np.isfinite(self.std) else None,
                "cost_min": float(min(self.costs)), "cost_max": float(max(self.costs))}


def like_derived(x: np.ndarray, period: float, window: float, order: int) -> np.ndarray:
    """Rows x (N, k) sampled every ``period`` s seen through the kernel the derivative filter puts α
    through: the Savitzky–Golay derivative of their running (trapezoidal) integral."""
    integral = (np.cumsum(x, axis=0) - 0.5 * x) * period
    return savitzky_golay(integral, period, window, order, deriv=1)


def residuals(recording, t, wrench, data: StreamData, offsets: dict, phi, rotations=None) -> np.ndarray:
    """f − V·φ̂ (N, 6) with the streams merged at ``offsets``. ``rotations``: a dict caching
    ``rotation_terms`` by the rotation streams' offsets (the accelerometer's search leaves them alone)."""
    rotation = None
    if rotations is not None:
        key = (offsets.get("orientation"), offsets.get("angular_velocity"))
        if key not in rotations:
            rotations[key] = rotation_terms(recording, t, data, offsets)
        rotation = rotations[key]
    return wrench - merge(recording, t, wrench, data, offsets, rotation).noncontact(phi)


def residual_cost(recording, t, wrench, data: StreamData, offsets: dict, phi, keep=None, rotations=None) -> float:
    """Σ var(f − V·φ̂)/Σ var(f) over the forces plus the same over the torques (module docstring), over
    the samples ``keep`` (all if None)."""
    residual = residuals(recording, t, wrench, data, offsets, phi, rotations)
    if keep is not None:
        residual, wrench = residual[keep], wrench[keep]
    residual_var = residual.var(axis=0).reshape(2, 3).sum(axis=1)
    wrench_var = wrench.var(axis=0).reshape(2, 3).sum(axis=1)
    return float(np.sum(residual_var / np.maximum(wrench_var, 1e-12)))


def contact_free(t: np.ndarray, residual: np.ndarray, guard: float, sensor_offsets=None) -> np.ndarray:
    """The samples at least ``guard`` s from any in contact, which no clock offset explains: the
    contact force |f − V·φ̂ − o_f| (o the ``sensor_offsets`` on the load's sign, else the force
    residual's median) above the threshold `heft compensate` would find in it (``quiet_threshold``)."""
    baseline = np.median(residual[:, :3], axis=0) if sensor_offsets is None else np.asarray(sensor_offsets)[:3]
    force = np.linalg.norm(residual[:, :3] - baseline, axis=1)
    outside = force > quiet_threshold(t, force).value
    if not outside.any():
        return np.ones(len(t), dtype=bool)
    edges = t[outside]
    left = np.searchsorted(edges, t - guard)
    right = np.searchsorted(edges, t + guard, side="right")
    return right <= left


def wrench_snapshot(source: RecordingSource, lo: float, hi: float, window: tuple[float, float] | None, offsets: dict,
                    margin: float, max_samples: int, purpose: str):
    """(t, wrench, data, stride) of the wrench rows in ``window`` ((start, duration) s of wrench time; default the
    first 60 s from ``lo``) within [``lo``, ``hi``], at most ``max_samples`` of them (every ``stride``-th), the
    other streams at ``offsets`` and ``margin`` s beyond; a ValueError, naming ``purpose``, if none is left."""
    start, duration = window if window is not None else (lo, 60.0)
    lo, hi = max(lo, start), min(hi, start + duration)
    if hi <= lo:
        raise ValueError(f"no wrench time is left to {purpose} in (window {start}–{start + duration} s, streams "
                         f"shared within ±{margin:g} s)")
    rows = max(1, int(round((hi - lo) / source.period("wrench"))))
    stride = max(1, rows // max_samples)
    return (*source.snapshot((lo, hi), offsets, margin=margin + 0.01, stride=stride), stride)


def estimate_clock_offsets(source: RecordingSource, phi, streams=None, window: tuple[float, float] | None = None,
                           search: float = 0.05, max_samples: int = 20000, initial: dict | None = None,
                           sensor_offsets=None) -> dict:
    """{stream: OffsetFit} for ``streams`` (default: those whose offset is 'estimate'), the others held
    at their stated (or ``initial``) offsets. ``window``: (start, duration) s of wrench time (default:
    the first 60 s the streams share); at most ``max_samples`` wrench rows of it are used.
    ``sensor_offsets`` (6,), on the load's sign, if known: contact is then judged against them."""
    stated = source.stated_offsets()
    streams = list(streams) if streams is not None else [n for n, v in stated.items() if v == "estimate"]
    offsets = {name: 0.0 if value == "estimate" else float(value) for name, value in stated.items()}
    offsets.update(initial or {})
    lo, hi = source.common_interval({n: offsets[n] for n in offsets if n not in streams})
    t, wrench, data, stride = wrench_snapshot(source, lo + search, hi - search, window, offsets, search, max_samples,
                                              "estimate clock offsets")
    diff = source.recording.differentiation
    wrench = like_derived(wrench, source.period("wrench") * stride, diff.seconds, diff.order)
    t_a, acc = data.rows["accelerometer"]
    data = StreamData({**data.rows, "accelerometer": (t_a, like_derived(acc, source.period("accelerometer"),
                                                                       diff.seconds, diff.order))}, data.periods)
    independent = (t[-1] - t[0]) / diff.seconds
    fits, keep, rotations = {}, None, {}
    for round_ in range(1 + (ROUNDS if len(streams) > 1 else 1)):
        for name in streams:
            fits[name] = _search(source.recording, t, wrench, data, offsets, name, phi, search, keep, rotations,
                                 independent)
            offsets[name] = fits[name].offset
        if round_ == 0:  # leave out contact (and what the filters smear of it) from then on
            keep = contact_free(t, residuals(source.recording, t, wrench, data, offsets, phi), 2 * search,
                                sensor_offsets)
            if keep.sum() < MIN_FREE * len(t):
                keep = None
            else:
                independent = keep.sum() / len(t) * (t[-1] - t[0]) / diff.seconds
    return fits


def _search(recording, t, wrench, data, offsets, name, phi, search, keep, rotations, independent) -> OffsetFit:
    centre = offsets[name]

    def cost(value):
        return residual_cost(recording, t, wrench, data, {**offsets, name: value}, phi, keep, rotations)

    step = search / COARSE_STEPS
    grid = centre + step * np.arange(-COARSE_STEPS, COARSE_STEPS + 1)
    costs = np.array([cost(x) for x in grid])
    best = grid[int(np.argmin(costs))]
    fine = best + (step / FINE_FACTOR) * np.arange(-FINE_FACTOR, FINE_FACTOR + 1)
    fine_costs = np.array([cost(x) for x in fine])
    k = int(np.clip(np.argmin(fine_costs), 1, len(fine) - 2))
    offset = _parabola_minimum(fine[k - 1:k + 2], fine_costs[k - 1:k + 2])
    all_offsets = np.concatenate((grid, fine))
    all_costs = np.concatenate((costs, fine_costs))
    order = np.argsort(all_offsets)
    inside = abs(best - centre) < search - step / 2
    std = _standard_error(fine, fine_costs, independent) if inside else np.inf
    return OffsetFit(float(offset), all_offsets[order].tolist(), all_costs[order].tolist(), std,
                     bool(std <= OBSERVABLE_STD))


def _standard_error(x, y, independent: float) -> float:
    """√(J₀ / (n · ½J'')) (s) from a parabola fitted by least squares to the cost ``y`` at offsets ``x``."""
    a, _, _ = np.polyfit(x - x.mean(), y, 2)
    if a <= 0:
        return np.inf
    return float(np.sqrt(y.min() / (max(independent, 1.0) * a)))


def _parabola_minimum(x, y) -> float:
    """The vertex of the parabola through three equally spaced points, kept within them."""
    denominator = y[0] - 2 * y[1] + y[2]
    if denominator <= 0:
        return float(x[1])
    h = x[1] - x[0]
    return float(np.clip(x[1] + 0.5 * h * (y[0] - y[2]) / denominator, x[0], x[2]))
