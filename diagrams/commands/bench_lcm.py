"""`heft bench lcm`: the controller's loop over real LCM between real processes.

Two processes exchange the lab's messages over UDP multicast (the drivers' on
the LCM URL, the controller's on the command URL): ``heft teleop --hardware``
(the controller at the rate under test) and a *probe*
playing the three drivers at their nominal rates (master and slave state at
2 kHz, wrist sensor at 8 kHz, buffered as the stand-in's: its samples since the
last arm state in one ``heft_ft_samples``) with fixed joint positions, real-time as
``heft stand-in`` runs them (``claim_lab_realtime``). Every
``STEP_PERIOD`` s the probe steps the sensor's force by ``STEP_FORCE``, sends the
samples so far at once, and stamps the wall-clock time right after publishing
them (on loopback the kernel has delivered them by then); the kernel stamps the arrival of
every master torque command on the probe's socket (so the probe's own
scheduling does not delay it). The latency of a step is the time from that
publish to the receipt of the first command that has moved half-way to its new
level: LCM both ways, the receiver's sampling, the controller's ticks and the
watchdog-gated sender. A step stamped more than ``PROBE_LATE`` after it was due
had the probe preempted around its publish; it is left out and counted. The controller reports the
loop rate it sustained and its tick cost. Each rate runs twice, the load estimate fixed and
learned online (``ONLINE``): the probe's accelerometer swings (``PROBE_ACCELERATION``) so that
the estimator's gate opens, and its learning window outlasts the run so that the sensor's steps
never close it: the estimator updates on every tick, its worst case. Where it may (root, ``ip``),
the bench runs both processes in a private network namespace so no packet leaves the machine. On a
virtual machine, each row says how long the hypervisor took each CPU away meanwhile (``cpu_steal_ms``),
which a tick or a message then waited out.
"""

from __future__ import annotations

import argparse
import json
import os
import select
import shutil
import socket
import struct
import subprocess
import sys
import tempfile
import time
import uuid
from pathlib import Path

import numpy as np

STEP_PERIOD = 0.1
"""Seconds between sensor force steps."""
STEP_FORCE = 20.0
"""Size of the sensor force step (N, along the sensor's z)."""
SETTLE = 1.5
"""Seconds of traffic before the first step (start guard and torque ramp)."""
PROBE_LATE = 0.001
"""A step published this much (s) after it was due had the probe preempted around its publish."""
PROBE_ACCELERATION = (3.0, 2.0)
"""The probe's accelerometer adds a horizontal acceleration of this magnitude (m/s²) turning at this
rate (Hz) to its reading at rest, so that the online estimator's gate (``min_excitation``) opens."""
CONTROLLER_START = 120.0
"""Seconds the probe, publishing, waits for the controller's first command: the controller's start, which on a
first run after an install or a change compiles its kernels (about a minute on a slow 2-core machine)."""
ESTIMATORS = ("fixed", "online")
ONLINE = {"controller.estimator.mode": "online", "controller.estimator.learning_window": 1e9}
"""The online estimator as benched: contact never judged, so that every excited tick updates it."""


def cpu_steal_ms(stat: str) -> dict[str, float]:
    """Per CPU (``cpu0``, ``cpu1``, …), the time (ms) the hypervisor ran something else while the CPU had work, since
    boot: the eighth number of its line in ``/proc/stat`` (``stat``: that file's text), in clock ticks
    (``SC_CLK_TCK``); empty where the kernel counts no steal (fewer fields)."""
    tick_ms = 1e3 / os.sysconf("SC_CLK_TCK")
    steal = {}
    for line in stat.splitlines():
        fields = line.split()
        if fields and fields[0].startswith("cpu") and fields[0] != "cpu" and len(fields) > 8:
            steal[fields[0]] = int(fields[8]) * tick_ms
    return steal


def _steal_since(before: dict[str, float]) -> dict[str, float]:
    """The steal (ms per CPU, ``cpu_steal_ms``) since ``before`` (the same, read earlier)."""
    now = cpu_steal_ms(Path("/proc/stat").read_text())
    return {cpu: now[cpu] - before[cpu] for cpu in before if cpu in now}


