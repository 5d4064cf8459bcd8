"""Recordings written the way a lab's own tools might: Python's csv module, stamps in µs on a wall clock,
the wrench on the sensor's sign with a status column heft does not read, the accelerometer in g in axes
of its own, biased and late, the orientation on a clock of its own in ms. Every value from Drake
(``drake_motion``). Used by the recording and compensation tests and for docs/example_recording."""

import csv
import io

import numpy as np
from drake_motion import SmoothMotion
from scipy.spatial.transform import Rotation

from heft.systems.accelerometer_reading import AccelerometerConvention, reading_from_motion

EPOCH_US = 1_700_000_000_000_000  # stamps on a wall clock, as drivers write them
R_SA = Rotation.from_rotvec([0.3, -0.5, 0.7]).as_matrix()  # not about one axis
P_SA = np.array([0.02, 0.01, -0.008])
BIAS_G = np.array([0.0, 0.08, 0.0])
LATE = 0.006  # the accelerometer's stamps run 6 ms late
DURATION = 3.0
CONTACT_S = (1.2, 1.5)
CONTACT_PEAK = np.array([2.0, -1.0, 15.0, 0.3, 0.2, 0.0])


_TRUTH = {}


def _truth(rate: float, duration: float) -> tuple:
    """(t, Drake's truth) of the motion sampled at ``rate`` over ``duration`` s, computed once per process."""
    if (rate, duration) not in _TRUTH:
        t = np.arange(0, duration, 1 / rate)
        _TRUTH[rate, duration] = t, SmoothMotion().truth(t)
    return _TRUTH[rate, duration]


def _write(path, header, rows):
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(header)
        writer.writerows(rows)


def contact_pulse(t: np.ndarray) -> np.ndarray:
    """A contact wrench on the load (N, N·m, at S in S): 15 N mostly along z with a moment, a half sine over
    CONTACT_S."""
    start, end = CONTACT_S
    shape = np.where((t >= start) & (t <= end), np.sin(np.pi * np.clip((t - start) / (end - start), 0, 1)), 0.0)
    return np.outer(shape, CONTACT_PEAK)


