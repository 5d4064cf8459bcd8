import numpy as np
import pytest
from pydrake.math import RigidTransform, RollPitchYaw

from heft.systems.pose_vectors import pose_vector, rigid_transform


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
