"""Poses on vector ports: [p (3, m); quaternion (w, x, y, z) (4)].

Controller ports carry poses as 7-vectors rather than AbstractValue RigidTransforms
(cheaper per tick, and loggable); these functions are the only conversions.
"""

import math

import numpy as np
from pydrake.common.eigen_geometry import Quaternion
from pydrake.math import RigidTransform, RotationMatrix

POSE_SIZE = 7


def pose_vector(X: RigidTransform) -> np.ndarray:
    """[p; w, x, y, z] of X, with the quaternion's w ≥ 0."""
    q = X.rotation().ToQuaternion().wxyz()
    return np.concatenate((X.translation(), q if q[0] >= 0 else -q))


def rotation_matrix(pose) -> np.ndarray | None:
    """R (3×3) of a pose vector's quaternion (normalised), or None if the pose is not
    7 finite numbers with a non-zero quaternion. Scalar arithmetic: no objects per call."""
    if len(pose) != POSE_SIZE or not math.isfinite(sum(pose)):
        return None
    w, x, y, z = pose[3], pose[4], pose[5], pose[6]
    norm2 = w * w + x * x + y * y + z * z
    if norm2 < 1e-18:
        return None
    s = 2.0 / norm2
    return np.array(((1.0 - s * (y * y + z * z), s * (x * y - w * z), s * (x * z + w * y)),
                     (s * (x * y + w * z), 1.0 - s * (x * x + z * z), s * (y * z - w * x)),
                     (s * (x * z - w * y), s * (y * z + w * x), 1.0 - s * (x * x + y * y))))


def rigid_transform(pose) -> RigidTransform:
    """The RigidTransform of a pose vector (the quaternion is normalised)."""
    pose = np.asarray(pose, dtype=float)
    q = pose[3:]
    norm = np.linalg.norm(q)
    if pose.shape != (POSE_SIZE,) or not np.isfinite(pose).all() or norm < 1e-9:
        raise ValueError(f"pose must be 7 finite numbers [p; w, x, y, z] with a non-zero quaternion; got {pose}")
    return RigidTransform(RotationMatrix(Quaternion(q / norm)), pose[:3])
