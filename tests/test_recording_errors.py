"""Bad recordings: each problem is one line naming the file, the column and the row, raised while opening
the streams or reading the row, before anything is computed from it."""

import numpy as np
import pytest

from heft.analysis.column_files import RecordingError
from heft.analysis.recording import load_recording
from heft.analysis.recording_merge import RecordingSource

ROWS = 40


def _rows(n, columns, rate, start=0.0):
    t = start + np.arange(n) / rate
    rng = np.random.default_rng(0)
    return t, rng.normal(size=(n, columns))


def _csv(path, header, t, values, time_format="{:.6f}"):
    lines = [",".join(header)] + [",".join([time_format.format(x)] + [f"{v:.6f}" for v in row])
                                  for x, row in zip(t, values)]
    path.write_text("\n".join(lines) + "\n")


def _identity_rows(n):
    return np.tile(np.eye(3).ravel(), (n, 1))


def write_small(folder, accel_unit="g", pose_start=0.0, R_SA="[[1, 0, 0], [0, 1, 0], [0, 0, 1]]"):
    t, w = _rows(ROWS, 6, 100.0)
    _csv(folder / "w.csv", ["t", "fx", "fy", "fz", "tx", "ty", "tz"], t, w)
    t, a = _rows(ROWS, 3, 100.0)
    _csv(folder / "a.csv", ["t", "ax", "ay", "az"], t, a)
    t = pose_start + np.arange(ROWS) / 100.0
    _csv(folder / "p.csv", ["t"] + [f"r{i}" for i in range(9)], t, _identity_rows(ROWS))
    (folder / "rec.yaml").write_text(f"""
wrench: {{file: w.csv, time: {{column: t, unit: s}}, columns: [fx, fy, fz, tx, ty, tz]}}
accelerometer: {{file: a.csv, time: {{column: t, unit: s}}, columns: [ax, ay, az], unit: {accel_unit}, R_SA: {R_SA}}}
orientation: {{file: p.csv, time: {{column: t, unit: s}}, kind: rotation_matrix,
               columns: [r0, r1, r2, r3, r4, r5, r6, r7, r8]}}
differentiation: {{window: 0.03, order: 2}}
""")
    return folder / "rec.yaml"


def _merge(path):
    source = RecordingSource(load_recording(path))
    return source.merged()


def _one_line(error) -> str:
    text = str(error.value)
    assert "\n" not in text
    return text


def test_a_well_formed_small_recording_merges(tmp_path):
    merged = _merge(write_small(tmp_path))
    assert len(merged) > ROWS // 2


def _edit(path, line_number, column, value):
    lines = path.read_text().splitlines()
    fields = lines[line_number - 1].split(",")
    fields[column] = value
    lines[line_number - 1] = ",".join(fields)
    path.write_text("\n".join(lines) + "\n")


def test_a_missing_column(tmp_path):
    path = write_small(tmp_path)
    (tmp_path / "a.csv").write_text((tmp_path / "a.csv").read_text().replace("ay", "a_y", 1))
    with pytest.raises(RecordingError) as error:
        _merge(path)
    assert "a.csv" in _one_line(error) and "'ay'" in _one_line(error) and "a_y" in _one_line(error)


@pytest.mark.parametrize("value, what", [("0.1", "before the previous"), ("0.110000", "repeats")])
def test_time_going_back_or_repeating(tmp_path, value, what):
    path = write_small(tmp_path)
    _edit(tmp_path / "w.csv", 14, 0, value)  # row 13: t = 0.12 s
    with pytest.raises(RecordingError) as error:
        _merge(path)
    text = _one_line(error)
    assert "w.csv" in text and "column 't'" in text and "row 13" in text and what in text


@pytest.mark.parametrize("value", ["nan", "NaN", "", "inf"])
def test_a_nan_row(tmp_path, value):
    path = write_small(tmp_path)
    _edit(tmp_path / "a.csv", 8, 2, value)
    with pytest.raises(RecordingError) as error:
        _merge(path)
    text = _one_line(error)
    assert "a.csv" in text and "column 'ay'" in text and "row 7" in text


def test_text_in_a_number_column(tmp_path):
    path = write_small(tmp_path)
    _edit(tmp_path / "w.csv", 6, 3, "12,5")
    with pytest.raises(RecordingError) as error:
        _merge(path)
    text = _one_line(error)
    assert "w.csv" in text and "row 5" in text


