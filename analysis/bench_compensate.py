"""`heft bench compensate`: the rate and peak memory of `heft compensate` on a long synthetic recording.

The recording (``write_synthetic_recording``): the paper's tool's mass on a wrist swinging about a fixed
axis and moving along a line, the wrench at 8 kHz (µs stamps, the sensor's sign, 0.1 N / 0.005 N·m
noise), the accelerometer at 1 kHz and the orientation (quaternions) at 500 Hz, written in chunks. The
command then runs as a process of its own on one CPU (its affinity set, numerical libraries on one
thread), and its wall time, CPU time and peak resident memory (``wait4``) are read by the parent.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.csv as pa_csv
import pyarrow.parquet as pq
import yaml

from heft.systems.load_dynamics import GRAVITY_W, noncontact_wrench

RATES = {"wrench": 8000.0, "accelerometer": 1000.0, "orientation": 500.0}
"""Hz: the wrench at the JR3's 8 kHz (docs/design.md §6), a fast IMU, a robot's pose stream."""
PHI = np.array([3.13, 0.0, 0.0, 0.199, 0.0249, 0.0, 0.0, 0.0263, 0.0, 0.00477])
"""A load of the paper's tool's mass and size (kg, kg·m, kg·m² about S); only its order of magnitude matters."""
AXIS = np.array([1.0, 2.0, 2.0]) / 3.0
CHUNK_SECONDS = 8.0


def _motion(t: np.ndarray):
    """R_WS as quaternions, and S's a, α, ω, g in S (closed form: rotation θ(t) about the fixed AXIS,
    translation along x and z)."""
    theta = 0.8 * np.sin(2 * np.pi * 0.5 * t)
    theta_dt = 0.8 * np.pi * np.cos(2 * np.pi * 0.5 * t)
    theta_ddt = -0.8 * np.pi ** 2 * np.sin(2 * np.pi * 0.5 * t)
    q = np.column_stack((np.cos(theta / 2), np.outer(np.sin(theta / 2), AXIS)))
    a_W = np.column_stack((3.0 * np.sin(2 * np.pi * 0.7 * t), np.zeros_like(t), 2.0 * np.cos(2 * np.pi * 1.1 * t)))
    w, u = q[:, :1], q[:, 1:]

    def into_S(v):
        uv = np.cross(u, v)
        return v - 2 * w * uv + 2 * np.cross(u, uv)
    g = into_S(np.broadcast_to(GRAVITY_W, a_W.shape))
    return q, into_S(a_W), np.outer(theta_ddt, AXIS), np.outer(theta_dt, AXIS), g


def _writer(path: Path, names: list[str], fmt: str):
    schema = pa.schema([(names[0], pa.int64())] + [(n, pa.float64()) for n in names[1:]])
    if fmt == "parquet":
        return pq.ParquetWriter(path, schema), schema
    return pa_csv.CSVWriter(path, schema, write_options=pa_csv.WriteOptions(quoting_style="none")), schema


def write_synthetic_recording(folder, duration: float, fmt: str = "csv", seed: int = 0) -> Path:
    """Writes the recording's three streams and its YAML into ``folder``; returns the YAML's path."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    names = {"wrench": ["t_us", "fx", "fy", "fz", "tx", "ty", "tz"], "accelerometer": ["t_us", "ax", "ay", "az"],
             "orientation": ["t_us", "qw", "qx", "qy", "qz"]}
    writers = {name: _writer(folder / f"{name}.{fmt}", names[name], fmt) for name in names}
    for start in np.arange(0.0, duration, CHUNK_SECONDS):
        for name, rate in RATES.items():
            first, last = int(np.ceil(start * rate)), int(np.ceil(min(start + CHUNK_SECONDS, duration) * rate))
            t = np.arange(first, last) / rate
            q, a, alpha, omega, g = _motion(t)
            if name == "wrench":
                values = -(noncontact_wrench(PHI, a, alpha, omega, g)
                           + rng.normal(size=(len(t), 6)) * [0.1, 0.1, 0.1, 0.005, 0.005, 0.005])
            elif name == "accelerometer":
                values = a - g + rng.normal(size=(len(t), 3)) * 0.05
            else:
                values = q
            stamps = np.round(t * 1e6).astype(np.int64)
            writer, schema = writers[name]
            columns = [pa.array(stamps)] + [pa.array(values[:, j]) for j in range(values.shape[1])]
            writer.write_table(pa.Table.from_arrays(columns, schema=schema))
    for writer, _ in writers.values():
        writer.close()
    spec = {"wrench": {"file": f"wrench.{fmt}", "time": {"column": "t_us", "unit": "us"},
                       "columns": names["wrench"][1:], "exerted_on": "sensor"},
            "accelerometer": {"file": f"accelerometer.{fmt}", "time": {"column": "t_us", "unit": "us"},
                              "columns": names["accelerometer"][1:], "unit": "m/s^2"},
            "orientation": {"file": f"orientation.{fmt}", "time": {"column": "t_us", "unit": "us"},
                            "kind": "quaternion_wxyz", "columns": names["orientation"][1:]}}
    (folder / "recording.yaml").write_text(yaml.safe_dump(spec, sort_keys=False))
    (folder / "estimate.yaml").write_text(yaml.safe_dump({"phi": PHI.tolist(), "offsets": [0.0] * 6}))
    return folder / "recording.yaml"


