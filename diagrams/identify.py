"""`heft identify`: excite the slave, record the wrist sensor, estimate the load
with every method (Sec. IV), and write what the teleoperation controller loads.

The excitation runs in free space (the paper's trajectory involves no contact):
the scenario's environment is removed for it. Signals: ω and g always from the
encoders through the kinematics; a and α either from the accelerometer or
derived from the encoders by harmonic differentiation (``--signals``).
"""

import dataclasses
import json
import math
import time
from pathlib import Path

import numpy as np
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, LogVectorOutput, TrajectorySource

from heft.analysis.identification_report import convergence_figure, estimate_errors
from heft.diagrams.running.progress import ProgressBar
from heft.diagrams.scenario import Scenario
from heft.diagrams.plants import MakeSlavePlant
from heft.diagrams.stations.sim_station import MakeSimStation, set_holding
from heft.diagrams.load_estimate import LoadEstimate, estimate_record, read_load_estimate, write_load_estimate
from heft.systems.accelerometer_reading import motion_from_reading
from heft.systems.estimators import (
    METHODS, NoiseLevels, RecursiveInstrumentalVariables, RecursiveLeastSquares, RecursiveTotalLeastSquares,
    batch_estimate, feed)
from heft.systems.excitation import ExcitationSettings, JointLimits, SensorFrameMotion, optimize_excitation
from heft.systems.periodic_differentiation import differentiate_periodic

RECURSIVE_METHODS = ("rls", "riv", "rtls")
ALL_METHODS = METHODS + RECURSIVE_METHODS
# Excitation envelope about the start pose (rad), joint speed share of the URDF limits, and
# joint acceleration limit (rad/s², the URDFs carry none): a motion that stays clear of the
# floor and the robot itself from the default start poses.
EXCITATION_RANGE = 0.5
EXCITATION_VELOCITY_FRACTION = 0.5
EXCITATION_ACCELERATION = 10.0
# Recursive estimates are sampled this often (samples) for the convergence plot.
HISTORY_STRIDE = 200


@dataclasses.dataclass
class Recording:
    """One excitation, sample-aligned at the controller rate (S samples, whole periods)."""
    t: np.ndarray                  # (S,) s
    wrench: np.ndarray             # (S, 6) measured [f; τ] on the load at S, in S
    accel_measured: np.ndarray     # (S, 6) the accelerometer's reading (accelerometer_reading)
    q: np.ndarray                  # (S, 6) encoder angles (rad)
    phi_true: np.ndarray | None = None      # (10,); truth exists only in simulation
    offsets_true: np.ndarray | None = None  # (S, 6) the offsets in the measurement
    accel_true: np.ndarray | None = None    # (S, 6)


def _slave_motion(scenario: Scenario):
    """(plant, SensorFrameMotion of S, arm instance) for the scenario's slave."""
    plant, parts = MakeSlavePlant(scenario)
    return plant, SensorFrameMotion(plant, plant.CreateDefaultContext(), parts.S, parts.arm), parts.arm


def design_excitation(scenario: Scenario, settings: ExcitationSettings):
    """The optimised Fourier excitation about the scenario's start pose (Eqs. 9–10)."""
    plant, motion, arm = _slave_motion(scenario)
    limits = JointLimits.from_plant(plant, EXCITATION_ACCELERATION, arm, EXCITATION_VELOCITY_FRACTION)
    limits = limits.within(scenario.slave_initial_q, EXCITATION_RANGE)
    return optimize_excitation(motion, scenario.slave_initial_q, limits, **dataclasses.asdict(settings))


