"""The paper's Sec. V across two processes: `heft teleop --hardware` with the estimator online
(η = 0.5, σ = 0, force scale 1) against `heft stand-in --scenario grasp --grasp-at 2`.

The controller starts from the gripper's φ alone; a third process, `heft load --rezero`, started
with the lab, re-zeroes the sensor at rest as soon as the controller is healthy; the stand-in's
gripper closes on the 0.5 kg block at 2 s while the slave follows the operator's strokes (from
``MOVE_FROM`` s), and the clutch is let go at ``STILL_FROM`` s so that the slave then holds still.
Judged by ``grasp_judge`` from what the processes wrote — the controller's φ̂ every 10 ms and its
recorded traffic (the master torques through the Phantom's Jacobian at the driver's positions each
command names) — against the stand-in's recorded truth of every FT sample (``test_grasp_lab``
judges the same in one process, on one explicit clock). A second run holds still throughout (the clutch engaged,
the operator not moving), the gripper closing at 2 s: the object is learned at rest (``RestLearner``) and judged
from 2.5 s.

Nothing here asserts how fast the machine is; a stand-in that could not keep its clock from the
second before the grasp on (a busy machine) skips the judging with its lateness, while the grasp's
answers and the force limits are checked either way. Times: the
stand-in's messages and truth are on its own clock, whose zero it prints as wall-clock time. Each
command is judged at the time of the master state it names (its ``master_utime``), so a stand-in
publishing late does not shift what it is compared with; the controller's φ̂ history, on its wall
clock, goes on the stand-in's clock through the two zeros.
"""

import json
import math
import re
import time

import lcm
import numpy as np
import pytest
import yaml
from drake import lcmt_iiwa_status

from heft.diagrams.commands.options import lab_settings_text
from heft.diagrams.running.simulation import true_load
from heft.diagrams.scenario import overrides_text, resolve_scenario
from heft.diagrams.stations.stand_in_wrist import GRIPPER_CLOSING_S
from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.lcmtypes import heft_haptic_command, heft_haptic_state

from grasp_judge import judge, report
from test_two_process import FOREVER, LCM_URL, _Process, _stop_all, _summary, layered_dict

pytestmark = pytest.mark.slow

MOVE_FROM, GRASP_AT, STILL_FROM, END = 1.8, 2.0, 4.5, 6.5
HELD_STILL_END = 4.0
"""s: the end of the run held still, judged from ``GRASP_AT`` + 0.5 s."""
ETA, BOUND, MAX_FORCE = 0.5, 0.05, 8.5
LATE_MS = 20.0
"""A stand-in publishing later than this (ms; the watchdog's timeout) behind its clock from the second
before the grasp on is not the lab in real time there: its run is not judged (skipped, with the
lateness and its CPU time)."""
WAIT = 0.2  # s after the grasp before learning (controller.estimator.new_load_wait): 2/prefilter


def _settings() -> str:
    lab = yaml.safe_load(lab_settings_text(resolve_scenario("grasp")))
    ours = yaml.safe_load(overrides_text({"controller.estimator.mode": "online", "controller.force.eta": ETA,
                                          "controller.force.sigma": 0.0, "controller.feedback.force_scale": 1.0,
                                          "controller.estimator.new_load_wait": WAIT}))
    return yaml.safe_dump(layered_dict(lab, ours), default_flow_style=True)


def _traffic(log):
    """From the controller's recording, on the stand-in's clock (s): its master commands (t, torques,
    enabled), each at the time of the master state it names (``master_utime``: the readings it was
    computed from, however late the stand-in published them), the Phantom driver's and the arm
    driver's states (t, positions), and how many commands were left out (their state not recorded)."""
    channels = LcmChannels()
    named, states, slave = [], {}, []
    for event in lcm.EventLog(str(log), "r"):
        if event.channel == channels.master_command.name:
            msg = heft_haptic_command.decode(event.data)
            named.append((msg.master_utime, np.array(msg.torque), msg.enable))
        elif event.channel == channels.master_state.name:
            msg = heft_haptic_state.decode(event.data)
            states[msg.utime] = np.array(msg.position)
        elif event.channel == channels.slave_status.name:
            msg = lcmt_iiwa_status.decode(event.data)
            slave.append((msg.utime * 1e-6, np.array(msg.joint_position_measured)))
    # Judged at its own state only: a command naming none (before the first), or one the recording lost.
    commands = sorted(((utime * 1e-6, torque, enabled) for utime, torque, enabled in named if utime in states),
                      key=lambda command: command[0])
    master = sorted(((utime * 1e-6, position) for utime, position in states.items()), key=lambda state: state[0])
    return commands, master, sorted(slave, key=lambda m: m[0]), len(named) - len(commands)


