"""The grasp on hardware in one process: `heft stand-in`'s lab (``StandIn``, the grasp scenario, its
gripper closing on the 0.5 kg block at 2 s) and the controller on the hardware station
(``HardwareTeleop``: estimator online, η = 0.5, σ = 0, force scale 1), both stepped on one
explicit clock over memq://, so that the machine's load cannot make either late. The controller
starts from the gripper's φ alone, re-zeroes the sensor at rest (``heft load --rezero``'s command:
the offsets then take in what the accelerometer's bias makes of the gripper's weight, as an
identification's would) and hears the grasp from the gripper's driver; the slave follows the
operator's strokes from ``MOVE_FROM`` s until the clutch is let go at ``STILL_FROM`` s, then holds still. Judged by
``grasp_judge`` against the stand-in's truth (docs/hardware.md's targets, which
``test_two_process_grasp`` judges across two processes)."""

import json
import math

import lcm
import numpy as np
import pytest

from heft.diagrams.load_estimate import LoadEstimate
from heft.diagrams.running.hardware_teleop import HardwareTeleop
from heft.diagrams.running.simulation import true_load
from heft.diagrams.scenario import layered, overrides_text, resolve_scenario
from heft.diagrams.stations.stand_in import FaultInjection, StandIn
from heft.diagrams.stations.stand_in_wrist import GRIPPER_CLOSING_S, GraspTimes
from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.lcmtypes import heft_load_command

from grasp_judge import judge, report

pytestmark = pytest.mark.slow

PERIOD = 0.0005
MOVE_FROM, GRASP_AT, STILL_FROM, END = 1.0, 2.0, 4.5, 6.5
REZERO_AT = 0.25  # s: healthy, the forces ramped in, the slave at rest
WAIT = 0.2  # s after the grasp before learning (controller.estimator.new_load_wait): 2/prefilter
ETA, BOUND, MAX_FORCE = 0.5, 0.05, 8.5


def run_lab(end: float, stalls=None, controller=None, move_from: float = MOVE_FROM, pauses=None):
    """The lab and the controller stepped to ``end`` s; ``stalls(now)`` True holds the lab still at that
    tick (it publishes nothing, then catches up at once, as a lab running late does); ``pauses(now)`` True
    skips the controller's tick (the next one covers the gap, as after the controller's computer paused
    while the lab's drivers ran on); ``controller``:
    more of the controller's settings; the operator's strokes from ``move_from`` s. Returns (summary,
    stand_in's truth, commands, master, slave, scenario)."""
    lab_scenario = layered(resolve_scenario("grasp"), overrides_text({"operator.start_time": move_from}))
    scenario = layered(lab_scenario, overrides_text({
        "controller.estimator.mode": "online", "controller.force.eta": ETA, "controller.force.sigma": 0.0,
        "controller.feedback.force_scale": 1.0, "controller.estimator.new_load_wait": WAIT, **(controller or {})}))
    truth_load, phi_gripper = true_load(lab_scenario)
    bus = lcm.LCM("memq://")
    stand_in = StandIn(lab_scenario, bus, LcmChannels(), FaultInjection(), 0.0, STILL_FROM,
                       grasp=GraspTimes(GRASP_AT), record_truth=True)
    teleop = HardwareTeleop(scenario, LoadEstimate(phi=phi_gripper, offsets=truth_load.offsets), bus, LcmChannels())
    station = teleop.station
    commands, master, slave = [], [], []
    now, last_tick = 0.0, 0.0
    for _ in range(round(end / PERIOD)):
        now += PERIOD
        if stalls is None or not stalls(now):
            stand_in.step(now)
        if pauses is not None and pauses(now):
            continue
        if now - PERIOD < REZERO_AT <= now:
            command = heft_load_command()
            command.utime, command.action = round(now * 1e6), heft_load_command.REZERO
            bus.publish(LcmChannels().load_command.name, command.encode())
        teleop.tick(now, now - last_tick)
        last_tick = now
        commands.append((now, station.torque_sent.copy(), station.healthy))
        master.append((now, station.master_position.copy()))
        slave.append((now, station.slave_position.copy()))
    summary = teleop.summary(end)
    print(summary["load_events"])
    return summary, stand_in.truth.arrays(), commands, master, slave, scenario


