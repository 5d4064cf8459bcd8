"""The real-time loop of the hardware path: ticks on a monotonic clock, late ticks skipped.

``run_realtime`` calls ``tick(now, dt)`` on the grid t0 + k·period of a monotonic
clock (s): ``now`` is the clock's reading at the tick (s since the loop began),
``dt`` the measured time since the previous tick. It sleeps between ticks, or, if
asked, waits the last part of each period busy (``MAX_DUTY``). A tick that overruns its period
delays the next one by up to half a period (``LATE_TOLERANCE``); grid points it
overran by more are skipped, never replayed, so after a stall the loop resumes at
the next grid point with one tick whose ``dt`` says how long the stall was.
``timing_summary`` turns the measurements into what a lab needs at exit: achieved
rate, skipped ticks, lateness and the tick cost p50/p99. ``claim_realtime`` asks
the OS for real-time scheduling of the loop's process and awake CPUs, ``claim_lab_realtime`` of a process that
plays the lab's drivers beside it.
"""

from __future__ import annotations

import dataclasses
import gc
import math
import os
import signal
import sys
import threading
import time

import numpy as np


LOOP_PRIORITY = 50
"""The control loop's default ``SCHED_FIFO`` priority (`heft teleop`, `heft identify --hardware`)."""
LAB_PRIORITY = 40
"""The default ``SCHED_FIFO`` priority of a process that plays the lab's drivers (`heft stand-in`):
below ``LOOP_PRIORITY``, so that the controller's LCM receive thread, on that process's CPU,
preempts it."""
LATE_TOLERANCE = 0.5
"""A tick may start up to this many periods after its grid point; later than that it is skipped."""
ANCHOR_WINDOW = 0.25
"""A loop that ticks as a message arrives (``run_realtime``'s ``anchor``) waits for it from this share
of a period before its grid point to as long after: a message that arrives elsewhere moves the grid
by up to this share a tick until it arrives inside."""
ANCHOR_SETTLE = 0.1
"""Such a loop ticks this share of a period after the message arrives, so that what its sender
published in the same step has arrived too (``heft stand-in`` publishes the arm's status, then the
master's state and the FT samples: ticking on the status alone, one tick in 25 saw the master's
state of the step before, and the next two new ones, which stalled and jumped the slave command)."""
MAX_DUTY = 0.8
"""A busy wait (``run_realtime``'s ``busy_wait``) shortens so that it and the last tick take at most
this share of a period: a ``SCHED_FIFO`` loop busy beyond Linux's real-time budget (95 % of each
second) is stopped by the kernel for tens of milliseconds (a 4 kHz loop of 190 µs ticks with a
100 µs busy wait: 47 ms stalls and 1–6 watchdog faults in 5 s)."""


CPU_LATENCY_DEVICE = "/dev/cpu_dma_latency"
"""Linux's PM QoS device for the CPUs' wake-up latency: a request holds while its file stays open."""
CPU_WAKE_LATENCY = 0
"""µs a CPU may take to wake while a real-time loop runs (``claim_realtime``): 0 keeps idle CPUs polling,
so that neither the loop's CPU nor the one that receives its commands halts between ticks: a halted virtual
CPU wakes late and cold (docs/benchmarks.md)."""
_cpu_latency_request: int | None = None
"""The open file that holds ``CPU_WAKE_LATENCY`` (None until ``claim_realtime`` opens it)."""


class HardwareRunFailed(RuntimeError):
    """A run against hardware that could not do its job (no hardware, a fault mid-way);
    the hardware station has already put the arm and the master in their safe state."""


@dataclasses.dataclass
class TickTimes:
    """Per-tick measurements (s): wall and CPU time of each ``tick``, its start's lateness after
    its grid point; ``skipped`` grid points, ``elapsed`` wall time of the loop (its start to its
    end: not the garbage collection after it, which took ~0.1 s, 2 % of a 5 s run's rate)."""

    wall: np.ndarray
    cpu: np.ndarray
    lateness: np.ndarray
    skipped: int
    elapsed: float
    period: float


def check_busy_wait(busy_wait: float) -> None:
    """Raises ValueError unless ``busy_wait`` is a share of the period from 0 to ``MAX_DUTY``."""
    if not 0.0 <= busy_wait <= MAX_DUTY:
        raise ValueError(f"the busy wait is a share of the period from 0 to {MAX_DUTY:g}; got {busy_wait}")


