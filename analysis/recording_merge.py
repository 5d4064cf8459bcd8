"""A recording's streams on the wrench's timeline: what Eq. 5 needs per wrench sample.

``RecordingSource`` opens the streams (``column_files``), checks that they overlap in time, and
yields ``MergedSamples`` chunk by chunk (``chunks``) or at once (``merged``, for short recordings).
``merge`` is the pure step: every other stream moved onto the wrench's clock by its offset and
interpolated at the wrench's stamps — linear for vectors, slerp for R_WS — with ω and α from the
orientation through the recording's ``differentiation`` filter when not recorded. Each choice is
in ``RecordingSource.choices`` (printed by the commands and kept in their metrics.json).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from heft.analysis.column_files import ColumnFile, RecordingError
from heft.analysis.recording import ESTIMATE, Recording, with_differentiation_window
from heft.systems.accelerometer_reading import AccelerometerConvention, motion_from_reading
from heft.systems.load_dynamics import noncontact_wrench
from heft.systems.identification.rotation_sampling import (
    ROTATION_TOLERANCE, body_angular_velocity, continuous, quaternions_from_matrices, rotate_into_body,
    rotation_defects, savitzky_golay, slerp, window_samples)

JointOrientation = Callable[[np.ndarray], np.ndarray]
"""q (N, 6) joint angles (rad) → R_WS (N, 3, 3), from heft's model of the arm
(``diagrams.recording_kinematics``)."""


@dataclasses.dataclass
class MergedSamples:
    """Per wrench sample, all in S: t (N,) s on the wrench's clock; ``wrench`` (N, 6) measured [f; τ]
    on the load (heft's sign, docs/design.md §4); S's kinematic a, α, ω and g (N, 3 each; m/s², rad/s², rad/s,
    m/s²). Without an orientation g is 0 and a is the specific force a − g (V needs only a − g)."""
    t: np.ndarray
    wrench: np.ndarray
    a: np.ndarray
    alpha: np.ndarray
    omega: np.ndarray
    g: np.ndarray

    def noncontact(self, phi) -> np.ndarray:
        """V·φ (Eq. 12), (N, 6)."""
        return noncontact_wrench(phi, self.a, self.alpha, self.omega, self.g)

    def __len__(self) -> int:
        return len(self.t)


@dataclasses.dataclass
class StreamData:
    """Rows of the streams other than the wrench, each on its own clock: {name: (t (n,), values (n, k))};
    the orientation as unit quaternions (w, x, y, z) of R_WS, the accelerometer already in S (m/s²,
    [linear; angular] if it measures α). ``periods``: {name: the stream's mean sample period (s)}."""
    rows: dict
    periods: dict


def rotation_terms(recording: Recording, t: np.ndarray, data: StreamData, offsets: dict):
    """(g, ω, α or None) in S at the wrench stamps ``t``: g from the orientation (zeros without one), ω
    recorded or from the orientation, α from ω's derivative unless the accelerometer measures it (None)."""
    rows, diff = data.rows, recording.differentiation
    g = np.zeros((len(t), 3))
    if "orientation" in rows:
        t_o, q_o = rows["orientation"]
        t_o = t_o - offsets["orientation"]
        g = rotate_into_body(slerp(t_o, q_o, t), recording.gravity_W)
    if "angular_velocity" in rows:
        t_w, raw = rows["angular_velocity"]
        t_w, period = t_w - offsets["angular_velocity"], data.periods["angular_velocity"]
        omega = _interpolate(t, t_w, raw)
    else:
        (t_w, raw), period = body_angular_velocity(t_o, q_o), data.periods["orientation"]
        omega = _interpolate(t, t_w, savitzky_golay(raw, period, diff.seconds, diff.order))
    alpha = None
    if rows["accelerometer"][1].shape[1] == 3:
        alpha = _interpolate(t, t_w, savitzky_golay(raw, period, diff.seconds, diff.order, deriv=1))
    return g, omega, alpha


def merge(recording: Recording, t: np.ndarray, wrench_on_load: np.ndarray, data: StreamData,
          offsets: dict, rotation=None) -> MergedSamples:
    """The streams of ``data`` at the wrench stamps ``t`` (inside their spans), each moved onto the
    wrench's clock by its offset (s, ``offsets[name]``: a stamp s is s − offset there). ``rotation``:
    ``rotation_terms`` at the same stamps and offsets, if already computed."""
    g, omega, alpha = rotation if rotation is not None else rotation_terms(recording, t, data, offsets)
    t_a, acc = data.rows["accelerometer"]
    t_a = t_a - offsets["accelerometer"]
    reading = np.empty((len(t), 6))
    reading[:, :3] = _interpolate(t, t_a, acc[:, :3])
    reading[:, 3:] = _interpolate(t, t_a, acc[:, 3:]) if alpha is None else alpha
    spec = recording.accelerometer
    convention = AccelerometerConvention(spec.includes_gravity, tuple(spec.p_SA))
    motion = motion_from_reading(reading, reading, g, omega, convention)
    return MergedSamples(t, wrench_on_load, motion[:, :3], motion[:, 3:], omega, g)


def _interpolate(t: np.ndarray, t_samples: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Each column of values (n, k) linearly at t."""
    out = np.empty((len(t), values.shape[1]))
    for j in range(values.shape[1]):
        out[:, j] = np.interp(t, t_samples, values[:, j])
    return out


class _Window:
    """A sliding window over one stream's rows (converted by ``convert``), on its own clock."""

    def __init__(self, file: ColumnFile, convert, margin: float):
        self._chunks, self._convert, self.margin = file.chunks(), convert, margin
        self.t, self.values, self._done, self.rows = np.empty(0), None, False, 0

    def covering(self, lo: float, hi: float) -> tuple[np.ndarray, np.ndarray]:
        """The rows from ``margin`` before lo to ``margin`` after hi (as far as the stream goes)."""
        while not self._done and (len(self.t) == 0 or self.t[-1] < hi + self.margin):
            try:
                t, values, row = next(self._chunks)
            except StopIteration:
                self._done = True
                break
            values = self._convert(values, row)
            self.rows += len(t)
            self.t = np.concatenate((self.t, t))
            self.values = values if self.values is None else np.concatenate((self.values, values))
        keep = max(int(np.searchsorted(self.t, lo - self.margin)) - 1, 0)
        self.t, self.values = self.t[keep:], self.values[keep:]
        end = int(np.searchsorted(self.t, hi + self.margin)) + 1  # only these: a chunk of the file holds far more
        return self.t[:end], self.values[:end]

    def drain(self) -> int:
        """Reads the stream's remaining rows through their checks and conversion; returns the rows read in all."""
        for t, values, row in self._chunks:
            self._convert(values, row)
            self.rows += len(t)
        self._done = True
        return self.rows


class RecordingSource:
    """A recording's streams, opened and checked (files, columns, overlap in time), ready to merge.

    ``joint_orientation``: for an orientation of kind joint_positions, the arm's forward kinematics
    (``diagrams.recording_kinematics.joint_orientation``). ``choices``: what was chosen how, for the
    report and metrics.json."""

    def __init__(self, recording: Recording, joint_orientation: JointOrientation | None = None):
        streams = recording.streams()
        if "wrench" not in streams:
            raise ValueError(f"{recording.source}: merging streams needs a wrench stream (a file)")
        if "accelerometer" not in streams:
            raise ValueError(f"{recording.source}: the load's non-contact wrench needs an accelerometer stream "
                             "(a − g and, unless recorded, α from the orientation)")
        if "orientation" not in streams and "angular_velocity" not in streams:
            raise ValueError(f"{recording.source}: ω needs an orientation or an angular_velocity stream")
        if "orientation" not in streams and not recording.accelerometer.includes_gravity:
            raise ValueError(f"{recording.source}: a gravity-free accelerometer needs the orientation for g")
        if "orientation" in streams and recording.orientation.kind == "joint_positions" \
                and joint_orientation is None:
            raise ValueError("joint positions need the arm's kinematics (pass joint_orientation)")
        self.recording = recording
        self._joint_orientation = joint_orientation
        self.files = {name: ColumnFile(recording.path(stream.file), stream.time, stream.columns, name,
                                        stream.delimiter)
                      for name, stream in recording.streams().items()}
        self.spans = {name: f.span() for name, f in self.files.items()}
        self.choices = self._describe()
        self._check_overlap({name: s.time.offset for name, s in recording.streams().items()
                             if s.time.offset != ESTIMATE})

    # --- what was chosen -------------------------------------------------------
    def stated_offsets(self) -> dict:
        """{stream: offset (s) or 'estimate'} of the streams other than the wrench."""
        return {name: stream.time.offset for name, stream in self.recording.streams().items() if name != "wrench"}

    def period(self, name: str) -> float:
        first, last, rows = self.spans[name]
        return (last - first) / max(rows - 1, 1)

    def _describe(self) -> dict:
        rec = self.recording
        choices = {"timeline": f"the wrench's stamps ({self.files['wrench'].path.name}, "
                               f"{1 / self.period('wrench'):.6g} Hz); other streams interpolated at them "
                               "(linear; R_WS by slerp)",
                   "wrench_sign": "negated: the file has what the load exerts on the sensor"
                   if rec.wrench.exerted_on == "sensor" else "as recorded: what the sensor exerts on the load"}
        choices["layout"] = {name: file.layout.describe() if file.layout else f"{file.path.name}: Parquet"
                             for name, file in self.files.items()}
        for name in self.files:
            first, last, rows = self.spans[name]
            choices[f"{name}_span"] = {"first_s": first, "last_s": last, "rows": rows,
                                       "rate_hz": 1 / self.period(name) if rows > 1 else None}
        acc = rec.accelerometer
        choices["accelerometer"] = (f"unit {acc.unit}, R_SA {acc.R_SA}, bias {acc.bias} ({acc.unit}), scale "
                                    f"{acc.scale:g}, p_SA {acc.p_SA} m, "
                                    + ("specific force a − g" if acc.includes_gravity else "gravity-free a"))
        window = rec.differentiation
        derived = []
        if "angular_velocity" in self.files:
            choices["omega"] = "recorded (angular_velocity stream)"
            source, period = "ω stream", self.period("angular_velocity")
        else:
            source, period = "orientation", self.period("orientation")
            derived.append("ω")
        if len(acc.columns) == 6:
            choices["alpha"] = "recorded (the accelerometer's angular channels)"
        else:
            derived.append("α")
        if derived:
            n = window_samples(period, window.seconds, window.order)
            text = (f"from the {source}: " + ("ω as the rotation between consecutive samples over their interval, "
                                              if "ω" in derived else "")
                    + f"Savitzky–Golay order {window.order} over {n} samples ({n * period * 1e3:.4g} ms"
                    + (", the default while the window is left to estimate" if window.window == ESTIMATE else "")
                    + ")" + (", α its derivative" if "α" in derived else ""))
            for what in derived:
                choices["omega" if what == "ω" else "alpha"] = text
        choices["gravity"] = (f"g_S = R_WSᵀ·{rec.gravity_W} m/s² from the orientation ({rec.orientation.kind})"
                              if "orientation" in self.files else
                              "no orientation: g left at 0 and a = the specific force (V needs only a − g)")
        choices["clock_offsets_s"] = {name: (offset if offset == ESTIMATE else float(offset))
                                      for name, offset in self.stated_offsets().items()}
        return choices

    def differentiated(self) -> bool:
        """Whether ω or α comes through the ``differentiation`` filter (not both recorded)."""
        return "angular_velocity" not in self.files or len(self.recording.accelerometer.columns) == 3

    def state_differentiation_window(self, window: float, how: str) -> None:
        """Takes the differentiation ``window`` (s) from here on, ``how`` it was chosen said in ``choices``."""
        self.recording = with_differentiation_window(self.recording, window)
        described = self._describe()
        for key in ("omega", "alpha"):
            if described[key] != self.choices[key]:
                self.choices[key] = f"{described[key]}; {how}"

    # --- overlap ---------------------------------------------------------------------
    def common_interval(self, offsets: dict) -> tuple[float, float]:
        """[first, last] wrench time (s) that every stream covers with ``offsets``, a margin kept for the
        derivative filter's window."""
        lo, hi, _ = self.spans["wrench"]
        for name, (first, last, _) in self.spans.items():
            if name == "wrench":
                continue
            margin = self._margin(name)
            lo, hi = max(lo, first - offsets.get(name, 0.0) + margin), min(hi, last - offsets.get(name, 0.0) - margin)
        return lo, hi

    def _margin(self, name: str) -> float:
        """Time kept clear of a stream's ends: the derivative filter's half window for a stream differentiated."""
        if name == "accelerometer":
            return 0.0
        return 0.5 * window_samples(self.period(name), self.recording.differentiation.seconds,
                                    self.recording.differentiation.order) * self.period(name)

    def _check_overlap(self, offsets: dict) -> None:
        lo, hi = self.common_interval(offsets)
        if hi > lo:
            return
        w = self.spans["wrench"]
        parts = []
        for name, (first, last, rows) in self.spans.items():
            off = offsets.get(name, 0.0)
            parts.append(f"{self.files[name].path.name} ({self.files[name].clock.column or 'rate'}, rows 1–{rows}) "
                         f"{first - off:.6g}–{last - off:.6g} s")
        raise RecordingError(f"streams do not overlap in time on the wrench's clock (wrench {w[0]:.6g}–{w[1]:.6g} s): "
                             + "; ".join(parts) + "; check the time columns' units and the clock offsets")

    def resolved_offsets(self, offsets: dict | None = None) -> dict:
        """The stated offsets with ``offsets`` laid over them; a ValueError if one is still 'estimate'."""
        resolved = {**self.stated_offsets(), **(offsets or {})}
        open_ = [name for name, value in resolved.items() if value == ESTIMATE]
        if open_:
            raise ValueError(f"the clock offset of {', '.join(open_)} is 'estimate': estimate it first "
                             "(analysis.clock_offsets.estimate_clock_offsets) or state it in the recording")
        return {name: float(value) for name, value in resolved.items()}

    # --- conversion of each stream's rows ---------------------------------------------
    def _convert(self, name: str):
        if name == "accelerometer":
            calibration = self.recording.accelerometer.calibration()

            def to_S(values, row):
                out = calibration.to_sensor_axes(values[:, :3])
                return np.hstack((out, values[:, 3:] @ calibration.R_SA.T)) if values.shape[1] == 6 else out
            return to_S
        if name == "orientation":
            return self._orientation_quaternions
        return lambda values, row: values

    def _orientation_quaternions(self, values: np.ndarray, first_row: int) -> np.ndarray:
        spec, file = self.recording.orientation, self.files["orientation"]
        if spec.kind == "joint_positions":
            R = self._joint_orientation(values)
        elif spec.kind == "rotation_matrix":
            R = values.reshape(-1, 3, 3)
        else:
            q = values if spec.kind == "quaternion_wxyz" else np.roll(values, 1, axis=1)
            norm = np.linalg.norm(q, axis=1)
            bad = np.abs(norm - 1.0) > ROTATION_TOLERANCE
            if bad.any():
                k = int(np.argmax(bad))
                raise RecordingError(f"{file.where(f'{spec.columns[0]}…{spec.columns[-1]}', first_row + k)}: "
                                     f"quaternion of norm {norm[k]:.6g} "
                                     f"is not a unit quaternion (tolerance {ROTATION_TOLERANCE:g})")
            return q / norm[:, None]
        defects = rotation_defects(R)
        bad = defects > ROTATION_TOLERANCE
        if bad.any():
            k = int(np.argmax(bad))
            raise RecordingError(f"{file.where(f'{spec.columns[0]}…{spec.columns[-1]}', first_row + k)}: "
                                 "not a rotation matrix (RᵀR or det off the identity "
                                 f"by {defects[k]:.3g}, tolerance {ROTATION_TOLERANCE:g})")
        return quaternions_from_matrices(R)

    def _wrench_on_load(self, values: np.ndarray) -> np.ndarray:
        return -values if self.recording.wrench.exerted_on == "sensor" else values

    # --- merged samples ---------------------------------------------------------------------
    def chunks(self, offsets: dict | None = None, t_range: tuple[float, float] | None = None, stride: int = 1,
               every_row: bool = False):
        """MergedSamples per chunk of the wrench file, inside the streams' common interval (and
        ``t_range``, s on the wrench's clock, if given); every ``stride``-th wrench row. ``offsets``
        lays clock offsets over the stated ones. Dropped rows: ``self.dropped`` after the loop. With
        ``every_row``, the rows no sample needs are read through their checks too (numbers, NaN, time
        order, rotations), so that a bad row anywhere stops the loop; ``self.checked``: {stream: rows}."""
        offsets = self.resolved_offsets(offsets)
        lo, hi = self.common_interval(offsets)
        if t_range is not None:
            lo, hi = max(lo, t_range[0]), min(hi, t_range[1])
        if hi <= lo:
            self._check_overlap(offsets)
            raise RecordingError(f"no wrench samples within {t_range} s that every stream covers ({lo:.6g}–{hi:.6g})")
        others = [name for name in self.files if name != "wrench"]
        windows = {name: _Window(self.files[name], self._convert(name), 3 * self.period(name) + self._margin(name))
                   for name in others}
        self.dropped, wrench_rows = 0, 0
        for t, values, row in self.files["wrench"].chunks():
            wrench_rows += len(t)
            if stride > 1:
                phase = (-(row - 1)) % stride
                t, values = t[phase::stride], values[phase::stride]
            inside = (t >= lo) & (t <= hi)
            self.dropped += int(len(t) - inside.sum()) if t_range is None else 0
            if not inside.any():
                if t[0] > hi and not every_row:
                    break
                continue
            t, values = t[inside], values[inside]
            data = StreamData({name: self._window_rows(name, windows[name], t, offsets) for name in others},
                              self._periods())
            yield merge(self.recording, t, self._wrench_on_load(values), data, offsets)
        if every_row:
            self.checked = {"wrench": wrench_rows, **{name: window.drain() for name, window in windows.items()}}

    def _window_rows(self, name, window: _Window, t: np.ndarray, offsets: dict):
        t_s, values = window.covering(t[0] + offsets[name], t[-1] + offsets[name])
        if name == "orientation":
            values = continuous(values)
        return t_s, values

    def merged(self, offsets: dict | None = None, t_range=None, stride: int = 1) -> MergedSamples:
        """All of ``chunks`` in one MergedSamples (for recordings that fit in memory)."""
        parts = list(self.chunks(offsets, t_range, stride))
        return MergedSamples(*(np.concatenate([getattr(p, f.name) for p in parts])
                               for f in dataclasses.fields(MergedSamples)))

    def snapshot(self, t_range: tuple[float, float], offsets: dict, margin: float, stride: int = 1):
        """The raw material of ``merge`` for a window of wrench time: (t, wrench on the load, StreamData)
        with every other stream's rows from ``margin`` s before to after it at ``offsets`` — for
        evaluating many clock offsets without reading the files again."""
        lo, hi = t_range
        t_parts, w_parts = [], []
        for t, values, row in self.files["wrench"].chunks():
            if t[0] > hi:
                break
            if stride > 1:
                phase = (-(row - 1)) % stride
                t, values = t[phase::stride], values[phase::stride]
            inside = (t >= lo) & (t <= hi)
            t_parts.append(t[inside])
            w_parts.append(values[inside])
        t, wrench = np.concatenate(t_parts), self._wrench_on_load(np.concatenate(w_parts))
        rows = {}
        for name in self.files:
            if name == "wrench":
                continue
            window = _Window(self.files[name], self._convert(name), margin + self._margin(name) + 3 * self.period(name))
            t_s, values = window.covering(lo + offsets[name], hi + offsets[name])
            rows[name] = (t_s.copy(), continuous(values) if name == "orientation" else values.copy())
        return t, wrench, StreamData(rows, self._periods())

    def _periods(self) -> dict:
        return {name: self.period(name) for name in self.files}