@pytest.fixture(scope="module")
def lab_run():
    """The run, judged from 1 s after the grasp (the target's) and from 2 s."""
    summary, truth, commands, master, slave, scenario = run_lab(END)
    holding_from = GRASP_AT + GRIPPER_CLOSING_S
    results = {after: judge(truth, summary["estimator"]["phi_history"], summary["estimator"]["phi_gripper"],
                            commands, master, slave, robot=scenario.robot, eta=ETA, force_scale=1.0,
                            learned_by=holding_from + after, still_from=STILL_FROM, end=END)
               for after in (1.0, 2.0)}
    for after, result in results.items():
        print(f"from {after:g} s after the grasp:\n{report(result)}")
    return summary, results


def test_the_grasp_is_heard_from_the_driver_and_the_object_learned(lab_run):
    summary, results = lab_run
    lag = summary["arm_command_lag"]  # one clock: every command on time, each echoed
    assert lag["statuses"] > 10000 and (lag["late"], lag["unmeasured"]) == (0, 0)
    assert results[1.0]["pauses"] == []
    events = summary["load_events"]
    assert "re-zeroed" in events[1] and events[2].startswith("gripper driver: grasp"), events
    assert summary["estimator"]["holding"]
    assert results[1.0]["object_mass"] > 0.4
    assert results[1.0]["mass_error_max"] <= 0.02  # from 1 s after the grasp on


def test_holding_still_the_stylus_feels_eta_of_the_objects_weight(lab_run):
    _, results = lab_run
    result = results[1.0]
    assert result["still_expected_force"] == pytest.approx(ETA * result["object_mass"] * 9.81, rel=0.02)
    assert len(result["still"]) > 50 and max(result["still"]) <= BOUND


def test_the_stylus_force_stays_within_the_devices_limits(lab_run):
    _, results = lab_run
    assert results[1.0]["stylus_force_peak"] <= MAX_FORCE + 1e-9


def test_while_moving_the_stylus_follows_contact_and_eta_of_the_objects_wrench(lab_run):
    _, results = lab_run
    result = results[1.0]
    assert len(result["moving"]) > 50 and max(result["moving"]) <= BOUND