def run_realtime(tick, period: float, duration: float, clock=time.perf_counter, sleep=time.sleep,
                 busy_wait: float = 0.0, anchor=None) -> TickTimes:
    """Runs ``tick(now, dt)`` every ``period`` s of ``clock`` for ``duration`` s, or until it
    returns True. ``clock`` must be monotonic (s); ``sleep(s)`` waits, but for the last ``busy_wait``
    of a period (a share, within ``MAX_DUTY``) before each tick, waited busy on ``clock``.

    With ``anchor`` (``anchor(s)``: waits up to s seconds for the message the loop follows, True once
    it has arrived since the last tick, at once if it already has), each tick waits for it from
    ``ANCHOR_WINDOW`` of a period before its grid point to as long after, and the grid moves to the
    tick that it wakes, ``ANCHOR_SETTLE`` of a period later: the loop ticks as that message arrives
    (one tick per message when both run at the same rate), and on its own grid, at most the window
    late, while none comes; a message always waiting (a flood from a second publisher) moves each
    tick to its window's opening, a period of 1 − ``ANCHOR_WINDOW`` + ``ANCHOR_SETTLE``, no shorter.
    Not with ``busy_wait``.

    The cyclic garbage collector is off during the loop (reference counting frees what a tick makes;
    a pass over the heap would stall a tick for milliseconds) and collects once at its end."""
    if not (math.isfinite(period) and period > 0):
        raise ValueError(f"period must be a positive number of seconds; got {period}")
    check_busy_wait(busy_wait)
    if anchor is not None and busy_wait:
        raise ValueError("a loop that ticks as a message arrives does not also wait busy: give one or the other")
    capacity = int(duration / period) + 2
    wall, cpu, lateness = np.empty(capacity), np.empty(capacity), np.empty(capacity)
    window, settle = ANCHOR_WINDOW * period, ANCHOR_SETTLE * period
    gc.collect()
    gc.disable()
    start = clock()
    origin, grid, last, ticks, skipped, busy_before = 0.0, 0, 0.0, 0, 0, 0.0
    try:
        while ticks < capacity:
            due = origin + grid * period
            opens = due - window if anchor is not None else due
            now = clock() - start
            if now < opens:
                if opens - now > busy_before:
                    sleep(opens - now - busy_before)
                if busy_before > 0.0:
                    while clock() - start < due:
                        pass
                now = clock() - start
            if anchor is not None:
                if anchor(max(0.0, due + window - now)):
                    sleep(settle)  # for what its sender published with it
                    now = clock() - start
                    origin += now - due  # the grid follows the message
                else:
                    now = clock() - start
            if now >= duration:
                break
            c0 = time.thread_time()  # a system call: read before the tick's wall time starts
            began = clock() - start
            stop = tick(now, now - last if ticks else 0.0)
            done = clock() - start
            wall[ticks], cpu[ticks], lateness[ticks] = done - began, time.thread_time() - c0, now - due
            busy_before = min(busy_wait * period, max(0.0, MAX_DUTY * period - wall[ticks]))
            ticks += 1
            last = now
            if stop:
                break
            # The next grid point that this tick's end leaves at most LATE_TOLERANCE periods late:
            # the ones before it are skipped.
            following = max(grid + 1, math.ceil((done - origin) / period - LATE_TOLERANCE))
            skipped += following - grid - 1
            grid = following
        elapsed = clock() - start
    finally:
        gc.enable()
        gc.collect()
    return TickTimes(wall[:ticks], cpu[:ticks], lateness[:ticks], skipped, elapsed, period)


class StopOnSignal:
    """While entered, SIGINT (Ctrl-C) and SIGTERM set ``requested`` instead of ending the process,
    so that a loop can stop between two ticks, leave the hardware safe and report."""

    def __init__(self):
        self.requested = False
        self._previous = {}

    def _handle(self, _signum, _frame) -> None:
        self.requested = True

    def __enter__(self) -> StopOnSignal:
        for signum in (signal.SIGINT, signal.SIGTERM):
            self._previous[signum] = signal.signal(signum, self._handle)
        return self

    def __exit__(self, *exc) -> None:
        for signum, handler in self._previous.items():
            signal.signal(signum, handler)


