"""Fig. 2 and Eq. 14: scaling and elimination of the non-contact wrench, checked
against Newton–Euler written out here, slewing of σ, γ, η, and fault handling."""

import dataclasses

import numpy as np
import pytest
from pydrake.common.yaml import yaml_load_typed
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import LogVectorOutput, TrajectorySource
from pydrake.trajectories import PiecewisePolynomial

from heft.systems.controller.force_scaling import (
    ForceScalingElimination, ForceScalingParams, clamp_scales, scale_wrench, slew)
from heft.systems.load_dynamics import InertialParameters, regressor

PERIOD = 0.0005
SLEW_RATE = 20.0
DECAY_TIME = 0.002
NUM_TICKS = 400
NAN_TICKS = range(150, 160)  # ticks whose wrench sample is NaN
STEP_TICK = 20               # σ requested 1 → 0 from here on


def newton_euler(body: InertialParameters, a, alpha, omega, g):
    """Eqs. 1–2 from the body's mass, COM and inertia about the COM, with the
    inertia moved to S by the parallel-axis theorem: [f; τ] at S on the body."""
    mc = body.mass * body.com
    inertia = body.inertia_origin
    f = body.mass * (a - g) + np.cross(alpha, mc) + np.cross(omega, np.cross(omega, mc))
    tau = inertia @ alpha + np.cross(omega, inertia @ omega) + np.cross(mc, a - g)
    return np.concatenate((f, tau))


@pytest.fixture(scope="module")
def scene():
    """A gripper, a gripped object, sensor offsets, and random motion samples with
    the measurement they produce plus a known contact wrench."""
    rng = np.random.default_rng(7)
    gripper, obj = InertialParameters.random(rng), InertialParameters.random(rng)
    load = gripper + obj
    n = NUM_TICKS
    motion = dict(a=rng.normal(size=(n, 3)) * 5, alpha=rng.normal(size=(n, 3)) * 10,
                  omega=rng.normal(size=(n, 3)) * 3,
                  g=rng.normal(size=(n, 3)) * (9.81 / np.sqrt(3)))
    offsets = rng.normal(size=6) * [2, 2, 2, 0.05, 0.05, 0.05]
    contact = rng.normal(size=(n, 6)) * [5, 5, 5, 0.3, 0.3, 0.3]
    V = regressor(motion["a"], motion["alpha"], motion["omega"], motion["g"])
    measured = V @ load.to_phi() + offsets + contact
    return dict(gripper=gripper, obj=obj, load=load, offsets=offsets, contact=contact,
                measured=measured, V=V, **motion)


def samples(scene):
    """(k, wrench, acceleration, omega, gravity) of each sample."""
    for k in range(NUM_TICKS):
        yield (k, scene["measured"][k], np.concatenate((scene["a"][k], scene["alpha"][k])),
               scene["omega"][k], scene["g"][k])


# --- the numpy core ---------------------------------------------------------------

def test_elimination_returns_exactly_the_contact_wrench(scene):
    phi = scene["load"].to_phi()
    for k, wrench, acc, omega, g in samples(scene):
        feedback, contact, noncontact = scale_wrench(
            wrench, scene["offsets"], phi, acc, omega, g, sigma=0.0, gamma=1.0, eta=1.0)
        expected_nc = newton_euler(scene["load"], scene["a"][k], scene["alpha"][k], omega, g)
        np.testing.assert_allclose(noncontact, expected_nc, atol=1e-10)
        np.testing.assert_allclose(contact, scene["contact"][k], atol=1e-10)
        np.testing.assert_allclose(feedback, scene["contact"][k], atol=1e-10)


def test_unity_scales_return_the_offset_free_measurement(scene):
    phi = scene["load"].to_phi()
    for _, wrench, acc, omega, g in samples(scene):
        feedback, _, _ = scale_wrench(wrench, scene["offsets"], phi, acc, omega, g, 1.0, 1.0, 1.0)
        np.testing.assert_allclose(feedback, wrench - scene["offsets"], atol=1e-10)