@pytest.fixture(scope="module")
def two_process_run(tmp_path_factory):
    from conftest import network_namespace

    folder = tmp_path_factory.mktemp("grasp")
    holding_from = GRASP_AT + GRIPPER_CLOSING_S
    with network_namespace() as netns:
        return _run(netns, folder, MOVE_FROM, STILL_FROM, STILL_FROM, END,
                    {after: holding_from + after for after in (1.0, 2.0)})


@pytest.fixture(scope="module")
def held_still_run(tmp_path_factory):
    """The operator holds still throughout, the clutch engaged; judged from 0.5 s after the grasp."""
    from conftest import network_namespace

    folder = tmp_path_factory.mktemp("grasp_held_still")
    with network_namespace() as netns:
        return _run(netns, folder, 2 * HELD_STILL_END, 2 * HELD_STILL_END, GRASP_AT, HELD_STILL_END,
                    {0.5: GRASP_AT + 0.5})


def _run(netns, folder, move_from, clutch_release_at, still_from, end, learned_by):
    """Both processes for ``end`` s: the operator's strokes from ``move_from`` s, the clutch let go at
    ``clutch_release_at`` s; judged (``grasp_judge``, the slave still from ``still_from`` s) from each
    ``learned_by`` time (s) under its key."""
    scenario = resolve_scenario("grasp")
    truth_load, phi_gripper = true_load(scenario)
    estimate = folder / "gripper.yaml"  # the gripper identified alone (its true φ and the sensor's offsets)
    estimate.write_text(f"phi: {phi_gripper.tolist()}\noffsets: {truth_load.offsets.tolist()}\n")
    log, stand_in_out = folder / "traffic.lcmlog", folder / "stand_in.json"
    teleop = stand_in = rezero = None
    try:
        teleop = _Process(netns, folder, "teleop", "teleop", "--hardware", "--scenario", "grasp", "--lcm-url",
                          LCM_URL, "--set", _settings(), "--estimate", str(estimate), "--duration", FOREVER,
                          "--record", str(log), "--out", str(folder / "teleop"))
        teleop.wait_for("teleop: running")
        # Started with the lab, it re-zeroes once the controller is healthy, with the slave still at rest.
        rezero = _Process(netns, folder, "rezero", "load", "--lcm-url", LCM_URL, "--rezero", "--timeout", "30")
        stand_in = _Process(netns, folder, "stand_in", "stand-in", "--scenario", "grasp", "--lcm-url", LCM_URL,
                            "--set", overrides_text({"operator.start_time": move_from}), "--duration", str(end + 1.0),
                            "--grasp-at", str(GRASP_AT), "--clutch-at", "0", "--clutch-release-at",
                            str(clutch_release_at),
                            "--out", str(folder))
        stand_in.wait_for("stand-in: publishing")
        epoch = float(re.search(r"stamps count from ([0-9.]+) s", stand_in.text()).group(1))
        while time.time() < epoch + end:
            assert stand_in.popen.poll() is None, stand_in.text()
            time.sleep(0.1)
        summary = _summary(teleop, folder)
        assert stand_in.wait() == 0, stand_in.text()
        rezero.wait(timeout=30)
    finally:
        _stop_all(teleop, stand_in, rezero)
    print(stand_in.text(), rezero.text())
    lab = json.loads(stand_in_out.read_text())
    lab["arm_late_steps"] = np.load(folder / "stand_in.truth.npz")["arm_late_steps"]
    late = max(lab["lateness_ms_by_second"][int(GRASP_AT) - 1:math.ceil(end)])
    if late > LATE_MS:
        return summary, lab, rezero.text(), (
            f"the stand-in published up to {late:.0f} ms behind its own clock around the grasp and after (CPU "
            f"{lab['cpu_s']:.1f} s over {lab['duration_s']:.1f} s): a machine this busy cannot play the lab in real "
            "time, so the grasp is not judged across processes here (test_grasp_lab judges it in one process, "
            "on one clock, and with a stalling lab)")
    truth = np.load(folder / "stand_in.truth.npz")
    commands, master, slave, unjudged = _traffic(log)
    print(f"{len(commands)} commands judged at their master states, {unjudged} not (their state not recorded)")
    history = [(summary["epoch"] + t - epoch, phi) for t, phi in summary["estimator"]["phi_history"]]
    results = {key: judge(truth, history, summary["estimator"]["phi_gripper"] or phi_gripper, commands, master,
                          slave, robot=scenario.robot, eta=ETA, force_scale=1.0, learned_by=start,
                          still_from=still_from, end=end)
               for key, start in learned_by.items()}
    for start, result in zip(learned_by.values(), results.values()):
        print(f"from {start:g} s:\n{report(result)}")
    return summary, lab, rezero.text(), results


