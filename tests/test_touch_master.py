"""The Touch-type master (``master: touch``): three actuated joints and a passive, measured wrist. Its model
against Drake's kinematics, the force-only torque against Drake's Jacobian, and fig6 with it in the loop."""

import numpy as np
import pytest
from pydrake.multibody.tree import JacobianWrtVariable

from heft.diagrams.plants import MakeMasterPlant, master_actuated
from heft.diagrams.running.simulation import run_teleop, unrendered_torque_peak, with_sigma
from heft.diagrams.scenario import overrides_text, resolve_scenario
from heft.systems.controller.master_kinematics import BASE_FRAME, STYLUS_FRAME
from heft.systems.controller.passivity_controller import PassivityController, master_torque

L1 = L2 = 0.13335  # m, the Touch's links (SOURCES.md)
TOUCH_FORCE = 3.3   # N, its force limit (SOURCES.md)
PLANT = MakeMasterPlant("touch")
ACTUATED = master_actuated(PLANT)
RNG = np.random.default_rng(39)


def drake_jacobian(q) -> np.ndarray:
    """J_M (6×6, rows [v_E; ω_E] in B) at ``q`` from Drake's own kinematics."""
    context = PLANT.CreateDefaultContext()
    PLANT.SetPositions(context, q)
    B, E = PLANT.GetFrameByName(BASE_FRAME), PLANT.GetFrameByName(STYLUS_FRAME)
    J = PLANT.CalcJacobianSpatialVelocity(context, JacobianWrtVariable.kV, E, np.zeros(3), B, B)
    return np.vstack((J[3:], J[:3]))


def random_q() -> np.ndarray:
    return RNG.uniform(PLANT.GetPositionLowerLimits(), PLANT.GetPositionUpperLimits())


def test_touch_model_is_three_motors_and_a_wrist_meeting_at_the_stylus():
    assert ACTUATED.tolist() == [1, 1, 1, 0, 0, 0]
    assert master_actuated(MakeMasterPlant()).tolist() == [1] * 6
    context = PLANT.CreateDefaultContext()
    for _ in range(5):
        q = random_q()
        PLANT.SetPositions(context, q)
        p = PLANT.GetFrameByName(STYLUS_FRAME).CalcPose(context, PLANT.GetFrameByName(BASE_FRAME)).translation()
        reach = L1 * np.cos(q[1]) + L2 * np.sin(q[1] + q[2])
        closed_form = (np.cos(q[0]) * reach, np.sin(q[0]) * reach, L1 * np.sin(q[1]) - L2 * np.cos(q[1] + q[2]))
        np.testing.assert_allclose(p, closed_form, atol=1e-12)
        np.testing.assert_allclose(drake_jacobian(q)[:3, 3:], 0.0, atol=1e-12)  # the wrist moves no point of E


def test_force_only_torque_renders_the_intended_force_and_leaves_the_wrist_unpowered():
    """τ_M = J_vᵀ·f on the motors, zero on the wrist; Drake's Jacobian maps it back to [f; 0] at E."""
    for _ in range(5):
        q, wrench = random_q(), RNG.normal(size=6)
        wrench[:3] *= 0.5
        J = drake_jacobian(q)
        torque, applied, energy, damping, _ = master_torque(wrench, RNG.normal(size=6), J, [10.0, 10.0], 1e-3,
                                                            [5.0, 0.004], TOUCH_FORCE, 0.188, ACTUATED)
        assert torque[3:].tolist() == [0.0] * 3 and damping.tolist() == [0.0, 0.0]
        np.testing.assert_allclose(torque[:3], J[:3, :3].T @ wrench[:3], rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(J.T @ np.concatenate((wrench[:3], np.zeros(3))), torque, atol=1e-12)
        np.testing.assert_array_equal(applied, np.concatenate((wrench[:3], np.zeros(3))))
        assert energy[1] == 10.0  # no torque, no rotational power


def test_actuated_set_is_checked():
    with pytest.raises(ValueError, match="actuated must be six values"):
        PassivityController(actuated=[1, 1, 1])


def test_fig6_on_the_touch():
    """fig6 with the Touch: its 3.3 N limit brought by the master, the wrist never commanded, the stylus force
    (the motors' torques through Drake's Jacobian) within the limit and the intended force wherever the PC
    does not damp, and the torque left unrendered reported."""
    scenario = resolve_scenario("fig6", overrides_text({"master": "touch", "duration": 1.2}))
    assert scenario.controller.feedback.max_force == TOUCH_FORCE
    from tests.test_teleop import true_load
    run = run_teleop(with_sigma(scenario, 1.0), true_load(scenario), quiet=True)
    torque, q = run["master_torque"], run["master_q"]
    assert np.all(torque[:, 3:] == 0.0)
    # The torque logged at row k was taken with the Jacobian at the encoder positions of row k − 1 (a logger
    # publishes before the update of its instant).
    forces = np.array([np.linalg.solve(drake_jacobian(q[k - 1])[:3, :3].T, torque[k, :3]) for k in range(1, len(q))])
    assert np.max(np.linalg.norm(forces, axis=1)) <= TOUCH_FORCE * (1 + 1e-9)
    assert np.max(np.linalg.norm(forces, axis=1)) > 1.0  # the load's weight and swing were felt
    np.testing.assert_allclose(forces, run["master_force_applied"][1:, :3], atol=1e-9)
    undamped = run["passivity_damping"][1:, 0] == 0.0
    assert undamped.mean() > 0.5
    intended = run["master_force"][:-1, :3]  # the feedback's wrench of the same tick, logged a row before
    np.testing.assert_allclose(forces[undamped], intended[undamped], atol=1e-9)
    assert unrendered_torque_peak(run) > 0.0