def run_probe(channels, duration: float, out: Path, master_q, slave_q) -> None:
    """Plays the drivers on ``channels`` (``LcmChannels``: publishing on ``lcm_url``, hearing the
    commands on the command URL) from when the first master command arrives (at most ``CONTROLLER_START`` s
    of waiting) until the commands stop for 1 s or ``duration`` s have passed, and writes {step
    publish times, command receipt times and torques} to ``out``."""
    import lcm
    from drake import lcmt_iiwa_status

    from heft.diagrams.running.realtime import LAB_PRIORITY, claim_lab_realtime
    from heft.hardware_interface.ft_messages import pack_samples
    from heft.hardware_interface.lcmtypes import heft_ft_sample, heft_haptic_command, heft_haptic_state

    claim_lab_realtime(LAB_PRIORITY)  # as the drivers' computers run: off the controller's CPU, real-time
    bus = lcm.LCM(channels.lcm_url)
    commands = _TimestampedReceiver(channels.command_lcm_url(), channels.master_command.name)
    receipts, torques = [], []
    master = heft_haptic_state()
    master.num_joints, master.position, master.velocity = 6, list(master_q), [0.0] * 6
    master.torque_applied = [0.0] * 6
    slave = lcmt_iiwa_status()
    slave.num_joints, slave.joint_position_measured = len(slave_q), list(slave_q)  # the scenario's arm's joints
    for field in ("joint_velocity_estimated", "joint_position_commanded", "joint_position_ipo",
                  "joint_torque_measured", "joint_torque_commanded", "joint_torque_external"):
        setattr(slave, field, [0.0] * len(slave_q))
    ft = heft_ft_sample()
    ft.acceleration = [0.0, 0.0, -9.81, 0.0, 0.0, 0.0]  # at rest: one g up, S's z points down at the start pose
    streams = [(channels.master_state, master), (channels.slave_status, slave), (channels.ft_sample, ft)]
    periods = [1.0 / channel.rate for channel, _ in streams]
    due = [0.0] * len(streams)
    start = time.time()
    first_command, steps, stepped = None, [], False
    counter, pending = 0, []  # FT samples not yet sent: a message holds ``per_message``
    per_message = max(1, round(channels.ft_sample.rate / channels.slave_status.rate))
    while True:
        now = time.time()
        if first_command is None and receipts:
            first_command = receipts[0]
        if first_command is None and now - start > CONTROLLER_START:
            raise SystemExit(f"probe: no master command within {CONTROLLER_START:g} s: is `heft teleop --hardware` "
                             "running?")
        if first_command is not None and (now - first_command > duration or now - receipts[-1] > 1.0):
            break
        for i, ((channel, msg), period) in enumerate(zip(streams, periods)):
            if now - start < due[i]:
                continue
            due[i] += period
            utime = int((now - start) * 1e6)
            if msg is ft:
                counter += 1
                magnitude, frequency = PROBE_ACCELERATION
                angle = 2 * np.pi * frequency * (now - start)
                msg.acceleration[0], msg.acceleration[1] = magnitude * np.cos(angle), magnitude * np.sin(angle)
                level = (first_command is not None and now - first_command > SETTLE
                         and int((now - first_command - SETTLE) / STEP_PERIOD) % 2 == 1)
                msg.wrench = [0.0, 0.0, STEP_FORCE if level else 0.0, 0.0, 0.0, 0.0]
                pending.append((utime, counter, msg.wrench, list(msg.acceleration)))
                if level != stepped or len(pending) == per_message:
                    utimes, counters, wrenches, accelerations = zip(*pending)
                    bus.publish(channel.name, pack_samples(utimes, counters, sum(wrenches, []),
                                                           sum(accelerations, []), [0] * len(pending),
                                                           [False] * len(pending)))
                    pending = []
                if level != stepped:
                    # Stamped once published (the kernel has delivered it by then), with the time
                    # it was due, so that a probe preempted meanwhile can be told apart.
                    steps.append((time.time(), 1.0 if level else -1.0, now))
                    stepped = level
                continue
            else:
                msg.utime = utime
            bus.publish(channel.name, msg.encode())
        wait = max(0.0, min(d - (time.time() - start) for d in due))
        if select.select([commands.fileno()], [], [], wait)[0]:
            for arrival, payload in commands.take():
                receipts.append(arrival)
                torques.append(heft_haptic_command.decode(payload).torque)
    out.write_text(json.dumps({"steps": steps, "receipts": receipts, "torques": torques}))


