"""`heft stand-in` and `heft teleop --hardware` as two processes with the Touch-type master (`master: touch`:
three motors, a passive measured wrist) on the lab's six-joint haptic channels, in a private network namespace
as in test_two_process. The stand-in plays the Touch's driver: it clips the motors' torque to their limits and
refuses, counted as "unactuated", a command with torque on a wrist joint; it judges each command's stylus force by
the Touch's Jacobian at the state the command names. Needs root and `ip`; skipped otherwise."""

import json
import time

import lcm
import numpy as np
import pytest
import yaml

from heft.diagrams.master_params import BUNDLED_MASTERS
from heft.diagrams.plants import MakeMasterPlant, master_actuated
from heft.diagrams.scenario import overrides_text
from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.lcmtypes import heft_haptic_command

from test_two_process import (FOREVER, LCM_URL, RUN_TIMEOUT, STAND_IN_SENSOR, _largest_rendered_force,
                              _Process, _stop_all, _summary, _teleop, forces_went_off, layered_dict)

pytestmark = pytest.mark.slow

MAX_FORCE = BUNDLED_MASTERS["touch"].max_force
"""The Touch's force limit (N), ``controller.feedback.max_force`` of a scenario naming it."""
TOUCH = yaml.safe_dump(layered_dict(yaml.safe_load(STAND_IN_SENSOR), {"master": "touch"}), default_flow_style=True)
"""The stand-in's sensor and the Touch."""
TOUCH_WHOLE_WEIGHT = yaml.safe_dump(layered_dict(yaml.safe_load(TOUCH), yaml.safe_load(
    overrides_text({"controller.feedback.force_scale": 1.0}))), default_flow_style=True)
"""The Touch, and the load's weight fed back unscaled (30.7 N: the Touch's 3.3 N clamp acts throughout)."""
WRIST = master_actuated(MakeMasterPlant("touch")) == 0.0
"""The Touch's joints without a motor: its wrist."""


def _touch_stand_in(netns, folder, *args, label="stand_in"):
    """The stand-in playing the Touch, publishing."""
    stand_in = _Process(netns, folder, label, "stand-in", "--scenario", "fig6", "--set", "{master: touch}",
                        "--lcm-url", LCM_URL, *args)
    stand_in.wait_for("stand-in: publishing")
    return stand_in


def _master_commands(log) -> np.ndarray:
    """The torques (N·m, one row a command) of every master command in the LCM log ``log``."""
    name = LcmChannels().master_command.name
    return np.array([heft_haptic_command.decode(event.data).torque for event in lcm.EventLog(str(log), "r")
                     if event.channel == name])


def test_the_touch_renders_its_force_within_its_limit_and_no_wrist_torque(netns, tmp_path):
    """With the load's whole weight fed back, the controller's clamp holds the stylus force at the Touch's 3.3 N
    (its rendered force reaches it), every torque it sent on a wrist joint is exactly zero while its motors'
    are not, the Touch's driver refused no command and the force its torques render at the driver's own joint
    positions, by the Touch's Jacobian, stays within 3.3 N."""
    log = tmp_path / "traffic.lcmlog"
    stand_in = teleop = None
    try:
        stand_in = _touch_stand_in(netns, tmp_path, "--duration", FOREVER, "--clutch-at", "0.5", "--out",
                                   str(tmp_path))
        teleop = _teleop(netns, tmp_path, "--record", str(log), settings=TOUCH_WHOLE_WEIGHT)
        time.sleep(3.0)
        summary = _summary(teleop, tmp_path)
        assert stand_in.finish() == 0, stand_in.text()
    finally:
        _stop_all(teleop, stand_in)
    print(stand_in.text())
    lab = json.loads((tmp_path / "stand_in.json").read_text())
    assert "the master: touch" in stand_in.text()
    assert summary["first_healthy"] is not None and summary["healthy_ticks"] > 0.5 * summary["ticks"], summary
    assert not any(summary["rejected"].values()), summary["rejected"]
    assert not any(lab["refused"].values()), lab["refused"]

    torques = _master_commands(log)
    assert len(torques) > 1000 and np.isfinite(torques).all()
    assert np.abs(torques[:, ~WRIST]).max() > 0.1, "the motors were never driven"
    assert not torques[:, WRIST].any(), f"wrist torque sent: {np.abs(torques[:, WRIST]).max()} N·m"

    rendered = _largest_rendered_force(log)
    print(f"touch: largest stylus force rendered {rendered:.4f} N, sent {summary['stylus_force_peak']:.4f} N, at the "
          f"driver's joints {lab['stylus_force_peak']:.4f} N; largest motor torque {np.abs(torques).max():.4f} N·m")
    assert rendered == pytest.approx(MAX_FORCE)  # the clamp acted
    assert summary["stylus_force_peak"] <= MAX_FORCE * (1 + 1e-9)
    assert 0.5 * MAX_FORCE < lab["stylus_force_peak"] <= MAX_FORCE * (1 + 1e-9)


def test_the_touchs_forces_go_off_when_the_stand_in_dies(netns, tmp_path):
    """Under 5 % drops and 5 % NaN samples the Touch's lab dies mid-run: every master command was finite, none
    had wrist torque, and the forces went off at the tick a channel's last message got older than the
    watchdog's timeout, within ``FORCES_OFF_MS`` of the last message the controller accepted."""
    log = tmp_path / "traffic.lcmlog"
    stand_in = teleop = None
    try:
        teleop = _teleop(netns, tmp_path, "--record", str(log), settings=TOUCH)
        stand_in = _touch_stand_in(netns, tmp_path, "--duration", FOREVER, "--die-at", "2.0", "--drop-rate", "0.05",
                                   "--nan-rate", "0.05", "--clutch-at", "0.5", "--out", str(tmp_path))
        assert stand_in.wait(timeout=RUN_TIMEOUT) == 0 and "died" in stand_in.text(), stand_in.text()
        time.sleep(0.5)
        summary = _summary(teleop, tmp_path)
    finally:
        _stop_all(teleop, stand_in)
    lab = json.loads((tmp_path / "stand_in.json").read_text())
    off = forces_went_off(summary)
    print(f"touch: forces off {off:.1f} ms after the lab's last message; largest stylus force "
          f"{summary['stylus_force_peak']:.3f} N sent, {lab['stylus_force_peak']:.3f} N at the driver's joints")
    assert not lab["refused"].get(LcmChannels().master_command.name), lab["refused"]
    torques = _master_commands(log)
    assert len(torques) > 1000 and not torques[:, WRIST].any()
    assert summary["stylus_force_peak"] <= MAX_FORCE * (1 + 1e-9)
    assert lab["stylus_force_peak"] <= MAX_FORCE * (1 + 1e-9)
