"""The accelerometer convention: what a sensor hanging still reports, and the load's weight
found from that reading once, even when the controller's idea of gravity in S is off."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from heft.systems.accelerometer_reading import motion_from_reading, reading_from_motion
from heft.systems.load_dynamics import regressor

G_W = np.array([0.0, 0.0, -9.81])
MASS, COM = 3.13, np.array([0.01, -0.02, 0.12])  # kg, m in S
PHI = np.concatenate(([MASS], MASS * COM, [0.05, 0.001, -0.002, 0.06, 0.003, 0.02]))


def test_hanging_still_the_reading_points_up_with_one_g():
    R_WS = Rotation.from_rotvec([0.4, -1.1, 0.3]).as_matrix()
    reading = reading_from_motion(np.zeros(6), R_WS.T @ G_W)
    np.testing.assert_allclose(R_WS @ reading[:3], [0.0, 0.0, 9.81], atol=1e-12)
    np.testing.assert_array_equal(reading_from_motion(np.zeros(6), R_WS.T @ G_W, includes_gravity=False), 0.0)


@pytest.mark.parametrize("includes_gravity", [True, False])
def test_the_weight_is_found_once_whatever_error_gravity_in_S_has(includes_gravity):
    """At rest the sensor carries the weight: f = −m·g_S, τ = c × f (closed form). The
    controller's g_S comes from kinematics that are 3° off; with a specific-force reading
    that error cancels, with a gravity-free one it cannot be avoided and stays small."""
    R_WS = Rotation.from_rotvec([0.2, 2.5, -0.4]).as_matrix()
    g_true = R_WS.T @ G_W
    g_believed = Rotation.from_rotvec([0.0, np.radians(3.0), 0.0]).as_matrix() @ g_true
    reading = reading_from_motion(np.zeros(6), g_true, includes_gravity)
    acceleration = motion_from_reading(np.empty(6), reading, g_believed, includes_gravity)
    wrench = regressor(acceleration[:3], acceleration[3:], np.zeros(3), g_believed) @ PHI
    f = -MASS * g_true
    expected = np.concatenate((f, np.cross(COM, f)))
    error = np.abs(wrench - expected).max()
    if includes_gravity:
        assert error < 1e-12
    else:
        assert 0.1 < error < MASS * 9.81 * np.radians(3.0) * 1.01


def test_batches_convert_row_by_row():
    rng = np.random.default_rng(0)
    motion, gravity = rng.normal(size=(5, 6)), rng.normal(size=(5, 3))
    reading = reading_from_motion(motion, gravity)
    np.testing.assert_allclose(reading[:, :3], motion[:, :3] - gravity)
    np.testing.assert_array_equal(reading[:, 3:], motion[:, 3:])
    np.testing.assert_allclose(motion_from_reading(np.empty((5, 6)), reading, gravity), motion, atol=1e-15)
