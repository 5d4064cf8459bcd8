"""`heft analyze passivity` and `heft analyze replay` on the LCM log of a real two-process run:
`heft teleop --hardware --record` against `heft stand-in` over UDP multicast in a private
network namespace (as tests/test_two_process.py), the operator holding the clutch, so that
master and slave move and the controller feeds the load's force back.

The passivity figures are checked against the raw messages, decoded here: the energy that
flowed from the hand into the network is −Σ τ·q̇·dt over the controller's ticks, in joint
space (τ the torques sent, divided by the watchdog's gain, q̇ the Phantom driver's velocities
the tick read), with no Jacobian; the analysis computes it in Cartesian space from the wrench
and J_M(q)·q̇ through MultibodyPlant, split into the port energy of the mapped wrench and what
the passivity controller dissipated.
"""

import collections
import json
import shutil
import subprocess
import sys
import time
from pathlib import Path

import lcm
import numpy as np
import pytest
from heft.analysis.run_log import complete_rows
from heft.diagrams.commands.analyze_passivity import analyze_log, read_log
from heft.diagrams.commands.replay import ARROW_ROOT, MASTER_BASE_IN_W, frame_indices, load_log
from heft.diagrams.models import model_path
from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.lcmtypes import heft_haptic_command, heft_haptic_state, heft_teleop_state
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from test_replay import CHROMEDRIVER, CHROMIUM, SCENE_PROBE, _browser
from test_two_process import FOREVER, _stand_in, _stop_all, _summary, _teleop

pytestmark = pytest.mark.slow

RUN_SECONDS = 3.0
FPS = 30.0


def _heft(*args) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "heft.diagrams.cli", *args], capture_output=True, text=True,
                          timeout=600)


@pytest.fixture(scope="module")
def recording(module_netns, tmp_path_factory):
    """The LCM log of 3 s of teleoperation against the stand-in, the clutch held from 0.3 s."""
    folder = tmp_path_factory.mktemp("hardware_log")
    log = folder / "teleop.lcmlog"
    stand_in = teleop = None
    try:
        stand_in = _stand_in(module_netns, folder, "--duration", FOREVER, "--clutch-at", "0.3")
        teleop = _teleop(module_netns, folder, "--record", str(log))
        time.sleep(RUN_SECONDS)
        summary = _summary(teleop, folder)
    finally:
        _stop_all(teleop, stand_in)
    assert summary["healthy_ticks"] > 0.5 * summary["ticks"], teleop.text()
    return log


def _raw_ticks(log):
    """Every controller tick's teleop state, decoded here, in order; per tick whose master
    command and the master state it read the log holds once, (teleop state, command, master
    state); and the master states by utime. (The run's last command, forces off, goes out on
    the last tick's stamp: that tick has two, and which one is its own the log does not say.)"""
    channels = LcmChannels()
    states, commands, masters = {}, collections.defaultdict(list), collections.defaultdict(list)
    for event in lcm.EventLog(str(log), "r"):
        if event.channel == channels.teleop_state.name:
            msg = heft_teleop_state.decode(event.data)
            states[msg.utime] = msg
        elif event.channel == channels.master_command.name:
            msg = heft_haptic_command.decode(event.data)
            commands[msg.utime].append(msg)
        elif event.channel == channels.master_state.name:
            msg = heft_haptic_state.decode(event.data)
            masters[msg.utime].append(msg)
    states = [state for _, state in sorted(states.items())]
    return states, [(state, commands[state.utime][0], masters[state.master_utime][0]) for state in states
                    if len(commands[state.utime]) == 1 and len(masters[state.master_utime]) == 1], masters


