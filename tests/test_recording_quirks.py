"""CSV files, streams and static poses, as labs' loggers write them (``recording_layouts.rewrite``: padded
or quoted names, a byte-order mark, ; tab or whitespace separators, comment lines, CRLF, a trailing
separator, exponents): each read to the very numbers of the plain file, giving the same estimate; files
that cannot be read are refused by `heft compensate` in one line naming the file (and the column and
row where there is one)."""

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml
from drake_motion import PAPER_TOOL
from recording_layouts import LATE, QUIRKS, rewrite, write_recording

from heft.analysis.recording import load_recording
from heft.analysis.recording_merge import RecordingSource
from heft.analysis.static_pose_table import read_static_poses
from heft.diagrams.cli import main
from heft.systems.identification.batch_estimation import batch_estimate

FILES = {"wrench": "ft.csv", "accelerometer": "imu.csv", "orientation": "pose.csv"}


def _merged(path):
    source = RecordingSource(load_recording(path))
    return source, source.merged({"accelerometer": LATE})


@pytest.fixture(scope="module")
def plain(tmp_path_factory):
    folder = tmp_path_factory.mktemp("plain")
    write_recording(folder, noise=0.1)
    source, merged = _merged(folder / "rec.yaml")
    return merged, batch_estimate(merged.wrench, merged.a, merged.alpha, merged.omega, merged.g, method="ols").phi


@pytest.mark.parametrize("quirk", QUIRKS)
def test_each_quirk_reads_the_same_numbers_and_gives_the_same_estimate(tmp_path, plain, quirk):
    expected, phi = plain
    write_recording(tmp_path, noise=0.1)
    document = yaml.safe_load((tmp_path / "rec.yaml").read_text())
    for stream, name in FILES.items():
        stated = rewrite(tmp_path / name, quirk)
        if stated:
            document[stream]["delimiter"] = stated
    (tmp_path / "rec.yaml").write_text(yaml.safe_dump(document))
    source, merged = _merged(tmp_path / "rec.yaml")
    for field in ("t", "wrench", "a", "alpha", "omega", "g"):
        np.testing.assert_array_equal(getattr(merged, field), getattr(expected, field), err_msg=field)
    again = batch_estimate(merged.wrench, merged.a, merged.alpha, merged.omega, merged.g, method="ols").phi
    np.testing.assert_array_equal(again, phi)
    for _ in source.chunks({"accelerometer": LATE}, stride=50, every_row=True):
        pass
    assert source.checked == {"wrench": 2100, "accelerometer": 750, "orientation": 300}


@pytest.mark.parametrize("quirk", QUIRKS)
def test_static_poses_in_each_quirk_read_the_same(tmp_path, quirk):
    example = Path(__file__).parent.parent / "docs" / "example_recording"
    for name in ("poses.yaml", "poses.csv"):
        shutil.copy(example / name, tmp_path / name)
    plain = read_static_poses(load_recording(tmp_path / "poses.yaml"))
    stated = rewrite(tmp_path / "poses.csv", quirk)
    if stated:
        document = yaml.safe_load((tmp_path / "poses.yaml").read_text())
        document["static_poses"]["delimiter"] = stated
        (tmp_path / "poses.yaml").write_text(yaml.safe_dump(document))
    again = read_static_poses(load_recording(tmp_path / "poses.yaml"))
    for field in ("wrench", "accelerometer", "gravity_S"):
        np.testing.assert_array_equal(getattr(again, field), getattr(plain, field))


def test_the_layout_read_is_kept_among_the_choices(tmp_path):
    write_recording(tmp_path)
    rewrite(tmp_path / "ft.csv", "all")
    source = RecordingSource(load_recording(tmp_path / "rec.yaml"))
    assert source.choices["layout"]["wrench"] == "ft.csv: separator ';' (detected), header on line 4"


def _estimate(folder):
    path = folder / "estimate.yaml"
    path.write_text(yaml.safe_dump({"phi": PAPER_TOOL.to_phi().tolist(), "offsets": [0.0] * 6}))
    return path


