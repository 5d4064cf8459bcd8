"""The HTML replay: frame selection, bad input, and the page in a real headless browser."""

import argparse
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest
from heft.diagrams.models import model_path
from heft.diagrams.commands.replay import (
    ARROW_ROOT,
    MASTER_BASE_IN_W,
    add_arguments,
    frame_indices,
    load_log,
    run,
    write_replay,
)
from heft.diagrams.plants import AddSlave
from heft.diagrams.stations.sim_station import MakeSimStation
from heft.diagrams.scenario import NOISE_OFF, overrides_text, resolve_scenario
from heft.diagrams.running.simulation import run_teleop, with_sigma
from heft.diagrams.load_estimate import LoadEstimate
from pydrake.geometry import Meshcat, MeshcatParams
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant

CHROMIUM, CHROMEDRIVER = "/usr/bin/chromium", "/usr/bin/chromedriver"
APT_LINE = "apt-get install -y chromium chromium-driver"
FPS = 30.0
SLAVE_M_PER_N = 0.005

# Walks the viewer's three.js scene: mesh paths, animated paths, and, after seeking the
# animation to arguments[0] s, the poses of arguments[1] (paths) in meshcat's world (z up).
SCENE_PROBE = """
const viewer = window.viewer;
if (!viewer) { return null; }
const THREE = MeshCat.THREE;
const pathOf = (o) => { const names = []; for (let n = o; n && n !== viewer.scene; n = n.parent) names.unshift(n.name);
                        return '/' + names.join('/'); };
const meshes = [];
viewer.scene.traverse((o) => { if (o.isMesh) meshes.push(pathOf(o)); });
const animated = viewer.animator.actions.filter((a) => a.getClip().tracks.length > 0).map((a) => pathOf(a.getRoot()));
viewer.animator.pause();
viewer.animator.seek(arguments[0]);
viewer.scene.updateMatrixWorld(true);
const toWorld = new THREE.Matrix4().copy(viewer.scene.matrixWorld).invert();
const poses = {};
for (const path of arguments[1]) {
  const node = viewer.scene_tree.find(path.split('/').filter((s) => s.length)).object;
  poses[path] = new THREE.Matrix4().multiplyMatrices(toWorld, node.matrixWorld).elements;
}
return {meshes, animated, duration: viewer.animator.duration, poses};
"""


@pytest.fixture(scope="module")
def replay(tmp_path_factory):
    """0.3 s of Fig. 8 without sensor noise (the tip meets the sheet spring at ≈ 0.22 s), its
    log round-tripped through log.npz, and the replay written from it."""
    scenario = resolve_scenario("fig8", overrides_text({**NOISE_OFF, "duration": 0.3}))
    station = MakeSimStation(scenario)
    phi = np.array(station.GetOutputPort("truth.phi").Eval(station.CreateDefaultContext()))
    folder = tmp_path_factory.mktemp("replay")
    load = LoadEstimate(phi=phi, offsets=np.zeros(6))
    np.savez_compressed(folder / "log.npz", **run_teleop(with_sigma(scenario, 1.0), load))
    log = load_log(folder / "log.npz")
    summary = write_replay(log, scenario, folder / "replay.html", fps=FPS, slave_metres_per_newton=SLAVE_M_PER_N)
    return scenario, log, summary


def test_frames_take_the_last_sample_at_or_before_each_frame_time():
    t = 0.1 + 0.0005 * np.arange(601)  # 0.3 s at 2 kHz, starting late
    indices = frame_indices(t, 30.0)
    frame_times = 0.1 + np.arange(len(indices)) / 30.0
    assert len(indices) == 10  # frames at 0, 1/30, …, 9/30 s ≤ 0.3 s
    assert np.all(t[indices] <= frame_times + 1e-12)
    assert np.all((indices == len(t) - 1) | (t[np.minimum(indices + 1, len(t) - 1)] > frame_times))


def test_bad_input_is_rejected_with_what_to_do(tmp_path):
    np.savez(tmp_path / "old.npz", t=np.arange(3.0), slave_q=np.zeros((3, 6)))
    with pytest.raises(ValueError, match="master_q.*heft simulate"):
        load_log(tmp_path / "old.npz")
    with pytest.raises(ValueError, match="heft simulate"):
        load_log(tmp_path / "missing.npz")
    np.save(tmp_path / "array.npy", np.zeros(3))
    with pytest.raises(ValueError, match="neither an .npz archive nor an LCM log"):
        load_log(tmp_path / "array.npy")
    with pytest.raises(ValueError, match="fps"):
        frame_indices(np.arange(3.0), 0.0)
    log = {key: np.zeros((3, 6)) for key in ("slave_q", "wrench_measured", "wrench_contact", "master_force")}
    log["t"], log["master_q"] = np.arange(3.0), np.zeros((2, 6))
    with pytest.raises(ValueError, match=r"'master_q' must have shape \(3, 6\)"):
        write_replay(log, resolve_scenario("fig6"), tmp_path / "r.html")


