"""Recordings in a layout heft did not choose: streams merged onto the wrench's timeline against Drake's
own motion and wrench, the clock offset found, chunked reading equal to whole, and the rotation math
against Drake's."""

import csv

import numpy as np
import pytest
from drake_motion import PAPER_TOOL, SmoothMotion
from pydrake.math import RotationMatrix
from pydrake.trajectories import PiecewiseQuaternionSlerp
from scipy.spatial.transform import Rotation

from heft.analysis import column_files
from heft.analysis.clock_offsets import estimate_clock_offsets
from heft.analysis.recording import load_recording
from heft.analysis.recording_merge import RecordingSource
from heft.systems.accelerometer_reading import AccelerometerConvention, reading_from_motion
from heft.systems.rotation_sampling import body_angular_velocity, continuous, rotate_into_body, slerp

EPOCH_US = 1_700_000_000_000_000  # stamps on a wall clock, as drivers write them
R_SA = Rotation.from_rotvec([0.3, -0.5, 0.7]).as_matrix()  # not about one axis
P_SA = np.array([0.02, 0.01, -0.008])
BIAS_G = np.array([0.0, 0.08, 0.0])
LATE = 0.006  # the accelerometer's stamps run 6 ms late
DURATION = 3.0


def _write(path, header, rows):
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(header)
        writer.writerows(rows)


