"""A recorded run compensated: per wrench sample the load's non-contact wrench V·φ̂ (Eq. 12) and the
contact estimate f − ô − V·φ̂ (Eq. 13), streamed chunk by chunk from ``RecordingSource`` to a CSV (or
Parquet) file, with what a report needs kept as it goes: the contact intervals found, the residual's
RMS per axis outside them, and a thinned copy for the figure.

Output columns: ``t`` (s, the wrench's clock), ``noncontact_fx … noncontact_tz``, ``contact_fx …
contact_tz`` (N, N·m, at S in S, in the recording's own sign: ``exerted_on``). The file is written
under a temporary name and renamed when the run is complete, so a run stopped by a bad row leaves none.

Contact: the contact force's magnitude |c_f| above a threshold (N), samples less than ``MERGE_GAP`` apart
joined, intervals shorter than ``MIN_DURATION`` dropped. The threshold (``contact_threshold``), unless
stated, is the level the model's residual and the sensor's noise leave while nothing is touched, found
in the recording itself wherever in it that is: |c_f| over the whole recording (at most
``SCAN_SAMPLES`` samples, evenly thinned) is cut into ``QUIET_WINDOW`` stretches; the quietest tenth
of them (lowest median |c_f|) give a first median + 6 robust standard deviations (1.4826 × MAD), which
then takes in every sample below it until it settles (σ-clipping), at least ``MIN_THRESHOLD``. Where
the estimate measured its fit's residual and even the quietest stretches lie above 6 times it, the
recording is taken to be in contact throughout and that level is the threshold.
"""

from __future__ import annotations

import dataclasses
import os
import time
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.csv as pa_csv
import pyarrow.parquet as pq

from heft.analysis.plotting import plt

AXES = ("fx", "fy", "fz", "tx", "ty", "tz")
COLUMNS = ("t",) + tuple(f"noncontact_{a}" for a in AXES) + tuple(f"contact_{a}" for a in AXES)
MIN_THRESHOLD = 0.5
"""N: five times the JR3's force noise (0.1 N RMS, docs/design.md §6), the least default contact threshold."""
ROBUST_SIGMAS = 6.0
SCAN_SAMPLES = 200_000
"""Wrench samples (at most, evenly thinned) from which the default threshold is found."""
QUIET_WINDOW = 0.1
"""s of wrench time per stretch when looking for the quietest (longer if it would hold fewer than
``QUIET_SAMPLES`` of the thinned samples)."""
QUIET_SAMPLES = 10
QUIET_SHARE = 0.1
"""The share of stretches (the lowest median |c_f|) that start the search; at least one."""
MERGE_GAP = 0.02
"""s: contact samples closer than this belong to one interval."""
MIN_DURATION = 0.005
"""s: shorter excursions are not reported as contact (they still count as contact for the RMS)."""
FIGURE_POINTS = 20000


@dataclasses.dataclass
class ContactThreshold:
    """|c_f| (N) above which a sample is in contact, and the reason for it (kept in metrics.json)."""
    value: float
    reason: str


def _robust_level(force: np.ndarray) -> float:
    median = float(np.median(force))
    return median + ROBUST_SIGMAS * 1.4826 * float(np.median(np.abs(force - median)))


def quiet_threshold(t: np.ndarray, force: np.ndarray, estimate_rms=None) -> ContactThreshold:
    """The default threshold (module docstring) from |c_f| ``force`` (N) at wrench times ``t`` (s), and
    the force residual RMS per axis the estimate's own fit left (``estimate_rms``, N), if it measured it."""
    length = max(QUIET_WINDOW, QUIET_SAMPLES * float(np.median(np.diff(t))) if len(t) > 1 else 0.0)
    edges = np.arange(t[0], t[-1] + length, length)
    window = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, None)
    counts = np.bincount(window)
    stretches = [force[window == k] for k in np.flatnonzero(counts >= 3)] or [force]
    levels = np.array([np.median(x) for x in stretches])
    quiet = np.argsort(levels)[:max(1, int(round(QUIET_SHARE * len(stretches))))]
    threshold = max(MIN_THRESHOLD, _robust_level(np.concatenate([stretches[k] for k in quiet])))
    for _ in range(50):
        settled = max(MIN_THRESHOLD, _robust_level(force[force <= threshold]))
        if abs(settled - threshold) <= 1e-3 * threshold:
            break
        threshold = settled
    quiet_level = float(np.median(levels[quiet]))
    reason = (f"the recording's quietest {len(quiet)} of {len(stretches)} stretches of {length:.3g} s (median "
              f"|c_f| {quiet_level:.3g} N), median + {ROBUST_SIGMAS:g} robust σ of |c_f|, widened over every sample "
              f"below it until it settled, at least {MIN_THRESHOLD:g} N; from {len(force)} samples")
    if estimate_rms is not None:
        noise = max(MIN_THRESHOLD, ROBUST_SIGMAS * float(np.linalg.norm(estimate_rms)))
        if quiet_level > noise:
            return ContactThreshold(noise, f"{ROBUST_SIGMAS:g} × the force residual the estimate's fit left "
                                           f"({float(np.linalg.norm(estimate_rms)):.3g} N RMS), at least "
                                           f"{MIN_THRESHOLD:g} N: even the recording's quietest stretches (median "
                                           f"|c_f| {quiet_level:.3g} N) lie above it, so it is in contact throughout")
        reason += f"; the estimate's fit left {float(np.linalg.norm(estimate_rms)):.3g} N RMS"
    return ContactThreshold(threshold, reason)