class _TimestampedReceiver:
    """The messages of one LCM channel on a udpm:// URL, each with the time (s, CLOCK_REALTIME)
    the kernel received it, so that the probe's own scheduling does not delay the stamp.
    Reads LCM's single-datagram packets: magic "LC02", sequence number, channel, NUL, payload."""

    _MAGIC = 0x4C433032
    _SO_TIMESTAMPNS = getattr(socket, "SO_TIMESTAMPNS", 35)  # Linux

    def __init__(self, lcm_url: str, channel: str):
        address = lcm_url.removeprefix("udpm://").split("?")[0]
        group, port = address.rsplit(":", 1)
        self._channel = channel.encode()
        self._socket = socket.socket(socket.AF_INET, socket.SOCK_DGRAM, socket.IPPROTO_UDP)
        self._socket.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self._socket.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEPORT, 1)
        self._socket.bind(("", int(port)))
        self._socket.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP,
                                struct.pack("4s4s", socket.inet_aton(group), socket.inet_aton("0.0.0.0")))
        self._socket.setsockopt(socket.SOL_SOCKET, self._SO_TIMESTAMPNS, 1)
        self._socket.setblocking(False)

    def fileno(self) -> int:
        return self._socket.fileno()

    def take(self) -> list[tuple[float, bytes]]:
        """(arrival time, payload) of every message of the channel waiting on the socket."""
        messages = []
        while True:
            try:
                data, ancillary, _, _ = self._socket.recvmsg(65536, socket.CMSG_SPACE(16))
            except BlockingIOError:
                return messages
            if len(data) < 9 or struct.unpack_from(">I", data)[0] != self._MAGIC:
                continue
            end = data.index(b"\0", 8)
            if data[8:end] != self._channel:
                continue
            for level, kind, value in ancillary:
                if level == socket.SOL_SOCKET and kind == self._SO_TIMESTAMPNS:
                    seconds, nanoseconds = struct.unpack("qq", value[:16])
                    messages.append((seconds + 1e-9 * nanoseconds, data[end + 1:]))


def step_latencies(steps, receipts, torques) -> np.ndarray:
    """Latency (s) of each force step (one per step, ``steps[i][0]`` its publish time): to the
    receipt of the first command whose torque has covered half of the change from before the
    step to just before the next; NaN where that cannot be seen (no command before or after, a
    torque change below 1e-4 N·m, or half-way never reached)."""
    receipts, torques = np.asarray(receipts), np.asarray(torques)
    times = [step[0] for step in steps]
    latencies = np.full(len(steps), np.nan)
    for i, (t_step, t_next) in enumerate(zip(times, times[1:] + [np.inf])):
        before = np.flatnonzero(receipts < t_step)
        after = np.flatnonzero((receipts >= t_step) & (receipts < t_next))
        if before.size == 0 or after.size < 2:
            continue
        start, end = torques[before[-1]], torques[after[-1]]
        change = end - start
        if np.linalg.norm(change) < 1e-4:
            continue
        progress = (torques[after] - start) @ change / (change @ change)
        reached = after[np.flatnonzero(progress >= 0.5)]
        if reached.size:
            latencies[i] = receipts[reached[0]] - t_step
    return latencies


def _namespace():
    """(prefix for commands, cleanup) for a private network namespace, or ([], no-op) if unavailable."""
    if os.geteuid() != 0 or shutil.which("ip") is None:
        return [], lambda: None
    name = f"heft_bench_{uuid.uuid4().hex[:8]}"
    if subprocess.run(["ip", "netns", "add", name], capture_output=True).returncode != 0:
        return [], lambda: None
    subprocess.run(["ip", "netns", "exec", name, "ip", "link", "set", "lo", "up"], check=True)
    subprocess.run(["ip", "netns", "exec", name, "ip", "route", "add", "224.0.0.0/4", "dev", "lo"], check=True)
    return ["ip", "netns", "exec", name], lambda: subprocess.run(["ip", "netns", "del", name], capture_output=True)


def _wait_for_line(process: subprocess.Popen, start: str, timeout: float) -> str:
    """Reads ``process``'s output (a pipe, read here unbuffered so that ``communicate`` later gets
    the rest) until a line begins with ``start``; returns what it read. Raises RuntimeError with
    that output if the process ends first or ``timeout`` s pass."""
    read, deadline, fd = b"", time.monotonic() + timeout, process.stdout.fileno()
    while time.monotonic() < deadline:
        if select.select([fd], [], [], 0.1)[0]:
            chunk = os.read(fd, 65536)
            read += chunk
            if any(line.startswith(start.encode()) for line in read.split(b"\n")[:-1]):
                return read.decode(errors="replace")
            if not chunk:
                break
    process.kill()
    raise RuntimeError(f"no line beginning {start!r} within {timeout:g} s:\n{read.decode(errors='replace')}")


