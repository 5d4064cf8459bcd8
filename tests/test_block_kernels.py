"""A block's kernels read its arrays by name: each takes its ports' and states' arrays and at most a record or two of
its settings and scratch (``compiled.record_views``), about a dozen arguments, on every bundled arm and with the
estimator online."""

import inspect

import pytest

from heft.diagrams.arm_params import BUNDLED_ARMS
from heft.diagrams.running.simulation import true_load
from heft.diagrams.scenario import resolve_scenario
from heft.diagrams.teleop import MakeTeleopController
from heft.systems.tick_program import TickProgram

MAX_ARGUMENTS = 13
"""The most arguments a block's kernel takes: about a dozen."""


def kernels(block):
    """(what, kernel, its arguments as declared) of every kernel ``block`` declares."""
    for calc in block.tick_calcs.values():
        yield f"calculation {calc.name}", calc.kernel, calc.args
    for what in ("updates", "initializations", "receives", "publishes"):
        for kernel, args in getattr(block, f"tick_{what}"):
            yield what, kernel, args


@pytest.mark.parametrize("arm", sorted(BUNDLED_ARMS))
def test_no_blocks_kernel_takes_more_than_about_a_dozen_arguments(arm):
    scenario = resolve_scenario("fig6", f"{{robot: {arm}, controller: {{estimator: {{mode: online}}}}}}")
    load, _ = true_load(scenario)
    program = TickProgram(MakeTeleopController(scenario.controller, load, scenario.robot, scenario.controller_period,
                                               scenario.slave_initial_q,
                                               accelerometer=scenario.accelerometer.convention()), compile=False)
    seen = 0
    for block in program.blocks:
        for what, kernel, args in kernels(block):
            function = getattr(kernel, "py_func", kernel)
            declared = len(inspect.signature(function).parameters)
            assert declared == len(args), (block.get_name(), what)
            assert declared <= MAX_ARGUMENTS, (f"{block.get_name()}'s {what} kernel {function.__name__} takes "
                                               f"{declared} arguments: gather its settings into a record")
            seen += 1
    assert seen >= 20  # every block's kernels were looked at
