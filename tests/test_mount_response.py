"""The stand-in's compliant mount (``mount.MountUnderMovingSensor``) against Drake: the paper's tool
released undeflected on its mount below a still, tilted sensor rings as Drake's own multibody plant
of the same load on the same bushing does (the sensor's wrench from the weld's reaction force); its
discrete step is stable at the stand-in's rate for every bundled load."""

import dataclasses

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import FixedOffsetFrame
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from heft.diagrams import mount
from heft.diagrams.plants import _add_compliant_mount, _add_load, load_phi, mount_for
from heft.diagrams.scenario import DEFAULT_MOUNT, LoadSpec, resolve_scenario
from heft.systems.drake_conventions import wrench_from_spatial_force
from heft.systems.load_dynamics import GRAVITY_W, regressor

PERIOD = 0.0005  # s, the stand-in's slave step
R_WS = RollPitchYaw(0.4, -0.7, 0.3).ToRotationMatrix()  # the sensor tilted: gravity on every axis of S


def drake_ring_down(load: LoadSpec, constants, times):
    """The wrench [f; τ] on the load at S in S (the plate's weld reaction) at ``times`` (s) after the
    load is released undeflected and at rest, Drake's continuous plant integrated to 1e-10."""
    builder = DiagramBuilder()
    plant = builder.AddSystem(MultibodyPlant(time_step=0.0))
    S = plant.AddFrame(FixedOffsetFrame("S", plant.world_frame(), RigidTransform(R_WS, [0.3, 0.1, 0.5])))
    bodies, _ = _add_load(plant, load)  # a gripper and its object welded together
    weld, joint = _add_compliant_mount(plant, S, bodies[0], constants)
    plant.mutable_gravity_field().set_gravity_vector(GRAVITY_W)
    plant.Finalize()
    diagram = builder.Build()
    simulator = Simulator(diagram)
    simulator.get_mutable_integrator().set_target_accuracy(1e-10)
    context = simulator.get_mutable_context()
    plant_context = plant.GetMyContextFromRoot(context)
    joint.SetPose(plant_context, RigidTransform())
    out = []
    for t in times:
        simulator.AdvanceTo(t)
        reaction = plant.get_reaction_forces_output_port().Eval(plant_context)[weld.index()]
        out.append(wrench_from_spatial_force(reaction))
    return np.array(out)


