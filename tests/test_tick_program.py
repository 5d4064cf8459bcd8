"""The controller Diagram stepped as a ``TickProgram`` (and as one ``TickProgramSystem``) against Drake's own
stepping of the same Diagram, tick for tick, on recorded readings (``controller_inputs``)."""

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource

from heft.diagrams.running.simulation import true_load
from heft.diagrams.teleop import MakeTeleopController
from heft.systems.controller.passivity_controller import PassivityController
from heft.systems.compiled import PURE_PYTHON
from heft.systems.tick_program import TickProgram
from heft.systems.tick_program_system import TickProgramSystem
from heft.systems.tick_system import TickConstant

from controller_inputs import FEEDTHROUGH, PERIOD, both_runs_scenario, drake_run, input_sequence, program_run


def make_controller():
    scenario = both_runs_scenario()
    load, _ = true_load(scenario)
    return MakeTeleopController(scenario.controller, load, scenario.robot, PERIOD, scenario.slave_initial_q,
                                accelerometer=scenario.accelerometer.convention()), scenario


@pytest.fixture(scope="module")
def recorded():
    scenario = both_runs_scenario()
    sequence = input_sequence(scenario, PERIOD)
    return sequence, drake_run(make_controller()[0], sequence)


@pytest.mark.parametrize("compile", [True, False], ids=["compiled", "kernel by kernel"])
def test_the_program_steps_the_diagram_exactly(recorded, compile):
    sequence, expected = recorded
    program = TickProgram(make_controller()[0], compile=compile)
    assert program.compiled == (compile and not PURE_PYTHON)
    for k, (tick, reference) in enumerate(zip(program_run(program, sequence), expected, strict=True)):
        for name, value in reference.items():
            np.testing.assert_array_equal(tick[name], value, err_msg=f"{name} at tick {k}")


def test_the_program_as_one_system_steps_the_diagram_exactly(recorded):
    """And an output port gathering others (state and calculated ones, interleaved) is theirs end to end."""
    sequence, expected = recorded
    diagram, _ = make_controller()
    held = ("master.torque_commanded", "slave.position_commanded", "log.offsets", "log.passivity_energy")
    gathered = [name for pair in zip(held, FEEDTHROUGH) for name in pair]
    system = TickProgramSystem(diagram, gathered={"gathered": gathered})
    simulator = Simulator(system)
    context = simulator.get_mutable_context()
    for k, inputs in enumerate(sequence):
        for name, value in inputs.items():
            system.GetInputPort(name).FixValue(context, value)
        if k == 0:
            simulator.Initialize()
        for name in FEEDTHROUGH:
            np.testing.assert_array_equal(system.GetOutputPort(name).Eval(context), expected[k][f"computed {name}"],
                                          err_msg=f"{name} at tick {k}")
        if k > 0:  # the state the last tick left, what this tick's inputs calculate
            np.testing.assert_array_equal(system.GetOutputPort("gathered").Eval(context), np.concatenate(
                [expected[k - 1][name] if name in held else expected[k][f"computed {name}"] for name in gathered]),
                err_msg=f"gathered at tick {k}")
        simulator.AdvanceTo((k + 1) * PERIOD)
        for name in held:
            np.testing.assert_array_equal(system.GetOutputPort(name).Eval(context), expected[k][name],
                                          err_msg=f"{name} at tick {k}")


def test_the_one_system_keeps_the_diagrams_ports_and_closes_loops_as_it_does():
    """Same ports; an output without feedthrough in the Diagram (its state) has none in the one system, so a
    loop the Diagram closes through the station closes through it too."""
    diagram, _ = make_controller()
    system = TickProgramSystem(diagram)
    assert [system.get_input_port(i).get_name() for i in range(system.num_input_ports())] == \
        [diagram.get_input_port(i).get_name() for i in range(diagram.num_input_ports())]
    assert [system.get_output_port(i).get_name() for i in range(system.num_output_ports())] == \
        [diagram.get_output_port(i).get_name() for i in range(diagram.num_output_ports())]
    for o in range(diagram.num_output_ports()):
        through = [diagram.HasDirectFeedthrough(i, o) for i in range(diagram.num_input_ports())]
        if not any(through):
            assert not any(system.HasDirectFeedthrough(i, o) for i in range(system.num_input_ports()))
        else:
            assert all(system.HasDirectFeedthrough(i, o) for i in range(system.num_input_ports()) if through[i])
    assert not system.HasDirectFeedthrough(system.GetOutputPort("master.torque_commanded").get_index())