def write_recording(folder, orientation="rotation_matrix", accel_offset="estimate", sensor_offsets=None,
                    contact=False, noise=0.0, name="rec.yaml", duration=DURATION):
    """A ``duration`` s (3 s) recording of Drake's motion of the paper's tool: the wrench at 700 Hz on the
    sensor's sign with µs stamps (and a status column heft does not read), plus ``sensor_offsets`` (on the
    load's sign) and, with ``contact``, ``contact_pulse`` (or ``contact(t)``, (N, 6) on the load), and
    Gaussian noise of ``noise`` N (a twentieth of it on the torques); the accelerometer at 250 Hz in g,
    rotated by R_SA, biased and stamped 6 ms late; the orientation at 100 Hz. Returns the wrench's stamps
    (s from the start) and Drake's truth at them."""
    t_w, truth = _truth(700.0, duration)
    on_load = truth["wrench"] + (0.0 if sensor_offsets is None else np.asarray(sensor_offsets))
    if contact:
        on_load = on_load + (contact(t_w) if callable(contact) else contact_pulse(t_w))
    if noise:
        on_load = on_load + np.random.default_rng(5).normal(size=on_load.shape) * noise * np.repeat([1, 0.05], 3)
    _write(folder / "ft.csv", ["stamp_us", "Fx", "Fy", "Fz", "Tx", "Ty", "Tz", "status"],
           [[EPOCH_US + int(round(1e6 * t))] + [f"{-x:.6f}" for x in w] + [0] for t, w in zip(t_w, on_load)])
    t_a, at_a = _truth(250.0, duration)
    specific = reading_from_motion(np.hstack((at_a["a"], at_a["alpha"])), at_a["g"], at_a["omega"],
                                   AccelerometerConvention(True, tuple(P_SA)))[:, :3]
    raw = specific @ R_SA / 9.80665 + BIAS_G
    _write(folder / "imu.csv", ["time", "ax", "ay", "az"],
           [[EPOCH_US + int(round(1e6 * (t + LATE)))] + [f"{x:.7f}" for x in r] for t, r in zip(t_a, raw)])
    t_p, at_p = _truth(100.0, duration)
    R = at_p["R_WS"]
    if orientation == "rotation_matrix":
        names, values = [f"r{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3)], R.reshape(-1, 9)
    else:
        names, values = ["qx", "qy", "qz", "qw"], Rotation.from_matrix(R).as_quat()
    _write(folder / "pose.csv", ["t_ms"] + names,
           [[f"{1e3 * t:.3f}"] + [f"{x:.8f}" for x in v] for t, v in zip(t_p, values)])
    offset = accel_offset if isinstance(accel_offset, str) else float(accel_offset)
    (folder / name).write_text(f"""
wrench:
  file: ft.csv
  time: {{column: stamp_us, unit: us}}
  columns: [Fx, Fy, Fz, Tx, Ty, Tz]
  exerted_on: sensor
accelerometer:
  file: imu.csv
  time: {{column: time, unit: us, offset: {offset}}}
  columns: [ax, ay, az]
  unit: g
  R_SA: {R_SA.tolist()}
  p_SA: {P_SA.tolist()}
  bias: {BIAS_G.tolist()}
orientation:
  file: pose.csv
  time: {{column: t_ms, unit: ms, offset: {-EPOCH_US * 1e-6}}}
  kind: {orientation}
  columns: {names}
""")
    return t_w, truth


QUIRKS = ("padded", "quoted", "bom", "semicolon", "tab", "whitespace", "stated_semicolon", "comments", "crlf",
          "trailing", "exponents", "all")
"""The ways a lab's logger may write a CSV (``rewrite``)."""


def rewrite(path, quirk: str) -> str | None:
    """Rewrites the comma-separated file at ``path`` (the csv module's) as a logger with ``quirk`` would, the
    same numbers in it; returns the ``delimiter:`` the recording must state, if any. With the csv module and
    plain string operations only."""
    with open(path, newline="") as f:
        header, *rows = list(csv.reader(f))
    separator, newline, prefix, comment_every = ",", "\n", "", 0
    if quirk in ("padded", "all"):
        header = [f"  {name} " for name in header]
        rows = [[f" {value}" for value in row] for row in rows]
    if quirk in ("exponents", "all"):
        rows = [[format(float(value), ".16e") for value in row] for row in rows]
    if quirk in ("trailing", "all"):
        header, rows = header + [""], [row + [""] for row in rows]
    if quirk in ("semicolon", "stated_semicolon", "all"):
        separator = ";"
    if quirk == "tab":
        separator = "\t"
    if quirk in ("crlf", "all"):
        newline = "\r\n"
    if quirk in ("bom", "all"):
        prefix = "\ufeff"
    if quirk in ("comments", "all"):
        comment_every = 97
    if quirk == "whitespace":  # columns aligned with runs of spaces, as fixed-width loggers print them
        width = max(len(x) for line in [header, *rows] for x in line) + 2
        lines = ["".join(x.rjust(width) for x in line) for line in [header, *rows]]
    else:
        buffer = io.StringIO()
        quoting = csv.QUOTE_ALL if quirk in ("quoted", "all") else csv.QUOTE_MINIMAL
        csv.writer(buffer, delimiter=separator, lineterminator="\n", quoting=quoting).writerows([header, *rows])
        lines = buffer.getvalue().splitlines()
    if comment_every:
        lines = ["# logger v2.1, serial 0042", "# units: s, N, N·m", ""] + [
            line for k, row in enumerate(lines) for line in ([row, "# resynchronised"] if k % comment_every == 5
                                                              else [row])]
    with open(path, "w", newline="", encoding="utf-8") as f:
        f.write(prefix + newline.join(lines) + newline)
    return ";" if quirk == "stated_semicolon" else None


STATIC_POSES = 24
"""How many wrist orientations the example holds still (gravity in every direction of S)."""
STATIC_NOISE = (0.01, 0.0005, 0.0002)
"""The averaged poses' noise: N, N·m, g (the 0.1 N of a stream's samples, averaged over about 100)."""


def write_static_poses(folder, phi, sensor_offsets) -> dict:
    """``poses.csv``: the tool ``phi`` held still in ``STATIC_POSES`` orientations R_WS (random, seeded), one
    averaged row each in the files' layout: the wrench on the sensor's sign with ``sensor_offsets`` (on the
    load's sign), the accelerometer in g in its own axes with its bias, R_WS row by row; the noise of
    ``STATIC_NOISE``. Returns the recording's ``static_poses`` section."""
    from heft.systems.load_dynamics import noncontact_wrench

    R_WS = Rotation.random(STATIC_POSES, random_state=11).as_matrix()
    g_S = np.einsum("pji,j->pi", R_WS, [0.0, 0.0, -9.81])  # gravity in S: R_WSᵀ·g_W
    zeros = np.zeros((STATIC_POSES, 3))
    on_load = noncontact_wrench(np.asarray(phi), zeros, zeros, zeros, g_S) + np.asarray(sensor_offsets)
    specific = reading_from_motion(np.hstack((zeros, zeros)), g_S, zeros,
                                   AccelerometerConvention(True, tuple(P_SA)))[:, :3]
    rng = np.random.default_rng(13)
    force, torque, accel = STATIC_NOISE
    on_load = on_load + rng.normal(size=on_load.shape) * np.repeat([force, torque], 3)
    raw = specific @ R_SA / 9.80665 + BIAS_G + rng.normal(size=specific.shape) * accel
    names = [f"r{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3)]
    _write(folder / "poses.csv", ["pose", "Fx", "Fy", "Fz", "Tx", "Ty", "Tz", "ax", "ay", "az", *names],
           [[k + 1] + [f"{-x:.6f}" for x in w] + [f"{x:.7f}" for x in a] + [f"{x:.8f}" for x in R.ravel()]
            for k, (w, a, R) in enumerate(zip(on_load, raw, R_WS))])
    return {"file": "poses.csv", "wrench": ["Fx", "Fy", "Fz", "Tx", "Ty", "Tz"], "accelerometer": ["ax", "ay", "az"],
            "orientation": names, "orientation_kind": "rotation_matrix"}


def write_example(folder) -> None:
    """docs/example_recording: the recording of ``write_recording`` with sensor offsets, a contact and the
    JR3's noise, its clock offset left to estimate (recording.yaml), and the static poses of
    ``write_static_poses`` of the same tool, offsets and accelerometer (poses.yaml), from which
    `heft identify --recording` finds the estimate that `heft compensate` takes."""
    import yaml
    from drake_motion import PAPER_TOOL

    offsets = [1.5, -2.0, 3.0, 0.1, -0.05, 0.02]
    write_recording(folder, sensor_offsets=offsets, contact=True, noise=0.1, name="recording.yaml")
    poses = write_static_poses(folder, PAPER_TOOL.to_phi(), offsets)
    (folder / "poses.yaml").write_text(yaml.safe_dump({"wrench": {"exerted_on": "sensor"},
                                                       "accelerometer": {"unit": "g"}, "static_poses": poses}))


if __name__ == "__main__":  # python tests/recording_layouts.py docs/example_recording
    import sys
    from pathlib import Path

    target = Path(sys.argv[1])
    target.mkdir(parents=True, exist_ok=True)
    write_example(target)
