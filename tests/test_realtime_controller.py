"""The one-computation-per-tick controller against the per-block Diagram it stands for.

Both get the same input sequence — the stylus moving, the clutch released and
re-engaged, a contact, a NaN sensor sample, the slave at rest and a re-zero — tick by tick; the master torque and
every logged signal agree at the same tick, the slave command one tick earlier
(systems.realtime_controller explains why)."""

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from heft.diagrams.scenario import Scenario
from heft.systems.accelerometer_reading import AT_S
from heft.diagrams.running.simulation import true_load
from heft.systems.offset_tracking import COLLECTING, DONE
from heft.diagrams.teleop import MakeRealtimeTeleopController, MakeTeleopController
from heft.systems.rx_inverse_kinematics import RxKinematics

from controller_inputs import (FAULT_TICK, FEEDTHROUGH, PERIOD, REZERO_TICK, both_runs_scenario,
                               input_sequence)

SIGNALS_READ = ("master.position_measured", "master.velocity_estimated", "slave.position_measured",
                "slave.velocity_estimated", "ft.wrench_measured", "ft.acceleration_measured")
STATE_LOGS = ("master.torque_commanded", "slave.position_commanded", "log.pose_RS_desired", "log.passivity_energy",
              "log.passivity_damping", "log.applied_wrench", "log.scales", "log.offsets", "log.rezero_status",
              "log.phi_hat")


def run_both(scenario: Scenario, load, sequence: list[dict]):
    """The per-block Diagram and the fused step on ``sequence`` (a re-zero where its ``rezero`` counter
    rises; online, a new load where its ``estimator_reset`` counter rises): per tick, the feedthrough
    signals the Diagram computed from its inputs and the state the update left, and the fused step's."""
    period = PERIOD
    accelerometer = scenario.accelerometer.convention()
    diagram = MakeTeleopController(scenario.controller, load, scenario.robot, period, scenario.slave_initial_q,
                                   accelerometer=accelerometer)
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    blocks = []
    for k, inputs in enumerate(sequence):
        for name, value in inputs.items():
            diagram.GetInputPort(name).FixValue(context, value)
        if k == 0:
            simulator.Initialize()
        # What tick k computes from its inputs and the state it starts with (feedthrough outputs) …
        used = {name: diagram.GetOutputPort(name).Eval(context).copy() for name in FEEDTHROUGH}
        simulator.AdvanceTo((k + 1) * period)  # runs the update of tick k on these inputs
        # … and the state its update leaves.
        blocks.append(used | {name: diagram.GetOutputPort(name).Eval(context).copy() for name in STATE_LOGS})

    fused = MakeRealtimeTeleopController(scenario.controller, load, scenario.robot, scenario.controller_period,
                                         accelerometer=accelerometer)
    fused.start(sequence[0]["slave.position_measured"])
    steps, previous = [], sequence[0]
    for inputs in sequence:
        if inputs["rezero"][0] > previous["rezero"][0]:
            fused.request_rezero()
        if "estimator_reset" in inputs and inputs["estimator_reset"][0] > previous["estimator_reset"][0]:
            fused.estimator.new_load()
        previous = inputs
        fused.step(period, *(inputs[name] for name in SIGNALS_READ), inputs["clutch"][0] > 0.5)
        steps.append({"master.torque_commanded": fused.torque.copy(), "slave.position_commanded": fused.position.copy(),
                      "log.wrench_feedback": fused.wrench_feedback.copy(), "log.wrench_contact":
                      fused.wrench_contact.copy(), "log.master_wrench": fused.master_wrench.copy(),
                      "log.pose_RS_desired": fused.pose_RS_desired.copy(), "log.passivity_energy": fused.energy.copy(),
                      "log.passivity_damping": fused.damping.copy(), "log.applied_wrench": fused.applied_wrench.copy(),
                      "log.scales": fused.scales.copy(),
                      "log.offsets": fused.offsets.copy(), "log.rezero_status": [fused.rezero_status],
                      "log.phi_hat": fused.phi.copy(),
                      "enabled": fused.estimator is not None and fused.estimator.enabled})
    return blocks, steps, fused


@pytest.fixture(scope="module")
def both_runs():
    scenario = both_runs_scenario()
    load, _ = true_load(scenario)
    assert scenario.accelerometer.convention().displaced  # displaced from S: the transport runs in both
    assert scenario.controller.force.mount_notch > 0  # and so does the notch on the contact
    blocks, steps, _ = run_both(scenario, load, input_sequence(scenario, PERIOD))
    return blocks, steps


COMPARED = ["master.torque_commanded", "log.wrench_feedback", "log.wrench_contact", "log.master_wrench",
            "log.pose_RS_desired", "log.passivity_energy", "log.passivity_damping", "log.applied_wrench", "log.scales",
            "log.offsets",
            "log.rezero_status", "log.phi_hat"]


