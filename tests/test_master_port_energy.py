"""The master port's energy in the closed loop: the passivity observer (PO) against Drake's
own master plant and the operator's hand, and where the rotational channel's deficit in
fig7 at σ = 1 comes from."""

import numpy as np
import pytest
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator
from pydrake.systems.framework import EventStatus

from heft.diagrams.running.simulation import true_load, with_sigma
from heft.diagrams.scenario import overrides_text, resolve_scenario
from heft.diagrams.teleop_simulation import MakeTeleopSimulation
from drake_reference import stylus_jacobian
from heft.systems.controller.master_kinematics import BASE_FRAME, STYLUS_FRAME


def fig7_master_port(overrides: dict) -> dict:
    """fig7 at σ = 1 with the true load and ``overrides``, recorded at every plant step t_k:
    ``t`` (s), ``q`` (N×6, rad), ``torque`` (N×6, N·m: what the amplifiers apply over
    [t_k, t_k+1)), ``jacobian`` (N×6×6, J_M, rows [v_E; ω_E] in B), ``omega`` (N×3: the
    stylus's angular velocity from Drake's plant, in W = B, rad/s), ``hand_torque`` (N×3: the
    hand's torque on the stylus about E, in W, N·m), ``energy`` (N×2: the PO's [E_t, E_r], J),
    and ``scenario``."""
    scenario = with_sigma(resolve_scenario("fig7", overrides_text(overrides)), 1.0)
    diagram, _ = MakeTeleopSimulation(scenario, true_load(scenario)[0])
    station = diagram.GetSubsystemByName("station")
    master = station.GetSubsystemByName("master_plant")
    amplifiers = station.GetSubsystemByName("master_amplifiers")
    operator = station.GetSubsystemByName("operator")
    controller = diagram.GetSubsystemByName("controller")
    B, E = master.GetFrameByName(BASE_FRAME), master.GetFrameByName(STYLUS_FRAME)
    stylus = master.GetBodyByName(STYLUS_FRAME)
    samples = {}

    def record(root):
        context = master.GetMyContextFromRoot(root)
        hand = operator.get_output_port().Eval(operator.GetMyContextFromRoot(root))[0]
        assert hand.body_index == stylus.index() and not hand.p_BoBq_B.any()
        samples[root.get_time()] = (  # keyed by time: the monitor also runs at initialization
            master.GetPositions(context).copy(),
            amplifiers.get_output_port().Eval(amplifiers.GetMyContextFromRoot(root)).copy(),
            stylus_jacobian(master, context, B, E),
            master.EvalBodySpatialVelocityInWorld(context, stylus).rotational().copy(),
            hand.F_Bq_W.rotational().copy(),
            controller.GetOutputPort("log.passivity_energy").Eval(controller.GetMyContextFromRoot(root)).copy())
        return EventStatus.Succeeded()

    simulator = Simulator(diagram)
    ApplySimulatorConfig(scenario.simulator, simulator)
    simulator.set_monitor(record)
    simulator.Initialize()
    simulator.AdvanceTo(scenario.duration)
    t = np.array(sorted(samples))
    columns = zip(*(samples[key] for key in t))
    names = ("q", "torque", "jacobian", "omega", "hand_torque", "energy")
    return {"t": t, "scenario": scenario, **{name: np.array(column) for name, column in zip(names, columns)}}


def plant_work(run) -> np.ndarray:
    """[translational, rotational] work (J) the master's actuators did on the stylus, from
    Drake's plant alone: per step the wrench the applied joint torques exert at E,
    w = J⁻ᵀ·τ, times the stylus's displacement J·Δq."""
    J, torque = run["jacobian"][:-1], run["torque"][:-1]
    wrench = np.linalg.solve(np.transpose(J, (0, 2, 1)), torque[..., None])[..., 0]
    displacement = np.einsum("nij,nj->ni", J, np.diff(run["q"], axis=0))
    work = wrench * displacement
    return np.array((work[:, :3].sum(), work[:, 3:].sum()))


def hand_rotational_energy(run) -> float:
    """Energy (J) the hand received from the stylus through rotation: −∫ τ_hand·ω dt."""
    return float(-np.sum(np.einsum("ni,ni->n", run["hand_torque"][:-1], run["omega"][:-1]) * np.diff(run["t"])))


def test_observed_energy_is_the_work_drakes_master_plant_receives():
    """0.7 s of fig7 at σ = 1: per channel, the PO's energy is (minus) the work the
    amplifiers' torques do on Drake's master, split at the stylus by J⁻ᵀ, and the rotational
    deficit is what the operator's hand receives through the stylus's rotation (its torque
    on the stylus and Drake's own ω, no Jacobian). The PO pairs each wrench with the velocity
    it was computed from; the plant applies it one step later: they agree to about 1 %."""
    run = fig7_master_port({"duration": 0.7})
    observed = run["energy"][-1]
    work = plant_work(run)
    assert -observed[1] > 0.03  # the hand got tens of mJ through the rotation
    np.testing.assert_allclose(work, -observed, rtol=0.03)
    assert hand_rotational_energy(run) == pytest.approx(-observed[1], rel=0.03)


@pytest.mark.slow
def test_fig7s_rotational_deficit_is_the_load_moment_driven_by_translation():
    """fig7 at σ = 1 (2 s): the load's moment m·c × a, which the horizontal motion makes at
    the sensor, twists the stylus against the hand. The rotational channel's observed deficit
    is the energy the hand's wrist damping dissipates; it stays as large when the slave's
    orientation does not follow the stylus (no rotational loop, so neither delay nor
    sample-and-hold of a rotational coupling makes it); the port as a whole stays passive once
    the hand moves (E_t + E_r > 0: the energy came in through translation); and the PC at its
    rotational bound could remove only a few percent of it, so E_r does not recover."""
    run = fig7_master_port({})
    scenario = run["scenario"]
    h = np.diff(run["t"])
    speed_squared = (run["omega"][:-1] ** 2).sum(axis=1)
    deficit = -run["energy"][-1, 1]
    wrist_damping = scenario.operator.rotational_damping * np.sum(speed_squared * h)
    assert deficit == pytest.approx(wrist_damping, rel=0.05)
    moving = run["t"] >= scenario.operator.start_time + 0.05
    assert (run["energy"][moving].sum(axis=1) > 0).all()
    pc_capacity = scenario.controller.passivity.max_rotational_damping * np.sum(speed_squared * h)
    assert pc_capacity < 0.05 * deficit
    no_loop = fig7_master_port({"controller.motion.rotation_scale": 0.0})
    assert -no_loop["energy"][-1, 1] == pytest.approx(deficit, rel=0.1)
