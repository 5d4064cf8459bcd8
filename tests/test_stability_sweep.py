"""The contact loop's stability by simulation, the communication delay, and the maps."""

import argparse
import json

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import DiscreteTimeDelay, LogVectorOutput, TrajectorySource
from pydrake.trajectories import PiecewisePolynomial

from heft.analysis.stability_map import draw_stability_map, stability_limits
from heft.diagrams.commands.analyze_stability import add_arguments, axis_values, run
from heft.diagrams.scenario import layered, overrides_text, resolve_scenario
from heft.diagrams.studies.stability_sweep import grid, point_scenario, simulate_point
from heft.diagrams.load_estimate import LoadEstimate
from heft.diagrams.teleop import AddDelay
from heft.diagrams.teleop_simulation import MakeTeleopSimulation

PERIOD = 0.0005


def wall(duration):
    return resolve_scenario("stability_wall", overrides_text({"duration": duration}))


def run_point(point, duration):
    return simulate_point(wall(duration), point, np.random.SeedSequence(0))


@pytest.mark.parametrize("steps", [1, 4])
def test_add_delay_shifts_a_step_by_whole_periods_and_starts_at_the_initial_value(steps):
    builder = DiagramBuilder()
    t_step = 10.2 * PERIOD  # between two samples: the step is first sampled at k = 11
    step = builder.AddSystem(TrajectorySource(PiecewisePolynomial.ZeroOrderHold(
        [0.0, t_step, 1.0], np.array([[1.0, 5.0, 5.0], [-2.0, -2.0, -2.0]]))))
    delayed = AddDelay(builder, step.get_output_port(), steps, PERIOD, initial=[1.0, -2.0])
    direct_log = LogVectorOutput(step.get_output_port(), builder, PERIOD)
    delayed_log = LogVectorOutput(delayed, builder, PERIOD)
    diagram = builder.Build()
    simulator = Simulator(diagram)
    simulator.AdvanceTo(30 * PERIOD)
    context = simulator.get_context()
    direct = direct_log.FindLog(context).data()[0]
    late = delayed_log.FindLog(context).data()[0]
    first_direct, first_late = np.argmax(direct > 3), np.argmax(late > 3)
    # A logger samples at t_k before the updates of t_k, as the controller does: the source's
    # step is seen at k = 11, the delayed one ``steps`` samples later.
    assert first_direct == 11 and first_late == 11 + steps
    np.testing.assert_array_equal(late[:first_late], 1.0)   # the initial value, not 0, until the step arrives
    np.testing.assert_array_equal(delayed_log.FindLog(context).data()[1], -2.0)


def test_the_simulation_puts_the_delay_in_every_channel_both_ways():
    scenario = wall(0.1)
    delayed = layered(scenario, overrides_text({"controller.delay": 3 * scenario.controller_period}))
    diagram, _ = MakeTeleopSimulation(delayed, LoadEstimate(np.zeros(10), np.zeros(6)))
    delays = [s for s in diagram.GetSystems() if isinstance(s, DiscreteTimeDelay)]
    assert len(delays) == 8  # six station outputs read, two station inputs driven
    undelayed = layered(delayed, overrides_text({"controller.delay": 0.0}))
    diagram, _ = MakeTeleopSimulation(undelayed, LoadEstimate(np.zeros(10), np.zeros(6)))
    assert not [s for s in diagram.GetSystems() if isinstance(s, DiscreteTimeDelay)]


def test_delay_must_be_whole_periods_and_axes_known():
    with pytest.raises(ValueError, match="controller.delay.*whole number of controller periods"):
        point_scenario(wall(0.1), {"delay": 0.7 * PERIOD})
    with pytest.raises(ValueError, match="controller.delay"):
        point_scenario(wall(0.1), {"delay": -PERIOD})
    with pytest.raises(ValueError, match="unknown sweep axis wobble"):
        grid({"wobble": [1.0]})
    slow = point_scenario(wall(0.1), {"period": 0.002})
    diagram, _ = MakeTeleopSimulation(slow, LoadEstimate(np.zeros(10), np.zeros(6)))
    # Every discrete update of the controller now runs at 500 Hz.
    controller = diagram.GetSubsystemByName("controller")
    assert controller.GetUniquePeriodicDiscreteUpdateAttribute().period_sec() == 0.002
    assert point_scenario(wall(0.1), {"passivity": 0.0}).controller.passivity.enabled is False
    assert all(v / PERIOD == round(v / PERIOD) for v in axis_values("delay", 6, PERIOD))


def test_a_soft_wall_holds_contact_without_a_growing_oscillation():
    """Soft wall (1 kN/m, rendered at the hand as 1000·2/17.5 ≈ 114 N/m, far below the
    device's 800 N/m): the push settles, the tool stays on the plate."""
    result = run_point({"stiffness": 1000.0, "passivity": 0.0}, duration=0.9)
    assert result["verdict"] != "growing" and result["stable"]
    assert result["out_of_contact"] == 0.0 and result["saturated"] == 0.0
    assert not result["bouncing"]