def judged(results):
    """The judge's results, or a skip saying why the run was not judged."""
    if isinstance(results, str):
        pytest.skip(results)
    return results


def test_the_grasp_is_heard_and_answered(two_process_run):
    """Judged or not: the re-zero, the gripper driver's grasp and the answer when the learning window ends
    (the object's mass, or that it was not learned: a late lab's readings are refused)."""
    summary, _, rezero, _ = two_process_run
    events = summary["load_events"]
    assert "re-zeroed" in rezero, rezero
    assert summary["estimator"]["holding"], events
    assert any(event.startswith("gripper driver: grasp") for event in events), events
    assert any(event.startswith(("object learned over", "object not learned over")) for event in events), events


def test_the_object_is_learned(two_process_run):
    results = judged(two_process_run[3])
    assert results[1.0]["object_mass"] > 0.4
    assert results[1.0]["mass_error_max"] <= 0.02  # from 1 s after the grasp on


def test_holding_still_the_stylus_feels_eta_of_the_objects_weight(two_process_run):
    result = judged(two_process_run[3])[1.0]
    assert result["still_expected_force"] == pytest.approx(ETA * result["object_mass"] * 9.81, rel=0.02)
    assert len(result["still"]) > 50 and max(result["still"]) <= BOUND


def test_the_controller_sees_the_arms_late_commands_within_what_the_lab_recorded(two_process_run):
    """Judged or not: the statuses whose echo showed the controller a late command (the newest status each
    tick) are at most the arm's late steps the stand-in recorded (every step), and lag no more."""
    summary, lab, _, _ = two_process_run
    lag, late = summary["arm_command_lag"], lab["arm_late_steps"]
    assert lag["statuses"] > 10000 and lag["late"] <= len(late)
    step_us = 1e6 / LcmChannels().slave_status.rate
    assert lag["max_lag"] <= (round(late[:, 1].max() / step_us) - 1 if len(late) else 0)


def test_the_stylus_force_stays_within_the_devices_limits(two_process_run):
    """Judged or not: by the controller's account and by the Phantom driver's, at the states commands name."""
    summary, lab, _, results = two_process_run
    assert lab["stylus_force_peak"] <= MAX_FORCE + 1e-9
    assert summary["stylus_force_peak"] <= MAX_FORCE + 1e-9 and summary["master_torque_finite"]
    if not isinstance(results, str):
        assert results[1.0]["stylus_force_peak"] <= MAX_FORCE + 1e-9


def test_while_moving_the_stylus_follows_contact_and_eta_of_the_objects_wrench(two_process_run):
    """Judged in the strokes but where the arm stepped on late commands (the loop paused, or its commands
    came after the arm's step) and the load rang on its mount after it (``grasp_judge``;
    ``test_grasp_lab.test_a_paused_loop_rings_the_mount``). A machine that paused so often that too little
    is left to judge skips it, naming the pauses."""
    result = judged(two_process_run[3])[1.0]
    if len(result["moving"]) <= 50:
        pytest.skip(f"the arm stepped on late commands {len(result['pauses'])} times ((first, last, lag in steps): "
                    f"{result['pauses']}): only {len(result['moving'])} windows of the strokes are clear of the "
                    "mount's ring")
    assert max(result["moving"]) <= BOUND


def test_held_still_the_object_is_learned_at_rest(held_still_run):
    """Judged or not: the grasp answered with the object's mass; judged: from 0.5 s after the gripper began to
    close (0.3 s after it holds), the object's mass within 2 %."""
    summary, _, _, results = held_still_run
    assert any(event.startswith("object learned over") for event in summary["load_events"]), summary["load_events"]
    result = judged(results)[0.5]
    assert result["object_mass"] > 0.4
    assert result["mass_error_max"] <= 0.02


def test_held_still_from_half_a_second_after_the_grasp_the_stylus_feels_eta_of_the_weight(held_still_run):
    result = judged(held_still_run[3])[0.5]
    assert result["still_expected_force"] == pytest.approx(ETA * result["object_mass"] * 9.81, rel=0.02)
    assert len(result["still"]) > 50 and max(result["still"]) <= BOUND