def _browser():
    webdriver = pytest.importorskip("selenium.webdriver")
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    profile = tempfile.mkdtemp(prefix="heft-chromium-")
    for flag in ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync",
                 f"--user-data-dir={profile}"):
        options.add_argument(flag)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    return webdriver.Chrome(service=Service(CHROMEDRIVER), options=options), profile


@pytest.mark.skipif(not (shutil.which(CHROMIUM) and shutil.which(CHROMEDRIVER)),
                    reason=f"needs Debian's chromium and its driver: {APT_LINE}")
def test_replay_opens_in_chromium_and_plays_the_logged_motion(replay):
    """The page loads without JS errors; at the last frame the animation puts the slave's
    flange, the master's stylus and the measured-force arrow where Drake's kinematics of the
    logged joint positions put them."""
    scenario, log, summary = replay
    last = frame_indices(log["t"], FPS)[-1]
    frame_time = (summary["frames"] - 1) / FPS

    plant = MultibodyPlant(time_step=0.0)
    parts = AddSlave(plant, scenario)
    (phantom,) = Parser(plant).AddModels(model_path("phantom_premium_6dof.urdf"))
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("phantom_base", phantom), MASTER_BASE_IN_W)
    plant.Finalize()
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, parts.arm, log["slave_q"][last])
    plant.SetPositions(context, phantom, log["master_q"][last])
    flange = plant.GetBodyByName("flange").EvalPoseInWorld(context)
    stylus = plant.GetBodyByName("stylus").EvalPoseInWorld(context)
    X_WS = parts.S.CalcPoseInWorld(context)
    measured_tip = X_WS.translation() - SLAVE_M_PER_N * (X_WS.rotation() @ log["wrench_measured"][last][:3])
    assert not np.allclose(log["slave_q"][last], log["slave_q"][0], atol=1e-3)  # the slave has moved
    assert np.linalg.norm(log["wrench_contact"][last][:3]) > 1.0  # and touches the sheet spring

    paths = {"/drake/visualizer/rx90/flange": flange.GetAsMatrix4(),
             "/drake/visualizer/phantom_premium_6dof/stylus": stylus.GetAsMatrix4()}
    driver, profile = _browser()
    try:
        driver.get(Path(summary["path"]).resolve().as_uri())
        driver.set_script_timeout(10)
        scene = driver.execute_script(SCENE_PROBE, frame_time, [*paths, f"{ARROW_ROOT}/measured/head"])
        console = driver.get_log("browser")
    finally:
        driver.quit()
        shutil.rmtree(profile, ignore_errors=True)

    assert scene is not None, "the page has no meshcat viewer"
    assert [entry for entry in console if entry["level"] == "SEVERE"] == []
    meshes = scene["meshes"]
    for link in ("rx90_base", "rx90_link1", "rx90_link3", "flange"):
        assert any(m.startswith(f"/drake/visualizer/rx90/{link}/") for m in meshes), link
    for body in ("/drake/visualizer/tool/", "/drake/visualizer/sheet_spring/plate/",
                 "/drake/visualizer/phantom_premium_6dof/stylus/"):
        assert any(m.startswith(body) for m in meshes), body
    for animated in ("/drake/visualizer/rx90/rx90_link2", "/drake/visualizer/phantom_premium_6dof/stylus",
                     f"{ARROW_ROOT}/contact", f"{ARROW_ROOT}/master/shaft"):
        assert animated in scene["animated"], animated
    assert scene["duration"] == pytest.approx(frame_time, abs=1e-6)
    for path, expected in paths.items():
        shown = np.array(scene["poses"][path]).reshape(4, 4).T  # three.js stores column-major
        np.testing.assert_allclose(shown, expected, atol=1e-5, err_msg=path)
    arrow_tip = np.array(scene["poses"][f"{ARROW_ROOT}/measured/head"]).reshape(4, 4).T[:3, 3]
    np.testing.assert_allclose(arrow_tip, measured_tip, atol=1e-5)


def test_cli_hook_writes_the_replay_and_one_summary_line(replay, tmp_path, capsys):
    _, log, summary = replay
    parser = argparse.ArgumentParser()
    add_arguments(parser)
    out = tmp_path / "replay.html"
    args = parser.parse_args([str(Path(summary["path"]).with_name("log.npz")), "--scenario", "fig8",
                              "--out", str(tmp_path), "--fps", "20"])
    assert run(args) == 0
    printed = capsys.readouterr().out.strip().splitlines()
    assert len(printed) == 1 and str(out) in printed[0]
    assert f"{len(frame_indices(log['t'], 20.0))} frames" in printed[0]
    assert out.read_text().startswith("<!DOCTYPE html>")


def test_simulation_draws_the_slave_live_on_a_meshcat():
    scenario = resolve_scenario("fig8", overrides_text({**NOISE_OFF, "duration": 0.002}))
    meshcat = Meshcat(MeshcatParams(host="localhost", port=0))
    run_teleop(with_sigma(scenario, 1.0), LoadEstimate(phi=np.zeros(10), offsets=np.zeros(6)), meshcat=meshcat)
    for path in ("/drake/visualizer/rx90/rx90_link1", "/drake/visualizer/tool", "/drake/visualizer/sheet_spring/plate"):
        assert meshcat.HasPath(path), path
