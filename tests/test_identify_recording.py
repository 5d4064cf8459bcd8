"""`heft identify --recording`: static poses and recorded streams from a lab's own files.

The fast tests write static poses here from Newton's statics (the weight m·g acting at c) in a
layout of their own; the slow ones take a run and 24 poses of heft's simulated station exported
by ``foreign_recording`` (not heft's writers) and hold the round trip's targets (docs/recordings.md)."""

import csv
import json

import numpy as np
import pytest
import yaml
from scipy.spatial.transform import Rotation

from heft.analysis.identification_report import estimate_errors
from heft.diagrams.cli import main
from heft.diagrams.identify import FitRefused, identify
from heft.diagrams.identify_recording import identify_recording
from heft.diagrams.load_estimate import read_load_estimate
from heft.diagrams.scenario import Scenario, resolve_scenario
from heft.systems.accelerometer_calibration import rotation_angle

G = 9.81
MASS, COM = 2.4, np.array([0.01, -0.02, 0.08])
OFFSETS = np.array([1.5, -2.0, 0.7, 0.03, -0.02, 0.01])


def write_static_poses(folder, gravity_S, noise=None, seed=0):
    """A lab's pose table: gravity in S and the wrench the load exerts on the sensor (its driver's
    sign), columns in an order of its own."""
    weight = MASS * np.asarray(gravity_S)
    on_load = np.hstack((-weight, -np.cross(COM, weight))) + OFFSETS
    if noise is not None:
        on_load = on_load + noise * np.random.default_rng(seed).standard_normal(on_load.shape)
    on_sensor = -on_load
    with (folder / "table.csv").open("w", newline="") as file:
        writer = csv.writer(file)
        writer.writerow(["gx", "gy", "gz", "torque_x", "torque_y", "torque_z", "force_x", "force_y", "force_z"])
        for g, w in zip(gravity_S, on_sensor):
            writer.writerow([*g, *w[3:], *w[:3]])
    path = folder / "poses.yaml"
    path.write_text(yaml.safe_dump({"static_poses": {
        "file": "table.csv", "wrench": ["force_x", "force_y", "force_z", "torque_x", "torque_y", "torque_z"],
        "gravity_S": ["gx", "gy", "gz"]}}))
    return path


def random_gravity(count, seed=0):
    return G * Rotation.random(count, random_state=seed).apply([0.0, 0.0, -1.0])


def test_static_poses_give_mass_com_offsets_and_a_loadable_estimate(tmp_path, capsys):
    path = write_static_poses(tmp_path, random_gravity(12), noise=np.repeat([0.01, 0.0005], 3))
    assert main(["identify", "--recording", str(path), "--out", str(tmp_path / "out")]) == 0
    printed = capsys.readouterr().out
    assert "the inertia is not identifiable" in printed
    static = json.loads((tmp_path / "out" / "metrics.json").read_text())["static_poses"]
    assert static["mass_kg"] == pytest.approx(MASS, rel=1e-3)
    np.testing.assert_allclose(static["com_m"], COM, atol=2e-4)
    np.testing.assert_allclose(static["offsets"], OFFSETS, atol=0.02)
    assert static["verdict"]["ok"]
    record = yaml.safe_load((tmp_path / "out" / "estimate.yaml").read_text())
    assert record["identifiable"] == [True] * 10 + [False] * 6
    assert record["signals"] == "static poses" and "accelerometer" not in record
    load = read_load_estimate(tmp_path / "out" / "estimate.yaml", Scenario().ft_sensor.full_scale)
    assert load.phi[0] == pytest.approx(MASS, rel=1e-3)
    assert (tmp_path / "out" / "static_poses.png").stat().st_size > 10_000


def test_poses_that_disagree_are_refused_unless_accepted(tmp_path):
    path = write_static_poses(tmp_path, random_gravity(12), noise=np.repeat([1.0, 0.05], 3))
    with pytest.raises(FitRefused, match="the poses disagree.*--accept-fit"):
        identify_recording(path, tmp_path / "out", Scenario())
    assert not (tmp_path / "out" / "estimate.yaml").exists()
    identify_recording(path, tmp_path / "out", Scenario(), accept_fit=True)
    assert yaml.safe_load((tmp_path / "out" / "estimate.yaml").read_text())["fit"]["accepted"]


def test_poses_turned_about_gravity_only_say_what_to_add(tmp_path):
    gravity = Rotation.from_euler("z", np.linspace(0, 3, 8)[:, None]).apply([0.0, 0.0, -G])  # all the same in S
    path = write_static_poses(tmp_path, gravity)
    with pytest.raises(ValueError, match="cannot be told apart.*tilted about two axes"):
        identify_recording(path, tmp_path / "out", Scenario())


