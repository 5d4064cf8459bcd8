import numpy as np
import pytest
from pydrake.common.eigen_geometry import Quaternion
from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix

from heft.systems.pose_vectors import pose_vector, rigid_transform, rotation_into


def test_round_trip_and_sign():
    rng = np.random.default_rng(0)
    for _ in range(50):
        X = RigidTransform(RollPitchYaw(rng.uniform(-np.pi, np.pi, 3)), rng.normal(size=3))
        v = pose_vector(X)
        assert v[3] >= 0 and np.linalg.norm(v[3:]) == pytest.approx(1.0)
        assert rigid_transform(v).IsNearlyEqualTo(X, 1e-12)
        assert rigid_transform(np.concatenate((v[:3], -2 * v[3:]))).IsNearlyEqualTo(X, 1e-12)


@pytest.mark.parametrize("bad", [np.zeros(7), np.ones(6), [0, 0, 0, np.nan, 0, 0, 1]])
def test_bad_pose_is_rejected(bad):
    with pytest.raises(ValueError, match="pose must be 7 finite numbers"):
        rigid_transform(bad)


def test_rotation_into_is_drakes_for_any_scale_of_the_quaternion():
    rng = np.random.default_rng(5)
    R = np.empty((3, 3))
    for _ in range(20):
        q = rng.normal(size=4) * rng.uniform(0.1, 10.0)
        expected = RotationMatrix(Quaternion(q / np.linalg.norm(q))).matrix()
        assert rotation_into(np.concatenate((rng.normal(size=3), q)), R)
        np.testing.assert_allclose(R, expected, atol=1e-14)
    before = R.copy()
    for bad in ([0, 0, 0, 0, 0, 0, 0.0], [0, 0, np.nan, 1, 0, 0, 0.0], [0, 0, 0, 1, 0, 0.0]):
        assert not rotation_into(np.array(bad), R)
    np.testing.assert_array_equal(R, before)


def test_pose_vector_is_drakes_quaternion_to_round_off():
    """``pose_into`` (Shepperd's method, scalar) against Drake's ``RotationMatrix.ToQuaternion``, w ≥ 0, for
    rotations of every kind, the near-π ones (where w is the smallest component) among them."""
    rng = np.random.default_rng(12)
    for k in range(2000):
        q = rng.normal(size=4)
        if k % 3 == 0:
            q[rng.integers(4)] *= 1e-4  # one component all but gone: each branch of the method
        X = RigidTransform(RotationMatrix(Quaternion(q / np.linalg.norm(q))), rng.normal(size=3))
        expected = X.rotation().ToQuaternion().wxyz()
        expected = expected if expected[0] >= 0 else -expected
        pose = pose_vector(X)
        np.testing.assert_array_equal(pose[:3], X.translation())
        np.testing.assert_allclose(pose[3:], expected, rtol=0, atol=2e-15)