def _finish(processes: dict, already: dict | None = None) -> None:
    """Waits for each {label: (Popen, timeout s)} in turn, killing one still running after its timeout; raises
    with every process's output (after what ``already`` {label: text} holds of it) if one failed or was killed."""
    outputs = dict(already or {})
    try:
        for label, (process, timeout) in processes.items():
            try:
                rest, _ = process.communicate(timeout=timeout)
            except subprocess.TimeoutExpired:
                process.kill()
                rest = process.communicate()[0] + f"\n(killed: still running {timeout:g} s after the ones before it)"
            outputs[label] = outputs.get(label, "") + rest
    finally:
        for process, _ in processes.values():
            if process.poll() is None:
                process.kill()
    if any(process.returncode != 0 for process, _ in processes.values()):
        raise RuntimeError("bench processes failed:\n" + "\n".join(f"--- {label}\n{output}"
                                                                  for label, output in outputs.items()))


def _url_arguments(channels) -> list[str]:
    """The command-line options that put a `heft` subcommand on ``channels``' two URLs."""
    return ["--lcm-url", channels.lcm_url, "--command-url", channels.command_lcm_url()]


def bench_rate(rate_hz: float, duration: float, channels, scenario: str, folder: Path, prefix,
               estimator: str = "fixed", busy_wait: float = 0.0, view: bool = False) -> dict:
    """One controller rate with the load ``estimator`` "fixed" or "online" (``ONLINE``), its loop's
    ``busy_wait`` and, if ``view``, the live view fed (``heft teleop --view``; no client): both processes, then
    the latency statistics and the controller's timing."""
    import yaml

    from heft.diagrams.commands.options import lab_settings_text
    from heft.diagrams.scenario import overrides_text, resolve_scenario

    loaded = resolve_scenario(scenario)
    settings = yaml.safe_load(lab_settings_text(loaded))
    if estimator == "online":
        online = yaml.safe_load(overrides_text(ONLINE))
        settings["controller"] = {**settings.get("controller", {}), **online["controller"]}
    summary_folder = folder / f"teleop_{rate_hz:g}_{estimator}"
    probe_path = folder / f"probe_{rate_hz:g}_{estimator}.json"
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", PYTHONUNBUFFERED="1")
    python = [*prefix, sys.executable]
    steal = cpu_steal_ms(Path("/proc/stat").read_text())
    teleop = subprocess.Popen(
        [*python, "-m", "heft.diagrams.cli", "teleop", "--hardware", *_url_arguments(channels), "--scenario", scenario,
         "--set", yaml.safe_dump(settings, default_flow_style=True), "--rate", str(rate_hz),
         "--busy-wait", str(busy_wait), "--duration", str(duration + SETTLE),
         "--out", str(summary_folder), *(["--view"] if view else [])],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=env, text=True)
    probe = subprocess.Popen(
        [*python, "-m", "heft.diagrams.commands.bench_lcm", "--probe", channels.lcm_url, channels.command_lcm_url(),
         str(20 * (duration + SETTLE)),
         str(probe_path),
         json.dumps(loaded.master_initial_q), json.dumps(loaded.slave_initial_q)],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=env, text=True)
    _finish({"teleop": (teleop, 20 * (duration + SETTLE) + 120), "probe": (probe, 30)})
    steal = _steal_since(steal)
    measured = json.loads(probe_path.read_text())
    # A step stamped more than PROBE_LATE after it was due had the probe preempted around its
    # publish: the stamp may then be later than the delivery, so its latency is left out, and counted.
    steps = measured["steps"]
    on_time = np.array([step[0] - step[2] <= PROBE_LATE for step in steps], dtype=bool)
    latencies = step_latencies(steps, measured["receipts"], measured["torques"])
    latencies = latencies[on_time & np.isfinite(latencies)]
    summary = json.loads((summary_folder / "teleop.json").read_text())
    timing = summary["timing"]
    receipts = np.asarray(measured["receipts"])
    learned = summary["estimator"].get("samples_since_new_load", 0)
    return {
        "rate_hz": rate_hz,
        "estimator": estimator,
        "estimator_updates_per_tick": learned / max(summary["ticks"], 1),
        "steps": len(measured["steps"]),
        "steps_published_late": int((~on_time).sum()),
        "latency_samples": int(latencies.size),
        "latency_p50_ms": float(np.percentile(latencies, 50) * 1e3) if latencies.size else None,
        "latency_p99_ms": float(np.percentile(latencies, 99) * 1e3) if latencies.size else None,
        "latency_max_ms": float(latencies.max() * 1e3) if latencies.size else None,
        "controller_faults": summary["faults"],
        "commands_received_hz": float((receipts.size - 1) / (receipts[-1] - receipts[0])) if receipts.size > 1
        else 0.0,
        "controller": timing,
        "steal_ms": steal,
    }


