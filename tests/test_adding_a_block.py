"""A block added to the controller Diagram runs in every way the Diagram is stepped: the example of
docs/adding_a_block.md, taken from the page as written, in the Diagram's program against Drake's stepping
and on the lab's LCM channels against the stand-in."""

import importlib.util
import math
import re
from pathlib import Path

import lcm
import numpy as np
import pytest

from heft.diagrams.load_estimate import LoadEstimate
from heft.diagrams.running.hardware_teleop import HardwareTeleop
from heft.diagrams.running.simulation import true_load
from heft.diagrams.scenario import resolve_scenario
from heft.diagrams.stations.stand_in import FaultInjection, StandIn
from heft.diagrams.teleop import MakeTeleopController
from heft.hardware_interface.channels import LcmChannels
from heft.systems.tick_program import TickProgram

from controller_inputs import PERIOD, both_runs_scenario, drake_run, input_sequence, program_run

PAGE = Path(__file__).resolve().parent.parent / "docs" / "adding_a_block.md"
CUTOFF = 5.0  # Hz


@pytest.fixture(scope="module")
def example(tmp_path_factory):
    """The page's example block, as a module of its own."""
    code = re.search(r"<!-- feedback-block -->\n```python\n(.*?)```", PAGE.read_text(), re.S).group(1)
    path = tmp_path_factory.mktemp("lab") / "lab_blocks.py"
    path.write_text(code)
    spec = importlib.util.spec_from_file_location("lab_blocks", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_block_runs_in_the_program_as_drake_steps_it(example):
    scenario = both_runs_scenario()
    load, _ = true_load(scenario)

    def make():
        return MakeTeleopController(scenario.controller, load, scenario.robot, PERIOD, scenario.slave_initial_q,
                                    accelerometer=scenario.accelerometer.convention(),
                                    feedback_blocks=[lambda period: example.FeedbackLowPass(CUTOFF, period)])

    sequence = input_sequence(scenario, PERIOD)
    program = TickProgram(make())
    assert ("feedback_block_0", "filtered") in program.calculation_order
    for k, (tick, reference) in enumerate(zip(program_run(program, sequence), drake_run(make(), sequence),
                                              strict=True)):
        for name, value in reference.items():
            np.testing.assert_array_equal(tick[name], value, err_msg=f"{name} at tick {k}")


def test_the_block_runs_on_the_lab_against_the_stand_in(example):
    """With φ̂ = 0 and σ = 0 the controller renders the load's whole weight; through the block the force on the
    hand rises from its start as a first-order low-pass's step response, 1 − (1 − α)^(n+1) at tick n."""
    scenario = resolve_scenario("fig6", "{operator: {amplitude: [0.0, 0.0, 0.0]}, ft_sensor: {white_noise: false}, "
                                        "accelerometer: {white_noise: false, offsets: false}, "
                                        "controller: {force: {sigma: 0.0}, offsets: {tracking: false}}}")
    true = true_load(scenario)[0]
    bus = lcm.LCM("memq://")
    stand_in = StandIn(scenario, bus, LcmChannels(), FaultInjection())
    teleop = HardwareTeleop(scenario, LoadEstimate(phi=np.zeros(10), offsets=true.offsets), bus, LcmChannels(),
                            feedback_blocks=[lambda period: example.FeedbackLowPass(CUTOFF, period)])
    period = scenario.controller_period
    forces, now = [], 0.0
    for _ in range(round(0.6 / period)):
        now += period
        stand_in.step(now)
        teleop.tick(now, period)
        if teleop.controller.started:
            forces.append(np.linalg.norm(teleop.controller.applied_wrench[:3]))
    assert teleop.starts == 1 and not teleop.faults
    forces = np.array(forces)
    weight = true.phi[0] * 9.81 * scenario.controller.feedback.force_scale
    assert forces[-1] == pytest.approx(weight, rel=0.01)
    alpha = 1.0 - math.exp(-2.0 * math.pi * CUTOFF * period)
    n = np.arange(len(forces))
    np.testing.assert_allclose(forces[:200], weight * (1.0 - (1.0 - alpha) ** (n[:200] + 1)), rtol=0.02)
    assert forces[10] < 0.2 * weight  # without the block the whole weight from the first tick
