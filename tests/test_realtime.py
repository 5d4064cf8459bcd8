"""The real-time loop on a fake monotonic clock: ticks on the grid, a late tick skips the grid
points it overran (never replays them) and reports the measured time since the last tick; and
the CPU a drivers' process leaves to the loop."""

import json
import os
import subprocess
import sys

import pytest

from heft.diagrams.running.realtime import ANCHOR_SETTLE, ANCHOR_WINDOW, MAX_DUTY, run_realtime, timing_summary

from conftest import FakeClock

PERIOD = 0.001


def test_a_stall_skips_the_overrun_ticks_and_the_next_tick_sees_it(fake_clock):
    clock, ticks = fake_clock, []

    def tick(now, dt):
        ticks.append((now, dt))
        clock.t += 0.0001  # the tick's own work
        if len(ticks) == 6:
            clock.t += 0.0036  # this tick stalls: it ends 3.7 ms after it began

    times = run_realtime(tick, PERIOD, 0.0195, clock=clock, sleep=clock.sleep)
    starts = [round(now / PERIOD, 6) for now, _ in ticks]
    assert starts == [0, 1, 2, 3, 4, 5, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19]
    assert times.skipped == 3
    assert ticks[0][1] == 0.0
    assert ticks[6][1] == pytest.approx(0.004) and ticks[7][1] == pytest.approx(PERIOD)
    summary = timing_summary(times)
    assert summary["ticks"] == 17 and summary["skipped_ticks"] == 3


def test_a_small_overrun_delays_the_next_tick_instead_of_skipping_it(fake_clock):
    clock, starts = fake_clock, []

    def tick(now, dt):
        starts.append(now)
        clock.t += 0.0012 if len(starts) == 3 else 0.0001  # the third tick overruns by 0.2 periods

    times = run_realtime(tick, PERIOD, 0.0055, clock=clock, sleep=clock.sleep)
    assert times.skipped == 0
    assert [round(t / PERIOD, 6) for t in starts] == [0, 1, 2, 3.2, 4, 5]


def test_the_rate_is_the_loops_not_counting_the_collection_after_it(fake_clock, monkeypatch):
    """The cyclic garbage collector runs once the loop has ended (0.1 s here): the run's elapsed time
    and so its achieved rate are the loop's own."""
    from heft.diagrams.running import realtime

    clock = fake_clock
    monkeypatch.setattr(realtime.gc, "collect", lambda: setattr(clock, "t", clock.t + 0.1))

    def tick(now, dt):
        clock.t += 0.0001

    times = run_realtime(tick, PERIOD, 0.0195, clock=clock, sleep=clock.sleep)
    summary = timing_summary(times)
    assert summary["ticks"] == 20 and summary["skipped_ticks"] == 0
    assert times.elapsed == pytest.approx(0.02, abs=PERIOD)
    assert summary["achieved_rate_hz"] == pytest.approx(1000.0, rel=0.05)


def test_a_tick_that_asks_to_stop_ends_the_loop(fake_clock):
    clock = fake_clock
    times = run_realtime(lambda now, dt: now >= 0.0045, PERIOD, 1.0, clock=clock, sleep=clock.sleep)
    assert len(times.wall) == 6 and times.skipped == 0


def test_a_busy_wait_takes_the_last_part_of_a_period_within_the_duty_limit():
    clock, sleeps, work = FakeClock(per_read=1e-6), [], [0.0001] * 4 + [0.0007] * 3
    todo = list(work)

    def sleep(seconds):
        sleeps.append(seconds)
        clock.sleep(seconds)

    def tick(now, dt):
        clock.t += todo.pop(0)
        return not todo

    times = run_realtime(tick, PERIOD, 1.0, clock=clock, sleep=sleep, busy_wait=0.4)
    assert len(times.wall) == 7 and times.skipped == 0 and len(sleeps) == 6
    # After a 0.1 ms tick the loop wakes 0.4 periods early and waits busy; after a 0.7 ms tick only
    # MAX_DUTY − 0.7 of a period is left to it; every tick still starts on its grid point.
    busy = [PERIOD - spent - slept for spent, slept in zip(work, sleeps)]
    assert busy == pytest.approx([0.4 * PERIOD] * 4 + [(MAX_DUTY - 0.7) * PERIOD] * 2, abs=2e-5)
    assert max(times.lateness) < 5e-6


def test_a_period_that_is_not_positive_or_a_busy_wait_beyond_the_duty_limit_is_refused():
    with pytest.raises(ValueError, match="period"):
        run_realtime(lambda now, dt: True, 0.0, 1.0)
    with pytest.raises(ValueError, match="busy wait is a share of the period from 0 to 0.8"):
        run_realtime(lambda now, dt: True, 0.001, 1.0, busy_wait=0.9)


class Arrivals:
    """Messages arriving on ``clock`` at the times (s since the loop's start) given; ``wait`` is a
    loop's ``anchor``: it waits on the clock for the next one not yet taken, and takes it."""

    def __init__(self, clock, times):
        self.clock, self.start, self.times = clock, clock.t, list(times)

    def wait(self, seconds):
        now = self.clock.t - self.start
        if self.times and self.times[0] <= now + seconds:
            self.clock.t = self.start + max(now, self.times.pop(0))
            while self.times and self.times[0] <= self.clock.t - self.start:  # two at once: one tick takes both
                self.times.pop(0)
            return True
        self.clock.t += seconds
        return False


