"""`heft simulate`: the paper's experiments (Sec. VI) in the simulated station.

One closed-loop run per σ; each writes a log, and the set gives metrics.json and
the paper-style figure (analysis/figures.py).
"""

import io
import json
import math
import sys
import time
from pathlib import Path

import numpy as np
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator

from heft.analysis.experiment_metrics import experiment_metrics, grasp_metrics
from heft.analysis.figures import paper_figure
from heft.diagrams.plants import MakeMasterPlant, master_actuated
from heft.diagrams.progress import ProgressBar
from heft.diagrams.scenario import Scenario, layered, overrides_text
from heft.diagrams.stations.sim_station import MakeSimStation, set_holding
from heft.diagrams.live_view import simulation_monitor
from heft.diagrams.load_estimate import LoadEstimate
from heft.diagrams.teleop_simulation import MakeTeleopSimulation
from heft.systems.station.operator_hand import stroke_windows

# Plant-truth logs, re-timed to the sensor sample they belong to (see run_teleop).
SAMPLE_ALIGNED_TRUTH = ("wrench_contact_true", "wrench_noncontact_true", "accel_true", "omega_true", "gravity_S",
                        "slave_q", "phi_true", "wrench_noncontact_object_true")


def true_load(scenario: Scenario) -> tuple[LoadEstimate, np.ndarray]:
    """(the load's true φ and the sensor's starting offsets as the controller's estimate,
    the gripper's true φ (zeros unless the load is a gripper with an object))."""
    station = MakeSimStation(scenario)
    context = station.CreateDefaultContext()
    phi = np.array(station.GetOutputPort("truth.phi").Eval(context))
    phi_gripper = np.array(station.GetOutputPort("truth.phi_gripper").Eval(context))
    sensor = scenario.ft_sensor
    offsets = (np.array(sensor.initial_offsets, dtype=float) if sensor.noise and sensor.offsets
               else np.zeros(6))
    return LoadEstimate(phi=phi, offsets=offsets), phi_gripper


PAPER_SIGMAS = (1.0, 0.5, 0.0)
"""The σ values the paper's Fig. 6–8 compare: what ``heft simulate`` compares when no σ is stated."""


def with_sigma(scenario: Scenario, sigma: float) -> Scenario:
    """``scenario`` with σ = ``sigma`` in effect from the start (``controller.force.sigma``)."""
    return layered(scenario, overrides_text({"controller.force.sigma": float(sigma)}))


LOG_NAMES = {"master_wrench": "master_force", "applied_wrench": "master_force_applied", "offsets": "offsets_hat"}
"""Signals logged under another name in log.npz: the names of a hardware run's log (analysis.run_log);
``offsets_hat`` (N, 6) is the estimate at start, then tracked."""


def run_teleop(scenario: Scenario, load: LoadEstimate, label: str = "", meshcat=None, quiet: bool = False,
               view=None) -> dict:
    """Simulates ``scenario.duration`` s of the closed loop (σ: ``controller.force.sigma``); returns
    the log arrays (names as the README's log.npz) and the achieved real-time factor; a
    ``meshcat`` shows the run live, and so does a ``view`` (``diagrams.live_view.LiveView``, opened
    here); ``quiet`` hides the progress bar."""
    sigma = scenario.controller.force.sigma
    diagram, log = MakeTeleopSimulation(scenario, load, meshcat=meshcat)
    simulator = Simulator(diagram)
    ApplySimulatorConfig(scenario.simulator, simulator)
    context = simulator.get_mutable_context()
    station = diagram.GetSubsystemByName("station")
    grasp_at = scenario.load.grasp_at
    if math.isfinite(grasp_at):
        set_holding(station, context, False, at_start=True)
    if view is not None:
        simulator.set_monitor(simulation_monitor(view, log, LOG_NAMES))
    simulator.Initialize()
    progress = ProgressBar(scenario.duration, label or f"σ = {sigma:g}", stream=io.StringIO() if quiet else sys.stderr)
    start = time.perf_counter()
    chunk = 0.05
    t = 0.0
    while t < scenario.duration:
        t_before, t = t, min(t + chunk, scenario.duration)
        if t_before < grasp_at <= t:  # the gripper closes on the object
            simulator.AdvanceTo(grasp_at)
            set_holding(station, context, True)
        simulator.AdvanceTo(t)
        progress.update(t)
    wall = time.perf_counter() - start
    progress.close()
    phi_gripper = station.GetOutputPort("truth.phi_gripper").Eval(station.GetMyContextFromRoot(context))
    data = log.arrays(context)
    # A logger publishes before the discrete updates of its instant, so at t_k it sees the
    # sensor sample taken at t_{k−1} (and what the controller made of it) beside the plant's
    # truth at t_k. Delay the truth by one sample: each row pairs a sample with its truth.
    for key in SAMPLE_ALIGNED_TRUTH:
        data[key] = np.concatenate((data[key][:1], data[key][:-1]))
    for name, log_name in LOG_NAMES.items():
        data[log_name] = data.pop(name)
    data["phi_gripper_true"] = np.asarray(phi_gripper).copy()
    data["phi_gripper_hat"] = np.asarray(scenario.controller.force.phi_gripper or np.zeros(10), dtype=float)
    data["sigma"] = np.array(sigma)
    data["realtime_factor"] = np.array(scenario.duration / wall)
    return data


def unrendered_torque_peak(run: dict) -> float:
    """The largest torque (N·m, at E in B) of the wrench meant for the hand (``master_force``) that a
    force-only master leaves unrendered."""
    return float(np.max(np.linalg.norm(run["master_force"][:, 3:], axis=1), initial=0.0))


def simulate(scenario: Scenario, load: LoadEstimate, out_dir, sigmas, name: str, meshcat=None, view=None) -> dict:
    """Runs ``scenario`` once per σ of ``sigmas`` (the study's axis, laid over ``controller.force.sigma``
    by ``with_sigma``: the one override path), writes log.npz (the first σ) and log_sigma<σ>.npz
    (each), metrics.json and figure.png into ``out_dir``; returns the metrics (with a force-only master, the
    peak torque it left unrendered, ``unrendered_torque_peak``). A ``meshcat`` or a ``view``
    (``diagrams.live_view.LiveView``) shows each run live."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    runs = {}
    for sigma in sigmas:
        runs[sigma] = run_teleop(with_sigma(scenario, sigma), load, meshcat=meshcat, view=view)
        np.savez_compressed(out / f"log_sigma{sigma:g}.npz", **runs[sigma])
    np.savez_compressed(out / "log.npz", **runs[sigmas[0]])
    operator = scenario.operator
    metrics = experiment_metrics(scenario.experiment, runs, scenario.controller.feedback.force_scale,
                                 stroke_windows(operator.start_time, operator.frequency, scenario.duration))
    metrics["realtime_factor"] = float(min(run["realtime_factor"] for run in runs.values()))
    if master_actuated(MakeMasterPlant(scenario.master)).min() < 1.0:  # a force-only master
        metrics["master_torque_unrendered_peak_Nm"] = {
            f"sigma{sigma:g}": unrendered_torque_peak(run) for sigma, run in runs.items()}
    if math.isfinite(scenario.load.grasp_at):
        metrics["grasp"] = {f"sigma{sigma:g}": grasp_metrics(run, scenario.load.grasp_at)
                            for sigma, run in runs.items()}
    (out / "metrics.json").write_text(json.dumps(metrics, indent=2) + "\n")
    paper_figure(runs, scenario.experiment, out / "figure.png", title=name)
    return metrics