def bench_stand_in(rate_hz: float, duration: float, channels, scenario: str, folder: Path, prefix,
                   busy_wait: float = 0.0) -> dict:
    """The controller (``heft teleop --hardware``) at ``rate_hz`` (its loop's ``busy_wait``) against
    ``heft stand-in`` for ``duration`` s of wall time: messages per wall second each way, as each side counted
    them, and the controller's summary."""
    from heft.diagrams.commands.options import lab_settings_text
    from heft.diagrams.scenario import resolve_scenario

    teleop_folder, stand_in_folder = folder / "teleop_stand_in", folder / "stand_in"
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", PYTHONUNBUFFERED="1")
    cli = [*prefix, sys.executable, "-m", "heft.diagrams.cli"]
    stand_in = subprocess.Popen(
        [*cli, "stand-in", "--scenario", scenario, *_url_arguments(channels), "--duration", str(duration + 4 * SETTLE),
         "--out", str(stand_in_folder)], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=env, text=True)
    # The controller's run starts once the lab publishes, so that all of it counts.
    started = _wait_for_line(stand_in, "stand-in: publishing", 120.0)
    teleop = subprocess.Popen(
        [*cli, "teleop", "--hardware", *_url_arguments(channels), "--scenario", scenario,
         "--set", lab_settings_text(resolve_scenario(scenario)), "--rate", str(rate_hz),
         "--busy-wait", str(busy_wait), "--duration", str(duration),
         "--out", str(teleop_folder)],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=env, text=True)
    _finish({"teleop": (teleop, duration + 120), "stand-in": (stand_in, duration + 120)}, {"stand-in": started})
    summary = json.loads((teleop_folder / "teleop.json").read_text())
    lab = json.loads((stand_in_folder / "stand_in.json").read_text())
    # The controller ran inside the stand-in's run: its commands per second of its own run.
    lab["received_hz_while_controlled"] = {name: count / summary["duration"]
                                           for name, count in lab["received"].items()}
    return {"rate_hz": rate_hz, "stand_in": lab,
            "controller": {key: summary[key] for key in ("sent_hz", "received_hz", "healthy_ticks", "ticks",
                                                          "faults", "timing", "scheduling", "rejected",
                                                          "second_publishers")}}


def _print_stand_in(result: dict) -> None:
    lab, controller = result["stand_in"], result["controller"]
    print(f"stand-in lab, controller at {result['rate_hz']:g} Hz ({controller['scheduling']}): messages per "
          "wall-clock second, as the stand-in counted them")
    print(f"{'channel':>22s}{'published':>11s}{'received':>10s}")
    for name, hz in lab["published_hz"].items():
        print(f"{name:>22s}{hz:11.0f}{'':>10s}")
    for name, hz in lab["received_hz_while_controlled"].items():
        print(f"{name:>22s}{'':>11s}{hz:10.0f}")
    print(f"controller: received {', '.join(f'{k} {v:.0f}' for k, v in controller['received_hz'].items())}; "
          f"sent {', '.join(f'{k} {v:.0f}' for k, v in controller['sent_hz'].items())}; healthy "
          f"{controller['healthy_ticks']} of {controller['ticks']} ticks; {len(controller['faults'])} faults")


