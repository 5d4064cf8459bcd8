"""The damped least-squares IK of any 6- or 7-joint chain (systems/controller/chain_inverse_kinematics.py) against
Drake's own forward kinematics (CalcRelativeTransform): it tracks a reachable pose trajectory on the
bundled UR5e and iiwa 14, keeps every command within the position and speed limits, draws a 7-joint
arm's null space to the start posture without moving the flange, and on the RX90 finds the pose its
closed form finds."""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np
import pytest
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant

from heft.diagrams.plants import MakeArmPlant
from heft.systems import compiled
from heft.systems.controller.chain_inverse_kinematics import (JOINT_LIMIT, NON_FINITE, NOT_CONVERGED, SLEWING, ChainIk,
                                                   chain_ik_update)
from heft.systems.pose_vectors import pose_vector
from heft.systems.controller.rx_inverse_kinematics import RxKinematics

MODELS = Path(__file__).resolve().parents[1] / "diagrams" / "models"
DT = 0.0005  # s, the controller's period
START = {"ur5e": np.array([0.3, -1.2, 1.4, -0.8, 1.1, 0.4]),
         "iiwa14": np.array([0.3, 0.6, -0.2, -1.2, 0.4, 0.9, 0.2])}


class Arm:
    """Drake's plant of a bundled arm alone, its base R and flange F."""

    def __init__(self, name):
        self.plant = MultibodyPlant(time_step=0.0)
        Parser(self.plant).AddModels(str(MODELS / f"{name}.urdf"))
        self.R, self.F = self.plant.GetFrameByName(f"{name}_base"), self.plant.GetFrameByName("flange")
        self.plant.WeldFrames(self.plant.world_frame(), self.R)
        self.plant.Finalize()
        self.context = self.plant.CreateDefaultContext()
        self.n = self.plant.num_positions()

    def X_RF(self, q):
        self.plant.SetPositions(self.context, q)
        return self.plant.CalcRelativeTransform(self.context, self.R, self.F)

    def ik(self, q_start, **kw) -> ChainIk:
        return ChainIk(self.plant, self.R, self.F, q_start, **kw)


@cache
def _arm(name) -> Arm:
    return Arm(name)


def _pose_error(X, Y) -> float:
    """The largest difference of position (m) and rotation matrix entries of two poses."""
    return max(np.abs(X.translation() - Y.translation()).max(),
               np.abs(X.rotation().matrix() - Y.rotation().matrix()).max())


def _within_limits(ik, q_last, command):
    assert ((command >= ik.lower) & (command <= ik.upper)).all()
    assert (np.abs(command - q_last) <= ik.velocity * DT * (1 + 1e-12)).all()


@pytest.mark.parametrize("name", ["ur5e", "iiwa14"])
def test_tracks_a_reachable_pose_trajectory(name):
    arm = _arm(name)
    q0 = START[name]
    ik = arm.ik(q0)
    q = q0.copy()
    phases = np.arange(arm.n)
    for k in range(2000):  # 1 s of a joint-space motion of 0.4 rad at 0.5 Hz, as poses
        t = k * DT
        X_target = arm.X_RF(q0 + 0.4 * (np.sin(np.pi * t + phases) - np.sin(phases)))
        q_last = q.copy()
        status = ik(pose_vector(X_target), q_last, DT, q)
        assert status == 0, (k, status)
        _within_limits(ik, q_last, q)
        assert _pose_error(arm.X_RF(q), X_target) < 1e-8, k


@pytest.mark.parametrize("name", ["ur5e", "iiwa14"])
def test_a_pose_beyond_a_joint_limit_holds_the_joint_there(name):
    arm = _arm(name)
    ik = arm.ik(START[name])
    q_beyond = START[name].copy()
    q_beyond[1] = ik.upper[1] + 0.3
    X_target = arm.X_RF(q_beyond)
    q = START[name].copy()
    q[1] = ik.upper[1] - 0.2
    statuses = 0
    for _ in range(4000):
        q_last = q.copy()
        statuses |= ik(pose_vector(X_target), q_last, DT, q)
        _within_limits(ik, q_last, q)
    assert statuses & JOINT_LIMIT and statuses & NOT_CONVERGED
    assert q[1] == pytest.approx(ik.upper[1], abs=1e-12)


def test_a_far_pose_is_approached_at_the_speed_limits():
    arm = _arm("iiwa14")
    ik = arm.ik(START["iiwa14"])
    q_far = START["iiwa14"] + 0.5
    X_far = arm.X_RF(q_far)
    q = START["iiwa14"].copy()
    q_last = q.copy()
    status = ik(pose_vector(X_far), q_last, DT, q)
    assert status & SLEWING
    _within_limits(ik, q_last, q)
    assert np.isclose(np.abs(q - q_last), ik.velocity * DT).any()
    for _ in range(4000):  # 2 s: there, the null space drawing toward q_start on the way
        q_last = q.copy()
        status = ik(pose_vector(X_far), q_last, DT, q)
        _within_limits(ik, q_last, q)
    assert status == 0 and _pose_error(arm.X_RF(q), X_far) < 1e-8