def contact_threshold(chunks, phi, offsets, stated: float | None = None, estimate_rms=None) -> ContactThreshold:
    """The threshold: ``stated`` (N), else ``quiet_threshold`` of the contact force over ``chunks`` (the
    recording's ``MergedSamples``, thinned to at most ``SCAN_SAMPLES``), φ̂ and the offsets (load's sign).
    ``chunks`` are read to their end either way (``RecordingSource.chunks`` with ``every_row`` checks
    every row of every file as they go)."""
    t_parts, force_parts = [], []
    for chunk in chunks:
        if stated is None:
            contact = chunk.wrench[:, :3] - np.asarray(offsets, dtype=float)[:3] - chunk.noncontact(phi)[:, :3]
            t_parts.append(chunk.t)
            force_parts.append(np.linalg.norm(contact, axis=1))
    if stated is not None:
        return ContactThreshold(float(stated), "stated (--contact-threshold)")
    if not t_parts:
        raise ValueError("no wrench sample to find the contact threshold from")
    return quiet_threshold(np.concatenate(t_parts), np.concatenate(force_parts), estimate_rms)


def scan_stride(rows: int) -> int:
    """Every how many wrench rows ``contact_threshold`` takes one."""
    return max(1, rows // SCAN_SAMPLES)


class _ContactIntervals:
    """Contact intervals from |c_f| > threshold, chunk by chunk."""

    def __init__(self, threshold: float):
        self.threshold, self.intervals, self._open = threshold, [], None  # _open: [start, end, peak]

    def add(self, t: np.ndarray, force: np.ndarray) -> np.ndarray:
        """Takes one chunk; returns its contact mask."""
        mask = force > self.threshold
        if not mask.any():
            return mask
        idx = np.flatnonzero(mask)
        breaks = np.flatnonzero(np.diff(t[idx]) > MERGE_GAP)
        starts, ends = np.concatenate(([0], breaks + 1)), np.concatenate((breaks, [len(idx) - 1]))
        for s, e in zip(starts, ends):
            t0, t1 = t[idx[s]], t[idx[e]]
            peak = float(force[idx[s]:idx[e] + 1].max())
            if self._open is not None and t0 - self._open[1] <= MERGE_GAP:
                self._open = [self._open[0], t1, max(self._open[2], peak)]
            else:
                self._close()
                self._open = [t0, t1, peak]
        return mask

    def _close(self):
        if self._open is not None and self._open[1] - self._open[0] >= MIN_DURATION:
            self.intervals.append({"start_s": float(self._open[0]), "end_s": float(self._open[1]),
                                   "peak_contact_force_N": self._open[2]})
        self._open = None

    def finish(self) -> list:
        self._close()
        return self.intervals


class _Writer:
    """compensated.csv (or .parquet) written in chunks under a temporary name."""

    def __init__(self, path: Path):
        self.path, self._partial = path, path.with_name(path.name + ".partial")
        self.parquet = path.suffix == ".parquet"
        schema = pa.schema([(name, pa.float64() if name == "t" else pa.float32()) for name in COLUMNS])
        self._writer = (pq.ParquetWriter(self._partial, schema) if self.parquet else
                        pa_csv.CSVWriter(self._partial, schema,
                                         write_options=pa_csv.WriteOptions(quoting_style="none")))
        self._schema = schema

    def write(self, t, noncontact, contact):
        arrays = [pa.array(t)] + [pa.array(noncontact[:, j].astype(np.float32)) for j in range(6)] + \
                 [pa.array(contact[:, j].astype(np.float32)) for j in range(6)]
        self._writer.write_table(pa.Table.from_arrays(arrays, schema=self._schema))

    def finish(self):
        self._writer.close()
        os.replace(self._partial, self.path)

    def abandon(self):
        self._writer.close()
        self._partial.unlink(missing_ok=True)


@dataclasses.dataclass
class Compensation:
    """What ``compensate`` found: ``samples`` written, ``duration_s`` of wrench time, ``threshold_N`` and its
    ``threshold_reason``,
    ``intervals`` of contact, the residual's ``rms`` and ``mean`` per axis outside them (N, N·m; the
    contact estimate where nothing is touched), the share of samples in contact, ``elapsed_s`` (wall) and
    ``cpu_s`` (this process's CPU time: what one core of its own would take), and
    thinned traces (``figure``: t, measured, noncontact, contact in the recording's sign)."""
    samples: int
    duration_s: float
    threshold_N: float
    threshold_reason: str
    intervals: list
    rms: list
    mean: list
    contact_share: float
    elapsed_s: float
    cpu_s: float
    figure: dict

    def metrics(self) -> dict:
        out = {key: value for key, value in dataclasses.asdict(self).items() if key != "figure"}
        out["residual_rms_without_contact"] = dict(zip(AXES, self.rms))
        out["residual_mean_without_contact"] = dict(zip(AXES, self.mean))
        out["real_time_factor"] = self.duration_s / max(self.elapsed_s, 1e-9)
        out["real_time_factor_cpu"] = self.duration_s / max(self.cpu_s, 1e-9)
        del out["rms"], out["mean"]
        return out


def compensate(chunks, phi, offsets, sign: float, out_path, threshold: ContactThreshold,
               total_rows: int | None = None) -> Compensation:
    """Compensates the ``MergedSamples`` of ``chunks`` with the load estimate (φ̂ (10,), offsets (6,) on
    the load's sign) and writes ``out_path`` (.csv or .parquet); contact is |c_f| above ``threshold``.
    ``sign``: −1 for a recording of what the load exerts on the sensor, else 1. ``total_rows`` (the
    wrench file's) thins the figure's traces."""
    started, started_cpu = time.perf_counter(), time.process_time()
    offsets = np.asarray(offsets, dtype=float)
    writer = _Writer(Path(out_path))
    detector = _ContactIntervals(threshold.value)
    sums, squares, count, samples = np.zeros(6), np.zeros(6), 0, 0
    stride = max(1, (total_rows or 0) // FIGURE_POINTS)
    kept = {key: [] for key in ("t", "measured", "noncontact", "contact")}
    first_t = last_t = None
    try:
        for chunk in chunks:
            noncontact = chunk.noncontact(phi)
            contact = chunk.wrench - offsets - noncontact
            force = np.sqrt(np.einsum("ij,ij->i", contact[:, :3], contact[:, :3]))
            free = ~detector.add(chunk.t, force)
            sums += contact[free].sum(axis=0)
            squares += np.einsum("ij,ij->j", contact[free], contact[free])
            count += int(free.sum())
            writer.write(chunk.t, sign * noncontact, sign * contact)
            phase = (-samples) % stride
            for key, value in (("t", chunk.t), ("measured", sign * chunk.wrench), ("noncontact", sign * noncontact),
                               ("contact", sign * contact)):
                kept[key].append(value[phase::stride].copy())  # a view would keep the chunk alive
            samples += len(chunk.t)
            first_t = chunk.t[0] if first_t is None else first_t
            last_t = chunk.t[-1]
    except BaseException:
        writer.abandon()
        raise
    writer.finish()
    if samples == 0:
        raise ValueError("no wrench sample was compensated")
    mean = sums / max(count, 1)
    rms = np.sqrt(squares / max(count, 1))
    return Compensation(samples, float(last_t - first_t), threshold.value, threshold.reason, detector.finish(),
                        rms.tolist(),
                        mean.tolist(), 1.0 - count / samples, time.perf_counter() - started,
                        time.process_time() - started_cpu,
                        {key: np.concatenate(value) for key, value in kept.items()})


def compensation_figure(result: Compensation, path, title: str = "") -> None:
    """Measured, non-contact and contact wrench per axis over the run (thinned), contact intervals shaded."""
    traces = result.figure
    t = traces["t"] - traces["t"][0]
    figure, panels = plt.subplots(6, 1, sharex=True, figsize=(9, 11))
    for j, panel in enumerate(panels):
        for key, style in (("measured", dict(lw=0.8, color="0.55")), ("noncontact", dict(lw=0.9, color="C0")),
                           ("contact", dict(lw=0.9, color="C3"))):
            panel.plot(t, traces[key][:, j], label=key.replace("noncontact", "non-contact"), **style)
        for interval in result.intervals:
            panel.axvspan(interval["start_s"] - traces["t"][0], interval["end_s"] - traces["t"][0], color="C1",
                          alpha=0.15, lw=0)
        panel.set_ylabel(f"{AXES[j]} ({'N' if j < 3 else 'N·m'})")
        panel.grid(alpha=0.3)
    panels[0].legend(loc="upper right", fontsize=8, ncol=3)
    panels[-1].set_xlabel(f"t − {traces['t'][0]:.6g} s (the wrench's clock)")
    figure.suptitle(title or "measured, non-contact (V·φ̂) and contact (measured − offsets − V·φ̂) wrench; "
                             "contact found shaded")
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)