def record_excitation(scenario: Scenario, trajectory, duration: float) -> Recording:
    """Drives the simulated slave through ``trajectory`` for ``duration`` s (free space)."""
    scenario = dataclasses.replace(scenario, environment=dataclasses.replace(scenario.environment, kind="none"))
    period = scenario.controller_period
    builder = DiagramBuilder()
    station = builder.AddNamedSystem("station", MakeSimStation(scenario))
    samples = int(round(duration / period))
    command = builder.AddNamedSystem("excitation", TrajectorySource(trajectory.to_drake(duration, samples + 1)))
    builder.Connect(command.get_output_port(), station.GetInputPort("slave.position_commanded"))
    builder.Connect(builder.AddSystem(ConstantVectorSource(np.zeros(6))).get_output_port(),
                    station.GetInputPort("master.torque_commanded"))
    names = ("ft.wrench_measured", "ft.acceleration_measured", "slave.position_measured", "truth.ft_offsets",
             "truth.acceleration")
    loggers = {name: LogVectorOutput(station.GetOutputPort(name), builder, period) for name in names}
    diagram = builder.Build()
    simulator = Simulator(diagram)
    ApplySimulatorConfig(scenario.simulator, simulator)
    if math.isfinite(scenario.load.grasp_at):  # the gripper alone is identified, before any grasp
        set_holding(station, simulator.get_mutable_context(), False)
    simulator.Initialize()
    progress = ProgressBar(duration + period, "excitation")
    for t in np.arange(1, int(np.ceil((duration + period) / 0.1)) + 1) * 0.1:
        simulator.AdvanceTo(min(t, duration + period))
        progress.update(simulator.get_context().get_time())
    progress.close()
    context = simulator.get_context()
    logs = {name: logger.FindLog(context).data().T for name, logger in loggers.items()}
    phi = station.GetOutputPort("truth.phi").Eval(station.GetMyContextFromRoot(context))
    # A logger publishes before the discrete updates of its instant: the held sensor samples
    # it sees at t_k were taken at t_{k−1}, while plant-derived signals are those of t_k.
    held = slice(1, samples + 1)
    now = slice(0, samples)
    return Recording(t=np.arange(samples) * period, wrench=logs["ft.wrench_measured"][held],
                     accel_measured=logs["ft.acceleration_measured"][held],
                     q=logs["slave.position_measured"][now], phi_true=np.asarray(phi).copy(),
                     offsets_true=logs["truth.ft_offsets"][held], accel_true=logs["truth.acceleration"][now])


def kinematic_signals(scenario: Scenario, recording: Recording, base_frequency: float, harmonics: int,
                      source: str):
    """(a, α, ω, g) in S per sample for the estimators, and the encoder-derived set
    (the instruments of RIV). ``source``: "accelerometer" (its reading converted with the
    encoders' g, ``accelerometer_reading``) or "encoders" for a and α."""
    period = recording.t[1] - recording.t[0]
    q, qd, qdd = differentiate_periodic(recording.q, period, base_frequency, harmonics)
    _, motion, _ = _slave_motion(scenario)
    encoders = motion(q, qd, qdd)
    if source == "encoders":
        return encoders, encoders
    if source != "accelerometer":
        raise ValueError(f"signals must be 'accelerometer' or 'encoders'; got {source!r}")
    gravity = encoders[3]
    acceleration = motion_from_reading(np.empty_like(recording.accel_measured), recording.accel_measured, gravity,
                                       scenario.accelerometer.includes_gravity)
    measured = (acceleration[:, :3], acceleration[:, 3:], encoders[2], gravity)
    return measured, encoders


def noise_levels(scenario: Scenario) -> NoiseLevels:
    """The sensor model's RMS levels (its defaults when noise is off: they then only weight)."""
    defaults = NoiseLevels()
    ft, acc = scenario.ft_sensor, scenario.accelerometer
    return NoiseLevels(
        force=float(max(ft.noise_rms[:3])) if ft.noise else defaults.force,
        torque=float(max(ft.noise_rms[3:])) if ft.noise else defaults.torque,
        linear_acceleration=float(max(acc.noise_rms[:3])) if acc.noise else defaults.linear_acceleration,
        angular_acceleration=float(max(acc.noise_rms[3:])) if acc.noise else defaults.angular_acceleration)


