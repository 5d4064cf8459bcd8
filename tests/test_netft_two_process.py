"""`heft driver netft` between the stand-in's Net F/T (RDT over UDP) and `heft teleop --hardware`, in
three processes inside a private network namespace (``test_two_process``'s helpers): the FT channel
reaches the controller at the rate the LCM stand-in gives it, and the packets the device withheld and
the status bits it set are reported by the driver and, where the status says error, by the controller.

Timing comes from what each process measures: the stand-in runs 3 s of its own clock and says how
long it ran and how late it fell; the controller counts the FT messages it received; the driver times
its stream. A stand-in starved of CPU (later than the watchdog's timeout) catches up in bursts: the
rates are then not judged (xfail, with its lateness), the counts still are. The stand-in plays every
device on one CPU, whose real-time budget (95 % of each second) it shares with the driver and the
controller's receive thread: on this loaded 2-core machine it fell about 50 ms behind its clock
while it streamed in half the runs (with the driver at normal scheduling it kept its clock, but the
driver, kept off the CPU, then published in bursts the controller's socket could not hold)."""

import json
import re

import pytest
import yaml

from heft.diagrams.scenario import overrides_text
from heft.hardware_interface.netft import STATUS_ERROR

from test_two_process import (FOREVER, LCM_URL, RUN_TIMEOUT, STAND_IN_SENSOR, _Process, _stop_all, _summary, _teleop,
                              layered_dict)

pytestmark = pytest.mark.slow

SECONDS = 3.0
"""The stand-in's run (s of its clock)."""
DROP_EVERY = 100
STATUS = STATUS_ERROR | 0x1
STATUS_AT, STATUS_UNTIL = 1.5, 1.55
KEPT_TIME_MS = 20.0
"""A stand-in later than this on its clock (the watchdog's timeout) was starved of CPU: the rates are not judged."""
CALIBRATION = overrides_text({"lab.netft.counts_per_force": 1_000_000.0, "lab.netft.counts_per_torque": 1_000_000.0})
"""The stand-in's Net F/T's calibration, as a lab's file states it (the driver takes it by its flags)."""
CONTROLLER = yaml.safe_dump(layered_dict(yaml.safe_load(STAND_IN_SENSOR),
                                         yaml.safe_load(overrides_text({"accelerometer.includes_gravity": False,
                                                                         "accelerometer.position": [0.0, 0.0, 0.0]}))),
                            default_flow_style=True)
"""The stand-in's sensor as a lab states it, its accelerometer reading 0 at S (a Net F/T has none: docs/netft.md)."""


def _ft_received(teleop, folder, stand_in) -> tuple[float, dict]:
    """(FT messages a second of the stand-in's run the controller received, its summary), once the
    stand-in has ended on its own (the controller started before it)."""
    assert stand_in.wait(timeout=RUN_TIMEOUT) == 0, stand_in.text()
    ran = float(re.search(r"stand-in: stopped at t = ([\d.]+) s", stand_in.text()).group(1))
    summary = _summary(teleop, folder)
    return summary["received_hz"]["ft_sample"] * summary["duration"] / ran, summary


def test_the_netft_driver_feeds_the_controller_as_the_lcm_stand_in_does(netns, tmp_path):
    processes = []
    try:
        lcm_folder = tmp_path / "lcm"
        lcm_folder.mkdir()
        processes.append(_teleop(netns, lcm_folder, settings=CONTROLLER))
        lcm_stand_in = _Process(netns, lcm_folder, "stand_in", "stand-in", "--lcm-url", LCM_URL,
                                "--duration", str(SECONDS))
        processes.append(lcm_stand_in)
        lcm_rate, _ = _ft_received(processes[0], lcm_folder, lcm_stand_in)

        teleop = _teleop(netns, tmp_path, settings=CONTROLLER)
        driver = _Process(netns, tmp_path, "driver", "driver", "netft", "--address", "127.0.0.1", "--lcm-url",
                          LCM_URL, "--counts-per-force", "1e6", "--counts-per-torque", "1e6", "--duration", FOREVER,
                          "--out", str(tmp_path / "driver"))
        processes += [teleop, driver]
        driver.wait_for("netft: asking")
        stand_in = _Process(netns, tmp_path, "stand_in", "stand-in", "--lcm-url", LCM_URL, "--set", CALIBRATION,
                            "--duration", str(SECONDS), "--netft", "127.0.0.1", "--netft-drop-every", str(DROP_EVERY),
                            "--netft-status", hex(STATUS), "--netft-status-at", str(STATUS_AT),
                            "--netft-status-until", str(STATUS_UNTIL))
        processes.append(stand_in)
        netft_rate, summary = _ft_received(teleop, tmp_path, stand_in)
        assert driver.finish() == 0, driver.text()
    finally:
        _stop_all(*processes)
    print(driver.text(), stand_in.text())
    print(f"FT messages a second at the controller: from the LCM stand-in {lcm_rate:.0f}, through the Net F/T "
          f"driver {netft_rate:.0f}")
    served = dict((key, int(value)) for value, key in re.findall(r"(\d+) (withheld|records sampled)", stand_in.text()))
    driven = json.loads((tmp_path / "driver" / "netft.json").read_text())
    # Whatever the machine's load: what the driver published, the controller received; every withheld packet
    # is a gap the driver counted (4 records each); each status bit is counted, the error bit as errors;
    # the driver is the FT channel's one source, and the controller refused nothing but flagged samples.
    received = summary["received_hz"]["ft_sample"] * summary["duration"]
    assert 0.99 * driven["published"] <= received <= driven["published"] + 1
    assert served["withheld"] > 0 and driven["lost"] >= 4 * served["withheld"]
    assert driven["errors"] == driven["status_bits"]["0x80000000"] >= driven["status_bits"].get("0x00000001", 0)
    assert not summary["second_publishers"]
    assert summary["rejected"]["ft_sample"].keys() <= {"driver_error"}, summary["rejected"]
    late = max(float(re.search(r"max lateness ([\d.]+) ms", text).group(1)) for text in (lcm_stand_in.text(),
                                                                                          stand_in.text()))
    if late > KEPT_TIME_MS:
        pytest.xfail(f"a stand-in fell {late:.0f} ms behind its clock (starved of CPU): its catching up comes in "
                     "bursts, so rates and losses say nothing of the driver")
    # The rate: an arm step's samples a message either way, less the withheld packets.
    assert driven["published_hz"] == pytest.approx(lcm_rate * (1 - 1 / DROP_EVERY), rel=0.03)
    assert driven["samples_hz"] == pytest.approx(4 * driven["published_hz"], rel=0.01)
    assert driven["lost"] <= 4 * served["withheld"] + 0.01 * driven["records"], driven  # little lost on the way
    # The window's records carry the injected bits; the error bit reached the controller as the samples'
    # error flag, and it refused them.
    injected = driven["status_bits"]["0x00000001"]
    assert 0.9 * 8000 * (STATUS_UNTIL - STATUS_AT) <= injected <= served["records sampled"]
    assert summary["rejected"]["ft_sample"].get("driver_error", 0) > 0, summary["rejected"]
    assert summary["first_healthy"] is not None
