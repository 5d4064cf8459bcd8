"""Time-domain passivity observer/controller at the master port: passive ports
are left alone, active ones are damped by exactly their deficit up to the bound,
energy bookkeeping, τ = Jᵀ(w − αv), and the independence of the two channels."""

import dataclasses

import numpy as np
import pytest
from pydrake.common.yaml import yaml_load_typed
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, LogVectorOutput, TrajectorySource
from pydrake.trajectories import PiecewisePolynomial

from heft.systems.controller.passivity_controller import (
    PassivityController, PassivityParams, passivity_channel, passivity_step)

PERIOD = 0.0005
NUM_TICKS = 400
MAX = np.array([PassivityParams().max_translational_damping,
                PassivityParams().max_rotational_damping])
ENERGY_TOL = 1e-12  # J


# --- the numpy core -----------------------------------------------------------

def test_channel_step_leaves_a_passive_port_alone_and_cancels_a_deficit():
    assert passivity_channel(1.0, 0.5, 4.0, 0.1, 5.0) == (pytest.approx(0.95), 0.0, 0.0)
    # Deficit 0.05 J; 0.05 / (0.1 · 4) = 0.125 N·s/m < bound: the energy returns to zero.
    energy, alpha, dissipated = passivity_channel(0.0, 0.5, 4.0, 0.1, 5.0)
    assert (energy, alpha, dissipated) == (0.0, pytest.approx(0.125), pytest.approx(0.05))
    # Bound 0.1: dissipates 0.1 · 4 · 0.1 = 0.04 J, 0.01 J of deficit remains.
    energy, alpha, dissipated = passivity_channel(0.0, 0.5, 4.0, 0.1, 0.1)
    assert (energy, alpha, dissipated) == (pytest.approx(-0.01), 0.1, pytest.approx(0.04))
    # At rest nothing can be dissipated; disabled (bound 0) never damps.
    assert passivity_channel(-1.0, 0.0, 0.0, 0.1, 5.0) == (-1.0, 5.0, 0.0)
    assert passivity_channel(-1.0, 0.0, 4.0, 0.1, 0.0) == (-1.0, 0.0, 0.0)


def bounce(max_damping, mass=0.1, stiffness=3000.0, speed=0.2, ticks=600):
    """A free mass (N·s²/m) thrown at a virtual wall x < 0 of ``stiffness`` (N/m)
    that is sampled every PERIOD and acts with one sample of delay, the force held
    between samples (Colgate's classic active case). The mass moves exactly under
    the held force. Returns (rebound speed, observed energies, α per tick)."""
    x, v, x_sampled = 0.005, -speed, 0.005
    energy = np.zeros(2)
    energies, alphas = [], []
    for _ in range(ticks):
        wall = np.array([-stiffness * min(x_sampled, 0.0), 0, 0, 0, 0, 0])
        applied, energy, alpha, _ = passivity_step(
            wall, np.array([v, 0, 0, 0, 0, 0]), energy, PERIOD, [max_damping, MAX[1]])
        x_sampled = x
        x += v * PERIOD + applied[0] / (2 * mass) * PERIOD**2
        v += applied[0] / mass * PERIOD
        energies.append(energy[0])
        alphas.append(alpha[0])
    assert x > 0.005, "the mass left the wall"
    return v, np.array(energies), np.array(alphas)


def test_delayed_stiff_wall_is_active_and_the_pc_removes_the_observed_excess():
    speed_free, energy_free, _ = bounce(max_damping=0.0)
    assert speed_free > 1.2 * 0.2             # it comes back faster than it came in
    assert energy_free.min() < -1e-4          # and the PO sees it
    speed_pc, energy_pc, alpha_pc = bounce(max_damping=50.0)
    assert energy_pc.min() >= -ENERGY_TOL
    assert 0 < alpha_pc.max() <= 50.0
    assert speed_pc < speed_free
    speed_bounded, energy_bounded, alpha_bounded = bounce(max_damping=MAX[0])
    assert alpha_bounded.max() == MAX[0]      # the bound binds: the rest is carried as a deficit
    assert energy_free.min() < energy_bounded.min() < -ENERGY_TOL
    assert speed_pc <= speed_bounded < speed_free


