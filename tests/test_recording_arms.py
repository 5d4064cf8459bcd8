"""Recordings whose orientation is the joint angles of any arm heft knows (docs/recordings.md): the bundled
iiwa 14's seven, and a lab's own arm (``robot: custom`` with the recording's ``arm`` section, its URDF
beside the recording). The gravity each sample sees in S is the one the same motion gives as R_WS rows
computed by Drake from the arm's URDF alone; a recording that names an arm heft does not know, or gives it
the wrong number of joints, is refused in one line naming the file and field."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml
from pydrake.math import RollPitchYaw
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant

from heft.diagrams.recordings import open_recording

from foreign_arm import START as PANDA_START, X_FS as PANDA_X_FS, panda_urdf

MODELS = Path(__file__).resolve().parents[1] / "diagrams" / "models"
IIWA_START = np.array([0.0, 0.476, 0.0, -1.553, 0.0, 1.110, 0.0])
RATE = 200.0  # Hz, every stream
GRAVITY_W = np.array([0.0, 0.0, -9.81])


def _motion(start, seconds=2.0):
    t = np.arange(0.0, seconds, 1.0 / RATE)
    swing = 0.3 * np.sin(2 * np.pi * 0.5 * t)[:, None] * np.linspace(1.0, 0.4, len(start))
    return t, np.asarray(start) + swing


def _R_WS(urdf: Path, base: str, flange: str, R_FS: np.ndarray, q: np.ndarray) -> np.ndarray:
    """R_WS by Drake from the arm's URDF alone (the base welded at W, S at R_FS on the flange)."""
    plant = MultibodyPlant(time_step=0.0)
    Parser(plant).AddModels(str(urdf))
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName(base))
    plant.Finalize()
    context = plant.CreateDefaultContext()
    out = np.empty((len(q), 3, 3))
    for k, angles in enumerate(q):
        plant.SetPositions(context, angles)
        out[k] = plant.CalcRelativeRotationMatrix(context, plant.world_frame(),
                                                  plant.GetFrameByName(flange)).matrix() @ R_FS
    return out


def _write(folder: Path, t, orientation_columns: dict, orientation: dict, extra: dict | None = None) -> Path:
    """A recording of an unloaded sensor (the wrench and the accelerometer's reading zero) and the arm's
    orientation stream."""
    folder.mkdir(parents=True, exist_ok=True)
    stamps = np.round(t * 1e6).astype(np.int64)
    np.savetxt(folder / "ft.csv", np.column_stack([stamps, np.zeros((len(t), 6))]), delimiter=",",
               header="us,fx,fy,fz,tx,ty,tz", comments="", fmt=["%d"] + ["%.1f"] * 6)
    np.savetxt(folder / "imu.csv", np.column_stack([stamps, np.zeros((len(t), 3))]), delimiter=",",
               header="us,ax,ay,az", comments="", fmt=["%d"] + ["%.1f"] * 3)
    names = list(orientation_columns)
    np.savetxt(folder / "pose.csv", np.column_stack([stamps] + [orientation_columns[n] for n in names]),
               delimiter=",", header=",".join(["us"] + names), comments="", fmt=["%d"] + ["%.15g"] * len(names))
    document = {"wrench": {"file": "ft.csv", "time": {"column": "us", "unit": "us"},
                           "columns": ["fx", "fy", "fz", "tx", "ty", "tz"]},
                "accelerometer": {"file": "imu.csv", "time": {"column": "us", "unit": "us"},
                                  "columns": ["ax", "ay", "az"], "unit": "m/s^2"},
                "orientation": {"file": "pose.csv", "time": {"column": "us", "unit": "us"}, "columns": names,
                                **orientation},
                "gravity_W": GRAVITY_W.tolist()}
    path = folder / "recording.yaml"
    path.write_text(yaml.safe_dump(document, sort_keys=False) + (extra or ""))
    return path


def _gravity_S(path) -> np.ndarray:
    return open_recording(path).merged().g


def _rows(R) -> dict:
    return {f"r{i + 1}{j + 1}": R[:, i, j] for i in range(3) for j in range(3)}


def test_the_iiwa14s_seven_joint_angles_give_the_orientation_drake_gives(tmp_path):
    t, q = _motion(IIWA_START)
    joints = _write(tmp_path / "joints", t, {f"a{j + 1}": q[:, j] for j in range(7)},
                    {"kind": "joint_positions", "robot": "iiwa14"})
    R_WS = _R_WS(MODELS / "iiwa14.urdf", "iiwa14_base", "flange", np.eye(3), q)  # the JR3's S is parallel to F
    rows = _write(tmp_path / "rows", t, _rows(R_WS), {"kind": "rotation_matrix"})
    g_joints, g_rows = _gravity_S(joints), _gravity_S(rows)
    assert len(g_joints) > 0.8 * len(t)
    np.testing.assert_allclose(g_joints, g_rows, atol=1e-9)


def test_a_custom_arm_from_the_recordings_own_arm_section(tmp_path):
    folder = tmp_path / "lab"
    (folder / "arms").mkdir(parents=True)
    (folder / "arms" / "panda.urdf").write_text(panda_urdf())
    t, q = _motion(PANDA_START)
    arm = f"arm:\n  urdf: arms/panda.urdf\n  base: panda_link0\n  flange: panda_link8\n  X_FS: {PANDA_X_FS}\n"
    joints = _write(folder, t, {f"j{j + 1}": q[:, j] for j in range(7)},
                    {"kind": "joint_positions", "robot": "custom"}, arm)
    R_FS = RollPitchYaw(0.0, 0.0, -np.pi / 4).ToRotationMatrix().matrix()
    R_WS = _R_WS(folder / "arms" / "panda.urdf", "panda_link0", "panda_link8", R_FS, q)
    rows = _write(tmp_path / "rows", t, _rows(R_WS), {"kind": "rotation_matrix"})
    np.testing.assert_allclose(_gravity_S(joints), _gravity_S(rows), atol=1e-9)


@pytest.mark.parametrize("robot, columns, extra, words", [
    ("ur10", 6, "", ["orientation.robot must be one of rx90, rx60, ur5e, iiwa14 or custom", "'ur10'"]),
    ("iiwa14", 6, "", ["orientation names 6 joint columns", "iiwa14 arm has 7 joints"]),
    ("custom", 7, "", ["orientation.robot custom needs the recording's arm section"]),
    ("rx90", 8, "", ["orientation.columns needs 6 or 7 column names; got 8"]),
])
def test_an_arm_heft_cannot_use_is_refused_in_one_line(tmp_path, robot, columns, extra, words):
    t = np.arange(0.0, 0.5, 1.0 / RATE)
    path = _write(tmp_path, t, {f"a{j}": np.zeros(len(t)) for j in range(columns)},
                  {"kind": "joint_positions", "robot": robot}, extra)
    with pytest.raises(ValueError) as refusal:
        open_recording(path)
    message = str(refusal.value)
    assert "\n" not in message and message.startswith(str(path)), message
    for word in words:
        assert word in message, message
