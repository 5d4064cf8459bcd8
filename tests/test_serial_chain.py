"""``SerialChain``'s closed-form kinematics against Drake's MultibodyPlant, on the arms and the Phantom."""

import numpy as np
import pytest
from pydrake.multibody.tree import JacobianWrtVariable

from heft.diagrams.plants import MakeArmPlant, MakeMasterPlant
from heft.systems.drake_conventions import swap_halves
from heft.systems.load_dynamics import GRAVITY_W
from heft.systems.controller.master_kinematics import BASE_FRAME, STYLUS_FRAME
from heft.systems.serial_chain import SerialChain


def arm(robot):
    plant, S = MakeArmPlant(robot)
    return plant, plant.GetFrameByName(f"{robot}_base"), S


def phantom():
    plant = MakeMasterPlant()
    return plant, plant.GetFrameByName(BASE_FRAME), plant.GetFrameByName(STYLUS_FRAME)


@pytest.mark.parametrize("model", [lambda: arm("rx90"), lambda: arm("rx60"), phantom], ids=["rx90", "rx60", "phantom"])
def test_pose_jacobian_and_motion_equal_drakes(model):
    plant, B, E = model()
    chain = SerialChain(plant, B, E, GRAVITY_W)
    assert [joint.position_start() for joint in chain.joints] == list(range(6))
    context = plant.CreateDefaultContext()
    rng = np.random.default_rng(3)
    for _ in range(20):
        q, qd, qdd = rng.uniform(-2.5, 2.5, (3, 6))
        chain.update(q, qd, qdd)
        plant.SetPositions(context, q)
        plant.SetVelocities(context, qd)
        X_BE = plant.CalcRelativeTransform(context, B, E)
        J = plant.CalcJacobianSpatialVelocity(context, JacobianWrtVariable.kV, E, np.zeros(3), B, B)
        bias = plant.CalcBiasSpatialAcceleration(context, JacobianWrtVariable.kV, E, np.zeros(3), B, B).get_coeffs()
        R_EB = X_BE.rotation().matrix().T
        alpha_a = (J @ qdd + bias).reshape(2, 3)
        np.testing.assert_allclose(chain.R, X_BE.rotation().matrix(), rtol=0, atol=1e-14)
        np.testing.assert_allclose(chain.p, X_BE.translation(), rtol=0, atol=1e-14)
        np.testing.assert_allclose(chain.J, swap_halves(J, axis=0), rtol=0, atol=1e-14)
        expected = np.concatenate((R_EB @ alpha_a[1], R_EB @ alpha_a[0], R_EB @ (J[:3] @ qd), R_EB @ GRAVITY_W))
        np.testing.assert_allclose(chain.motion, expected, rtol=0, atol=1e-12 * (1 + np.abs(expected).max()))


def test_velocity_and_acceleration_are_the_derivatives_of_the_pose():
    """Independent of Drake: central differences of p_BE along q(t) = q₀ + q̇₀t + q̈₀t²/2 give v and a."""
    plant, B, E = arm("rx90")
    chain = SerialChain(plant, B, E)
    q0, qd0, qdd0 = np.random.default_rng(4).uniform(-1.5, 1.5, (3, 6))
    h = 1e-4

    def p_at(t):
        chain.update(q0 + qd0 * t + 0.5 * qdd0 * t * t)
        return chain.p.copy()

    chain.update(q0, qd0, qdd0)
    R_BE, v, motion = chain.R.copy(), chain.J[:3] @ qd0, chain.motion.copy()
    np.testing.assert_allclose(v, (p_at(h) - p_at(-h)) / (2 * h), rtol=0, atol=1e-7)
    a_B = (p_at(h) - 2 * p_at(0.0) + p_at(-h)) / (h * h)
    np.testing.assert_allclose(R_BE @ motion[:3], a_B, rtol=0, atol=1e-4 * (1 + np.abs(a_B).max()))


def test_a_frame_off_the_chain_is_refused():
    plant, B, E = arm("rx90")
    with pytest.raises(ValueError, match="not on a chain of joints below frame"):
        SerialChain(plant, E, B)
