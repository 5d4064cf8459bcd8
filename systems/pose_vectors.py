"""Poses on vector ports: [p (3, m); quaternion (w, x, y, z) (4)].

Controller ports carry poses as 7-vectors rather than AbstractValue RigidTransforms
(cheaper per tick, and loggable); these functions are the only conversions.
"""

import math

import numpy as np
from pydrake.common.eigen_geometry import Quaternion
from pydrake.math import RigidTransform, RotationMatrix

from heft.systems.compiled import compiled

POSE_SIZE = 7


def pose_vector(X: RigidTransform) -> np.ndarray:
    """[p; w, x, y, z] of X, with the quaternion's w ≥ 0 (``pose_into``)."""
    pose = np.empty(POSE_SIZE)
    pose_into(X.rotation().matrix(), np.array(X.translation()), pose)
    return pose


@compiled("void(float64[:, :], float64[:], float64[:])")
def pose_into(R, p, pose) -> None:
    """[p; w, x, y, z] of the rotation matrix ``R`` and the position ``p`` into ``pose`` (7), the
    quaternion's w ≥ 0: Shepperd's method (J. Guidance Control 1(3), 1978), from the largest of
    w², x², y², z², as Eigen's ``Quaternion(Matrix3)``."""
    trace = R[0, 0] + R[1, 1] + R[2, 2]
    if trace > 0.0:
        t = math.sqrt(trace + 1.0)
        w, t = 0.5 * t, 0.5 / t
        x, y, z = (R[2, 1] - R[1, 2]) * t, (R[0, 2] - R[2, 0]) * t, (R[1, 0] - R[0, 1]) * t
    else:
        i = 0
        if R[1, 1] > R[0, 0]:
            i = 1
        if R[2, 2] > R[i, i]:
            i = 2
        j, k = (i + 1) % 3, (i + 2) % 3
        t = math.sqrt(R[i, i] - R[j, j] - R[k, k] + 1.0)
        v_i, t = 0.5 * t, 0.5 / t
        w, v_j, v_k = (R[k, j] - R[j, k]) * t, (R[j, i] + R[i, j]) * t, (R[k, i] + R[i, k]) * t
        x = v_i if i == 0 else (v_k if i == 1 else v_j)
        y = v_j if i == 0 else (v_i if i == 1 else v_k)
        z = v_k if i == 0 else (v_j if i == 1 else v_i)
    sign = 1.0 if w >= 0.0 else -1.0
    pose[0], pose[1], pose[2] = p[0], p[1], p[2]
    pose[3], pose[4], pose[5], pose[6] = sign * w, sign * x, sign * y, sign * z


@compiled("boolean(float64[:], float64[:, :])")
def rotation_into(pose, R) -> bool:
    """Writes into R (3×3) the rotation of a pose vector's quaternion (normalised); returns False,
    R untouched, if the pose is not 7 finite numbers with a non-zero quaternion."""
    if pose.shape[0] != POSE_SIZE:
        return False
    total = 0.0
    for value in pose:
        total += value
    if not math.isfinite(total):
        return False
    w, x, y, z = pose[3], pose[4], pose[5], pose[6]
    norm2 = w * w + x * x + y * y + z * z
    if norm2 < 1e-18:
        return False
    s = 2.0 / norm2
    R[0, 0], R[0, 1], R[0, 2] = 1.0 - s * (y * y + z * z), s * (x * y - w * z), s * (x * z + w * y)
    R[1, 0], R[1, 1], R[1, 2] = s * (x * y + w * z), 1.0 - s * (x * x + z * z), s * (y * z - w * x)
    R[2, 0], R[2, 1], R[2, 2] = s * (x * z - w * y), s * (y * z + w * x), 1.0 - s * (x * x + y * y)
    return True


def rigid_transform(pose) -> RigidTransform:
    """The RigidTransform of a pose vector (the quaternion is normalised)."""
    pose = np.asarray(pose, dtype=float)
    q = pose[3:]
    norm = np.linalg.norm(q)
    if pose.shape != (POSE_SIZE,) or not np.isfinite(pose).all() or norm < 1e-9:
        raise ValueError(f"pose must be 7 finite numbers [p; w, x, y, z] with a non-zero quaternion; got {pose}")
    return RigidTransform(RotationMatrix(Quaternion(q / norm)), pose[:3])