def estimate_all(wrench, signals, instruments, noise: NoiseLevels):
    """Every method's estimate: {method: Estimate or recursive estimator}, and the recursive
    ones' histories {method: (sample indices, θ (K, 16))}."""
    a, alpha, omega, g = signals
    results, histories = {}, {}
    for method in METHODS:
        results[method] = batch_estimate(wrench, a, alpha, omega, g, method=method, noise=noise)
    recursive = {"rls": RecursiveLeastSquares(noise=noise), "riv": RecursiveInstrumentalVariables(noise=noise),
                 "rtls": RecursiveTotalLeastSquares(noise=noise)}
    progress = ProgressBar(len(wrench) * len(recursive), "recursive estimators")
    for done, (method, estimator) in enumerate(recursive.items()):
        steps, thetas = [], []
        for taken in feed(estimator, wrench, a, alpha, omega, g, instruments):
            if taken % HISTORY_STRIDE == 0:
                steps.append(taken)
                thetas.append(np.concatenate((estimator.offsets, estimator.phi)))
                progress.update(done * len(wrench) + taken)
        results[method], histories[method] = estimator, (np.array(steps), np.array(thetas))
    progress.close()
    return results, histories


def identify(scenario: Scenario, out_dir, method: str = "tls", signals: str = "accelerometer",
             settings: ExcitationSettings | None = None, periods: int = 1) -> dict:
    """Designs and runs the excitation, estimates with every method and writes
    estimate.yaml (``method``'s result), metrics.json, convergence.png. Returns metrics."""
    if method not in ALL_METHODS:
        raise ValueError(f"method must be one of {', '.join(ALL_METHODS)}; got {method!r}")
    settings = settings or ExcitationSettings()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    excitation = design_excitation(scenario, settings)
    print(f"excitation: {settings.harmonics} harmonics of {settings.base_frequency:g} Hz, criterion "
          f"{excitation.criterion}, condition number {excitation.metrics.condition_number:.2f} "
          f"(random start {excitation.initial_metrics.condition_number:.1f})")
    duration = periods / settings.base_frequency
    recording = record_excitation(scenario, excitation.trajectory, duration)
    signal_set, instruments = kinematic_signals(scenario, recording, settings.base_frequency,
                                                settings.harmonics, signals)
    results, histories = estimate_all(recording.wrench, signal_set, instruments, noise_levels(scenario))
    offsets_true = recording.offsets_true.mean(axis=0)
    errors = {m: estimate_errors(r.phi, r.offsets, recording.phi_true, offsets_true) for m, r in results.items()}
    metrics = {"signals": signals, "samples": len(recording.t), "duration_s": duration,
               "excitation_condition_number": excitation.metrics.condition_number,
               "phi_true": recording.phi_true.tolist(), "offsets_true_mean": offsets_true.tolist(),
               "errors": errors, "wall_time_s": time.perf_counter() - started}
    record = estimate_record(results[method], method, signals, len(recording.t))
    write_load_estimate(out / "estimate.yaml", record)
    (out / "metrics.json").write_text(json.dumps(metrics, indent=2) + "\n")
    convergence_figure(histories, recording.t[1] - recording.t[0], recording.phi_true, offsets_true,
                       out / "convergence.png")
    print(f"{'method':8s}{'mass (g)':>10s}{'COM (mm)':>10s}{'I_S (%)':>9s}{'offsets f (N)':>15s}{'τ (N·m)':>10s}")
    for m, e in errors.items():
        print(f"{m:8s}{1e3 * e['mass_kg']:10.2f}{1e3 * e['com_m']:10.3f}{100 * e['inertia_relative']:9.2f}"
              f"{e['force_offsets_N']:15.3f}{e['torque_offsets_Nm']:10.4f}")
    return metrics


def identify_in_simulation(scenario: Scenario, out_dir, settings: ExcitationSettings | None = None) -> LoadEstimate:
    """Identifies the scenario's load (default method) and returns the estimate."""
    identify(scenario, out_dir, settings=settings)
    return read_load_estimate(Path(out_dir) / "estimate.yaml")