def _break(folder, how):
    """Spoils ft.csv (or the recording) as ``how`` says; returns what the one line must name."""
    ft = folder / "ft.csv"
    lines = ft.read_text().splitlines()
    if how == "stated separator wrong":
        document = yaml.safe_load((folder / "rec.yaml").read_text())
        document["wrench"]["delimiter"] = ";"
        (folder / "rec.yaml").write_text(yaml.safe_dump(document))
        return ["ft.csv", "column 'Fx'", "no such column"]
    if how == "decimal commas":
        ft.write_text("\n".join(line.replace(",", ";").replace(".", ",") for line in lines) + "\n")
        return ["ft.csv", "column 'Fx'", "row 1 (line 2)", "with a decimal point"]
    if how == "a row short of a field":
        lines[300] = ",".join(lines[300].split(",")[:-2])
        ft.write_text("\n".join(lines) + "\n")
        return ["ft.csv", "row 300 (line 301)", "columns"]
    if how == "text in a row, after comments":
        ft.write_text("# exported\n# by the logger\n" + "\n".join(lines[:500]) + "\n# paused\nsensor error\n"
                      + "\n".join(lines[500:]) + "\n")
        return ["ft.csv", "row 500 (line 504)", "sensor error"]
    if how == "header and rows separated differently":
        ft.write_text("\n".join([lines[0]] + [line.replace(",", ";") for line in lines[1:]]) + "\n")
        return ["ft.csv", "cannot tell the columns' separator", "delimiter"]
    if how == "empty":
        ft.write_text("")
        return ["ft.csv", "no header row"]
    if how == "comments only":
        ft.write_text("# nothing was logged\n\n# end\n")
        return ["ft.csv", "no header row"]
    if how == "binary":
        ft.write_bytes(np.random.default_rng(1).integers(0, 256, 5000, dtype=np.uint8).tobytes())
        return ["ft.csv", "binary data"]
    if how == "UTF-16 text":
        ft.write_bytes("\n".join(lines).encode("utf-16"))
        return ["ft.csv", "UTF-16", "save it as UTF-8"]
    if how == "a name twice":
        lines[0] = lines[0].replace("status", "Fz")
        ft.write_text("\n".join(lines) + "\n")
        return ["ft.csv", "column 'Fz'", "2 times"]
    if how == "header only":
        ft.write_text(lines[0] + "\n# nothing after\n")
        return ["ft.csv", "no rows"]
    if how == "a bad separator stated":
        document = yaml.safe_load((folder / "rec.yaml").read_text())
        document["accelerometer"]["delimiter"] = "space"
        (folder / "rec.yaml").write_text(yaml.safe_dump(document))
        return ["rec.yaml", "accelerometer.delimiter 'space'"]
    if how == "a tab indenting the recording":
        text = (folder / "rec.yaml").read_text()
        (folder / "rec.yaml").write_text(text.replace("\n  file: ft.csv", "\n\tfile: ft.csv"))
        return ["rec.yaml, line 3, column 1", "found character '\\t'"]
    if how == "a bad pose after the run":  # read by no sample, yet checked
        pose = folder / "pose.csv"
        pose.write_text(pose.read_text() + "9000.000," + ",".join(["0.5"] * 9) + "\n")
        return ["pose.csv", "row 301 (line 302)", "not a rotation matrix"]
    if how == "a corrupt Parquet file":
        ft.rename(folder / "ft.parquet")
        document = yaml.safe_load((folder / "rec.yaml").read_text())
        document["wrench"]["file"] = "ft.parquet"
        (folder / "rec.yaml").write_text(yaml.safe_dump(document))
        return ["ft.parquet", "not a Parquet file"]
    raise AssertionError(how)


BROKEN = ("stated separator wrong", "decimal commas", "a row short of a field", "text in a row, after comments",
          "header and rows separated differently", "empty", "comments only", "binary", "UTF-16 text",
          "a name twice", "header only", "a bad separator stated", "a tab indenting the recording",
          "a bad pose after the run", "a corrupt Parquet file")


@pytest.mark.parametrize("how", BROKEN)
def test_a_file_that_cannot_be_read_is_refused_in_one_line(tmp_path, capsys, how):
    write_recording(tmp_path, accel_offset=LATE)
    named = _break(tmp_path, how)
    code = main(["compensate", "--recording", str(tmp_path / "rec.yaml"), "--estimate", str(_estimate(tmp_path)),
                 "--out", str(tmp_path / "out")])
    error = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in error and "Traceback" not in error, error
    for text in named:
        assert text in error, error
    assert not (tmp_path / "out" / "compensated.csv").exists()


def test_compensate_reads_a_quirky_recording_as_the_plain_one(tmp_path):
    for name, quirk in (("plain", None), ("quirky", "all")):
        folder = tmp_path / name
        folder.mkdir()
        write_recording(folder, accel_offset=LATE, contact=True)
        for file in FILES.values():
            if quirk:
                rewrite(folder / file, quirk)
        assert main(["compensate", "--recording", str(folder / "rec.yaml"), "--estimate", str(_estimate(folder)),
                     "--out", str(folder / "out")]) == 0
    plain, quirky = (json.loads((tmp_path / name / "out" / "metrics.json").read_text()) for name in ("plain", "quirky"))
    assert quirky["intervals"] == plain["intervals"] and quirky["samples"] == plain["samples"]
    assert (tmp_path / "quirky" / "out" / "compensated.csv").read_bytes() == \
        (tmp_path / "plain" / "out" / "compensated.csv").read_bytes()