def test_a_loop_anchored_to_a_message_ticks_as_it_arrives_and_on_its_own_grid_while_none_does(fake_clock):
    """Messages every period, 0.4 of a period off the loop's grid: the grid moves by the window a tick
    until they arrive inside it, then every tick starts as one arrives. While none arrives the loop
    ticks at its period, the window late; messages that come back half a period off are followed."""
    clock, starts = fake_clock, []
    first = [0.4 * PERIOD + k * PERIOD for k in range(10)]
    later = [15.5 * PERIOD + k * PERIOD for k in range(8)]
    arrivals = Arrivals(clock, first + later)

    def tick(now, dt):
        starts.append(now)
        clock.t += 0.1 * PERIOD

    times = run_realtime(tick, PERIOD, 23.2 * PERIOD, clock=clock, sleep=clock.sleep, anchor=arrivals.wait)
    window, settle = ANCHOR_WINDOW * PERIOD, ANCHOR_SETTLE * PERIOD
    # The first tick waits the window for a message 0.4 periods after its grid point, and ticks the
    # window late; the next three wake at their window's opening, the message already there, and tick
    # the settling time later, the grid following them; from the fourth message on each tick starts
    # the settling time after one arrives.
    assert starts[:4] == pytest.approx([window] + [k * (PERIOD - window + settle) for k in (1, 2, 3)])
    locked = [start for start in starts if start < first[-1] + 0.5 * PERIOD][4:]
    assert len(locked) == 7 and locked == pytest.approx([t + settle for t in first[3:]], abs=1e-12)
    # Silence: on its own period, the window late (the lateness is measured from the grid).
    silent = [start for start in starts if first[-1] + 0.5 * PERIOD < start < later[0] - window]
    assert len(silent) >= 4 and all(b - a == pytest.approx(PERIOD) for a, b in zip(silent, silent[1:]))
    assert max(times.lateness) == pytest.approx(window)
    # The messages come back half a period off the grid the loop kept: followed within two ticks.
    assert starts[-3:] == pytest.approx([t + settle for t in later[-3:]], abs=1e-12)
    assert times.skipped == 0


def test_a_flood_of_the_followed_message_speeds_the_loop_by_a_bounded_share(fake_clock):
    """A message always waiting (a second publisher flooding the arm's channel) moves each tick to its
    window's opening: the loop then ticks every 1 − ANCHOR_WINDOW + ANCHOR_SETTLE periods, no faster."""
    clock, starts = fake_clock, []

    def tick(now, dt):
        starts.append(now)
        clock.t += 0.1 * PERIOD

    run_realtime(tick, PERIOD, 20 * PERIOD, clock=clock, sleep=clock.sleep, anchor=lambda seconds: True)
    spacing = [b - a for a, b in zip(starts, starts[1:])]
    assert spacing == pytest.approx([(1 - ANCHOR_WINDOW + ANCHOR_SETTLE) * PERIOD] * len(spacing))


def test_a_loop_that_follows_a_message_does_not_also_wait_busy():
    with pytest.raises(ValueError, match="one or the other"):
        run_realtime(lambda now, dt: True, PERIOD, 1.0, busy_wait=0.2, anchor=lambda seconds: True)


LEAVE_LOOP_CPU = """
import json, os, threading
from heft.diagrams.running.realtime import leave_loop_cpu
os.sched_setaffinity(0, set(json.loads(os.environ["CPUS"])))
started, done = threading.Event(), threading.Event()
def early():
    started.set()
    done.wait()
    print(json.dumps(sorted(os.sched_getaffinity(0))))
thread = threading.Thread(target=early)
thread.start()
started.wait()
said = leave_loop_cpu()
print(json.dumps(sorted(os.sched_getaffinity(0))))
done.set()
thread.join()
print(said)
"""


@pytest.mark.parametrize("cpus", [[0, 1], [0]])
def test_a_drivers_process_leaves_the_loops_cpu(cpus):
    """``leave_loop_cpu`` moves the process, a thread started before it included, off the CPU that
    ``claim_realtime`` would pin a loop to (the last allowed); a process with one CPU stays."""
    if not set(cpus) <= os.sched_getaffinity(0):
        pytest.skip(f"this machine lets tests use CPUs {sorted(os.sched_getaffinity(0))}")
    run = subprocess.run([sys.executable, "-c", LEAVE_LOOP_CPU], env=dict(os.environ, CPUS=json.dumps(cpus)),
                         capture_output=True, text=True, check=True)
    caller, early, said = run.stdout.splitlines()
    expected = cpus[:-1] or cpus
    assert json.loads(caller) == expected and json.loads(early) == expected, run.stdout
    assert (f"off CPU {cpus[-1]}" in said) == (len(cpus) > 1), said