def test_params_validate_and_load_from_yaml():
    params = yaml_load_typed(schema=PassivityParams,
                             data="{max_rotational_damping: 0.01, enabled: false}")
    assert params.max_rotational_damping == 0.01 and not params.enabled
    for bad in (dict(max_translational_damping=-1.0), dict(max_rotational_damping=np.nan)):
        with pytest.raises(ValueError):
            dataclasses.replace(PassivityParams(), **bad).validate()
    with pytest.raises(ValueError, match="period"):
        PassivityController(PassivityParams(), period=0.0)


# --- the Drake system ------------------------------------------------------------

def hold_per_tick(values):
    """A source whose value changes half a period before each tick k·T to values[k]."""
    breaks = np.concatenate(([0.0], (np.arange(1, len(values)) - 0.5) * PERIOD,
                             [(len(values) + 1) * PERIOD]))
    return TrajectorySource(PiecewisePolynomial.ZeroOrderHold(
        breaks, np.vstack((values, values[-1:])).T))


# Desired wrench = diag(gains)·twist per case: negative gains damp (passive), positive
# ones pump energy in (active). Bounds: 5 N·s/m and 0.004 N·m·s/rad.
CASES = {
    "passive": ([-3.0, -0.002], True),
    "active_translation": ([3.0, -0.002], True),
    "active_translation_no_pc": ([3.0, -0.002], False),
    "active_rotation": ([-3.0, 0.003], True),
    "beyond_bounds": ([8.0, 0.01], True),
}


@pytest.fixture(scope="module")
def run():
    """One simulation of a controller per case on the same joint motion and Jacobian;
    the inputs at each tick and every output logged once per tick."""
    rng = np.random.default_rng(5)
    t = np.arange(NUM_TICKS) * PERIOD
    qdot = np.sin(2 * np.pi * rng.uniform(2, 8, 6) * t[:, None] + rng.uniform(0, 6, 6)) * 2.0
    jacobian = np.vstack((0.15 * rng.normal(size=(3, 6)),
                          np.eye(3, 6, 3) + 0.2 * rng.normal(size=(3, 6))))
    twist = qdot @ jacobian.T
    builder = DiagramBuilder()
    velocity = builder.AddSystem(hold_per_tick(qdot))
    jacobian_source = builder.AddSystem(ConstantVectorSource(jacobian.ravel()))
    wrenches, loggers = {}, {}
    for name, (gains, enabled) in CASES.items():
        wrenches[name] = twist * np.repeat(gains, 3)
        pc = builder.AddSystem(PassivityController(PassivityParams(enabled=enabled), period=PERIOD))
        builder.Connect(builder.AddSystem(hold_per_tick(wrenches[name])).get_output_port(),
                        pc.GetInputPort("wrench"))
        builder.Connect(velocity.get_output_port(), pc.GetInputPort("velocity"))
        builder.Connect(jacobian_source.get_output_port(), pc.GetInputPort("jacobian"))
        for port in ("torque", "energy_observed", "damping", "energy_dissipated"):
            loggers[name, port] = LogVectorOutput(pc.GetOutputPort(port), builder, PERIOD)
    diagram = builder.Build()
    assert not diagram.HasAnyDirectFeedthrough()
    simulator = Simulator(diagram)
    simulator.AdvanceTo(NUM_TICKS * PERIOD)
    context = simulator.get_context()
    # Loggers publish before the tick's update: the row for tick k + 1 holds what the
    # update at tick k computed from the inputs of tick k.
    logs = {key: logger.FindLog(context).data().T[1:] for key, logger in loggers.items()}
    return dict(logs=logs, wrenches=wrenches, twist=twist, jacobian=jacobian, qdot=qdot)


def channels(x):
    """(translational, rotational) halves of (N, 6) rows."""
    return x[:, :3], x[:, 3:]


def test_pc_has_no_direct_feedthrough():
    assert not PassivityController().HasAnyDirectFeedthrough()