def test_half_sigma_halves_the_apparent_mass_under_pure_linear_acceleration(scene):
    load, phi = scene["load"], scene["load"].to_phi()
    rng = np.random.default_rng(8)
    for _ in range(20):
        a = rng.normal(size=3) * 10
        contact = rng.normal(size=6)
        zero = np.zeros(3)
        wrench = newton_euler(load, a, zero, zero, zero) + scene["offsets"] + contact
        feedback, _, _ = scale_wrench(wrench, scene["offsets"], phi, np.concatenate((a, zero)),
                                      zero, zero, sigma=0.5, gamma=1.0, eta=1.0)
        np.testing.assert_allclose(feedback[:3], 0.5 * load.mass * a + contact[:3], atol=1e-10)


def test_gamma_scales_only_the_contact_part(scene):
    phi = scene["load"].to_phi()
    for k, wrench, acc, omega, g in samples(scene):
        feedback, _, noncontact = scale_wrench(wrench, scene["offsets"], phi, acc, omega, g,
                                               sigma=0.3, gamma=2.5, eta=1.0)
        np.testing.assert_allclose(feedback, 2.5 * scene["contact"][k] + 0.3 * noncontact,
                                   atol=1e-9)


def test_gripper_split_with_sigma_0_gamma_1_is_eq_14(scene):
    phi, phi_gr = scene["load"].to_phi(), scene["gripper"].to_phi()
    for eta in (0.0, 0.25, 0.8, 1.0):
        for k, wrench, acc, omega, g in samples(scene):
            feedback, _, _ = scale_wrench(wrench, scene["offsets"], phi, acc, omega, g,
                                          sigma=0.0, gamma=1.0, eta=eta, phi_gripper=phi_gr)
            phi_mod = phi_gr + (1.0 - eta) * (phi - phi_gr)  # Eq. 14: φ_mod = φ_gr + (1 − η)·φ_obj
            np.testing.assert_allclose(
                feedback, wrench - scene["offsets"] - scene["V"][k] @ phi_mod, atol=1e-10)


def test_eta_1_keeps_the_whole_object_and_none_of_the_gripper(scene):
    phi, phi_gr = scene["load"].to_phi(), scene["gripper"].to_phi()
    for k, wrench, acc, omega, g in samples(scene):
        feedback, _, _ = scale_wrench(wrench, scene["offsets"], phi, acc, omega, g,
                                      sigma=0.0, gamma=1.0, eta=1.0, phi_gripper=phi_gr)
        obj = newton_euler(scene["obj"], scene["a"][k], scene["alpha"][k], omega, g)
        np.testing.assert_allclose(feedback, scene["contact"][k] + obj, atol=1e-10)


def test_requests_are_clamped_and_slewed():
    assert clamp_scales(-1.0, -2.0, 3.0) == (0.0, 0.0, 1.0)
    assert clamp_scales(2.0, 0.5, -0.1) == (2.0, 0.5, 0.0)
    assert slew(1.0, 0.0, 0.1) == pytest.approx(0.9)
    assert slew(0.0, 0.05, 0.1) == 0.05


def test_params_validate_and_load_from_yaml():
    params = yaml_load_typed(schema=ForceScalingParams,
                             data="{sigma: 0.5, phi_gripper: [1, 0, 0, 0.1, 0, 0, 0, 0, 0, 0]}")
    assert params.sigma == 0.5 and len(params.phi_gripper) == 10
    for bad in (dict(sigma=-1.0), dict(eta=1.5), dict(slew_rate=0.0),
                dict(phi_gripper=[1.0] * 9), dict(fault_decay_time=-1.0)):
        with pytest.raises(ValueError):
            ForceScalingElimination(dataclasses.replace(ForceScalingParams(), **bad))
    with pytest.raises(ValueError, match="period"):
        ForceScalingElimination(ForceScalingParams(), period=np.inf)


# --- the Drake system ----------------------------------------------------------------

def hold_per_tick(values):
    """A source whose value changes half a period before each tick k·T to values[k]."""
    breaks = np.concatenate(([0.0], (np.arange(1, len(values)) - 0.5) * PERIOD,
                             [(len(values) + 1) * PERIOD]))
    knots = np.vstack((values, values[-1:])).T
    return TrajectorySource(PiecewisePolynomial.ZeroOrderHold(breaks, knots))