def run_compensate(folder: Path, fmt: str, cpu: int) -> dict:
    """`heft compensate` on the recording in ``folder`` as a child process pinned to ``cpu``: its wall
    and CPU time (s), peak resident memory (MB) and its own metrics.json."""
    env = {**os.environ, **{k: "1" for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")}}
    command = [sys.executable, "-m", "heft.diagrams.cli", "compensate", "--recording", str(folder / "recording.yaml"),
               "--estimate", str(folder / "estimate.yaml"), "--out", str(folder / "out"), "--format", fmt]
    started = time.perf_counter()
    child = subprocess.Popen(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                             preexec_fn=lambda: os.sched_setaffinity(0, {cpu}))
    output = child.stdout.read()
    _, status, usage = os.wait4(child.pid, 0)
    wall = time.perf_counter() - started
    child.returncode = os.waitstatus_to_exitcode(status)
    if child.returncode != 0:
        raise RuntimeError(f"heft compensate failed ({child.returncode}): {output.decode()[-2000:]}")
    import json
    metrics = json.loads((folder / "out" / "metrics.json").read_text())
    return {"wall_s": wall, "cpu_s": usage.ru_utime + usage.ru_stime, "peak_rss_MB": usage.ru_maxrss / 1024,
            "metrics": metrics}


def bench(durations, formats, folder, cpu: int, keep: bool = False) -> dict:
    """Runs ``run_compensate`` on a synthetic recording of each duration (s) and format in ``folder``;
    prints a line per run and the one hour at 8 kHz extrapolated from the two longest runs per format
    (CPU time: fixed cost + per-row cost; memory: the runs' peak). Returns every number."""
    import shutil

    results = {}
    print(f"one hour at {RATES['wrench']:g} Hz is {int(3600 * RATES['wrench'])} wrench rows; accelerometer "
          f"{RATES['accelerometer']:g} Hz, orientation {RATES['orientation']:g} Hz; "
          f"heft compensate pinned to CPU {cpu}")
    print("format   duration  wrench rows  CPU s  wall s  rows/s (CPU)  × real time (CPU, wall)  peak RSS MB  input MB")
    for fmt in formats:
        runs = []
        for duration in durations:
            where = Path(folder) / f"{fmt}_{duration:g}s"
            write_synthetic_recording(where, duration, fmt)
            size = sum(f.stat().st_size for f in where.glob(f"*.{fmt}")) / 1e6
            run = run_compensate(where, fmt, cpu)
            m = run["metrics"]
            run.update(duration_s=duration, rows=m["samples"], input_MB=size)
            runs.append(run)
            print(f"{fmt:8s} {duration:7g} s {m['samples']:12d} {run['cpu_s']:6.1f} {run['wall_s']:7.1f} "
                  f"{m['samples'] / run['cpu_s']:13.0f} {duration / run['cpu_s']:10.1f} {duration / run['wall_s']:7.1f}"
                  f"       {run['peak_rss_MB']:10.0f} {size:9.0f}")
            if not keep:
                shutil.rmtree(where)
        results[fmt] = {"runs": [{k: v for k, v in r.items() if k != "metrics"} for r in runs]}
        if len(runs) >= 2:
            a, b = runs[-2], runs[-1]
            per_row = (b["cpu_s"] - a["cpu_s"]) / (b["rows"] - a["rows"])
            fixed = a["cpu_s"] - per_row * a["rows"]
            hour_rows = 3600 * RATES["wrench"]
            hour_cpu = fixed + per_row * hour_rows
            peak = max(r["peak_rss_MB"] for r in runs)
            growth = b["peak_rss_MB"] - a["peak_rss_MB"]
            results[fmt]["hour_extrapolated"] = {"cpu_s": hour_cpu, "real_time_factor": 3600 / hour_cpu,
                                                 "per_row_us": 1e6 * per_row, "fixed_cpu_s": fixed,
                                                 "peak_rss_MB": peak, "rss_growth_MB": growth}
            print(f"{fmt}: one hour extrapolated from the {a['duration_s']:g} s and {b['duration_s']:g} s runs: "
                  f"{1e6 * per_row:.2f} µs per row + {fixed:.1f} s fixed = {hour_cpu:.0f} s CPU, "
                  f"{3600 / hour_cpu:.1f}× real time (target ≥ 20×); peak memory {peak:.0f} MB, "
                  f"{growth:+.0f} MB from the shorter to the longer run (target < 1024 MB)")
    return results
