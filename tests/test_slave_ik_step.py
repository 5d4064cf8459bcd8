"""One tick of the slave IK (``ik_step`` through ``IkStep``, as the slave IK block runs it) against Drake's
forward kinematics of the arm + sensor plant: the command puts S on the desired pose, moves at most at the
speed limits, and holds on a pose it cannot reach, the status saying why."""

import numpy as np
import pytest

from heft.diagrams.plants import MakeArmPlant
from heft.systems.pose_vectors import pose_vector
from heft.systems.controller.rx_inverse_kinematics import (JOINT_LIMIT, NON_FINITE, OUT_OF_REACH, SHOULDER_SINGULARITY,
                                                WRIST_SINGULARITY, RxKinematics, limit_joints)
from heft.systems.controller.slave_inverse_kinematics import SLEWING, IkStep


class Slave:
    """Drake's plant of an arm with its sensor, and the tick's IK for the sensor frame S."""

    def __init__(self, robot):
        self.plant, self.S = MakeArmPlant(robot)
        self.context = self.plant.CreateDefaultContext()
        self.base, self.flange = self.plant.GetFrameByName(f"{robot}_base"), self.plant.GetFrameByName("flange")
        self.kin = getattr(RxKinematics, robot)()
        self.ik_step = IkStep(self.kin, self.S.CalcPose(self.context, self.flange).inverse())

    def pose(self, q, frame=None):
        """X_R(frame) (default S) at joint angles q, from Drake."""
        self.plant.SetPositions(self.context, q)
        return self.plant.CalcRelativeTransform(self.context, self.base, frame or self.S)

    def wrist_centre(self, q):
        X_RF = self.pose(q, self.flange)
        return X_RF.translation() - self.kin.d6 * X_RF.rotation().matrix()[:, 2]

    def regular_q(self, rng, count):
        """Joint angles within the limits where the branches are well apart (as test_rx_inverse_kinematics)."""
        kin, samples = self.kin, []
        while len(samples) < count:
            q = rng.uniform(kin.lower, kin.upper)
            x1 = kin.a2 * np.sin(q[1]) + kin.d4 * np.sin(q[1] + q[2])
            if abs(np.sin(q[2])) >= 0.1 and abs(np.sin(q[4])) >= kin.wrist_band and abs(x1) >= 0.05:
                samples.append(q)
        return samples


@pytest.fixture(scope="module", params=["rx90", "rx60"])
def slave(request):
    return Slave(request.param)


def test_the_command_puts_S_on_the_desired_pose(slave):
    rng = np.random.default_rng(21)
    command = np.empty(6)
    for q in slave.regular_q(rng, 100):
        q_last = np.clip(q + rng.normal(0.0, 0.01, 6), slave.kin.lower, slave.kin.upper)
        X_RS = slave.pose(q)
        status = slave.ik_step(pose_vector(X_RS), q_last, 0.05, command)  # 0.05 s: no speed limit binds
        assert status == 0
        np.testing.assert_allclose(command, q, atol=1e-9)  # the nearest solution, the same turn of joints 4, 6
        assert slave.pose(command).IsNearlyEqualTo(X_RS, 1e-9)


def test_far_commands_move_at_the_speed_limits_until_they_arrive(slave):
    rng = np.random.default_rng(22)
    dt = 5e-4
    max_step = slave.kin.velocity * dt
    for q in slave.regular_q(rng, 10):
        q_last = np.clip(q + rng.uniform(-0.02, 0.02, 6), slave.kin.lower, slave.kin.upper)
        pose = pose_vector(slave.pose(q))
        command = q_last.copy()
        for _ in range(int(np.ceil((np.abs(q - q_last) / max_step).max())) - 1):
            expected = command + np.clip(q - command, -max_step, max_step)
            assert slave.ik_step(pose, command, dt, command) == SLEWING  # in place: command is q_last
            np.testing.assert_allclose(command, expected, rtol=0, atol=1e-12)
        assert slave.ik_step(pose, command, dt, command) == 0
        assert slave.pose(command).IsNearlyEqualTo(slave.pose(q), 1e-9)


def test_a_tick_of_no_time_moves_nothing(slave):
    """A dt that is NaN or negative (a clock gone wrong) gives the joints no time to move in: the command
    stays where it was, and the speed limit says so."""
    rng = np.random.default_rng(23)
    command = np.empty(6)
    for q in slave.regular_q(rng, 5):
        q_last = np.clip(q + 0.05, slave.kin.lower, slave.kin.upper)
        for dt in (np.nan, -1e-3):
            assert slave.ik_step(pose_vector(slave.pose(q)), q_last, dt, command) == SLEWING
            np.testing.assert_array_equal(command, q_last)


def test_a_pose_it_cannot_reach_holds_the_command_and_says_why():
    slave = Slave("rx90")
    q_last = np.array([0.3, 0.4, 1.0, 0.2, 0.7, 0.1])
    command = np.empty(6)
    far = pose_vector(slave.pose(q_last))
    far[:3] += [2.0, 0.0, 0.0]
    not_a_pose = pose_vector(slave.pose(q_last))
    not_a_pose[3:] = 0.0
    nan_pose = pose_vector(slave.pose(q_last))
    nan_pose[5] = np.nan
    past_joint3 = pose_vector(slave.pose([0.3, 0.4, 2.6, 0.2, 0.7, 0.1]))  # |q3| = 2.6 > 142.5° on every branch
    for pose, expected in ((far, OUT_OF_REACH), (not_a_pose, NON_FINITE), (nan_pose, NON_FINITE),
                           (past_joint3, JOINT_LIMIT | 1 << 7)):
        command[:] = np.nan
        status = slave.ik_step(pose, q_last, 0.05, command)
        assert status == expected
        np.testing.assert_array_equal(command, q_last)
    assert limit_joints(JOINT_LIMIT | 1 << 7) == [3]


def test_near_the_singularities_the_wrist_centre_stays_exact(slave):
    """Within the wrist band the orientation is approximate (rx_inverse_kinematics), the wrist centre not;
    on the J1 axis (RX90) q1 keeps the last command's value."""
    rng = np.random.default_rng(23)
    command = np.empty(6)
    for q in slave.regular_q(rng, 20):
        q[4] = rng.uniform(-0.02, 0.02)
        status = slave.ik_step(pose_vector(slave.pose(q)), q, 0.05, command)
        assert status == WRIST_SINGULARITY
        np.testing.assert_allclose(slave.wrist_centre(command), slave.wrist_centre(q), atol=1e-9)
    if slave.kin.d3 == 0.0:
        q = np.array([0.3, -0.3, 0.8, 0.2, 0.7, 0.1])
        X_RF = slave.pose(q, slave.flange)
        p_C = slave.wrist_centre(q)
        on_axis = X_RF.translation() - [p_C[0], p_C[1], 0.0]  # the flange moved so that its wrist centre is on J1
        X_RS = slave.pose(q)
        pose = pose_vector(X_RS)
        pose[:3] = X_RS.translation() - [p_C[0], p_C[1], 0.0]
        assert slave.ik_step(pose, q, 0.05, command) == SHOULDER_SINGULARITY
        assert command[0] == pytest.approx(q[0], abs=1e-12)
        np.testing.assert_allclose(slave.wrist_centre(command)[:2], 0.0, atol=1e-12)
        np.testing.assert_allclose(slave.pose(command, slave.flange).translation(), on_axis, atol=1e-9)