@pytest.fixture(scope="module")
def run(scene):
    """One simulation of both systems (without and with the gripper split) on the
    scene's samples: σ requested 1 → 0 at STEP_TICK, γ 1 → 0.5 at 2·STEP_TICK, η
    held at 0.4, NaN wrench samples at NAN_TICKS; every output logged once per tick
    (loggers publish before the tick's update, the controller's view)."""
    wrench = scene["measured"].copy()
    wrench[list(NAN_TICKS), 2] = np.nan
    ticks = np.arange(NUM_TICKS)
    sources = dict(
        wrench=wrench, acceleration=np.hstack((scene["a"] - scene["g"], scene["alpha"])),  # what a sensor reads
        omega=scene["omega"], gravity=scene["g"],
        phi=np.tile(scene["load"].to_phi(), (NUM_TICKS, 1)),
        offsets=np.tile(scene["offsets"], (NUM_TICKS, 1)),
        sigma=np.where(ticks < STEP_TICK, 1.0, 0.0)[:, None],
        gamma=np.where(ticks < 2 * STEP_TICK, 1.0, 0.5)[:, None],
        eta=np.full((NUM_TICKS, 1), 0.4))
    builder = DiagramBuilder()
    base = ForceScalingParams(slew_rate=SLEW_RATE, fault_decay_time=DECAY_TIME)
    systems = {"whole": builder.AddSystem(ForceScalingElimination(base, PERIOD)),
               "split": builder.AddSystem(ForceScalingElimination(dataclasses.replace(
                   base, phi_gripper=scene["gripper"].to_phi().tolist()), PERIOD))}
    for name, values in sources.items():
        source = builder.AddSystem(hold_per_tick(values))
        for system in systems.values():
            builder.Connect(source.get_output_port(), system.GetInputPort(name))
    loggers = {(key, port): LogVectorOutput(system.GetOutputPort(port), builder, PERIOD)
               for key, system in systems.items()
               for port in ("wrench_feedback", "wrench_contact", "wrench_noncontact", "scales",
                            "fault")}
    diagram = builder.Build()
    simulator = Simulator(diagram)
    simulator.AdvanceTo((NUM_TICKS - 1) * PERIOD)
    context = simulator.get_context()
    logs = {key: logger.FindLog(context).data().T for key, logger in loggers.items()}
    times = loggers["whole", "fault"].FindLog(context).sample_times()
    np.testing.assert_allclose(times, ticks * PERIOD, atol=1e-12)
    return dict(logs=logs, wrench=wrench, systems=systems, diagram=diagram)


def test_scales_slew_toward_the_request_without_jumps(run):
    scales = run["logs"]["whole", "scales"]
    step = np.abs(np.diff(scales, axis=0))
    assert step.max() <= SLEW_RATE * PERIOD * (1 + 1e-9)
    sigma, gamma, eta = scales.T
    assert np.all(sigma[:STEP_TICK + 1] == 1.0)
    ramp_ticks = int(np.ceil(1.0 / (SLEW_RATE * PERIOD)))
    assert np.all(np.diff(sigma[STEP_TICK:]) <= 0)
    # The update at STEP_TICK consumes the request; its result shows from the next tick.
    first_zero = np.argmax(sigma == 0.0)
    assert STEP_TICK + ramp_ticks <= first_zero <= STEP_TICK + ramp_ticks + 1
    assert gamma[-1] == 0.5 and eta[-1] == 0.4
    np.testing.assert_array_equal(run["logs"]["split", "scales"], scales)


@pytest.mark.parametrize("key", ["whole", "split"])
def test_simulated_outputs_match_the_core_at_every_good_tick(scene, run, key):
    logs = run["logs"]
    phi_gripper = scene["gripper"].to_phi() if key == "split" else None
    good = 0
    for k, _, acc, omega, g in samples(scene):
        if logs[key, "fault"][k, 0]:
            continue
        sigma, gamma, eta = logs[key, "scales"][k]
        expected = scale_wrench(run["wrench"][k], scene["offsets"], scene["load"].to_phi(), acc,
                                omega, g, sigma, gamma, eta, phi_gripper)
        for port, value in zip(("wrench_feedback", "wrench_contact", "wrench_noncontact"),
                               expected):
            np.testing.assert_allclose(logs[key, port][k], value, rtol=1e-12, atol=1e-10)
        good += 1
    assert good == NUM_TICKS - len(NAN_TICKS)