def test_an_accelerometer_left_to_estimate_needs_static_poses(tmp_path):
    path = tmp_path / "run.yaml"
    path.write_text(yaml.safe_dump({
        "wrench": {"file": "ft.csv", "time": {"column": "t", "unit": "s"}},
        "accelerometer": {"file": "imu.csv", "time": {"column": "t", "unit": "s"}, "R_SA": "estimate"},
        "orientation": {"file": "pose.csv", "time": {"column": "t", "unit": "s"}}}))
    with pytest.raises(ValueError, match="R_SA or bias is 'estimate', which needs static_poses"):
        identify_recording(path, tmp_path / "out", Scenario())


def test_recording_options_of_an_excitation_are_refused(tmp_path, capsys):
    path = write_static_poses(tmp_path, random_gravity(6))
    assert main(["identify", "--recording", str(path), "--out", str(tmp_path), "--hardware"]) == 2
    assert "--hardware belongs to an excitation heft drives" in capsys.readouterr().err
    assert main(["identify", "--out", str(tmp_path)]) == 2
    assert "needs --scenario (the excitation heft drives) or --recording" in capsys.readouterr().err


# --- the round trip in a foreign layout ----------------------------------------------------------

@pytest.fixture(scope="module")
def simulated_lab(tmp_path_factory):
    """One excitation run and 24 static poses of the default station, exported in the lab's layout
    with R_WS rows and, beside it, with joint angles."""
    from foreign_recording import export_recording, simulate_excitation, simulate_static_poses

    scenario = resolve_scenario("fig6")
    run, poses = simulate_excitation(scenario), simulate_static_poses(scenario)
    folder = tmp_path_factory.mktemp("lab")
    paths = {kind: export_recording(folder / kind, scenario, run, poses, kind)
             for kind in ("rotation_matrix", "joint_positions")}
    return scenario, run, poses, paths


def _static_errors(static, poses):
    from foreign_recording import ACCELEROMETER_R_SA

    phi = poses.phi_true
    accelerometer = static["accelerometer"]
    return {"mass_relative": abs(static["mass_kg"] / phi[0] - 1),
            "com_m": float(np.linalg.norm(np.asarray(static["com_m"]) - phi[1:4] / phi[0])),
            "bias_g": float(np.abs(np.asarray(accelerometer["bias"]) - poses.accelerometer_bias_true_g).max()),
            "R_SA_deg": float(np.degrees(rotation_angle(accelerometer["R_SA"], ACCELEROMETER_R_SA)))}


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["rotation_matrix", "joint_positions"])
def test_round_trip_static_poses_and_excitation(simulated_lab, kind, tmp_path):
    from foreign_recording import ACCELEROMETER_CLOCK_LATE, ACCELEROMETER_R_SA

    scenario, run, poses, paths = simulated_lab
    metrics = identify_recording(paths[kind], tmp_path, scenario)
    static = _static_errors(metrics["static_poses"], poses)
    print(kind, "static poses:", static)
    assert static["mass_relative"] < 0.005 and static["com_m"] < 1e-3
    assert static["bias_g"] < 0.005 and static["R_SA_deg"] < 1.0
    streams = metrics["streams"]
    offset = streams["clock_offsets"]["accelerometer"]["offset_s"]
    assert abs(offset - ACCELEROMETER_CLOCK_LATE) < 1e-3
    estimate = read_load_estimate(tmp_path / "estimate.yaml")
    errors = estimate_errors(estimate.phi, estimate.offsets, run.phi_true, run.offsets_true.mean(axis=0))
    print(kind, "excitation (tls):", errors, "clock offset", offset)
    assert errors["mass_kg"] / run.phi_true[0] < 0.01 and errors["inertia_relative"] < 0.05
    assert rotation_angle(estimate.accelerometer.R_SA, ACCELEROMETER_R_SA) < np.radians(1.0)


@pytest.mark.slow
def test_native_recording_of_the_same_run_meets_the_same_targets(simulated_lab, tmp_path):
    """The run as heft's own identify takes it (2 kHz, encoders, the accelerometer in S's axes)."""
    scenario, run, _, _ = simulated_lab
    metrics = identify(scenario, tmp_path, lambda trajectory, duration: (run, {}))
    errors = metrics["errors"]["tls"]
    print("native (tls):", errors)
    assert errors["mass_kg"] / run.phi_true[0] < 0.01 and errors["inertia_relative"] < 0.05
