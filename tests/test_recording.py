"""Recordings in a layout heft did not choose: streams merged onto the wrench's timeline against Drake's
own motion and wrench, the clock offset found, chunked reading equal to whole, and the rotation math
against Drake's."""

import numpy as np
import pytest
from drake_motion import PAPER_TOOL
from pydrake.math import RotationMatrix
from pydrake.trajectories import PiecewiseQuaternionSlerp
from scipy.spatial.transform import Rotation

from recording_layouts import EPOCH_US, LATE, write_recording

from heft.analysis import column_files
from heft.analysis.clock_offsets import estimate_clock_offsets
from heft.analysis.differentiation_window import estimate_differentiation_window
from heft.analysis.recording import load_recording, with_differentiation_window
from heft.analysis.recording_merge import RecordingSource
from heft.systems.identification.rotation_sampling import (
    body_angular_velocity, continuous, rotate_into_body, savitzky_golay, slerp, window_samples)

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
    assert fit.observable and fit.std < 1e-4
    assert abs(fit.offset - LATE) < 1e-4
    with pytest.raises(ValueError, match="'estimate'"):
        source.merged()


def test_an_offset_the_recording_cannot_tell_is_not_observable(tmp_path):
    """The accelerometer held at one reading: no offset of its clock changes V·φ̂, whatever the wrench does."""
    write_recording(tmp_path)
    lines = (tmp_path / "imu.csv").read_text().splitlines()
    still = [lines[0]] + [",".join(line.split(",")[:1] + lines[1].split(",")[1:]) for line in lines[1:]]
    (tmp_path / "imu.csv").write_text("\n".join(still) + "\n")
    fit = estimate_clock_offsets(RecordingSource(load_recording(tmp_path / "rec.yaml")), PAPER_TOOL.to_phi())
    assert not fit["accelerometer"].observable
    assert fit["accelerometer"].summary()["observable"] is False


def _shaken_poses(folder, sigma: float) -> None:
    """pose.csv's rotations each turned by a random rotation of ``sigma`` rad RMS per axis (a coarse tracker)."""
    lines = (folder / "pose.csv").read_text().splitlines()
    values = np.array([[float(x) for x in line.split(",")[1:]] for line in lines[1:]])
    turns = Rotation.from_rotvec(np.random.default_rng(3).normal(size=(len(values), 3)) * sigma).as_matrix()
    shaken = (values.reshape(-1, 3, 3) @ turns).reshape(-1, 9)
    (folder / "pose.csv").write_text("\n".join([lines[0]] + [",".join([line.split(",")[0]] + [f"{x:.8f}" for x in row])
                                                              for line, row in zip(lines[1:], shaken)]) + "\n")


@pytest.mark.parametrize("sigma", [0.0, 0.002])
def test_the_differentiation_window_is_the_one_that_explains_the_wrench_best(tmp_path, sigma):
    """Exact poses at 100 Hz: the shortest window (50 ms), which smooths the motion least; poses shaken by 2 mrad:
    a longer one, whose α is nearer Drake's than the 50 ms window's (its derivative lifts the shaking)."""
    t, truth = write_recording(tmp_path)
    if sigma:
        _shaken_poses(tmp_path, sigma)
    recording = load_recording(tmp_path / "rec.yaml")
    assert recording.differentiation.window == "estimate" and recording.differentiation.seconds == 0.05
    source = RecordingSource(recording)
    fit = estimate_differentiation_window(source, PAPER_TOOL.to_phi(), source.resolved_offsets({"accelerometer": LATE}))
    assert fit.windows[0] == pytest.approx(0.05) and fit.windows[-1] <= 0.2 + 0.01
    assert min(fit.costs) == fit.costs[fit.windows.index(fit.window)] <= fit.default_cost
    if not sigma:
        assert fit.window == pytest.approx(0.05)
        return
    assert fit.window > 0.1

    def alpha_error(window):
        merged = RecordingSource(with_differentiation_window(recording, window)).merged({"accelerometer": LATE})
        return np.sqrt(((merged.alpha - _at_truth(merged, t, truth, "alpha")) ** 2).mean())
    assert alpha_error(fit.window) < 0.3 * alpha_error(0.05)


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


@pytest.mark.parametrize("order", [2, 3])
@pytest.mark.parametrize("deriv", [0, 1])
def test_savitzky_golay_is_scipys(order, deriv):
    from scipy.signal import savgol_filter

    x = np.cumsum(np.random.default_rng(order).normal(size=(60, 3)), axis=0)
    samples = window_samples(0.004, 0.05, order)
    expected = savgol_filter(x, samples, order, deriv=deriv, delta=0.004, axis=0, mode="interp")
    np.testing.assert_allclose(savitzky_golay(x, 0.004, 0.05, order, deriv), expected, atol=1e-9 * np.abs(x).max())


def test_like_derived_is_the_kernel_the_derivative_filter_puts_alpha_through():
    """α = sin(2π·5 t): the Savitzky–Golay derivative of its exact integral ω (closed form) is α seen
    through the derivative filter; ``like_derived`` gets it from α's samples alone (and scipy's
    trapezoidal integral and filter agree)."""
    from scipy.integrate import cumulative_trapezoid
    from scipy.signal import savgol_filter

    from heft.analysis.clock_offsets import like_derived

    period, w = 1e-3, 2 * np.pi * 5.0
    t = np.arange(0, 2.0, period)
    alpha, omega = np.sin(w * t)[:, None], ((1 - np.cos(w * t)) / w)[:, None]
    through_filter = savitzky_golay(omega, period, 0.05, 2, deriv=1)
    ours = like_derived(alpha, period, 0.05, 2)
    assert np.abs(ours - alpha).max() > 0.01  # the kernel smooths: 5 Hz over 50 ms loses some percent
    trapezoid = 1.05 * period ** 2 * w ** 2 / 12  # the trapezoidal rule's error on α's derivative's scale
    np.testing.assert_allclose(ours, through_filter, atol=trapezoid)
    samples = window_samples(period, 0.05, 2)
    integral = cumulative_trapezoid(alpha[:, 0], dx=period, initial=0.0)
    scipys = savgol_filter(integral, samples, 2, deriv=1, delta=period, mode="interp")
    np.testing.assert_allclose(ours[:, 0], scipys, atol=1e-9)
