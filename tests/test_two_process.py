"""`heft stand-in` and `heft teleop --hardware` as two processes over LCM UDP multicast.

Both run inside a network namespace this test creates (only its own `lo`, with
the multicast route on it) on ``udpm://239.255.76.67:7667?ttl=0``, so no packet
can leave the machine (docs/design.md §5). Needs root and `ip`; skipped otherwise.
No assertion here depends on how fast the machine is: each process is waited for by
what it prints when it is up ("stand-in: publishing", "teleop: running"), the controller
runs until the test has seen what it needs and then stops it with SIGTERM (it stops as at
the end of its duration: forces off, slave held, summary written); the rates and delays
are printed, and measured by `heft bench lcm`.
"""

import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import lcm
import numpy as np
import pytest
import yaml
from heft.diagrams.arm_params import BUNDLED_ARMS
from heft.diagrams.cli import main
from heft.diagrams.commands.options import lab_settings_text
from heft.diagrams.device_limits import device_limits
from heft.diagrams.scenario import overrides_text, resolve_scenario
from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.hardware_station import HardwareStationParams

pytestmark = pytest.mark.slow

LCM_URL = "udpm://239.255.76.67:7667?ttl=0"
STARTUP_TIMEOUT = 60.0
RUN_TIMEOUT = 120.0
FOREVER = "1000"
"""--duration of a process that the test stops itself (s)."""
MIN_HEALTHY_SHARE = 0.5
"""The share of its ticks a controller run must have stepped healthy for its counts to be judged."""
STAND_IN_SENSOR = lab_settings_text(resolve_scenario("fig6"))  # the stand-in's sensor, stated as a lab states its own
ARMS = tuple(BUNDLED_ARMS)
"""The bundled arms, each the slave of a lab in the tests parametrized over them."""
FORCES_OFF_MS = 25.0
"""The latest (ms after the lab's last message) the forces may go off: the watchdog's 20 ms timeout, a tick,
and a message or two lost before the lab went silent."""


class _Process:
    """A `heft` subcommand inside the namespace (`heft stand-in` claims real-time scheduling itself, as
    a lab's drivers run); output to a file in ``folder``."""

    def __init__(self, ns, folder, label, *args, script=None):
        self.log = folder / f"{label}.log"
        env = dict(os.environ, OPENBLAS_NUM_THREADS="1", PYTHONUNBUFFERED="1")
        program = [script] if script else ["-m", "heft.diagrams.cli"]
        with open(self.log, "w") as out:
            self.popen = subprocess.Popen(
                ["ip", "netns", "exec", ns, sys.executable, *program, *args],
                stdout=out, stderr=subprocess.STDOUT, cwd=folder, env=env)

    def text(self) -> str:
        return self.log.read_text()

    def wait_for(self, marker: str, timeout: float = STARTUP_TIMEOUT):
        deadline = time.monotonic() + timeout
        while marker not in self.text():
            assert self.popen.poll() is None, f"exited early:\n{self.text()}"
            assert time.monotonic() < deadline, f"no {marker!r} within {timeout} s:\n{self.text()}"
            time.sleep(0.05)

    def wait(self, timeout: float = RUN_TIMEOUT) -> int:
        return self.popen.wait(timeout=timeout)

    def finish(self) -> int:
        """Asks it to stop (SIGTERM: `ip netns exec` passes it on) and waits for it."""
        self.popen.send_signal(signal.SIGTERM)
        return self.wait()

    def stop(self):
        if self.popen.poll() is None:
            self.popen.terminate()
            try:
                self.popen.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.popen.kill()
                self.popen.wait()


def _teleop(netns, folder, *args, label="teleop", settings=STAND_IN_SENSOR):
    """The controller with ``settings`` (``--set``), running (its loop started) until the test
    stops it; its summary goes to ``folder / label / "teleop.json"``."""
    teleop = _Process(netns, folder, label, "teleop", "--hardware", "--lcm-url", LCM_URL, "--set", settings,
                      "--duration", FOREVER, "--out", str(folder / label), *args)
    teleop.wait_for("teleop: running")
    return teleop


def _stand_in(netns, folder, *args, label="stand_in"):
    """The stand-in, publishing."""
    stand_in = _Process(netns, folder, label, "stand-in", "--scenario", "fig6", "--lcm-url", LCM_URL, *args)
    stand_in.wait_for("stand-in: publishing")
    return stand_in