def _self_motion(arm, q_from, q_toward, X, seconds, null_rate):
    """Ticks holding pose X from q_from with the null space drawn toward q_toward; the postures and the
    largest pose error on the way."""
    ik = arm.ik(q_toward, null_rate=null_rate)
    q, worst, postures = q_from.copy(), 0.0, []
    for _ in range(int(seconds / DT)):
        q_last = q.copy()
        ik(pose_vector(X), q_last, DT, q)
        _within_limits(ik, q_last, q)
        worst = max(worst, _pose_error(arm.X_RF(q), X))
        postures.append(q.copy())
    return np.array(postures), worst


def test_the_null_space_drifts_to_the_start_posture_with_the_flange_held():
    arm = _arm("iiwa14")
    q_start = START["iiwa14"]
    X = arm.X_RF(q_start)
    # Another posture of the same flange pose: the null space drawn elsewhere for a while.
    elsewhere = q_start + np.array([0.6, 0.0, 0.6, 0.0, -0.6, 0.0, 0.6])
    postures, worst = _self_motion(arm, q_start, elsewhere, X, 1.0, null_rate=2.0)
    q_other = postures[-1]
    assert worst < 1e-8 and np.linalg.norm(q_other - q_start) > 0.3
    # From there, drawn to the start posture: back to it, the flange held all the way.
    postures, worst = _self_motion(arm, q_other, q_start, X, 4.0, null_rate=2.0)
    distance = np.linalg.norm(postures - q_start, axis=1)
    assert worst < 1e-8
    assert distance[-1] < 1e-3 * distance[0]
    assert (np.diff(distance) <= 1e-12).all()  # nearer every tick
    # Without the pull it stays where it is.
    postures, worst = _self_motion(arm, q_other, q_start, X, 0.5, null_rate=0.0)
    assert worst < 1e-8 and np.abs(postures - q_other).max() < 1e-9


def test_converges_on_the_rx90_to_the_pose_of_its_closed_form():
    plant, _ = MakeArmPlant("rx90")
    context = plant.CreateDefaultContext()
    R, F = plant.GetFrameByName("rx90_base"), plant.GetFrameByName("flange")
    kin = RxKinematics.rx90()
    ik = ChainIk(plant, R, F, np.zeros(6))
    rng = np.random.default_rng(5)
    tried = 0
    while tried < 30:
        q_true = rng.uniform(kin.lower, kin.upper)
        if abs(np.sin(q_true[2])) < 0.2 or abs(np.sin(q_true[4])) < 0.2:
            continue  # away from the elbow and wrist singularities
        tried += 1
        R_RF, p_RF = kin.forward(q_true)
        q = np.clip(q_true + rng.normal(0.0, 0.05, 6), kin.lower, kin.upper)
        closed_form = kin.solve_nearest(R_RF, p_RF, q)
        assert closed_form.reachable
        X_target = RigidTransform(RotationMatrix(R_RF), p_RF)
        pose = pose_vector(X_target)
        for _ in range(20):
            status = ik(pose, q, 1.0, q)  # 1 s ticks: no speed limit binds
            if status == 0:
                break
        assert status == 0
        np.testing.assert_allclose(q, closed_form.q, atol=1e-8)
        plant.SetPositions(context, q)
        assert _pose_error(plant.CalcRelativeTransform(context, R, F), X_target) < 1e-9


def test_a_pose_that_is_not_one_leaves_the_command_and_no_time_moves_nothing():
    arm = _arm("ur5e")
    ik = arm.ik(START["ur5e"])
    command = np.empty(6)
    assert ik(np.full(7, np.nan), START["ur5e"], DT, command) == NON_FINITE
    np.testing.assert_array_equal(command, START["ur5e"])
    X = arm.X_RF(START["ur5e"] + 0.1)
    for dt in (np.nan, -1.0, 0.0):
        assert ik(pose_vector(X), START["ur5e"], dt, command) & SLEWING
        np.testing.assert_array_equal(command, START["ur5e"])


def test_chains_of_other_lengths_and_open_limits_are_refused():
    arm = _arm("ur5e")
    with pytest.raises(ValueError, match="has 5 joints; the inverse kinematics takes 6 or 7"):
        ChainIk(arm.plant, arm.plant.GetFrameByName("ur5e_link1"), arm.F, np.zeros(5))
    with pytest.raises(ValueError, match="finite joint limits"):
        arm.ik(START["ur5e"], lower=np.full(6, -np.inf))
    with pytest.raises(ValueError, match="within the limits"):
        arm.ik(np.full(6, 7.0))


@pytest.mark.skipif(compiled.PURE_PYTHON, reason="the kernels run as plain Python")
def test_a_tick_allocates_nothing():
    from numba.core.runtime import _nrt_python, rtsys
    arm = _arm("iiwa14")
    ik = arm.ik(START["iiwa14"])
    pose = pose_vector(arm.X_RF(START["iiwa14"] + 0.05))
    arguments = (START["iiwa14"].copy(), np.zeros(2), np.zeros(1), pose, np.array([DT]), ik.record)  # a tick's
    boxed = len(arguments)  # numba wraps each array argument once per call
    _nrt_python.memsys_enable_stats()
    try:
        chain_ik_update[7](*arguments)
        before = rtsys.get_allocation_stats().alloc
        for _ in range(10):
            chain_ik_update[7](*arguments)
        assert rtsys.get_allocation_stats().alloc - before == 10 * boxed
    finally:
        _nrt_python.memsys_disable_stats()
