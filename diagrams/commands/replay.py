"""`heft analyze replay`: a run's log as a self-contained HTML animation (Drake's Meshcat).

A visualisation-only plant holds the slave (arm, JR3, the scenario's load), its
environment as the simulated station builds it, and the Phantom master placed
beside it at ``MASTER_BASE_IN_W``. Each frame poses them from the log's joint
positions (``slave_q``, ``master_q``) and draws three force arrows:

- grey, at S: the force the sensor measures on the load, as the load pushes it
  (−R_WS·f of ``wrench_measured``: weight and inertia included);
- red, at S: the contact part of that measurement (−R_WS·f of ``wrench_contact``,
  Eq. 13), i.e. what the environment does to the tool;
- blue, at the stylus frame E: the force sent to the master (``master_force``, in B).

The log is a simulation's ``log.npz`` or the LCM log of ``heft teleop --hardware --record``
(`analysis.run_log`: on hardware ``wrench_contact`` is the controller's estimate, the stylus
force the wrench mapped for the hand). The page needs no server: open it in a browser and
press play.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from heft.analysis.run_log import KINDS, complete_rows, read_run_log
from heft.diagrams.scenario import Scenario
from heft.diagrams.plants import AddMaster, AddSlave
from heft.diagrams.stations.sim_station import AddSheetSpring
from heft.diagrams.scenario import resolve_scenario
from pydrake.geometry import (
    Cylinder,
    Meshcat,
    MeshcatCone,
    MeshcatParams,
    MeshcatVisualizer,
    MeshcatVisualizerParams,
    Rgba,
)
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlantConfig
from pydrake.systems.framework import DiagramBuilder

from heft.diagrams.commands.console import logger
from heft.diagrams.commands.options import add_out, add_scenario, out_file

say = logger(__name__)

# Where the replay draws the master's base B in the slave's world W: beside the arm, its pedestal
# standing on the ground (z = 0).
MASTER_BASE_IN_W = RigidTransform([0.3, -0.8, 0.2])
# The opening view, in W (m): from the front right, onto slave and master.
CAMERA_IN_W, CAMERA_TARGET_IN_W = np.array([1.3, -1.6, 0.8]), np.array([0.35, -0.35, 0.15])
# Log keys the replay reads, with the width of one row.
REPLAY_KEYS = {"t": None, "slave_q": 6, "master_q": 6, "wrench_measured": 6, "wrench_contact": 6, "master_force": 6}
ARROW_ROOT = "/forces"
# name → (colour, log key, drawn at the slave's S or the master's E).
ARROWS = {"measured": (Rgba(0.55, 0.55, 0.55, 0.9), "wrench_measured", "slave"),
          "contact": (Rgba(0.85, 0.1, 0.1, 0.9), "wrench_contact", "slave"),
          "master": (Rgba(0.1, 0.3, 0.9, 0.9), "master_force", "master")}
ARROW_RADIUS = 0.01     # m, shaft
ARROW_HEAD = 0.05       # m, cone height
SHORTEST_ARROW = 1e-4   # m: a zero force is drawn as a dot (a zero scale would be singular)


def load_log(path, kind: str | None = None) -> dict:
    """The arrays of a ``log.npz`` / ``log_sigma*.npz`` written by ``heft simulate`` or of an
    LCM log of ``heft teleop --hardware --record`` (`read_run_log`), checked for what a replay
    needs (``REPLAY_KEYS``, one row per sample of ``t``; rows where the log lacks a message
    left out)."""
    run = read_run_log(path, kind)
    missing = [key for key in REPLAY_KEYS if key not in run.arrays]
    if missing:
        raise ValueError(f"{path} lacks {', '.join(missing)}: write the log with the current `heft simulate`")
    return complete_rows(run, [key for key, width in REPLAY_KEYS.items() if width], "the log lacks a message "
                                                                                   "they show").arrays


def _check_log(log) -> np.ndarray:
    t = np.asarray(log["t"], dtype=float)
    if t.ndim != 1 or len(t) < 1 or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise ValueError("log 't' must be a non-empty, finite, strictly increasing vector of times (s)")
    for key, width in REPLAY_KEYS.items():
        if width is not None and np.shape(log[key]) != (len(t), width):
            raise ValueError(f"log '{key}' must have shape ({len(t)}, {width}), one row per time; "
                             f"got {np.shape(log[key])}")
    return t


def frame_indices(t: np.ndarray, fps: float) -> np.ndarray:
    """Indices into ``t`` of the samples shown at ``fps`` frames per second: for frame k
    (time k/fps from ``t[0]``), the last sample at or before it."""
    if not (np.isfinite(fps) and fps > 0):
        raise ValueError(f"fps must be a positive number of frames per second; got {fps}")
    frame_times = t[0] + np.arange(int(np.floor((t[-1] - t[0]) * fps + 1e-9)) + 1) / fps
    return np.searchsorted(t, frame_times + 1e-12, side="right") - 1


def _add_arrow(meshcat: Meshcat, path: str, rgba: Rgba):
    """A unit arrow along +z at ``path``: the shaft scales along z, the head sits at its end."""
    meshcat.SetObject(f"{path}/shaft/cylinder", Cylinder(ARROW_RADIUS, 1.0), rgba)
    meshcat.SetTransform(f"{path}/shaft/cylinder", RigidTransform([0.0, 0.0, 0.5]))
    # MeshcatCone has its apex at the origin and opens towards +z; flip it to point along +z.
    meshcat.SetObject(f"{path}/head/cone", MeshcatCone(ARROW_HEAD, 2 * ARROW_RADIUS, 2 * ARROW_RADIUS), rgba)
    meshcat.SetTransform(f"{path}/head/cone", RigidTransform(RotationMatrix.MakeXRotation(np.pi), [0, 0, ARROW_HEAD]))


def _record_arrow(meshcat: Meshcat, path: str, origin_W, vector_W, time: float):
    """Poses the arrow at ``path`` from ``origin_W`` along ``vector_W`` (m) in the recording."""
    length = max(float(np.linalg.norm(vector_W)), SHORTEST_ARROW)
    direction = vector_W / length if length > SHORTEST_ARROW else np.array([0.0, 0.0, 1.0])
    R = RotationMatrix.MakeFromOneVector(direction, 2)
    meshcat.SetTransform(path, RigidTransform(R, origin_W), time)
    meshcat.SetProperty(f"{path}/shaft", "scale", [1.0, 1.0, length], time)
    meshcat.SetTransform(f"{path}/head", RigidTransform([0.0, 0.0, length]), time)


class ReplayScene:
    """The visualisation-only plant (slave, environment, master beside it) on ``meshcat``."""

    def __init__(self, scenario: Scenario, meshcat: Meshcat, fps: float):
        scenario.validate()
        builder = DiagramBuilder()
        plant, scene_graph = AddMultibodyPlant(MultibodyPlantConfig(time_step=0.0), builder)
        self.slave = AddSlave(plant, scenario)
        if scenario.environment.kind == "sheet_spring":
            AddSheetSpring(plant, scenario.environment)
        self.phantom, self.B, self.E = AddMaster(plant, MASTER_BASE_IN_W)
        plant.Finalize()
        self.visualizer = MeshcatVisualizer.AddToBuilder(
            builder, scene_graph, meshcat, MeshcatVisualizerParams(publish_period=1.0 / fps))
        self.diagram = builder.Build()
        self.plant = plant
        self.context = self.diagram.CreateDefaultContext()
        self.plant_context = plant.GetMyMutableContextFromRoot(self.context)

    def pose(self, slave_q, master_q):
        """Sets the joint positions (rad) of slave and master."""
        self.plant.SetPositions(self.plant_context, self.slave.arm, slave_q)
        self.plant.SetPositions(self.plant_context, self.phantom, master_q)

    def frames_in_world(self):
        """(X_WS, X_WE) in the current pose."""
        world = self.plant.world_frame()
        return self.slave.S.CalcPose(self.plant_context, world), self.E.CalcPose(self.plant_context, world)


def write_replay(log, scenario: Scenario, path, fps: float = 30.0, slave_metres_per_newton: float = 0.01,
                 master_metres_per_newton: float = 0.04, meshcat: Meshcat | None = None) -> dict:
    """Writes the HTML replay of ``log`` (arrays as ``load_log`` returns) for ``scenario`` to
    ``path``, ``fps`` frames per simulated second, arrows ``*_metres_per_newton`` long per N.
    Returns a summary: frames, duration (s), fps, peak drawn forces (N), bytes written, path."""
    t = _check_log(log)
    if not all(np.isfinite(s) and s > 0 for s in (slave_metres_per_newton, master_metres_per_newton)):
        raise ValueError("the arrows' metres per newton must be positive numbers")
    indices = frame_indices(t, fps)
    meshcat = meshcat or Meshcat(MeshcatParams(host="localhost", port=0))
    scene = ReplayScene(scenario, meshcat, fps)
    meshcat.SetCameraPose(CAMERA_IN_W, CAMERA_TARGET_IN_W)
    for name, (rgba, _, _) in ARROWS.items():
        _add_arrow(meshcat, f"{ARROW_ROOT}/{name}", rgba)
    R_WB = MASTER_BASE_IN_W.rotation()
    scale = {"slave": slave_metres_per_newton, "master": master_metres_per_newton}
    peaks = dict.fromkeys(ARROWS, 0.0)

    scene.visualizer.StartRecording(set_transforms_while_recording=False)
    for frame, i in enumerate(indices):
        time = frame / fps
        scene.context.SetTime(time)
        scene.pose(log["slave_q"][i], log["master_q"][i])
        scene.visualizer.ForcedPublish(scene.visualizer.GetMyContextFromRoot(scene.context))
        X_WS, X_WE = scene.frames_in_world()
        for name, (_, key, side) in ARROWS.items():
            force = np.asarray(log[key][i][:3], dtype=float)
            # Sensor wrenches are what S exerts on the load: the load pushes back with −f (docs/design.md §4).
            force_W = -(X_WS.rotation() @ force) if side == "slave" else R_WB @ force
            origin_W = X_WS.translation() if side == "slave" else X_WE.translation()
            _record_arrow(meshcat, f"{ARROW_ROOT}/{name}", origin_W, scale[side] * force_W, time)
            peaks[name] = max(peaks[name], float(np.linalg.norm(force)))
    scene.visualizer.StopRecording()
    scene.visualizer.PublishRecording()

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    html = meshcat.StaticHtml()
    path.write_text(html)
    return {"path": str(path), "frames": len(indices), "duration_s": float(t[indices[-1]] - t[0]), "fps": fps,
            "peak_force_N": peaks, "bytes": len(html.encode())}


def add_arguments(parser):
    """The arguments of ``heft analyze replay``."""
    parser.add_argument("log", help="log.npz or log_sigma*.npz written by `heft simulate`, or the LCM log of "
                                    "`heft teleop --hardware --record`")
    parser.add_argument("--kind", choices=KINDS, default=None,
                        help="the log's kind (default: told by the file's first bytes)")
    add_scenario(parser, more="the one the log was run with")
    add_out(parser, "replay.html", shown="the log's folder")
    parser.add_argument("--fps", type=float, default=30.0, help="frames per simulated second (default 30)")


def run(args) -> int:
    """``heft analyze replay``: writes the HTML and prints a one-line summary."""
    run_log = load_log(args.log, args.kind)
    out = out_file(args, "replay.html") if args.out else Path(args.log).with_name("replay.html")
    summary = write_replay(run_log, resolve_scenario(args.scenario), out, fps=args.fps)
    peaks = summary["peak_force_N"]
    say.info(f"wrote {out}: {summary['frames']} frames over {summary['duration_s']:.2f} s at {args.fps:g} fps, "
             f"{summary['bytes'] / 1e6:.1f} MB; peak forces measured {peaks['measured']:.1f} N, contact "
             f"{peaks['contact']:.1f} N, at the master {peaks['master']:.2f} N (open it in a browser)")
    return 0