@pytest.mark.parametrize("pause", [PERIOD, 0.004])
def test_a_paused_loop_rings_the_mount(pause):
    """The controller's computer pauses once in the strokes (from ``PAUSE_AT`` s), the lab's drivers running
    on: the arm holds its last command through the pause, then takes the command the master's motion
    meanwhile asks for; the stand-in's truth records each step its arm took on a late command, and the
    controller sees the lag in the arm's echo of the command it took. One tick skipped (the loop's usual
    hiccup: a tick 1 ms after the last) leaves every window within the bound, and the judge sees no pause.
    A 4 ms pause in these strokes (the slave's joints at up to 2.1 rad/s) brakes the arm hard enough to ring
    the load on its compliant mount, and the ring is the object's own non-contact wrench, which the stylus
    does not render: the accelerometer sits on the sensor, not on the rocking load, and the contact
    channel's notch holds the ring back from the stylus by design. The windows in the pause and its ring
    miss the bound (the judge sets them apart); those before and after it meet it."""
    end = STILL_FROM + 0.1
    summary, truth, commands, master, slave, scenario = run_lab(
        end, pauses=lambda now: 0 < round((now - PAUSE_AT) / PERIOD) <= round(pause / PERIOD))
    result = judge(truth, summary["estimator"]["phi_history"], summary["estimator"]["phi_gripper"], commands,
                   master, slave, robot=scenario.robot, eta=ETA, force_scale=1.0,
                   learned_by=GRASP_AT + GRIPPER_CLOSING_S + 1.0, still_from=STILL_FROM, end=end)
    print(report(result))
    assert len(result["moving"]) > 50 and max(result["moving"]) <= BOUND
    # The arm's step after the last tick before the pause takes that tick's command, on time; the next ones
    # step on it, one step older each.
    skipped = round(pause / PERIOD)
    late = truth["arm_late_steps"] * 1e-6
    np.testing.assert_allclose(late, np.column_stack((PAUSE_AT + PERIOD * np.arange(2, skipped + 2),
                                                      PERIOD * np.arange(2, skipped + 2))), atol=1e-7)
    # The controller saw the same from the arm's echo, at the one status it read after the pause.
    lag = summary["arm_command_lag"]
    assert (lag["late"], lag["max_lag"], lag["unmeasured"]) == (1, skipped, 0)
    # Timed from the first status heard after a command: the arm's second step, at 2 periods.
    assert lag["max_lag_at"] == pytest.approx(late[-1, 0] - 2 * PERIOD)
    if skipped == 1:
        assert result["pauses"] == [] and result["after_pause"] == []
    else:
        assert result["pauses"] == [(late[0, 0], late[-1, 0], skipped * (skipped + 1) // 2)]
        assert max(result["after_pause"]) > 3 * BOUND


PAUSE_AT = 3.7
"""s: the middle of the judged strokes (1 s after the object is held, until the clutch is let go)."""
STALL_EVERY, STALL_FOR = 0.7, 0.04
"""s: from 1.5 s on, the lab stalls this long this often (a lab running late on a busy computer); the
controller's watchdog (20 ms) cuts the forces meanwhile and brings them back."""


@pytest.mark.parametrize("max_input_age", [0.005, math.inf])
def test_a_stalling_lab_is_not_learned_from(max_input_age):
    """The object learned while the lab stalls now and then: a stall's catch-up jerks the arm and rings
    the load on its compliant mount. Judging the readings' age (``controller.estimator.max_input_age``),
    the estimator learns only from a steady stream, and the object's mass is right at the window's end;
    without (inf) it learns the ringing too, and the mass is off by more than the 2 % (the mechanism
    behind the two-process runs on a busy machine, ``test_two_process_grasp``)."""
    end = GRASP_AT + GRIPPER_CLOSING_S + WAIT + 1.5
    summary, truth, *_ = run_lab(end, stalls=lambda now: now > 1.5 and now % STALL_EVERY < STALL_FOR,
                                 controller={"controller.estimator.max_input_age": max_input_age})
    json.dumps(summary)  # as `heft teleop --out` writes it
    object_mass = truth["phi"][-1, 0] - truth["phi_gripper"][0]
    learned = summary["estimator"]["phi_final"][0] - summary["estimator"]["phi_gripper"][0]
    learned_event = summary["load_events"][-1]
    assert learned_event.startswith("object learned over"), summary["load_events"]
    if math.isfinite(max_input_age):
        assert abs(learned - object_mass) <= 0.02 * object_mass
        assert "ticks refused, their readings older than 5 ms" in learned_event
        assert summary["estimator"]["stale_since_new_load"] > 0
    else:
        assert abs(learned - object_mass) > 0.02 * object_mass
        assert "refused" not in learned_event


def test_strokes_started_late_do_not_swing_the_grippers_estimate():
    """The strokes start 1.8 s in, past the estimator's learning window (1.5 s) and just before the
    grasp, as in the two-process test: the first samples taken, at the strokes' slow start, barely
    excite what they would pull φ̂ along, and the estimate's prior holds it (with none, one sample
    set I_yy to −2.9 kg·m² and the contact that φ̂ then saw closed the gate for good). The gripper's
    φ̂ at the grasp is its own, and the object is learned within 2 %."""
    summary, truth, *_ = run_lab(GRASP_AT + GRIPPER_CLOSING_S + WAIT + 1.5, move_from=1.8)
    phi_gripper, kept = truth["phi_gripper"], np.array(summary["estimator"]["phi_gripper"])
    assert abs(kept[0] - phi_gripper[0]) <= 0.005 * phi_gripper[0]
    np.testing.assert_allclose(kept[1:4], phi_gripper[1:4], atol=0.005)  # kg·m: m·c within 3 mm of c
    object_mass = truth["phi"][-1, 0] - phi_gripper[0]
    learned = summary["estimator"]["phi_final"][0] - kept[0]
    assert abs(learned - object_mass) <= 0.02 * object_mass


def test_held_still_the_object_is_learned_at_rest_and_felt_at_eta():
    """The operator holds still throughout (the clutch engaged, no strokes), the gripper closing at 2 s: the object
    is learned at rest (``RestLearner``: its mass and the moment the pose shows), within 2 % from 0.5 s after the
    grasp, and from then the stylus feels η of its weight within the bound on 10 ms averages; the answer says what
    waits for the arm to move."""
    end = GRASP_AT + GRIPPER_CLOSING_S + 1.6  # the learning window over, answered
    summary, truth, commands, master, slave, scenario = run_lab(end, move_from=2 * end)
    result = judge(truth, summary["estimator"]["phi_history"], summary["estimator"]["phi_gripper"], commands,
                   master, slave, robot=scenario.robot, eta=ETA, force_scale=1.0, learned_by=GRASP_AT + 0.5,
                   still_from=GRASP_AT, end=end)
    print(report(result))
    assert "at rest only: its centre of mass along gravity and its inertia are learned once the arm moves" in \
        summary["load_events"][-1], summary["load_events"]
    assert result["object_mass"] > 0.4 and result["mass_error_max"] <= 0.02
    assert result["still_expected_force"] == pytest.approx(ETA * result["object_mass"] * 9.81, rel=0.02)
    assert len(result["still"]) > 50 and max(result["still"]) <= BOUND