@pytest.mark.parametrize("name", list(CASES))
def test_torque_is_jacobian_transpose_of_wrench_minus_damping(run, name):
    logs = run["logs"]
    alpha = logs[name, "damping"]
    applied = run["wrenches"][name] - np.repeat(alpha, 3, axis=1) * run["twist"]
    np.testing.assert_allclose(logs[name, "torque"], applied @ run["jacobian"], atol=1e-12)


@pytest.mark.parametrize("name", list(CASES))
def test_damping_is_bounded_and_dissipation_is_the_sum_of_alpha_v_squared_t(run, name):
    logs = run["logs"]
    alpha = logs[name, "damping"]
    assert np.all(alpha >= 0) and np.all(alpha <= MAX)
    speed_squared = np.column_stack([(c**2).sum(axis=1) for c in channels(run["twist"])])
    np.testing.assert_allclose(logs[name, "energy_dissipated"],
                               np.cumsum(alpha * speed_squared * PERIOD, axis=0), atol=1e-15)
    # The observed energy is the port energy (desired wrench) plus the dissipation.
    port = -np.column_stack([(w * v).sum(axis=1) for w, v in
                             zip(channels(run["wrenches"][name]), channels(run["twist"]))])
    np.testing.assert_allclose(logs[name, "energy_observed"],
                               np.cumsum(port * PERIOD, axis=0) + logs[name, "energy_dissipated"],
                               rtol=1e-12, atol=1e-14)


def test_passive_damper_never_triggers_the_pc(run):
    logs = run["logs"]
    assert not logs["passive", "damping"].any()
    energy = logs["passive", "energy_observed"]
    assert np.all(np.diff(energy, axis=0) >= 0) and energy[-1].min() > 0


def test_negative_damping_is_seen_by_the_po_and_cancelled_within_the_bound(run):
    logs = run["logs"]
    free = logs["active_translation_no_pc", "energy_observed"][:, 0]
    assert np.all(np.diff(free) <= 0) and free[-1] < -1e-4
    assert not logs["active_translation_no_pc", "damping"].any()
    energy = logs["active_translation", "energy_observed"][:, 0]
    assert energy.min() >= -ENERGY_TOL
    # From zero energy the deficit of one step is 3·|v|²·T: the PC answers with α = 3.
    np.testing.assert_allclose(logs["active_translation", "damping"][:, 0], 3.0, rtol=1e-9)
    np.testing.assert_allclose(logs["active_translation", "energy_dissipated"][-1, 0], -free[-1],
                               rtol=1e-9)


def test_channels_are_independent(run):
    logs = run["logs"]
    for active, passive in (("active_translation", 1), ("active_rotation", 0)):
        assert not logs[active, "damping"][:, passive].any()
        np.testing.assert_allclose(logs[active, "energy_observed"][:, passive],
                                   logs["passive", "energy_observed"][:, passive], rtol=1e-12)
        assert logs[active, "damping"][:, 1 - passive].min() > 0
    assert logs["active_rotation", "energy_observed"][:, 1].min() >= -ENERGY_TOL


def test_beyond_the_bound_the_pc_saturates_and_carries_the_deficit(run):
    logs = run["logs"]
    np.testing.assert_array_equal(logs["beyond_bounds", "damping"], np.tile(MAX, (NUM_TICKS, 1)))
    energy = logs["beyond_bounds", "energy_observed"]
    assert np.all(np.diff(energy, axis=0) <= ENERGY_TOL) and np.all(energy[-1] < 0)


def test_non_finite_sample_commands_zero_torque_and_keeps_the_energies():
    pc = PassivityController()
    context = pc.CreateDefaultContext()
    context.SetDiscreteState(1, [0.3, 0.02])
    pc.GetInputPort("wrench").FixValue(context, [np.nan, 0, 0, 0, 0, 0])
    pc.GetInputPort("velocity").FixValue(context, np.ones(6))
    pc.GetInputPort("jacobian").FixValue(context, np.eye(6).ravel())
    updated = pc.EvalUniquePeriodicDiscreteUpdate(context)
    context.get_mutable_discrete_state().SetFrom(updated)
    np.testing.assert_array_equal(pc.GetOutputPort("torque").Eval(context), np.zeros(6))
    np.testing.assert_array_equal(pc.GetOutputPort("energy_observed").Eval(context), [0.3, 0.02])