def _with_arm(robot: str, settings: str = STAND_IN_SENSOR) -> str:
    """``settings`` (YAML) with the slave ``robot``, which brings its own start posture and motion scale."""
    return yaml.safe_dump(layered_dict(yaml.safe_load(settings), {"robot": robot}), default_flow_style=True)


def forces_went_off(summary: dict) -> float:
    """Asserts that a controller whose lab died went healthy first, then faulted for good with every channel stale,
    its forces off within ``FORCES_OFF_MS`` of the last message it accepted, every torque it sent finite; returns
    that time (ms)."""
    assert summary["first_healthy"] is not None, "the watchdog never became healthy"
    assert summary["faults"] and summary["faults"][-1]["recovered"] is None, summary["faults"]
    assert summary["final_fault_bits"] == 0b111, "every channel of the dead lab should be stale"
    off = max(summary["faults"][-1]["ages_ms"])
    assert off <= FORCES_OFF_MS, off
    assert not summary["final_healthy"] and summary["master_torque_finite"]
    return off


def _summary(teleop, folder, label="teleop") -> dict:
    """Stops the controller and returns its summary."""
    assert teleop.finish() == 0, teleop.text()
    print(teleop.text())
    return json.loads((folder / label / "teleop.json").read_text())


def _stop_all(*processes):
    for process in processes:
        if process is not None:
            process.stop()


def test_controller_runs_against_the_stand_in(netns, tmp_path):
    log = tmp_path / "traffic.lcmlog"
    stand_in = teleop = None
    try:
        stand_in = _stand_in(netns, tmp_path, "--duration", FOREVER, "--clutch-at", "1.0")
        teleop = _teleop(netns, tmp_path, "--record", str(log))
        time.sleep(3.0)
        summary = _summary(teleop, tmp_path)
    finally:
        _stop_all(teleop, stand_in)
    assert summary["stopped_by_signal"]
    assert summary["first_healthy"] is not None, "the watchdog never became healthy"
    assert summary["healthy_ticks"] > 0.5 * summary["ticks"], teleop.text()
    assert summary["master_torque_finite"]
    assert not any(summary["rejected"].values()) and not summary["second_publishers"], summary["rejected"]
    # The recorded traffic is an LCM log with every channel of both sides.
    counts = {}
    for event in lcm.EventLog(str(log), "r"):
        counts[event.channel] = counts.get(event.channel, 0) + 1
    channels = LcmChannels()
    for channel in (channels.master_state, channels.master_command, channels.slave_status, channels.slave_command,
                    channels.ft_sample):
        assert counts.get(channel.name, 0) > 100, counts


@pytest.mark.parametrize("robot", ARMS)
def test_the_controller_diagram_steps_in_the_real_time_loop_against_the_stand_in(netns, tmp_path, robot):
    """`heft teleop --hardware` (the controller Diagram's program, as `heft bench lcm` measures it) against the
    stand-in, both on each bundled arm (its status and commands in its own joints, the iiwa's 7): it goes healthy,
    rejects nothing, the lab receives about a command per arm step while it runs and refuses none, and the forces
    it renders stay within the Phantom's 8.5 N."""
    teleop = stand_in = None
    seconds = 3.0
    try:
        teleop = _teleop(netns, tmp_path, settings=_with_arm(robot))
        stand_in = _stand_in(netns, tmp_path, "--set", f"{{robot: {robot}}}", "--duration", str(seconds),
                             "--out", str(tmp_path))
        assert stand_in.wait(timeout=RUN_TIMEOUT) == 0, stand_in.text()
        summary = _summary(teleop, tmp_path)
    finally:
        _stop_all(teleop, stand_in)
    assert "the controller Diagram (the blocks the simulation runs) steps each tick" in teleop.text()
    lab = json.loads((tmp_path / "stand_in.json").read_text())
    joints = len(BUNDLED_ARMS[robot].start)
    assert summary["slave_joints"] == lab["slave_joints"] == joints
    assert f"the slave is the {robot}, {joints} joints" in teleop.text()
    ticks = seconds / resolve_scenario("fig6").controller_period  # the stand-in's arm steps at the loop's rate
    assert summary["healthy_ticks"] > MIN_HEALTHY_SHARE * ticks, summary
    assert not any(summary["rejected"].values()) and not any(lab["refused"].values()), (summary["rejected"],
                                                                                        lab["refused"])
    channels = LcmChannels()
    for channel in (channels.master_command, channels.slave_command):
        assert lab["received"][channel.name] > 0.9 * ticks, lab["received"]
    print(f"{robot}: healthy in {summary['healthy_ticks']} of {summary['ticks']} ticks; largest stylus force "
          f"{summary['stylus_force_peak']:.3f} N sent, {lab['stylus_force_peak']:.3f} N at the driver's joints")
    assert 0.0 < lab["stylus_force_peak"] <= 8.5 + 1e-9
    assert summary["stylus_force_peak"] <= 8.5 + 1e-9 and summary["master_torque_finite"]


