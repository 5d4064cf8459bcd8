"""`heft compensate` on recordings in a foreign layout: the non-contact wrench against Drake's, the contact
found where it was put and nowhere else, the offsets and the recording's sign, the clock offset found; a
bad row deep in a file stops it before anything is computed or written."""

import json

import numpy as np
import pyarrow.csv as pa_csv
import pytest
import yaml
from drake_motion import PAPER_TOOL
from recording_layouts import CONTACT_PEAK, CONTACT_S, EPOCH_US, LATE, contact_pulse, write_recording

from heft.diagrams.cli import main

OFFSETS = np.array([1.5, -2.0, 3.0, 0.1, -0.05, 0.02])  # the sensor's, on the load's sign


def _estimate(folder, offsets=OFFSETS):
    path = folder / "estimate.yaml"
    path.write_text(yaml.safe_dump({"phi": PAPER_TOOL.to_phi().tolist(), "offsets": np.asarray(offsets).tolist()}))
    return path


@pytest.fixture(scope="module")
def compensated(tmp_path_factory):
    folder = tmp_path_factory.mktemp("compensate")
    t, truth = write_recording(folder, sensor_offsets=OFFSETS, contact=True)
    code = main(["compensate", "--recording", str(folder / "rec.yaml"), "--estimate", str(_estimate(folder)),
                 "--out", str(folder / "out")])
    assert code == 0
    table = pa_csv.read_csv(folder / "out" / "compensated.csv")
    columns = {name: table.column(name).to_numpy() for name in table.column_names}
    metrics = json.loads((folder / "out" / "metrics.json").read_text())
    return folder, t, truth, columns, metrics


def test_the_output_has_the_issues_columns_on_the_wrenchs_clock(compensated):
    folder, t, _, columns, _ = compensated
    assert list(columns) == ["t"] + [f"{kind}_{axis}" for kind in ("noncontact", "contact")
                                     for axis in ("fx", "fy", "fz", "tx", "ty", "tz")]
    stamps_us = EPOCH_US + np.round(1e6 * t)
    assert np.isin(np.round(columns["t"] * 1e6), stamps_us).all()
    assert (folder / "out" / "figure.png").stat().st_size > 10000


def test_noncontact_is_drakes_wrench_in_the_recordings_sign(compensated):
    _, t, truth, columns, _ = compensated
    index = np.round((columns["t"] - EPOCH_US * 1e-6) * 700).astype(int)
    noncontact = np.column_stack([columns[f"noncontact_{a}"] for a in ("fx", "fy", "fz", "tx", "ty", "tz")])
    expected = -truth["wrench"][index]  # the recording has what the load exerts on the sensor
    peak = np.repeat([np.abs(expected[:, :3]).max(), np.abs(expected[:, 3:]).max()], 3)  # forces, torques
    rms = np.sqrt(((noncontact - expected) ** 2).mean(axis=0))
    assert (rms < 1e-3 * peak).all(), rms / peak  # 100 Hz orientation, 250 Hz accelerometer


def test_contact_is_found_where_it_was_put_with_its_size(compensated):
    _, t, _, columns, metrics = compensated
    contact = np.column_stack([columns[f"contact_{a}"] for a in ("fx", "fy", "fz", "tx", "ty", "tz")])
    t_run = columns["t"] - EPOCH_US * 1e-6
    expected = -contact_pulse(t_run)  # offsets removed, in the recording's (sensor's) sign
    np.testing.assert_allclose(contact, expected, atol=0.12 * np.abs(CONTACT_PEAK).max())
    assert np.abs(contact - expected).max(axis=0)[:3].max() < 0.3
    (interval,) = metrics["intervals"]
    start, end = interval["start_s"] - EPOCH_US * 1e-6, interval["end_s"] - EPOCH_US * 1e-6
    assert CONTACT_S[0] < start < CONTACT_S[0] + 0.05 and CONTACT_S[1] - 0.05 < end < CONTACT_S[1]
    assert abs(interval["peak_contact_force_N"] - np.linalg.norm(CONTACT_PEAK[:3])) < 0.3
    residual = metrics["residual_rms_without_contact"]
    assert max(residual[a] for a in ("fx", "fy", "fz")) < 0.05 and max(residual[a] for a in ("tx", "ty", "tz")) < 0.005


def test_the_clock_offset_is_estimated_and_every_choice_is_kept(compensated):
    *_, metrics = compensated
    offset = metrics["choices"]["clock_offsets_s"]["accelerometer"]
    assert offset["how"] == "estimated" and abs(offset["offset_s"] - LATE) < 1e-3
    for key in ("timeline", "wrench_sign", "accelerometer", "omega", "alpha", "gravity"):
        assert metrics["choices"][key]
    assert metrics["samples"] > 0.9 * 700 * 3


def test_a_bad_row_deep_in_a_file_stops_it_before_anything_is_written(tmp_path, capsys):
    write_recording(tmp_path, accel_offset=LATE)
    lines = (tmp_path / "ft.csv").read_text().splitlines()
    fields = lines[2001].split(",")
    fields[3] = "nan"
    lines[2001] = ",".join(fields)
    (tmp_path / "ft.csv").write_text("\n".join(lines) + "\n")
    code = main(["compensate", "--recording", str(tmp_path / "rec.yaml"), "--estimate", str(_estimate(tmp_path)),
                 "--out", str(tmp_path / "out")])
    error = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in error
    assert "ft.csv, column 'Fz', row 2001 (line 2002)" in error
    assert not (tmp_path / "out").exists()


def test_an_accelerometer_left_to_estimate_needs_a_calibration(tmp_path, capsys):
    write_recording(tmp_path, accel_offset=LATE)
    text = (tmp_path / "rec.yaml").read_text()
    (tmp_path / "rec.yaml").write_text(text.replace("  bias: [0.0, 0.08, 0.0]", "  bias: estimate"))
    code = main(["compensate", "--recording", str(tmp_path / "rec.yaml"),
                 "--estimate", str(_estimate(tmp_path, np.zeros(6))), "--out", str(tmp_path / "out")])
    assert code == 2 and "has no accelerometer calibration" in capsys.readouterr().err
    estimate = yaml.safe_load((tmp_path / "estimate.yaml").read_text())
    R_SA = yaml.safe_load(text)["accelerometer"]["R_SA"]
    estimate["accelerometer"] = {"R_SA": R_SA, "bias": [0.0, 0.08, 0.0], "scale": 1.0, "unit": "g"}
    (tmp_path / "estimate.yaml").write_text(yaml.safe_dump(estimate))
    code = main(["compensate", "--recording", str(tmp_path / "rec.yaml"), "--estimate", str(tmp_path / "estimate.yaml"),
                 "--out", str(tmp_path / "out")])
    assert code == 0
    metrics = json.loads((tmp_path / "out" / "metrics.json").read_text())
    assert "calibration from" in metrics["choices"]["accelerometer"]
    assert max(metrics["residual_rms_without_contact"][a] for a in ("fx", "fy", "fz")) < 0.05