@pytest.mark.parametrize("key", ["whole", "split"])
def test_nan_sample_raises_fault_and_decays_the_last_good_feedback(run, key):
    logs = run["logs"]
    fault = logs[key, "fault"][:, 0]
    np.testing.assert_array_equal(np.flatnonzero(fault), list(NAN_TICKS))
    for port in ("wrench_feedback", "wrench_contact", "wrench_noncontact", "scales"):
        assert np.isfinite(logs[key, port]).all()
    feedback = logs[key, "wrench_feedback"]
    decay = np.exp(-PERIOD / DECAY_TIME)
    for k in NAN_TICKS:
        np.testing.assert_allclose(feedback[k], decay * feedback[k - 1], rtol=1e-12)
        assert not logs[key, "wrench_contact"][k].any()
    assert np.abs(feedback[NAN_TICKS[0] - 1]).max() > 1.0


def test_feedthrough_is_limited_to_the_signal_inputs(run):
    system = run["systems"]["whole"]
    feedthrough = {(i, o) for i in range(system.num_input_ports())
                   for o in range(system.num_output_ports()) if system.HasDirectFeedthrough(i, o)}
    signals = {int(system.GetInputPort(n).get_index()) for n in
               ("wrench", "acceleration", "omega", "gravity", "phi", "offsets", "phi_gripper", "split")}
    outputs = {int(system.GetOutputPort(n).get_index()) for n in
               ("wrench_feedback", "wrench_contact", "wrench_noncontact", "fault")}
    assert feedthrough == {(i, o) for i in signals for o in outputs}


def test_non_finite_request_holds_the_scales_and_raises_fault(scene, run):
    system = run["systems"]["whole"]
    context = system.CreateDefaultContext()
    _, wrench, acc, omega, g = next(samples(scene))
    for name, value in (("wrench", wrench), ("acceleration", acc), ("omega", omega),
                        ("gravity", g), ("phi", scene["load"].to_phi()),
                        ("offsets", scene["offsets"]), ("sigma", [np.nan]), ("gamma", [0.0])):
        system.GetInputPort(name).FixValue(context, value)
    fault = system.GetOutputPort("fault")
    feedback = system.GetOutputPort("wrench_feedback").Eval(context)
    assert fault.Eval(context)[0] == 0.0
    updated = system.EvalUniquePeriodicDiscreteUpdate(context)
    context.get_mutable_discrete_state().SetFrom(updated)
    np.testing.assert_array_equal(system.GetOutputPort("scales").Eval(context), [1.0, 1.0, 1.0])
    assert fault.Eval(context)[0] == 1.0
    np.testing.assert_allclose(system.GetOutputPort("wrench_feedback").Eval(context),
                               np.exp(-PERIOD / DECAY_TIME) * feedback, rtol=1e-12)


# --- the mount notch ---------------------------------------------------------------

NOTCH_HZ, NOTCH_Q = 48.0, 0.7


def contact_through_notch(contact, notch_hz=NOTCH_HZ, nan_ticks=()):
    """Simulates the block with no load (φ = 0, no offsets: c = f) on the contact wrenches
    ``contact`` (N × 6), σ = 0, γ = 1, and NaN wrenches at ``nan_ticks``: the logged
    (wrench_feedback, wrench_contact, fault)."""
    count = len(contact)
    wrench = contact.copy()
    wrench[list(nan_ticks)] = np.nan
    sources = dict(wrench=wrench, acceleration=np.zeros((count, 6)), omega=np.zeros((count, 3)),
                   gravity=np.tile([0.0, 0.0, -9.81], (count, 1)), phi=np.zeros((count, 10)),
                   offsets=np.zeros((count, 6)))
    builder = DiagramBuilder()
    system = builder.AddSystem(ForceScalingElimination(ForceScalingParams(
        sigma=0.0, mount_notch=notch_hz, mount_notch_quality=NOTCH_Q), PERIOD))
    for name, values in sources.items():
        builder.Connect(builder.AddSystem(hold_per_tick(values)).get_output_port(), system.GetInputPort(name))
    loggers = [LogVectorOutput(system.GetOutputPort(port), builder, PERIOD)
               for port in ("wrench_feedback", "wrench_contact", "fault")]
    diagram = builder.Build()
    simulator = Simulator(diagram)
    simulator.AdvanceTo((count - 1) * PERIOD)
    return [logger.FindLog(simulator.get_context()).data().T for logger in loggers]