def test_passivity_on_the_hardware_log_agrees_with_the_raw_messages(recording, tmp_path):
    result = _heft("analyze", "passivity", str(recording), "--out", str(tmp_path))
    assert result.returncode == 0, result.stderr
    line = result.stdout.strip()
    print(line)
    assert len(line.splitlines()) == 1 and "no wrench_contact_true" in line
    assert (tmp_path / "passivity.png").stat().st_size > 10_000
    report = json.loads((tmp_path / "passivity.json").read_text())
    assert report["log"]["kind"] == "lcm" and "environment_port" not in report
    run = read_log(recording)
    assert report["master_port"] == json.loads(json.dumps(analyze_log(run.arrays, observer_lag=0)["master_port"]))

    # The energy from the hand into the network over the ticks of the analysed stretch whose
    # command and master state the log holds: raw, in joint space, and by the analysis.
    states, ticks, _ = _raw_ticks(recording)
    longest = run.arrays["starts"][0]  # the stretch the analysis took
    stretch = sum(state.starts == longest for state in states)
    ticks = [tick for tick in ticks if tick[0].starts == longest]
    # A tick of no duration carries no energy: the run's first (its dt 0, so its gain's ramp 0 too),
    # which is in the stretch when the lab was already publishing.
    flow = -sum(np.dot(command.torque, master.velocity) * state.dt / state.gain for state, command, master in ticks
                if state.dt > 0)
    complete = complete_rows(run, ("master_torque",), "no command in the log")
    np.testing.assert_allclose(complete.arrays["t"], [(state.utime - states[0].utime) * 1e-6 for state, _, _ in ticks],
                               atol=1e-9)
    analysed_report = analyze_log(complete.arrays, observer_lag=0)
    ports, pc = analysed_report["master_port"], analysed_report["passivity_controller"]
    throughput = sum(port["energy_in_J"] + port["energy_out_J"] for port in ports.values())
    analysed = sum(ports[c]["final_J"] + pc[f"{c}_dissipated_J"] + pc[f"{c}_clamp_withheld_J"]
                   for c in ("translational", "rotational"))
    print(f"energy into the network over {len(ticks)} ticks: {analysed:.9g} J by the analysis, {flow:.9g} J from "
          f"τ·q̇ (throughput {throughput:.4g} J; PC dissipated {pc['translational_dissipated_J']:.4g} J, "
          f"{pc['rotational_dissipated_J']:.4g} J)")
    assert throughput > 1e-3  # energy did flow: the check below is not 0 = 0
    assert analysed == pytest.approx(flow, rel=1e-9, abs=1e-9 * throughput)
    print(f"{stretch - len(ticks)} of the stretch's {stretch} ticks lack their command or master state in the log")
    if len(ticks) == stretch:  # none left out
        for port in ports.values():  # the observer's energy, as the controller published it, is the same
            assert port["observer_identity_gap_J"] < 1e-9 * throughput


@pytest.mark.skipif(not (Path(CHROMIUM).exists() and Path(CHROMEDRIVER).exists()),
                    reason="needs Debian's chromium and its driver: apt-get install -y chromium chromium-driver")
def test_replay_of_the_hardware_log_opens_in_chromium(recording, tmp_path):
    """The page plays the recorded motion: at the last frame, the stylus where Drake's kinematics
    of the Phantom driver's recorded joint positions put it, and the slave's links animated."""
    page = tmp_path / "replay.html"
    result = _heft("analyze", "replay", str(recording), "--out", str(tmp_path), "--fps", str(FPS))
    assert result.returncode == 0, result.stderr
    print(result.stdout.strip())
    log = load_log(recording)  # the rows the replay shows
    frames = frame_indices(log["t"], FPS)
    states, _, masters = _raw_ticks(recording)
    read = {state.utime - states[0].utime: state.master_utime for state in states}  # the tick's master state
    (master,) = masters[read[round(log["t"][frames[-1]] * 1e6)]]
    master_q = np.array(master.position)  # as the Phantom driver sent it
    np.testing.assert_array_equal(log["master_q"][frames[-1]], master_q)
    assert np.ptp(log["master_q"][frames], axis=0).max() > 0.01  # the master moved

    plant = MultibodyPlant(time_step=0.0)
    (phantom,) = Parser(plant).AddModels(model_path("phantom_premium_6dof.urdf"))
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("phantom_base", phantom), MASTER_BASE_IN_W)
    plant.Finalize()
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, master_q)
    stylus = plant.GetBodyByName("stylus").EvalPoseInWorld(context).GetAsMatrix4()

    path = "/drake/visualizer/phantom_premium_6dof/stylus"
    driver, profile = _browser()
    try:
        driver.get(page.resolve().as_uri())
        driver.set_script_timeout(10)
        scene = driver.execute_script(SCENE_PROBE, (len(frames) - 1) / FPS, [path])
        console = driver.get_log("browser")
    finally:
        driver.quit()
        shutil.rmtree(profile, ignore_errors=True)
    assert scene is not None, "the page has no meshcat viewer"
    assert [entry for entry in console if entry["level"] == "SEVERE"] == []
    for animated in ("/drake/visualizer/rx90/rx90_link2", path, f"{ARROW_ROOT}/measured/shaft",
                     f"{ARROW_ROOT}/master/shaft"):
        assert animated in scene["animated"], animated
    assert scene["duration"] == pytest.approx((len(frames) - 1) / FPS, abs=1e-6)
    np.testing.assert_allclose(np.array(scene["poses"][path]).reshape(4, 4).T, stylus, atol=1e-5)