@pytest.mark.parametrize("robot", ARMS)
def test_controller_goes_safe_when_the_stand_in_dies(netns, tmp_path, robot):
    """Under 5 % drops and 5 % NaN samples the lab of each bundled arm dies mid-run: every master command is
    finite and within the device's limits, and the forces go off when a channel's last message gets older than
    the watchdog's timeout: at that tick, as the controller measured it, within ``FORCES_OFF_MS`` of the last
    message it accepted (the watchdog's timing is checked on an explicit clock in test_hardware_teleop)."""
    stand_in = teleop = None
    try:
        teleop = _teleop(netns, tmp_path, settings=_with_arm(robot))
        stand_in = _stand_in(netns, tmp_path, "--set", f"{{robot: {robot}}}", "--duration", FOREVER, "--die-at",
                             "2.0", "--drop-rate", "0.05", "--nan-rate", "0.05", "--clutch-at", "0.5")
        assert stand_in.wait(timeout=RUN_TIMEOUT) == 0 and "died" in stand_in.text(), stand_in.text()
        time.sleep(0.5)
        summary = _summary(teleop, tmp_path)
    finally:
        _stop_all(teleop, stand_in)
    assert summary["slave_joints"] == len(BUNDLED_ARMS[robot].start)
    off = forces_went_off(summary)
    print(f"{robot}: forces off {off:.1f} ms after the lab's last message; largest stylus force "
          f"{summary['stylus_force_peak']:.3f} N, torque {summary['stylus_torque_peak']:.4f} N·m")
    assert summary["stylus_force_peak"] <= 8.5 + 1e-9 and summary["stylus_torque_peak"] <= 0.188 + 1e-9


def test_restarted_stand_in_recovers_without_a_jump(netns, tmp_path):
    """The stand-in dies and a new one starts from scratch (clocks and counters from zero, the arm
    where the first one started, not where it went): the controller recovers, master torque ramps
    back in from zero, and apart from the restart itself, which sets the slave command to the
    measured position (a hold where the arm is, counted apart), slave commands never step faster
    than the joint speed limits allow."""
    stand_ins, teleop = [], None
    try:
        teleop = _teleop(netns, tmp_path)
        stand_ins.append(_stand_in(netns, tmp_path, "--duration", FOREVER, "--die-at", "1.0"))
        assert stand_ins[0].wait(timeout=RUN_TIMEOUT) == 0, stand_ins[0].text()
        stand_ins.append(_stand_in(netns, tmp_path, "--duration", FOREVER, label="stand_in_again"))
        time.sleep(2.0)
        summary = _summary(teleop, tmp_path)
    finally:
        _stop_all(teleop, *stand_ins)
    outages = [f for f in summary["faults"] if f["recovered"] is not None and f["recovered"] - f["onset"] > 0.1]
    assert outages, f"no recovered outage: {summary['faults']}"
    # Healthy most of the time since (a busy machine's stand-in stalls past the watchdog now and then).
    back, end = outages[-1]["recovered"], summary["duration"]
    faulted = sum(min(end, f["recovered"] if f["recovered"] is not None else end) - max(back, f["onset"])
                  for f in summary["faults"] if (f["recovered"] or end) > back)
    assert faulted < 0.5 * (end - back), teleop.text()
    assert summary["driver_restarts"]["slave_status"] >= 1, summary["driver_restarts"]
    assert summary["slave_reanchors"]["count"] >= 2, summary["slave_reanchors"]  # the start, the restart
    limits, params = device_limits(resolve_scenario("fig6")), HardwareStationParams()
    # A tick moves the command by at most the speed limit × its measured duration, which the
    # watchdog caps at its timeout (a longer gap is a stall: the command then holds).
    assert summary["max_slave_command_step"] <= max(limits.slave_velocity) * params.watchdog.timeout


