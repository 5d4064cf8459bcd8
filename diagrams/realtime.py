"""Running a Simulator against hardware one controller period at a time, timed.

``run_realtime`` advances ``ticks`` periods at real-time rate 1 (one
``AdvanceTo`` per period, so the caller can look at the diagram after each)
and measures every tick: wall and CPU time of the ``AdvanceTo`` and its
lateness against the real-time deadline. ``timing_summary`` turns that into
what a lab needs at exit: achieved rate, deadline misses, tick cost p50/p99.
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np
from pydrake.systems.analysis import Simulator


class HardwareRunFailed(RuntimeError):
    """A run against hardware that could not do its job (no hardware, a fault mid-way);
    the hardware station has already put the arm and the master in their safe state."""


@dataclasses.dataclass
class TickTimes:
    """Per-tick measurements (s): wall and CPU time of each ``AdvanceTo``, lateness of its
    completion after the tick's real-time deadline; ``elapsed`` wall time of the whole run."""

    wall: np.ndarray
    cpu: np.ndarray
    lateness: np.ndarray
    elapsed: float
    period: float


def run_realtime(simulator: Simulator, period: float, ticks: int, on_tick=None) -> TickTimes:
    """Advances ``simulator`` ``ticks`` × ``period`` s from its current time at real-time rate 1,
    calling ``on_tick(k, t)`` after tick k (t: its diagram time, s). Stops early if
    ``on_tick`` returns True."""
    simulator.set_target_realtime_rate(1.0)
    wall, cpu, lateness = np.empty(ticks), np.empty(ticks), np.empty(ticks)
    t0 = simulator.get_context().get_time()
    start = time.perf_counter()
    done = ticks
    for k in range(ticks):
        target = t0 + (k + 1) * period
        c0, w0 = time.thread_time(), time.perf_counter()
        simulator.AdvanceTo(target)
        w1 = time.perf_counter()
        cpu[k], wall[k] = time.thread_time() - c0, w1 - w0
        lateness[k] = (w1 - start) - (target - t0)
        if on_tick is not None and on_tick(k, target):
            done = k + 1
            break
    return TickTimes(wall[:done], cpu[:done], lateness[:done], time.perf_counter() - start, period)


def _percentile_us(values, q) -> float:
    return float(np.percentile(values, q) * 1e6) if len(values) else math.nan


def timing_summary(times: TickTimes) -> dict:
    """Achieved rate (Hz), real-time factor, deadline misses (ticks finished more than one
    period late), max lateness (s), tick wall and CPU cost p50/p99 (µs)."""
    ticks = len(times.wall)
    return {
        "wall": times.elapsed,
        "achieved_rate_hz": ticks / times.elapsed,
        "realtime_factor": ticks * times.period / times.elapsed,
        "deadline_misses": int(np.count_nonzero(times.lateness > times.period)),
        "max_lateness": float(times.lateness.max()) if ticks else math.nan,
        "tick_wall_p50_us": _percentile_us(times.wall, 50),
        "tick_wall_p99_us": _percentile_us(times.wall, 99),
        "tick_cpu_p50_us": _percentile_us(times.cpu, 50),
        "tick_cpu_p99_us": _percentile_us(times.cpu, 99),
    }


def format_timing(timing: dict) -> str:
    """One line of ``timing_summary``."""
    return (f"timing: achieved {timing['achieved_rate_hz']:.0f} Hz ({timing['realtime_factor']:.2f}× real time), "
            f"{timing['deadline_misses']} deadline misses (max lateness {1e3 * timing['max_lateness']:.1f} ms); "
            f"tick wall p50 {timing['tick_wall_p50_us']:.0f} µs p99 {timing['tick_wall_p99_us']:.0f} µs, "
            f"cpu p50 {timing['tick_cpu_p50_us']:.0f} µs p99 {timing['tick_cpu_p99_us']:.0f} µs")