def run(rates, duration: float, scenario: str, channels, busy_wait: float = 0.0, view: bool = False) -> dict:
    """Benchmarks every rate in ``rates`` (Hz) against the probe, then the first against the
    stand-in, the controller's loop waiting ``busy_wait`` of each period busy and feeding the live view if
    ``view``; prints tables; returns the numbers."""
    prefix, cleanup = _namespace()
    where = "a private network namespace" if prefix else "this host's network"
    print(f"bench lcm: controller (heft teleop --hardware) and driver probe as two processes on {channels.lcm_url} "
          f"(commands on {channels.command_lcm_url()}), in "
          f"{where}; {duration:g} s per rate, a {STEP_FORCE:g} N sensor step every {STEP_PERIOD:g} s"
          + (f"; the controller waits the last {busy_wait:g} of each period busy" if busy_wait else "")
          + ("; the controller feeds the live view (heft teleop --view)" if view else ""), flush=True)
    results = []
    try:
        with tempfile.TemporaryDirectory() as folder:
            for rate in rates:
                for estimator in ESTIMATORS:
                    results.append(bench_rate(rate, duration, channels, scenario, Path(folder), prefix, estimator,
                                              busy_wait, view))
            stand_in = bench_stand_in(rates[0], duration, channels, scenario, Path(folder), prefix, busy_wait)
    finally:
        cleanup()
    print(f"{'rate (Hz)':>10s}{'estimator':>10s}{'sustained (Hz)':>16s}{'ratio':>7s}{'skipped':>9s}"
          f"{'late max (ms)':>15s}{'tick wall p50/p99 (µs)':>24s}"
          f"{'cpu p50/p99 (µs)':>18s}{'commands (Hz)':>15s}{'latency p50/p99 (ms)':>22s}{'faults':>8s}")
    for r in results:
        c = r["controller"]
        latency = ("n/a" if r["latency_p50_ms"] is None
                   else f"{r['latency_p50_ms']:.2f} / {r['latency_p99_ms']:.2f}")
        if r["steps_published_late"]:
            latency += f" ({r['steps_published_late']} late)"
        print(f"{r['rate_hz']:10.0f}{r['estimator']:>10s}{c['achieved_rate_hz']:16.0f}"
              f"{c['achieved_rate_hz'] / r['rate_hz']:7.2f}{c['skipped_ticks']:9d}{1e3 * c['max_lateness']:15.2f}"
              f"{c['tick_wall_p50_us']:>13.0f} / {c['tick_wall_p99_us']:<8.0f}"
              f"{c['tick_cpu_p50_us']:>9.0f} / {c['tick_cpu_p99_us']:<6.0f}"
              f"{r['commands_received_hz']:15.0f}{latency:>22s}{len(r['controller_faults']):8d}")
        for fault in r["controller_faults"]:  # a stale channel or a stalled loop, with the ages then
            print(f"{'':10s}fault at {fault['onset']:.4f} s: bits {fault['fault_bits']}, ages {fault['ages_ms']} ms, "
                  f"recovered {fault['recovered']}")
        if any(r["steal_ms"].values()):  # a virtual machine's CPUs taken away meanwhile: outliers to expect
            stolen = ", ".join(f"{ms:.0f} ms of {cpu}" for cpu, ms in r["steal_ms"].items())
            print(f"{'':10s}the hypervisor took {stolen} during this row's run")
    for fixed, online in zip(results[::2], results[1::2]):
        costs = "; ".join(f"{name} {online['controller'][key]:.0f} against {fixed['controller'][key]:.0f} µs "
                          f"(× {online['controller'][key] / fixed['controller'][key]:.2f})"
                          for name, key in (("tick wall p50", "tick_wall_p50_us"), ("p99", "tick_wall_p99_us"),
                                            ("cpu p50", "tick_cpu_p50_us"), ("p99", "tick_cpu_p99_us")))
        rate, updated = fixed["rate_hz"], 100 * online["estimator_updates_per_tick"]
        print(f"estimator online at {rate:g} Hz (updated on {updated:.0f} % of ticks), against fixed: {costs}")
    _print_stand_in(stand_in)
    return {"duration_s": duration, "network": where, "busy_wait": busy_wait, "view": view, "results": results,
            "stand_in": stand_in}


if __name__ == "__main__":
    arguments = argparse.ArgumentParser(description="the driver probe of `heft bench lcm`")
    arguments.add_argument("--probe", nargs=6, metavar=("URL", "COMMAND_URL", "DURATION", "OUT", "MASTER_Q", "SLAVE_Q"),
                           required=True)
    probe_args = arguments.parse_args().probe
    from heft.hardware_interface.channels import LcmChannels

    run_probe(LcmChannels(lcm_url=probe_args[0], command_url=probe_args[1]), float(probe_args[2]),
              Path(probe_args[3]), json.loads(probe_args[4]), json.loads(probe_args[5]))
