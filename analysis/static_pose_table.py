"""A recording's static calibration poses, read whole (a few dozen rows) and checked like the streams."""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.spatial.transform import Rotation

from heft.analysis.column_files import ColumnFile, RecordingError
from heft.analysis.recording import Clock, Recording
from heft.systems.identification.rotation_sampling import ROTATION_TOLERANCE, rotation_defects


@dataclasses.dataclass
class StaticPoseTable:
    """One row per pose: ``wrench`` (N, 6) [f; τ] on the load (heft's sign, N, N·m, at S in S);
    ``accelerometer`` (N, 3) the raw linear reading in its own axes and unit (the recording's
    accelerometer stream says which), or None; ``gravity_S`` (N, 3) gravity in S (m/s²)."""
    wrench: np.ndarray
    accelerometer: np.ndarray | None
    gravity_S: np.ndarray


def read_static_poses(recording: Recording, joint_orientation=None) -> StaticPoseTable:
    """The ``static_poses`` table of ``recording``. The wrench takes the wrench stream's sign
    (``exerted_on``; sensor if the recording has no wrench stream); an orientation gives
    g_S = R_WSᵀ·gravity_W (``joint_orientation`` as for ``RecordingSource`` for joint angles)."""
    spec = recording.static_poses
    if spec is None:
        raise ValueError(f"{recording.source}: the recording has no static_poses")
    columns = list(spec.wrench) + list(spec.accelerometer or []) + list(spec.gravity_S or spec.orientation)
    file = ColumnFile(recording.path(spec.file), Clock(rate=1.0), columns, "static_poses", spec.delimiter)
    values = np.concatenate([v for _, v, _ in file.chunks()])
    sign = -1.0 if (recording.wrench is None or recording.wrench.exerted_on == "sensor") else 1.0
    wrench = sign * values[:, :6]
    k = 6
    accelerometer = None
    if spec.accelerometer:
        accelerometer, k = values[:, 6:9], 9
    rest = values[:, k:]
    if spec.gravity_S:
        return StaticPoseTable(wrench, accelerometer, rest)
    if spec.orientation_kind == "joint_positions":
        if joint_orientation is None:
            raise ValueError("static poses given as joint positions need the arm's kinematics (joint_orientation)")
        R = joint_orientation(rest)
    elif spec.orientation_kind == "rotation_matrix":
        R = rest.reshape(-1, 3, 3)
    else:
        xyzw = rest if spec.orientation_kind == "quaternion_xyzw" else np.roll(rest, -1, axis=1)
        norms = np.linalg.norm(xyzw, axis=1)
        bad = np.abs(norms - 1.0) > ROTATION_TOLERANCE
        if bad.any():
            row = int(np.argmax(bad)) + 1
            raise RecordingError(f"{file.where(f'{spec.orientation[0]}…{spec.orientation[-1]}', row)}: quaternion "
                                 f"of norm {norms[row - 1]:.6g} is not a unit quaternion")
        R = Rotation.from_quat(xyzw).as_matrix()
    defects = rotation_defects(R)
    bad = defects > ROTATION_TOLERANCE
    if bad.any():
        row = int(np.argmax(bad)) + 1
        raise RecordingError(f"{file.where(f'{spec.orientation[0]}…{spec.orientation[-1]}', row)}: not a rotation "
                             f"matrix (off by {defects[row - 1]:.3g})")
    return StaticPoseTable(wrench, accelerometer, np.einsum("nji,j->ni", R, np.asarray(recording.gravity_W, float)))
