"""Recorded station readings that exercise the controller's features tick by tick, and the scenario
they are meant for: the tests hold two ways of stepping the controller equal on them."""

import numpy as np
from pydrake.systems.analysis import Simulator

from heft.diagrams.scenario import Scenario, layered, overrides_text

TICKS = 440
FAULT_TICK = 300
REST_TICK = 320    # the slave stands still from here on, out of contact
REZERO_TICK = 330  # a re-zero is requested here; its window is 40 ticks
FEEDTHROUGH = ("log.wrench_feedback", "log.wrench_contact", "log.master_wrench")
PERIOD = Scenario().controller_period


def input_sequence(scenario: Scenario, period: float) -> list[dict]:
    """Station readings for ``TICKS`` ticks: smooth master and slave motion, the load's weight
    with a contact over ticks 150–319, the clutch released over ticks 200–259, NaN at tick 300,
    the slave at rest from ``REST_TICK``, a re-zero requested at ``REZERO_TICK``."""
    rng = np.random.default_rng(7)
    q_M0, q_S0 = np.array(scenario.master_initial_q), np.array(scenario.slave_initial_q)
    w_M, w_S = rng.uniform(-1, 1, 6), rng.uniform(-0.5, 0.5, 6)
    sequence = []
    for k in range(TICKS):
        t = k * period
        contact = np.array([0, 0, 5.0, 0.2, 0, 0]) if 150 <= k < REST_TICK else np.zeros(6)
        wrench = np.array([0.3, -0.2, 30.7, 0.05, -0.1, 0.02]) + contact
        if k == FAULT_TICK:
            wrench = np.full(6, np.nan)
        slave_t = min(t, REST_TICK * period)
        sequence.append({
            "master.position_measured": q_M0 + 0.2 * np.sin(w_M * t * 10),
            "master.velocity_estimated": 2.0 * w_M * np.cos(w_M * t * 10),
            "slave.position_measured": q_S0 + 0.05 * np.sin(w_S * slave_t * 10),
            "slave.velocity_estimated": 0.5 * w_S * np.cos(w_S * t * 10) * (k < REST_TICK),
            "ft.wrench_measured": wrench,
            "ft.acceleration_measured": np.array([0.1, 0.0, 0.3, 0.5, -0.2, 0.1]) * np.sin(5 * t),
            "clutch": np.array([0.0 if 200 <= k < 260 or k >= REST_TICK else 1.0]),
            "rezero": np.array([float(k >= REZERO_TICK)]),
        })
    return sequence



def both_runs_scenario() -> Scenario:
    """The scenario ``both_runs`` runs."""
    return layered(Scenario(), overrides_text({
        "controller.motion.translation_scale": 2.0,
        "controller.motion.R_RB": [0.0, 0.0, 0.4],  # the master's base turned: both map the feedback back through it
        "controller.motion.master_filter": 60.0,  # the master's positions low-passed for the motion mapping
        "controller.force.sigma": 0.5,
        "controller.offsets.rezero_window": 40 * PERIOD,
        # The sequence's wrench is not a load at rest; wide gates let the re-zero and tracking run.
        **{f"controller.offsets.{gate}": 1e3
           for gate in ("rezero_force", "rezero_torque")},
        "controller.contact.force": 1e3, "controller.contact.torque": 1e3}))


def _outputs(diagram) -> tuple[list[str], list[str]]:
    """The Diagram's outputs without feedthrough (its state) and those with (computed from a tick's inputs)."""
    state, computed = [], []
    for i in range(diagram.num_output_ports()):
        (computed if diagram.HasDirectFeedthrough(i) else state).append(diagram.get_output_port(i).get_name())
    return state, computed


def drake_run(diagram, sequence: list[dict]) -> list[dict]:
    """Drake's Simulator on the controller ``diagram`` fed ``sequence`` (each tick's inputs by name): per tick,
    the outputs computed from the tick's inputs (feedthrough; as "computed NAME") and the others after its
    update."""
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    state, computed = _outputs(diagram)
    ticks = []
    for k, inputs in enumerate(sequence):
        for name, value in inputs.items():
            diagram.GetInputPort(name).FixValue(context, value)
        if k == 0:
            simulator.Initialize()
        tick = {f"computed {name}": diagram.GetOutputPort(name).Eval(context).copy() for name in computed}
        simulator.AdvanceTo((k + 1) * PERIOD)
        ticks.append({name: diagram.GetOutputPort(name).Eval(context).copy() for name in state} | tick)
    return ticks


def program_run(program, sequence: list[dict], each_tick=None) -> list[dict]:
    """``TickProgram`` ``program`` fed ``sequence`` as ``drake_run`` feeds its Diagram, the same record per tick;
    ``each_tick(k, program)`` after each tick adds what it returns to the record."""
    state, computed = _outputs(program.diagram)
    ticks = []
    for k, inputs in enumerate(sequence):
        for name, value in inputs.items():
            program.input(name)[:] = value
        if k == 0:
            program.reset()
            program.initialize()
        program.tick()
        ticks.append({name: program.output(name).copy() for name in state}
                     | {f"computed {name}": program.output(name).copy() for name in computed}
                     | (each_tick(k, program) if each_tick else {}))
    return ticks
