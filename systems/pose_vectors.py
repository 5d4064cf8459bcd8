"""Poses on vector ports: [p (3, m); quaternion (w, x, y, z) (4)].

Controller ports carry poses as 7-vectors rather than AbstractValue RigidTransforms
(cheaper per tick, and loggable); these two functions are the only conversions.
"""

import numpy as np
from pydrake.common.eigen_geometry import Quaternion
from pydrake.math import RigidTransform, RotationMatrix

POSE_SIZE = 7


def pose_vector(X: RigidTransform) -> np.ndarray:
    """[p; w, x, y, z] of X, with the quaternion's w ≥ 0."""
    q = X.rotation().ToQuaternion().wxyz()
    return np.concatenate((X.translation(), q if q[0] >= 0 else -q))


def rigid_transform(pose) -> RigidTransform:
    """The RigidTransform of a pose vector (the quaternion is normalised)."""
    pose = np.asarray(pose, dtype=float)
    q = pose[3:]
    norm = np.linalg.norm(q)
    if pose.shape != (POSE_SIZE,) or not np.isfinite(pose).all() or norm < 1e-9:
        raise ValueError(f"pose must be 7 finite numbers [p; w, x, y, z] with a non-zero quaternion; got {pose}")
    return RigidTransform(RotationMatrix(Quaternion(q / norm)), pose[:3])