def test_the_one_system_reads_each_contexts_own_inputs():
    """Two contexts of one system, σ fixed in one and at its default in the other, stepped in turn: each tick
    takes its own σ, as a system of its own would."""
    diagram, scenario = make_controller()
    inputs = input_sequence(both_runs_scenario(), PERIOD)[50]
    sigma = np.array([0.1 if scenario.controller.force.sigma > 0.5 else 0.9])  # not the default

    def context_of(system, fixed):
        context = system.CreateDefaultContext()
        for name, value in inputs.items():
            system.GetInputPort(name).FixValue(context, value)
        if fixed:
            system.GetInputPort("sigma").FixValue(context, sigma)
        return context

    def step(system, context):
        return system.EvalUniquePeriodicDiscreteUpdate(context).get_vector().CopyToVector()

    expected = []
    for fixed in (True, False):
        alone = TickProgramSystem(diagram)
        expected.append(step(alone, context_of(alone, fixed)))
    assert np.abs(expected[0] - expected[1]).max() > 1e-3  # σ shows in the tick
    system = TickProgramSystem(diagram)
    contexts = [context_of(system, fixed) for fixed in (True, False)]
    for _ in range(3):
        for context, reference in zip(contexts, expected):
            system.GetInputPort("ft.wrench_measured").FixValue(context, inputs["ft.wrench_measured"])  # a new value
            np.testing.assert_array_equal(step(system, context), reference)


def test_the_recording_exercises_what_it_claims(recorded):
    """Guards the equality against a sequence that leaves the controller's branches untouched."""
    _, expected = recorded
    contact = np.array([tick["computed log.wrench_contact"] for tick in expected])
    assert np.abs(contact[150] - contact[149] - [0, 0, 5.0, 0.2, 0, 0]).max() < 0.05
    assert not contact[300].any()  # the NaN sample
    command = np.array([tick["slave.position_commanded"] for tick in expected])
    assert np.ptp(command, axis=0).max() > 0.01
    offsets = np.array([tick["log.offsets"] for tick in expected])
    assert np.abs(offsets[-1] - offsets[330]).max() > 0.1  # the re-zero


def test_a_block_added_to_the_diagram_is_in_the_program():
    """A block wired into a Diagram runs in its program with nothing else written."""
    builder = DiagramBuilder()
    passivity = builder.AddNamedSystem("passivity", PassivityController(period=PERIOD))
    wrench = builder.AddNamedSystem("wrench", TickConstant([1.0, 2.0, 0.0, 0.0, 0.0, 0.0]))
    builder.Connect(wrench.get_output_port(), passivity.GetInputPort("wrench"))
    builder.ExportInput(passivity.GetInputPort("velocity"), "velocity")
    builder.ExportInput(passivity.GetInputPort("jacobian"), "jacobian")
    builder.ExportOutput(passivity.GetOutputPort("torque"), "torque")
    program = TickProgram(builder.Build())
    jacobian = np.arange(36.0) / 10
    program.input("jacobian")[:] = jacobian
    program.tick()
    np.testing.assert_allclose(program.output("torque"), jacobian.reshape(6, 6).T @ [1.0, 2.0, 0, 0, 0, 0])


def test_a_diagram_of_other_systems_is_refused():
    builder = DiagramBuilder()
    builder.AddSystem(ConstantVectorSource([1.0]))
    with pytest.raises(TypeError, match="not a TickSystem"):
        TickProgram(builder.Build())


def test_an_input_connected_to_nothing_without_a_default_is_refused():
    builder = DiagramBuilder()
    builder.AddNamedSystem("passivity", PassivityController(period=PERIOD))
    with pytest.raises(ValueError, match="'wrench' of 'passivity' is connected to nothing"):
        TickProgram(builder.Build())


def test_a_diagram_inside_a_diagram_is_one_program(recorded):
    """The controller Diagram inside another (as beside a station): the same ticks, through the outer
    Diagram's ports."""
    sequence, expected = recorded
    builder = DiagramBuilder()
    controller = builder.AddNamedSystem("controller", make_controller()[0])
    for i in range(controller.num_input_ports()):
        builder.ExportInput(controller.get_input_port(i), controller.get_input_port(i).get_name())
    for i in range(controller.num_output_ports()):
        builder.ExportOutput(controller.get_output_port(i), controller.get_output_port(i).get_name())
    program = TickProgram(builder.Build())
    assert program.block("force_scaling") is controller.GetSubsystemByName("force_scaling")
    for k, (tick, reference) in enumerate(zip(program_run(program, sequence), expected, strict=True)):
        for name, value in reference.items():
            np.testing.assert_array_equal(tick[name], value, err_msg=f"{name} at tick {k}")


def test_an_input_feeding_blocks_of_different_defaults_is_refused():
    """Which default would hold is not the program's to choose: Drake takes each block's own."""
    from heft.systems.controller.motion_scaling import MotionScaling
    from heft.systems.controller.motion_scaling_params import MotionScalingParams

    builder = DiagramBuilder()
    one, two = (builder.AddNamedSystem(name, MotionScaling(MotionScalingParams(translation_scale=scale), PERIOD))
                for name, scale in (("one", 1.0), ("two", 2.0)))
    builder.ExportInput(one.GetInputPort("translation_scale"), "translation_scale")
    builder.ConnectInput("translation_scale", two.GetInputPort("translation_scale"))
    for name in ("pose_BE", "clutch", "pose_RT_measured"):
        builder.ExportInput(one.GetInputPort(name), name)
        builder.ConnectInput(name, two.GetInputPort(name))
    with pytest.raises(ValueError, match="'translation_scale' feeds block inputs of different defaults"):
        TickProgram(builder.Build())