def analog_notch_gain(frequency):
    """|H(jω)| of the continuous notch (s² + ω₀²) / (s² + (ω₀/Q)·s + ω₀²), closed form."""
    w, w0 = 2 * np.pi * frequency, 2 * np.pi * NOTCH_HZ
    return abs(w0 ** 2 - w ** 2) / np.hypot(w0 ** 2 - w ** 2, w * w0 / NOTCH_Q)


@pytest.mark.parametrize("frequency", [2.5, 15.0, NOTCH_HZ, 150.0])
def test_the_contact_is_fed_back_through_a_notch_at_the_mounts_mode(frequency):
    """A sinusoidal contact wrench comes back scaled by the notch's gain, the continuous
    notch's closed form (the bilinear transform, prewarped at the centre, is exact there and
    within 3 % up to 150 Hz); the wrench_contact output stays c (Eq. 13), unfiltered."""
    ticks = np.arange(4000)
    wave = np.sin(2 * np.pi * frequency * ticks * PERIOD)
    contact = np.outer(wave, [3.0, -2.0, 1.0, 0.2, -0.1, 0.05])
    feedback, logged_contact, _ = contact_through_notch(contact)
    np.testing.assert_allclose(logged_contact, contact, atol=1e-12)
    settled = ticks >= 2000  # the notch's transient has died out (time constant 2Q/ω₀ ≈ 5 ms)
    gain = np.abs(feedback[settled]).max(axis=0) / np.abs(contact[settled]).max(axis=0)
    expected = analog_notch_gain(frequency)
    if frequency == NOTCH_HZ:
        assert gain.max() < 1e-3
    else:
        np.testing.assert_allclose(gain, expected, rtol=0.03)
        assert expected < 0.99 or frequency < 3  # each frequency tests something


def test_the_notch_is_scipys_notch_sample_by_sample():
    """On a broadband contact wrench, f′ is scipy's ``lfilter`` of the same notch (phase included),
    started in its steady state (``lfilter_zi``)."""
    from scipy.signal import iirnotch, lfilter, lfilter_zi

    contact = np.random.default_rng(3).normal(size=(600, 6)) * [3.0, 3.0, 3.0, 0.2, 0.2, 0.2]
    feedback, _, _ = contact_through_notch(contact)
    b, a = iirnotch(NOTCH_HZ, NOTCH_Q, fs=1.0 / PERIOD)
    expected, _ = lfilter(b, a, contact, axis=0, zi=np.outer(lfilter_zi(b, a), contact[0]))
    np.testing.assert_allclose(feedback, expected, rtol=1e-9, atol=1e-9)


def test_the_notch_starts_and_restarts_after_a_fault_in_steady_state():
    """A constant contact wrench passes unchanged from the first tick (the notch starts in its
    steady state, no ringing); after a faulted sample it returns unchanged at once."""
    contact = np.tile([4.0, 0.0, -1.0, 0.1, 0.0, 0.2], (200, 1))
    contact[120:] *= 2.0  # a new constant after the fault
    feedback, _, fault = contact_through_notch(contact, nan_ticks=range(100, 120))
    live = fault[:, 0] == 0
    np.testing.assert_allclose(feedback[live], contact[live], rtol=1e-9, atol=1e-12)
    assert not live[100:120].any()


def test_a_notch_at_or_above_nyquist_is_refused_with_what_to_do():
    with pytest.raises(ValueError, match="Nyquist.*set it to 0"):
        ForceScalingElimination(ForceScalingParams(mount_notch=1000.0), PERIOD)
    for bad in (dict(mount_notch=-1.0), dict(mount_notch_quality=0.0)):
        with pytest.raises(ValueError, match=next(iter(bad))):
            ForceScalingElimination(dataclasses.replace(ForceScalingParams(), **bad))


def test_the_notch_is_told_to_the_lab_with_how_to_set_it():
    assert "48 Hz" in ForceScalingParams(mount_notch=48.0).mount_notch_summary()
    assert "tapped" in ForceScalingParams(mount_notch=48.0).mount_notch_summary()
    assert "without a mount notch" in ForceScalingParams().mount_notch_summary()