def test_tool_change_and_rezero_reach_the_running_controller(netns, tmp_path):
    """A third process, `heft load`, gives the running controller a new tool's estimate and then
    re-zeroes the offsets (the clutch never pressed, so the slave is still), each answered over
    LCM; the controller never restarts."""
    from heft.diagrams.running.simulation import true_load

    true = true_load(resolve_scenario("fig6"))[0]
    estimate = tmp_path / "estimate.yaml"
    estimate.write_text(f"phi: {true.phi.tolist()}\noffsets: {true.offsets.tolist()}\n")
    stand_in = teleop = change = rezero = None
    try:
        stand_in = _stand_in(netns, tmp_path, "--duration", FOREVER, "--clutch-at", FOREVER)  # the slave stays still
        teleop = _teleop(netns, tmp_path)
        time.sleep(1.0)  # the forces ramped in (0.2 s) and the slave at rest for a re-zero
        change = _Process(netns, tmp_path, "load_estimate", "load", "--lcm-url", LCM_URL, "--estimate", str(estimate))
        assert change.wait(timeout=30) == 0, change.text()
        assert "new estimate in use: m = 3.13 kg" in change.text(), change.text()
        rezero = _Process(netns, tmp_path, "load_rezero", "load", "--lcm-url", LCM_URL, "--rezero")
        assert rezero.wait(timeout=30) == 0, rezero.text()
        assert "re-zeroed" in rezero.text(), rezero.text()
        print(change.text(), rezero.text())
        summary = _summary(teleop, tmp_path)
    finally:
        _stop_all(teleop, stand_in, change, rezero)
    assert summary["load_events"][0].startswith("new estimate in use") and "re-zeroed" in summary["load_events"][-1]


HOSTILE_SECONDS = 3.0


def layered_dict(base: dict, over: dict) -> dict:
    """``over`` laid over ``base``, nested dictionaries merged."""
    merged = dict(base)
    for key, value in over.items():
        merged[key] = layered_dict(base[key], value) if isinstance(value, dict) and key in base else value
    return merged


WHOLE_WEIGHT = yaml.safe_dump(layered_dict(yaml.safe_load(STAND_IN_SENSOR),
                                            yaml.safe_load(overrides_text({"controller.feedback.force_scale": 1.0}))),
                               default_flow_style=True)
"""The stand-in's sensor, and the load's weight fed back unscaled (30.7 N: the 8.5 N clamp acts)."""


def _controller_traffic(log):
    """From an LCM log: the master commands the controller sent, as (wall-clock µs of their tick,
    torques, enable), its slave commands' positions, every load status it answered and every
    station status it published."""
    from drake import lcmt_iiwa_command
    from heft.hardware_interface.lcmtypes import heft_haptic_command, heft_load_status, heft_station_status

    channels = LcmChannels()
    commands, slave_commands, statuses, station = [], [], [], []
    for event in lcm.EventLog(str(log), "r"):
        if event.channel == channels.master_command.name:
            msg = heft_haptic_command.decode(event.data)
            commands.append((msg.utime, np.array(msg.torque), msg.enable))
        elif event.channel == channels.slave_command.name:
            slave_commands.append(np.array(lcmt_iiwa_command.decode(event.data).joint_position))
        elif event.channel == channels.load_status.name:
            statuses.append(heft_load_status.decode(event.data))
        elif event.channel == channels.station_status.name:
            station.append(heft_station_status.decode(event.data))
    return commands, slave_commands, statuses, station


def _largest_rendered_force(log) -> float:
    """The largest stylus force (N) in the controller's recorded ``heft_teleop_state``: the feedback
    wrench it rendered after its clamp, before the watchdog's gain."""
    from heft.hardware_interface.lcmtypes import heft_teleop_state

    name = LcmChannels().teleop_state.name
    return max(float(np.linalg.norm(heft_teleop_state.decode(event.data).master_wrench[:3]))
               for event in lcm.EventLog(str(log), "r") if event.channel == name)