def loop_cpu(cpus: set[int]) -> int:
    """The CPU of ``cpus`` (those a process may run on) that ``claim_realtime`` pins a real-time loop
    to: the last."""
    return max(cpus)


def leave_loop_cpu() -> str:
    """Keeps the calling process (its threads, and every thread started afterwards) off the CPU a
    real-time controller on the same machine claims (``loop_cpu``), for a process that plays the
    lab's drivers beside it (``heft stand-in``, the bench's probe), as the drivers' own computers do
    in a lab. On that CPU the loop's ``SCHED_FIFO`` would preempt it every tick and leave it only
    what the loop does not use, so that it fell behind its clock (measured: docs/design.md, "The
    hardware path"). Call it before opening an LCM bus. Returns what was done; a process allowed on
    one CPU only is left alone."""
    mine = os.sched_getaffinity(0)
    loop = loop_cpu(mine)
    others = mine - {loop}
    if not others:
        return f"on CPU {loop}, the only one it may use, which a real-time controller here would share"
    for task in os.listdir("/proc/self/task"):  # the caller and the threads already started (BLAS's)
        try:
            os.sched_setaffinity(int(task), others)
        except OSError:  # a thread that ended meanwhile
            pass
    return f"off CPU {loop} (a real-time controller's), on CPU " + ", ".join(str(cpu) for cpu in sorted(others))


def _check_priority(priority: int) -> None:
    """Raises ValueError unless ``priority`` is a ``SCHED_FIFO`` priority (1–99) or 0 (normal scheduling)."""
    if not 0 <= priority <= 99:
        raise ValueError(f"real-time priority must be 1–99 (SCHED_FIFO), or 0 for normal scheduling; got {priority}")


def _claim_fifo(priority: int) -> str | None:
    """Asks for ``SCHED_FIFO`` at ``priority`` (1–99) for the calling thread; None if granted, else
    why not and how to grant it."""
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
    except PermissionError:
        return (f"normal scheduling: SCHED_FIFO {priority} was refused (run as root, or allow it with "
                "`ulimit -r` / an rtprio line in /etc/security/limits.conf)")
    return None


def _hold_cpus_awake() -> str:
    """Asks the kernel to keep every CPU out of the idle states that take time to leave, for as long as this
    process runs (a PM QoS request of ``CPU_WAKE_LATENCY`` µs on ``CPU_LATENCY_DEVICE``, as ``cyclictest``
    makes; the kernel drops it when the process ends). Returns what was granted, or why not and how to grant it."""
    global _cpu_latency_request
    if _cpu_latency_request is None:
        try:
            _cpu_latency_request = os.open(CPU_LATENCY_DEVICE, os.O_WRONLY)
            os.write(_cpu_latency_request, CPU_WAKE_LATENCY.to_bytes(4, sys.byteorder, signed=True))
        except OSError as error:
            if _cpu_latency_request is not None:
                os.close(_cpu_latency_request)
                _cpu_latency_request = None
            how = ("run as root, or let the user write it (a udev rule)" if isinstance(error, PermissionError)
                   else "a kernel without PM QoS: ticks may start late after the CPU idles")
            return (f"idle CPUs may sleep deeply: {CPU_LATENCY_DEVICE} refused a wake-up latency of "
                    f"{CPU_WAKE_LATENCY} µs ({error.strerror}; {how})")
    return f"CPUs kept awake between ticks (wake-up latency {CPU_WAKE_LATENCY} µs)"


def claim_realtime(priority: int) -> str:
    """Asks the OS to run the calling thread as a real-time one: ``SCHED_FIFO`` at ``priority``
    (1–99; 0 leaves the scheduling alone), pinned to the last CPU so that other processes
    (the drivers, a stand-in) neither preempt it nor move it between caches, with the CPUs kept
    out of deep idle states while the process runs (``CPU_WAKE_LATENCY``). Threads and
    processes started afterwards inherit the first two: claim it before opening an LCM bus, whose
    receive thread then runs at the loop's priority instead of waiting behind every other
    process for a CPU (``keep_cpu_for_loop`` then moves it to another CPU). Returns what was
    granted, or why not and how to grant it; never raises for a refusal."""
    _check_priority(priority)
    if priority == 0:
        return "normal scheduling (real-time priority 0)"
    cpu = loop_cpu(os.sched_getaffinity(0))
    os.sched_setaffinity(0, {cpu})
    refused, awake = _claim_fifo(priority), _hold_cpus_awake()
    if refused is not None:
        return f"{refused}; ticks may be preempted; {awake}"
    return f"SCHED_FIFO priority {priority} on CPU {cpu}; {awake}"