@pytest.mark.parametrize("kind, at", [("tool", None), ("gripper_object", None), ("tool", [0.01, -0.02, 0.1])])
def test_a_released_load_rings_on_its_mount_as_drakes_plant_does(kind, at):
    """Also with the bushing placed off S (``MountSpec.at``): its constants at that point, moved to S
    (``mount.stiffness``), against Drake's bushing between frames there."""
    load = LoadSpec(kind=kind)
    phi = load_phi(load)
    constants = dataclasses.replace(DEFAULT_MOUNT, at=at)
    model = mount.MountUnderMovingSensor(constants, phi, PERIOD)
    g_S = R_WS.matrix().T @ GRAVITY_W
    rigid = regressor(np.zeros(3), np.zeros(3), np.zeros(3), g_S) @ phi  # the sensor holding the load still
    steps = 400  # 0.2 s: ten periods of the rocking mode
    state, wrench, acceleration = np.zeros(12), np.empty(6), np.empty(6)
    ours = []
    for _ in range(steps):
        model.step(state, rigid, rigid, wrench, acceleration)
        ours.append(wrench.copy())
    ours = np.array(ours)
    drake = drake_ring_down(load, constants, np.arange(1, steps + 1) * PERIOD)  # each step's end
    ringing = drake - rigid
    # It rings: at release the sensor holds nothing, then swings about the load's weight.
    np.testing.assert_allclose(drake_ring_down(load, constants, [0.0])[0], 0.0, atol=1e-9)
    assert np.abs(ringing[steps // 2:, :3]).max() > 0.05 * np.abs(rigid[:3]).max()
    for axes in (slice(0, 3), slice(3, 6)):  # forces (N), torques (N·m): within 0.5 % of the ringing's peak
        assert np.abs(ours[:, axes] - drake[:, axes]).max() < 0.005 * np.abs(ringing[:, axes]).max()
    # And settles on the weight, as the static closed form says.
    np.testing.assert_allclose(model.output @ model.at_rest(rigid), rigid, atol=1e-9)


@pytest.mark.parametrize("name", ["fig6", "grasp"])
def test_the_step_is_stable_at_the_stand_ins_rate(name):
    """Every eigenvalue of the step inside the unit circle, and the decay per step what the modes on
    a still sensor (``modes_on_fixed_sensor``) say: e^(−ζ·ω·T) for the least damped."""
    scenario = resolve_scenario(name)
    phi = load_phi(scenario.load)
    constants = mount_for(scenario)
    model = mount.MountUnderMovingSensor(constants, phi, PERIOD)
    radius = np.abs(np.linalg.eigvals(model.transition))
    modes = mount.modes_on_fixed_sensor(phi, constants)
    omega = 2 * np.pi * modes.frequencies
    assert radius.max() < 1.0
    assert radius.max() == pytest.approx(np.exp(-(modes.damping_ratios * omega).min() * PERIOD), abs=2e-4)


def test_under_a_moving_sensor_the_step_follows_the_continuous_mount():
    """S shaken at 20 Hz on every axis (the rigid wrench w(t) a sum of sines): the step's w_S at each
    step's end, w going linearly between the steps' values, follows scipy's integration of
    M·ξ̈ + C·ξ̇ + K·ξ = −w(t) within 0.1 % of w_S's swing (holding w over each step instead lags half a
    step: 1.7–2.7 % at 20 Hz)."""
    model = mount.MountUnderMovingSensor(DEFAULT_MOUNT, load_phi(LoadSpec(kind="gripper_object")), PERIOD)
    amplitude, phase = np.array([20.0, 15.0, 30.0, 1.0, 1.5, 0.5]), np.linspace(0.0, 2.5, 6)

    def rigid(t):
        return amplitude * np.sin(2 * np.pi * 20.0 * t + phase)

    steps = 400
    times = np.arange(1, steps + 1) * PERIOD
    state, wrench, acceleration, ours = model.at_rest(rigid(0.0)), np.empty(6), np.empty(6), []
    for t in times:
        model.step(state, rigid(t - PERIOD), rigid(t), wrench, acceleration)
        ours.append(wrench.copy())
    damping = -model.output[:, 6:]

    def dynamics(t, x):
        return np.concatenate((x[6:], model.inverse_inertia @ (-model.stiffness @ x[:6] - damping @ x[6:] - rigid(t))))

    solution = solve_ivp(dynamics, (0.0, times[-1]), model.at_rest(rigid(0.0)), t_eval=times, rtol=1e-10,
                         atol=1e-14, max_step=PERIOD)
    expected = (model.output @ solution.y).T
    swing = np.ptp(expected, axis=0)
    assert np.all(swing > 0.5 * amplitude)  # the mount passes the motion on
    assert np.all(np.abs(np.array(ours) - expected).max(axis=0) < 0.001 * swing)
    np.testing.assert_allclose(acceleration, model.inverse_inertia @ (wrench - rigid(times[-1])), rtol=1e-12)


def test_the_mount_step_is_its_matrices_products():
    """``mount_step`` (the kernel of ``MountUnderMovingSensor.step``) against the products it stands for:
    x ← transition·x + gain_start·w_start + gain_end·w, w_S = output·x, ξ̈ = M⁻¹·(w_S − w)."""
    rng = np.random.default_rng(4)
    model = mount.MountUnderMovingSensor(DEFAULT_MOUNT, load_phi(LoadSpec(kind="gripper_object")), PERIOD)
    state, wrench, acceleration = rng.normal(0.0, 1e-4, 12), np.empty(6), np.empty(6)
    previous = rng.normal(0.0, 10.0, 6)
    for _ in range(20):
        rigid, before = rng.normal(0.0, 10.0, 6), state.copy()
        model.step(state, previous, rigid, wrench, acceleration)
        np.testing.assert_allclose(state, model.transition @ before + model.gain_start @ previous
                                   + model.gain_end @ rigid, rtol=1e-12, atol=1e-15)
        expected_wrench = model.output @ state
        np.testing.assert_allclose(wrench, expected_wrench, rtol=1e-12, atol=1e-12 * np.abs(expected_wrench).max())
        np.testing.assert_allclose(acceleration, model.inverse_inertia @ (expected_wrench - rigid), rtol=1e-12,
                                   atol=1e-9)
        previous = rigid