def test_hostile_traffic_never_reaches_the_motors(netns, tmp_path):
    """A third process publishes malformed and hostile traffic on every channel for 3 s
    (``hostile_traffic``) while the controller runs against the stand-in with the load's whole
    weight fed back (force scale 1: the Phantom's 8.5 N clamp is active throughout). The
    controller runs to its end; every command it sent is finite; the stylus force that its
    torques render at the driver's own joint positions (measured by the Phantom driver at each
    command's arrival, at the positions it published within the time a state may take to
    reach the controller and be read: ``StandIn.stylus_force_peak``) stays within 8.5 N; no
    non-physical estimate is ever in use; it is healthy and enabled again within 1 s after the
    traffic stops; its summary counts what it rejected per channel."""
    from heft.systems.load_dynamics import checked_load

    log = tmp_path / "traffic.lcmlog"
    stand_in = teleop = hostile = None
    try:
        stand_in = _stand_in(netns, tmp_path, "--duration", FOREVER, "--clutch-at", "0.0",
                             "--out", str(tmp_path))
        teleop = _teleop(netns, tmp_path, "--record", str(log), settings=WHOLE_WEIGHT)
        time.sleep(1.0)
        hostile = _Process(netns, tmp_path, "hostile", LCM_URL, str(HOSTILE_SECONDS), "7",
                           script=str(Path(__file__).with_name("hostile_traffic.py")))
        hostile.wait_for("hostile: publishing")
        assert hostile.wait(timeout=RUN_TIMEOUT) == 0, hostile.text()
        stopped = float(re.search(r"stopped at ([0-9.]+)", hostile.text()).group(1))
        time.sleep(1.5)
        summary = _summary(teleop, tmp_path)
        assert stand_in.finish() == 0, stand_in.text()
    finally:
        _stop_all(teleop, stand_in, hostile)
    print(hostile.text())
    rejected = summary["rejected"]
    for channel in ("master_state", "slave_status", "ft_sample"):
        assert sum(rejected[channel].values()) > 50, rejected
    assert summary["second_publishers"], "the hostile states on the drivers' clocks went unnoticed"
    refused = [event for event in summary["load_events"] if event.startswith("new estimate refused")]
    assert refused and not any(event.startswith("new estimate in use") for event in summary["load_events"])

    commands, slave_commands, statuses, station = _controller_traffic(log)
    # The recording keeps what was rejected: the controller's last status, as its summary says,
    # and second publishers flagged while the traffic lasted.
    last = station[-1]
    assert {channel: {reason: count for reason, count in zip(last.reasons, row) if count}
            for channel, row in zip(last.channels, last.rejected)} == rejected
    assert any(any(status.second_publisher) for status in station if status.utime < stopped * 1e6)
    assert commands and all(np.isfinite(torque).all() for _, torque, _ in commands)
    limits = device_limits(resolve_scenario("fig6"))
    assert all(np.isfinite(q).all() and np.all(limits.slave_lower <= q) and np.all(q <= limits.slave_upper)
               for q in slave_commands)
    for status in statuses:
        checked_load(status.phi, status.offsets, resolve_scenario("fig6").ft_sensor.full_scale)

    peak = json.loads((tmp_path / "stand_in.json").read_text())["stylus_force_peak"]
    print(f"largest stylus force the driver rendered at its own joint positions: {peak:.4f} N")
    # The controller's clamp acted: the stylus force it rendered (before the watchdog's gain, which
    # ramps back from zero after every fault) reached 8.5 N, and what it sent stayed within it.
    assert _largest_rendered_force(log) == pytest.approx(8.5)
    assert summary["stylus_force_peak"] <= 8.5 * (1 + 1e-9)
    assert peak <= 8.5 * (1 + 1e-9)  # and held at the driver's own positions

    after = [(t, enable) for t, _, enable in commands if t >= stopped * 1e6]
    enabled = next((t for t, enable in after if enable), None)
    assert enabled is not None and enabled - stopped * 1e6 <= 1e6, "not enabled within 1 s of the traffic's end"
    print(f"enabled {1e-3 * (enabled - stopped * 1e6):.1f} ms after the hostile traffic stopped")
    settled = [enable for t, enable in after if t >= enabled]
    # Mostly enabled since (a busy machine's stalls fault single ticks).
    assert sum(settled) > 0.5 * len(settled), "mostly faulted after the traffic stopped"