def assert_same_signal(blocks, steps, name):
    expected = np.array([b[name] for b in blocks])
    actual = np.array([s[name] for s in steps])
    if name == "log.pose_RS_desired":  # a quaternion and its negative are the same rotation
        actual[:, 3:] *= np.sign(np.sum(actual[:, 3:] * expected[:, 3:], axis=1, keepdims=True))
    np.testing.assert_allclose(actual, expected, rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("name", COMPARED)
def test_same_tick_signals_equal_the_per_block_diagram(both_runs, name):
    assert_same_signal(*both_runs, name)


def test_slave_command_is_the_per_block_command_one_tick_earlier(both_runs):
    blocks, steps = both_runs
    expected = np.array([b["slave.position_commanded"] for b in blocks])[1:]
    actual = np.array([s["slave.position_commanded"] for s in steps])[:-1]
    np.testing.assert_allclose(actual, expected, rtol=0, atol=1e-9)
    assert np.ptp(actual, axis=0).max() > 0.01, "the sequence should move the slave command"


def test_the_sequence_exercises_contact_clutch_and_fault(both_runs):
    """Guards the equality tests against a sequence that leaves branches untouched."""
    _, steps = both_runs
    contact = np.array([s["log.wrench_contact"] for s in steps])
    np.testing.assert_allclose(contact[150] - contact[149], [0, 0, 5.0, 0.2, 0, 0], atol=0.05)
    assert np.all(contact[FAULT_TICK] == 0.0)
    desired = np.array([s["log.pose_RS_desired"] for s in steps])
    np.testing.assert_array_equal(desired[200:260], np.repeat(desired[199:200], 60, axis=0))
    status = np.array([s["log.rezero_status"][0] for s in steps])
    assert status[REZERO_TICK] == COLLECTING and status[-1] == DONE
    offsets = np.array([s["log.offsets"] for s in steps])
    assert np.abs(offsets[-1] - offsets[REZERO_TICK]).max() > 0.1, "the re-zero should move the offsets"
    assert np.abs(offsets[-1] - offsets[-30]).max() > 0, "tracking should run at rest after the re-zero"


def test_step_before_start_is_refused():
    scenario = Scenario()
    load, _ = true_load(scenario)
    fused = MakeRealtimeTeleopController(scenario.controller, load, scenario.robot, scenario.controller_period,
                                         accelerometer=AT_S)
    with pytest.raises(RuntimeError, match="start"):
        fused.step(5e-4, *([np.zeros(6)] * 6), True)
    with pytest.raises(ValueError, match="finite"):
        fused.start([0.0, np.nan, 0, 0, 0, 0])


def test_the_diagram_controller_steps_the_per_block_diagram_tick_for_tick(both_runs):
    """``DiagramTeleopController`` (``--controller diagram``) on the same sequence: its commands and logged
    signals are the per-block Diagram's as the simulator steps it, exactly, up to the re-zero it does not
    take (the state its update leaves, and the wrenches the tick computed before it); before its start it
    reports the load it was given; restarted, it starts over from the slave's position and keeps the offsets."""
    from heft.diagrams.diagram_teleop_controller import DiagramTeleopController

    blocks, _ = both_runs
    scenario = both_runs_scenario()
    load, _ = true_load(scenario)
    sequence = input_sequence(scenario, PERIOD)
    controller = DiagramTeleopController(scenario.controller, load, scenario.robot, PERIOD,
                                         accelerometer=scenario.accelerometer.convention())
    np.testing.assert_array_equal(controller.phi, load.phi)
    np.testing.assert_array_equal(controller.offsets, load.offsets)
    controller.start(sequence[0]["slave.position_measured"])
    for k, inputs in enumerate(sequence[:REZERO_TICK]):
        controller.step(PERIOD, *(inputs[name] for name in SIGNALS_READ), inputs["clutch"][0] > 0.5)
        for name, value in (("master.torque_commanded", controller.torque),
                            ("slave.position_commanded", controller.position),
                            ("log.applied_wrench", controller.applied_wrench), ("log.offsets", controller.offsets),
                            ("log.passivity_energy", controller.energy), ("log.phi_hat", controller.phi),
                            # what the tick computed from its readings, as the fused step reports it
                            ("log.wrench_feedback", controller.wrench_feedback),
                            ("log.wrench_contact", controller.wrench_contact),
                            ("log.master_wrench", controller.master_wrench)):
            np.testing.assert_array_equal(value, blocks[k][name], err_msg=f"{name} at tick {k}")
    offsets = controller.offsets.copy()
    controller.start(sequence[0]["slave.position_measured"])
    arm = RxKinematics.rx90() if scenario.robot == "rx90" else RxKinematics.rx60()
    np.testing.assert_array_equal(controller.position, np.clip(sequence[0]["slave.position_measured"], arm.lower,
                                                               arm.upper))
    np.testing.assert_array_equal(controller.offsets, offsets)