def claim_lab_realtime(priority: int) -> str:
    """For a process that plays the lab's drivers (``heft stand-in``): ``leave_loop_cpu``, then
    ``SCHED_FIFO`` at ``priority`` (0 leaves the scheduling alone) on the CPUs left, inherited by
    the threads started afterwards, as a lab's drivers run. At normal scheduling on an otherwise
    idle 2-core machine a 0.4 ms sleep overslept up to 1.5 ms; the stand-in's arm, its master
    state late by 2 ms, shook its compliant mount with the stalled, then jumping, command stream
    that answered it. Claim it before opening an LCM bus. Returns what was done and granted."""
    _check_priority(priority)
    placed = leave_loop_cpu()
    if priority == 0:
        return f"{placed}; normal scheduling (real-time priority 0)"
    refused = _claim_fifo(priority)
    if refused is not None:
        return f"{placed}; {refused}: its messages may be late"
    return f"{placed}; SCHED_FIFO priority {priority}"


def keep_cpu_for_loop() -> str:
    """Moves every other thread of this process off the calling (loop) thread's CPU onto the
    remaining ones, with the scheduling they inherited: call it once the LCM buses have their
    subscriptions, whose first starts python-lcm's receive thread. That thread, on the loop's
    CPU with the loop's ``SCHED_FIFO``, added its own load to the loop's; beyond 95 % of the CPU
    together (Linux's ``sched_rt_runtime_us``) the kernel stalled both for the rest of every second
    (20–40 ms: a watchdog fault a second). Returns what was done; a process on one CPU, or not
    pinned, is left alone."""
    mine = os.sched_getaffinity(0)
    others = set(range(os.cpu_count() or 1)) - mine
    if len(mine) != 1 or not others:
        return "the loop shares its CPU with the process's other threads"
    loop = threading.get_native_id()
    moved = 0
    for task in os.listdir("/proc/self/task"):
        if int(task) != loop:
            try:
                os.sched_setaffinity(int(task), others)
                moved += 1
            except OSError:  # a thread that ended meanwhile, or CPUs outside the process's cpuset
                pass
    return (f"CPU {min(mine)} for the loop alone: {moved} other thread(s) (LCM's receive thread) on CPU "
            + ", ".join(str(cpu) for cpu in sorted(others)))


def _percentile_us(values, q) -> float:
    return float(np.percentile(values, q) * 1e6) if len(values) else math.nan


def timing_summary(times: TickTimes) -> dict:
    """Achieved rate (Hz), real-time factor, skipped ticks, max lateness (s), tick wall and
    CPU cost p50/p99 (µs)."""
    ticks = len(times.wall)
    return {
        "wall": times.elapsed,
        "ticks": ticks,
        "achieved_rate_hz": ticks / times.elapsed,
        "realtime_factor": ticks * times.period / times.elapsed,
        "skipped_ticks": times.skipped,
        "max_lateness": float(times.lateness.max()) if ticks else math.nan,
        "lateness_p99_us": _percentile_us(times.lateness, 99),
        "tick_wall_p50_us": _percentile_us(times.wall, 50),
        "tick_wall_p99_us": _percentile_us(times.wall, 99),
        "tick_cpu_p50_us": _percentile_us(times.cpu, 50),
        "tick_cpu_p99_us": _percentile_us(times.cpu, 99),
    }


def format_timing(timing: dict) -> str:
    """One line of ``timing_summary``."""
    return (f"timing: achieved {timing['achieved_rate_hz']:.0f} Hz ({timing['realtime_factor']:.2f}× real time), "
            f"{timing['skipped_ticks']} ticks skipped (start lateness p99 {timing['lateness_p99_us']:.0f} µs, "
            f"max {1e3 * timing['max_lateness']:.1f} ms); "
            f"tick wall p50 {timing['tick_wall_p50_us']:.0f} µs p99 {timing['tick_wall_p99_us']:.0f} µs, "
            f"cpu p50 {timing['tick_cpu_p50_us']:.0f} µs p99 {timing['tick_cpu_p99_us']:.0f} µs")
