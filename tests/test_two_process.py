"""`heft stand-in` and `heft teleop --hardware` as two processes over LCM UDP multicast.

Both run inside a network namespace this test creates (only its own `lo`, with
the multicast route on it) on ``udpm://239.255.76.67:7667?ttl=0``, so no packet
can leave the machine (DESIGN §5). Needs root and `ip`; skipped otherwise.
No assertion here depends on how fast the machine is: the rates and delays are
printed, and measured by `heft bench lcm`.
"""

import json
import os
import subprocess
import sys
import time

import lcm
import pytest
from heft.diagrams.commands.options import lab_settings_text
from heft.diagrams.scenario import resolve_scenario
from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.hardware_station import HardwareStationParams

pytestmark = pytest.mark.slow

LCM_URL = "udpm://239.255.76.67:7667?ttl=0"
STARTUP_TIMEOUT = 60.0
RUN_TIMEOUT = 120.0
STAND_IN_SENSOR = lab_settings_text(resolve_scenario("fig6"))  # the stand-in's sensor, stated as a lab states its own


class _Process:
    """A `heft` subcommand inside the namespace; output to a file in ``folder``."""

    def __init__(self, ns, folder, label, *args):
        self.log = folder / f"{label}.log"
        env = dict(os.environ, OPENBLAS_NUM_THREADS="1", PYTHONUNBUFFERED="1")
        with open(self.log, "w") as out:
            self.popen = subprocess.Popen(
                ["ip", "netns", "exec", ns, sys.executable, "-m", "heft.diagrams.cli", *args],
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

    def stop(self):
        if self.popen.poll() is None:
            self.popen.terminate()
            try:
                self.popen.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.popen.kill()
                self.popen.wait()


def _run(netns, folder, teleop_duration, stand_in_args, teleop_args=(), restart=False):
    """Starts the controller, then (once it is building) the stand-in — and, with
    ``restart``, a second stand-in once the first has died; returns the controller's
    JSON summary and the processes."""
    out = folder / "teleop.json"
    teleop = _Process(netns, folder, "teleop", "teleop", "--hardware", "--lcm-url", LCM_URL,
                      "--set", STAND_IN_SENSOR, "--duration", str(teleop_duration), "--out", str(out), *teleop_args)
    stand_ins = []
    try:
        teleop.wait_for("teleop: controller on")
        stand_ins.append(_Process(netns, folder, "stand_in", "stand-in", "--scenario", "fig6", "--lcm-url",
                                  LCM_URL, *stand_in_args))
        if restart:
            assert stand_ins[0].wait(timeout=RUN_TIMEOUT) == 0, stand_ins[0].text()
            stand_ins.append(_Process(netns, folder, "stand_in_again", "stand-in", "--scenario", "fig6",
                                      "--lcm-url", LCM_URL, "--duration", "1000"))
        assert teleop.wait() == 0, teleop.text()
        return json.loads(out.read_text()), teleop, stand_ins
    finally:
        for process in (teleop, *stand_ins):
            process.stop()


def test_controller_runs_against_the_stand_in(netns, tmp_path):
    log = tmp_path / "traffic.lcmlog"
    summary, teleop, _ = _run(netns, tmp_path, 3.0, ["--duration", "1000", "--clutch-at", "1.0"],
                              ["--record", str(log)])
    print(teleop.text())
    assert summary["first_healthy"] is not None, "the watchdog never became healthy"
    assert summary["healthy_ticks"] > 0.5 * summary["ticks"], teleop.text()
    assert summary["master_torque_finite"]
    # The recorded traffic is an LCM log with every channel of both sides.
    counts = {}
    for event in lcm.EventLog(str(log), "r"):
        counts[event.channel] = counts.get(event.channel, 0) + 1
    channels = LcmChannels()
    for channel in (channels.master_state, channels.master_command, channels.slave_status, channels.slave_command,
                    channels.ft_sample):
        assert counts.get(channel.name, 0) > 100, counts


def test_controller_goes_safe_when_the_stand_in_dies(netns, tmp_path):
    """Under 5 % drops and 5 % NaN samples the lab dies mid-run: every master command is finite
    and within the device's limits, and the forces go off when a channel's last message gets
    older than the watchdog's timeout (the age at that tick is printed; the watchdog's timing is
    checked on an explicit clock in test_hardware_teleop)."""
    summary, teleop, (stand_in,) = _run(
        netns, tmp_path, 6.0, ["--duration", "1000", "--die-at", "2.0", "--drop-rate", "0.05", "--nan-rate", "0.05",
                               "--clutch-at", "0.5"])
    print(teleop.text())
    assert stand_in.wait(timeout=10) == 0 and "died" in stand_in.text(), stand_in.text()
    assert summary["first_healthy"] is not None, "the watchdog never became healthy"
    assert summary["faults"] and summary["faults"][-1]["recovered"] is None, summary["faults"]
    assert summary["final_fault_bits"] == 0b111, "every channel of the dead lab should be stale"
    print(f"forces off {max(summary['faults'][-1]['ages_ms']):.1f} ms after the lab's last message")
    assert not summary["final_healthy"]
    assert summary["master_torque_finite"]
    assert summary["stylus_force_peak"] <= 8.5 + 1e-9 and summary["stylus_torque_peak"] <= 0.188 + 1e-9


def test_restarted_stand_in_recovers_without_a_jump(netns, tmp_path):
    """The stand-in dies and a new one starts from scratch (clocks and counters from zero): the
    controller recovers, master torque ramps back in from zero and slave commands never step
    faster than the joint speed limits allow."""
    summary, teleop, _ = _run(netns, tmp_path, 8.0, ["--duration", "1000", "--die-at", "1.0"], restart=True)
    print(teleop.text())
    outages = [f for f in summary["faults"] if f["recovered"] is not None and f["recovered"] - f["onset"] > 0.1]
    assert outages, f"no recovered outage: {summary['faults']}"
    assert summary["final_healthy"], teleop.text()
    params = HardwareStationParams()
    # A tick moves the command by at most the speed limit × its measured duration, which the
    # watchdog caps at its timeout (a longer gap is a stall: the command then holds).
    assert summary["max_slave_command_step"] <= max(params.slave_velocity_limits) * params.watchdog.timeout


def test_tool_change_and_rezero_reach_the_running_controller(netns, tmp_path):
    """A third process, `heft load`, gives the running controller a new tool's estimate and then
    re-zeroes the offsets (the clutch never pressed, so the slave is still), each answered over
    LCM; the controller never restarts."""
    from heft.diagrams.scenario import resolve_scenario
    from heft.diagrams.running.simulation import true_load

    true = true_load(resolve_scenario("fig6"))[0]
    estimate = tmp_path / "estimate.yaml"
    estimate.write_text(f"phi: {true.phi.tolist()}\noffsets: {true.offsets.tolist()}\n")
    out = tmp_path / "teleop.json"
    teleop = _Process(netns, tmp_path, "teleop", "teleop", "--hardware", "--lcm-url", LCM_URL, "--duration", "8",
                      "--set", STAND_IN_SENSOR, "--out", str(out))
    processes = [teleop]
    try:
        teleop.wait_for("teleop: controller on")
        processes.append(_Process(netns, tmp_path, "stand_in", "stand-in", "--scenario", "fig6", "--lcm-url", LCM_URL,
                                  "--duration", "1000", "--clutch-at", "1000"))  # the slave stays still
        time.sleep(3.0)  # start-up of both and a healthy station
        change = _Process(netns, tmp_path, "load_estimate", "load", "--lcm-url", LCM_URL, "--estimate", str(estimate))
        processes.append(change)
        assert change.wait(timeout=30) == 0, change.text()
        assert "new estimate in use: m = 3.13 kg" in change.text(), change.text()
        rezero = _Process(netns, tmp_path, "load_rezero", "load", "--lcm-url", LCM_URL, "--rezero")
        processes.append(rezero)
        assert rezero.wait(timeout=30) == 0, rezero.text()
        assert "re-zeroed" in rezero.text(), rezero.text()
        print(change.text(), rezero.text())
        assert teleop.wait() == 0, teleop.text()
        summary = json.loads(out.read_text())
        assert summary["load_events"][0].startswith("new estimate in use") and "re-zeroed" in summary["load_events"][-1]
    finally:
        for process in processes:
            process.stop()