def write_recording(folder, orientation="rotation_matrix", accel_offset="estimate"):
    """A 3 s recording of Drake's motion of the paper's tool: the wrench at 700 Hz on the sensor's sign with
    µs stamps (and a status column heft does not read), the accelerometer at 250 Hz in g, rotated by R_SA,
    biased and stamped 6 ms late, the orientation at 100 Hz. Returns the truth at the wrench's stamps."""
    motion = SmoothMotion()
    t_w = np.arange(0, DURATION, 1 / 700)
    truth = motion.truth(t_w)
    _write(folder / "ft.csv", ["stamp_us", "Fx", "Fy", "Fz", "Tx", "Ty", "Tz", "status"],
           [[EPOCH_US + int(round(1e6 * t))] + [f"{-x:.6f}" for x in w] + [0] for t, w in zip(t_w, truth["wrench"])])
    t_a = np.arange(0, DURATION, 1 / 250)
    at_a = motion.truth(t_a)
    specific = reading_from_motion(np.hstack((at_a["a"], at_a["alpha"])), at_a["g"], at_a["omega"],
                                   AccelerometerConvention(True, tuple(P_SA)))[:, :3]
    raw = specific @ R_SA / 9.80665 + BIAS_G
    _write(folder / "imu.csv", ["time", "ax", "ay", "az"],
           [[EPOCH_US + int(round(1e6 * (t + LATE)))] + [f"{x:.7f}" for x in r] for t, r in zip(t_a, raw)])
    t_p = np.arange(0, DURATION, 1 / 100)
    R = motion.truth(t_p)["R_WS"]
    if orientation == "rotation_matrix":
        names, values = [f"r{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3)], R.reshape(-1, 9)
    else:
        names, values = ["qx", "qy", "qz", "qw"], Rotation.from_matrix(R).as_quat()
    _write(folder / "pose.csv", ["t_ms"] + names,
           [[f"{1e3 * t:.3f}"] + [f"{x:.8f}" for x in v] for t, v in zip(t_p, values)])
    offset = accel_offset if isinstance(accel_offset, str) else float(accel_offset)
    (folder / "rec.yaml").write_text(f"""
wrench:
  file: ft.csv
  time: {{column: stamp_us, unit: us}}
  columns: [Fx, Fy, Fz, Tx, Ty, Tz]
  exerted_on: sensor
accelerometer:
  file: imu.csv
  time: {{column: time, unit: us, offset: {offset}}}
  columns: [ax, ay, az]
  unit: g
  R_SA: {R_SA.tolist()}
  p_SA: {P_SA.tolist()}
  bias: {BIAS_G.tolist()}
orientation:
  file: pose.csv
  time: {{column: t_ms, unit: ms, offset: {-EPOCH_US * 1e-6}}}
  kind: {orientation}
  columns: {names}
""")
    return t_w, truth


@pytest.fixture(scope="module")
def foreign(tmp_path_factory):
    folder = tmp_path_factory.mktemp("foreign")
    t, truth = write_recording(folder)
    return folder, t, truth


def _at_truth(merged, t, truth, key):
    index = np.round((merged.t - EPOCH_US * 1e-6) * 700).astype(int)
    return truth[key][index]


def test_merged_streams_match_drakes_motion(foreign):
    folder, t, truth = foreign
    source = RecordingSource(load_recording(folder / "rec.yaml"))
    merged = source.merged({"accelerometer": LATE})
    assert 0.9 * len(t) < len(merged) <= len(t)
    np.testing.assert_allclose(merged.wrench, _at_truth(merged, t, truth, "wrench"), atol=1e-5)
    np.testing.assert_allclose(merged.g, _at_truth(merged, t, truth, "g"), atol=0.06)  # 100 Hz, slerp
    np.testing.assert_allclose(merged.omega, _at_truth(merged, t, truth, "omega"), atol=0.06)  # of 5.5 rad/s
    np.testing.assert_allclose(merged.alpha, _at_truth(merged, t, truth, "alpha"), atol=0.7)  # of 34 rad/s²
    np.testing.assert_allclose(merged.a, _at_truth(merged, t, truth, "a"), atol=0.35)  # of 22 m/s², 250 Hz
    residual = merged.wrench - merged.noncontact(PAPER_TOOL.to_phi())
    peak = np.abs(merged.wrench).max(axis=0)
    assert (np.sqrt((residual ** 2).mean(axis=0)) < 2e-3 * peak + 1e-3).all()
    assert "slerp" in source.choices["timeline"] and "Savitzky–Golay" in source.choices["alpha"]


def test_the_accelerometers_clock_offset_is_found(foreign):
    folder, _, _ = foreign
    source = RecordingSource(load_recording(folder / "rec.yaml"))
    fit = estimate_clock_offsets(source, PAPER_TOOL.to_phi())["accelerometer"]
    assert fit.observable
    assert abs(fit.offset - LATE) < 2e-4
    with pytest.raises(ValueError, match="'estimate'"):
        source.merged()


def test_chunked_reading_gives_what_whole_reading_gives(foreign, monkeypatch):
    folder, _, _ = foreign
    whole = RecordingSource(load_recording(folder / "rec.yaml")).merged({"accelerometer": LATE})
    monkeypatch.setattr(column_files, "CSV_BLOCK_BYTES", 4096)
    source = RecordingSource(load_recording(folder / "rec.yaml"))
    assert len(list(source.chunks({"accelerometer": LATE}))) > 20
    chunked = source.merged({"accelerometer": LATE})
    for name in ("t", "wrench", "a", "alpha", "omega", "g"):
        np.testing.assert_allclose(getattr(chunked, name), getattr(whole, name), rtol=0, atol=1e-12)


def test_a_quaternion_orientation_gives_the_matrices_gravity(tmp_path):
    write_recording(tmp_path, orientation="quaternion_xyzw", accel_offset=LATE)
    from_quaternions = RecordingSource(load_recording(tmp_path / "rec.yaml")).merged()
    write_recording(tmp_path, orientation="rotation_matrix", accel_offset=LATE)
    from_matrices = RecordingSource(load_recording(tmp_path / "rec.yaml")).merged()
    np.testing.assert_allclose(from_quaternions.g, from_matrices.g, atol=1e-6)
    np.testing.assert_allclose(from_quaternions.omega, from_matrices.omega, atol=1e-5)


def test_slerp_and_angular_velocity_agree_with_drakes_quaternion_trajectory():
    rng = np.random.default_rng(3)
    t = np.cumsum(rng.uniform(0.005, 0.015, 30))
    R = Rotation.from_rotvec(np.cumsum(rng.normal(scale=0.3, size=(30, 3)), axis=0)).as_matrix()
    q = continuous(np.roll(Rotation.from_matrix(R).as_quat(), 1, axis=1))
    reference = PiecewiseQuaternionSlerp(list(t), [RotationMatrix(r) for r in R])
    queries = np.sort(rng.uniform(t[0], t[-1], 200))
    ours = slerp(t, q, queries)
    for k, tq in enumerate(queries):
        theirs = reference.orientation(tq).rotation()
        np.testing.assert_allclose(Rotation.from_quat(np.roll(ours[k], -1)).as_matrix(), theirs, atol=1e-9)
        g_S = theirs.T @ np.array([0.0, 0.0, -9.81])
        np.testing.assert_allclose(rotate_into_body(ours[k:k + 1], [0.0, 0.0, -9.81])[0], g_S, atol=1e-9)
    t_mid, omega_S = body_angular_velocity(t, q)
    for k, tm in enumerate(t_mid):
        omega_W = reference.angular_velocity(tm)  # constant between samples, in the world
        np.testing.assert_allclose(omega_S[k], R[k].T @ omega_W, atol=1e-9)