@pytest.mark.parametrize("field, text, expected", [
    ("accel_unit", "G", "accelerometer.unit 'G' is not a unit"),
    ("time_unit", "sec", "wrench.time.unit 'sec' is not a unit"),
])
def test_a_unit_that_is_not_one(tmp_path, field, text, expected):
    path = write_small(tmp_path, accel_unit=text if field == "accel_unit" else "g")
    if field == "time_unit":
        path.write_text(path.read_text().replace("file: w.csv, time: {column: t, unit: s}",
                                                 f"file: w.csv, time: {{column: t, unit: {text}}}"))
    with pytest.raises(ValueError) as error:
        load_recording(path)
    assert "rec.yaml" in _one_line(error) and expected in _one_line(error)


def test_an_R_SA_that_is_not_a_rotation(tmp_path):
    path = write_small(tmp_path, R_SA="[[1, 0, 0], [0, 1, 0], [0, 0, -1]]")
    with pytest.raises(ValueError) as error:
        load_recording(path)
    assert "rec.yaml" in _one_line(error) and "accelerometer.R_SA is not a rotation" in _one_line(error)


def test_an_orientation_row_that_is_not_a_rotation(tmp_path):
    path = write_small(tmp_path)
    _edit(tmp_path / "p.csv", 11, 1, "2.0")
    with pytest.raises(RecordingError) as error:
        _merge(path)
    text = _one_line(error)
    assert "p.csv" in text and "r0" in text and "row 10" in text and "not a rotation" in text


def test_streams_that_do_not_overlap(tmp_path):
    path = write_small(tmp_path, pose_start=100.0)
    with pytest.raises(RecordingError) as error:
        RecordingSource(load_recording(path))
    text = _one_line(error)
    assert "do not overlap" in text and "p.csv" in text and "rows 1–40" in text


def test_a_missing_file_and_an_unknown_field(tmp_path):
    path = write_small(tmp_path)
    (tmp_path / "a.csv").unlink()
    with pytest.raises(RecordingError, match="a.csv: the accelerometer stream's file does not exist"):
        RecordingSource(load_recording(path))
    path.write_text(path.read_text() + "sample_rate: 5\n")
    with pytest.raises(ValueError, match="rec.yaml.*sample_rate"):
        load_recording(path)


def test_static_poses_give_gravity_in_S_and_the_loads_sign(tmp_path):
    from scipy.spatial.transform import Rotation

    from heft.analysis.static_pose_table import read_static_poses

    rotations = Rotation.random(5, random_state=2)
    rows = [[f"{x:.9f}" for x in (*w, *a, *q)] for w, a, q in
            zip(np.arange(30.0).reshape(5, 6), np.arange(15.0).reshape(5, 3), rotations.as_quat())]
    (tmp_path / "poses.csv").write_text("\n".join([",".join(
        ["Fx", "Fy", "Fz", "Tx", "Ty", "Tz", "ax", "ay", "az", "qx", "qy", "qz", "qw"])] + [",".join(r) for r in rows]))
    (tmp_path / "rec.yaml").write_text("""
static_poses: {file: poses.csv, wrench: [Fx, Fy, Fz, Tx, Ty, Tz], accelerometer: [ax, ay, az],
               orientation: [qx, qy, qz, qw], orientation_kind: quaternion_xyzw}
""")
    table = read_static_poses(load_recording(tmp_path / "rec.yaml"))
    np.testing.assert_allclose(table.wrench, -np.arange(30.0).reshape(5, 6))  # sensor's sign by default
    np.testing.assert_allclose(table.accelerometer, np.arange(15.0).reshape(5, 3))
    np.testing.assert_allclose(table.gravity_S, rotations.inv().apply([0.0, 0.0, -9.81]), atol=1e-8)
    rows[3][10] = "0.9"
    (tmp_path / "poses.csv").write_text("\n".join([(tmp_path / "poses.csv").read_text().splitlines()[0]]
                                                   + [",".join(r) for r in rows]))
    with pytest.raises(RecordingError) as error:
        read_static_poses(load_recording(tmp_path / "rec.yaml"))
    assert "poses.csv" in _one_line(error) and "row 4" in _one_line(error) and "unit quaternion" in _one_line(error)