def test_the_map_marks_verdicts_and_finds_the_limit(tmp_path):
    results = [{"point": {"stiffness": k, "passivity": p}, "verdict": v, "stable": v != "growing",
                "growth_ratio": r, "bouncing": b}
               for k, p, v, r, b in ((1e3, 0, "decaying", 0.5, False), (1e4, 0, "sustained", 1.0, False),
                                     (1e5, 0, "growing", 3.0, False), (1e3, 1, "decaying", 0.4, False),
                                     (1e4, 1, "sustained", 1.0, True), (1e5, 1, "sustained", 1.0, True))]
    limits = stability_limits(results, "stiffness", "passivity")
    assert limits == {"0": {"last_good": 1e4, "first_bad": 1e5}, "1": {"last_good": 1e3, "first_bad": 1e4}}
    png, document = draw_stability_map(results, "stiffness", None, tmp_path)
    assert png.stat().st_size > 10_000
    assert json.loads(document.read_text())["limits"] == limits
    with pytest.raises(ValueError, match="was not swept"):
        draw_stability_map(results, "force_scale", None, tmp_path)


@pytest.mark.slow
def test_a_wall_far_stiffer_than_the_device_renders_makes_the_tool_bounce_with_or_without_the_pc():
    """100 kN/m is rendered as ≈ 11 kN/m at the hand, 14× the device's 800 N/m: the tool
    bounces off the plate in a limit cycle with the master force at its 8.5 N limit. The
    passivity controller's 5 N·s/m (the device's damping limit) does not stop it."""
    for passivity in (0.0, 1.0):
        result = run_point({"stiffness": 1e5, "passivity": passivity}, duration=1.5)
        assert result["bouncing"] and result["out_of_contact"] > 0.2
        assert result["saturated"] > 0.02 and result["master_force_peak"] == pytest.approx(8.5, rel=1e-3)


@pytest.mark.slow
def test_a_long_delay_destabilises_the_loop_through_the_fed_back_inertial_wrench():
    """At the default 2 kN/m wall, with σ = 1 (the tool's non-contact wrench fed back), 20 ms
    of delay each way turns a steady sideways chatter (1.9 N peak) into an oscillation of the master that
    grows toward the force limit, past twice the chatter's peak (5.0 of 8.5 N within 1.5 s, growth ratio 1.82;
    6.9 N and 2.05 without the notch on the master's positions); eliminating the non-contact wrench (σ = 0)
    keeps it small."""
    prompt = run_point({"delay": 0.0, "sigma": 1.0, "passivity": 0.0}, duration=1.5)
    late = run_point({"delay": 0.02, "sigma": 1.0, "passivity": 0.0}, duration=1.5)
    eliminated = run_point({"delay": 0.02, "sigma": 0.0, "passivity": 0.0}, duration=1.5)
    assert prompt["verdict"] != "growing" and prompt["master_force_peak"] < 4.0
    assert late["verdict"] == "growing" and late["growth_ratio"] > 1.2
    assert late["master_force_peak"] > 2 * prompt["master_force_peak"]
    assert eliminated["verdict"] != "growing" and eliminated["master_rms_last"] < 0.2 * late["master_rms_last"]


@pytest.mark.slow
def test_near_the_limit_the_pc_keeps_contact_where_the_loop_without_it_bounces():
    """At 14 kN/m (rendered ≈ 1.6 kN/m at the hand; 1.16 times the linear model's 12.1 kN/m limit with the
    default notches) the loop without the passivity controller bounces; its 5 N·s/m of damping on the
    master holds the tool on the plate."""
    without = run_point({"stiffness": 1.4e4, "passivity": 0.0}, duration=1.5)
    with_pc = run_point({"stiffness": 1.4e4, "passivity": 1.0}, duration=1.5)
    assert without["bouncing"] and without["out_of_contact"] > 0.1
    assert not with_pc["bouncing"] and with_pc["out_of_contact"] == 0.0 and with_pc["stable"]


def test_analyze_stability_writes_the_map_and_a_summary(tmp_path, capsys):
    parser = argparse.ArgumentParser()
    add_arguments(parser)
    args = parser.parse_args(["--axes", "stiffness", "--grid", "1", "--passivity", "off", "--duration", "0.3",
                              "--workers", "1", "--out", str(tmp_path)])
    assert run(args) == 0
    document = json.loads((tmp_path / "stability_map.json").read_text())
    assert document["axes"] == {"stiffness": [300.0], "passivity": [0.0]}
    assert (tmp_path / "stability_map.png").stat().st_size > 10_000
    assert "1 point(s):" in capsys.readouterr().out
    with pytest.raises(ValueError, match="one or two parameters"):
        run(parser.parse_args(["--axes", "stiffness,damping,sigma"]))


@pytest.mark.slow
def test_the_simulated_stiffness_limit_brackets_the_linear_models_prediction():
    """The linearised loop (analysis.linear_teleoperator) predicts where the contact loop's
    poles leave the unit circle (12.6 kN/m with the default controller's mount notch, 16.2
    without: the notch's phase lag); the full simulation without the PC holds contact below
    that stiffness and bounces above it."""
    from heft.analysis.linear_teleoperator import predicted_stiffness_limit
    from heft.diagrams.studies.linear_model_params import linear_model_params

    limit = predicted_stiffness_limit(linear_model_params(wall(1.5)))
    assert 5e3 < limit < 5e4
    below = run_point({"stiffness": 0.75 * limit, "passivity": 0.0}, duration=1.5)
    above = run_point({"stiffness": 1.5 * limit, "passivity": 0.0}, duration=1.5)
    assert not below["bouncing"] and below["out_of_contact"] == 0.0
    assert above["bouncing"] and above["out_of_contact"] > 0.2