LAB_CLAIM = """
import json, os, sys, threading
from heft.diagrams.running.realtime import claim_lab_realtime
said = claim_lab_realtime(int(sys.argv[1]))
seen = {}
thread = threading.Thread(target=lambda: seen.update(policy=os.sched_getscheduler(0),
                                                     priority=os.sched_getparam(0).sched_priority))
thread.start()
thread.join()
print(json.dumps({"said": said, "cpus": sorted(os.sched_getaffinity(0)), **seen}))
"""


@pytest.mark.parametrize("priority", [40, 0])
def test_a_drivers_process_runs_real_time_off_the_loops_cpu_and_its_threads_inherit_it(priority):
    """``claim_lab_realtime`` (`heft stand-in --rt-priority`): off the loop's CPU, ``SCHED_FIFO`` at the
    priority asked for a thread started afterwards too, or a refusal that says how to grant it; 0 leaves
    the scheduling normal."""
    run = subprocess.run([sys.executable, "-c", LAB_CLAIM, str(priority)], capture_output=True, text=True,
                         check=True)
    result = json.loads(run.stdout)
    mine = os.sched_getaffinity(0)
    assert result["cpus"] == (sorted(mine - {max(mine)}) or sorted(mine)), result
    if priority and "refused" not in result["said"]:
        assert result["policy"] == os.SCHED_FIFO and result["priority"] == priority, result
        assert result["said"].endswith(f"SCHED_FIFO priority {priority}"), result
    else:
        assert result["policy"] == os.SCHED_OTHER and result["priority"] == 0, result
        assert ("ulimit -r" in result["said"]) == (priority != 0), result


LOOP_CLAIM = """
import json, os, sys
from heft.diagrams.running.realtime import CPU_LATENCY_DEVICE, claim_realtime
said = claim_realtime(int(sys.argv[1]))
print(json.dumps({"said": said, "latency": int.from_bytes(open(CPU_LATENCY_DEVICE, "rb").read(4), sys.byteorder,
                                                          signed=True)}))
"""


@pytest.mark.parametrize("priority", [50, 0])
def test_a_loop_keeps_the_cpus_awake_while_its_process_runs(priority):
    """``claim_realtime`` holds a CPU wake-up latency of ``CPU_WAKE_LATENCY`` (the kernel's PM QoS, read back
    from ``CPU_LATENCY_DEVICE``) until its process ends, or says why it could not; 0 leaves it alone."""
    from heft.diagrams.running.realtime import CPU_LATENCY_DEVICE, CPU_WAKE_LATENCY

    if not os.access(CPU_LATENCY_DEVICE, os.R_OK):
        pytest.skip(f"{CPU_LATENCY_DEVICE} is missing or readable by root only")

    def latency() -> int:
        with open(CPU_LATENCY_DEVICE, "rb") as device:
            return int.from_bytes(device.read(4), sys.byteorder, signed=True)

    before = latency()
    if before <= CPU_WAKE_LATENCY:
        pytest.skip(f"another process holds a wake-up latency of {before} µs already (a real-time loop running)")
    run = subprocess.run([sys.executable, "-c", LOOP_CLAIM, str(priority)], capture_output=True, text=True,
                         check=True)
    result = json.loads(run.stdout)
    if priority == 0:
        assert result == {"said": "normal scheduling (real-time priority 0)", "latency": before}, result
    elif "refused a wake-up latency" in result["said"]:
        assert "run as root" in result["said"] and result["latency"] == before, result
    else:
        assert result["said"].endswith(f"CPUs kept awake between ticks (wake-up latency {CPU_WAKE_LATENCY} µs)")
        assert result["latency"] == CPU_WAKE_LATENCY < before, result
    assert latency() == before  # released with the process


@pytest.mark.parametrize("device, how", [("/sys/devices/system/cpu/online", "run as root, or let the user write it"),
                                         (None, "a kernel without PM QoS")])
def test_a_loop_that_may_not_keep_the_cpus_awake_says_why_and_runs_on(monkeypatch, tmp_path, device, how):
    """A device the process may not write (a read-only sysfs file: refused even to root) or none at all: the
    claim says which, and how to grant it, and holds nothing."""
    from heft.diagrams.running import realtime

    device = device or str(tmp_path / "cpu_dma_latency")
    if device.startswith("/sys") and not os.path.exists(device):
        pytest.skip(f"no {device} here")
    monkeypatch.setattr(realtime, "CPU_LATENCY_DEVICE", device)
    monkeypatch.setattr(realtime, "_cpu_latency_request", None)  # none held in this process
    said = realtime._hold_cpus_awake()
    assert said.startswith(f"idle CPUs may sleep deeply: {device} refused a wake-up latency of 0 µs") and how in said
    assert realtime._cpu_latency_request is None


def test_a_real_time_priority_outside_1_to_99_is_refused_before_anything_changes():
    from heft.diagrams.running.realtime import claim_lab_realtime, claim_realtime

    before = os.sched_getaffinity(0)
    for claim in (claim_realtime, claim_lab_realtime):
        with pytest.raises(ValueError, match="real-time priority must be 1–99"):
            claim(100)
    assert os.sched_getaffinity(0) == before