def test_a_labs_scenario_file_runs_teleop_with_no_other_flag(netns, tmp_path):
    """One file per lab: its LCM URLs (not the defaults: another group, the command URL given), the
    controller's rate, the watchdog's timeout and its sensor and mount. `heft stand-in --scenario
    lab.yaml` and `heft teleop --hardware --scenario lab.yaml`, no other flag, find each other on
    them; the controller says what it runs on, runs its default 10 s, exits 0 and heard the lab."""
    lab_url, command_url = "udpm://239.255.76.69:7701?ttl=0", "udpm://239.255.76.69:7705?ttl=0"
    lab = tmp_path / "lab.yaml"
    lab.write_text(
        "# The lab: where its drivers publish and listen, the loop's rate, the watchdog.\n"
        f"lab:\n  lcm: {{lcm_url: '{lab_url}', command_url: '{command_url}'}}\n"
        "  station: {watchdog: {timeout: 0.05}}\n"
        "controller_period: 0.001\n"
        + yaml.safe_dump(yaml.safe_load(STAND_IN_SENSOR), default_flow_style=False))
    scenario = resolve_scenario(str(lab))
    assert (scenario.lab.lcm.lcm_url, scenario.lab.lcm.command_lcm_url()) == (lab_url, command_url)
    stand_in = teleop = None
    try:
        stand_in = _Process(netns, tmp_path, "stand_in", "stand-in", "--scenario", str(lab), "--duration", FOREVER)
        stand_in.wait_for("stand-in: publishing")
        teleop = _Process(netns, tmp_path, "teleop", "teleop", "--hardware", "--scenario", str(lab))
        teleop.wait_for("teleop: running")
        assert teleop.wait() == 0, teleop.text()
        assert stand_in.finish() == 0, stand_in.text()
    finally:
        _stop_all(teleop, stand_in)
    text = teleop.text()
    print(text, stand_in.text())
    assert (f"teleop: controller on {lab_url} (commands on {command_url}) at 1000 Hz for 10 s of wall time; "
            "watchdog timeout 0.05 s") in text
    assert f"stand-in: {lab} on {lab_url} (commands on {command_url})" in stand_in.text()
    ran = re.search(r"ran [\d.]+ s at 1000 Hz: (\d+) ticks, healthy in (\d+) \(first at ([\d.]+) s\)", text)
    assert ran is not None and int(ran.group(2)) > 0, text
    received = dict(re.findall(r"(\w+) (\d+)", re.search(r"messages per second: received ([^;]*);", text).group(1)))
    for channel in ("master_state", "slave_status", "ft_sample"):
        assert int(received[channel]) > 0, received
    heard = re.search(r"received Hz ([^;]*);", stand_in.text()).group(1)  # the controller's commands reached the lab
    assert int(dict(re.findall(r"(\w+) (\d+)", heard))[scenario.lab.lcm.master_command.name]) > 0, heard


@pytest.mark.parametrize("robot", ["rx90", "iiwa14"])
def test_the_lab_file_of_heft_init_runs_as_written(netns, tmp_path, robot):
    """`heft init lab --robot ROBOT --out lab.yaml`, then `heft stand-in --scenario lab.yaml` and `heft teleop
    --hardware --scenario lab.yaml` with no other flag: the controller runs its default 10 s against the
    stand-in, healthy, hearing every driver, heard by the lab."""
    lab = tmp_path / "lab.yaml"
    assert main(["init", "lab", "--robot", robot, "--out", str(lab)]) == 0
    stand_in = teleop = None
    try:
        # The lab runs until the test stops it (--duration), so that it outlasts the controller's start.
        stand_in = _Process(netns, tmp_path, "stand_in", "stand-in", "--scenario", str(lab), "--duration", FOREVER)
        stand_in.wait_for("stand-in: publishing")
        teleop = _Process(netns, tmp_path, "teleop", "teleop", "--hardware", "--scenario", str(lab))
        teleop.wait_for("teleop: running")
        assert teleop.wait() == 0, teleop.text()
        assert stand_in.finish() == 0, stand_in.text()
    finally:
        _stop_all(teleop, stand_in)
    text = teleop.text()
    print(text, stand_in.text())
    assert f"the slave is the {robot}, {len(BUNDLED_ARMS[robot].start)} joints" in text
    ran = re.search(r"ran [\d.]+ s at 2000 Hz: (\d+) ticks, healthy in (\d+)", text)
    assert ran is not None and int(ran.group(2)) > MIN_HEALTHY_SHARE * int(ran.group(1)), text
    received = dict(re.findall(r"(\w+) (\d+)", re.search(r"messages per second: received ([^;]*);", text).group(1)))
    for channel in ("master_state", "slave_status", "ft_sample"):
        assert int(received[channel]) > 0, received
    heard = re.search(r"received Hz ([^;]*);", stand_in.text()).group(1)
    assert int(dict(re.findall(r"(\w+) (\d+)", heard))[LcmChannels().master_command.name]) > 0, heard
