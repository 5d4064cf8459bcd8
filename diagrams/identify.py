"""`heft identify`: excite the slave, record the wrist sensor, estimate the load
with every method (Sec. IV), and write what the teleoperation controller loads —
one path for simulation and hardware, which differ only in the recorder
(``running.sim_identification``, ``running.hardware_identify``).

The excitation runs in free space (the paper's trajectory involves no contact):
the scenario's environment is removed for it. Signals: ω and g always from the
encoders through the kinematics; a and α either from the accelerometer or
derived from the encoders by harmonic differentiation (``--signals``).
"""

import dataclasses
import json
import logging
import time
from pathlib import Path

import numpy as np

from heft.analysis.fit_verdict import FitEvidence, fit_verdict, noise_floor
from heft.analysis.identification_report import convergence_figure, estimate_errors, verdict_report
from heft.diagrams.progress import ProgressBar
from heft.diagrams.scenario import Scenario
from heft.diagrams.plants import MakeSlavePlant, arm_name, payload_max, slave_arm
from heft.diagrams.load_estimate import estimate_record, write_load_estimate
from heft.systems.accelerometer_reading import motion_from_reading
from heft.systems.identification.batch_estimation import METHODS, batch_estimate
from heft.systems.identification.recursive_estimation import (
    RecursiveInstrumentalVariables, RecursiveLeastSquares, RecursiveTotalLeastSquares, feed)
from heft.systems.identification.regression_noise import NoiseLevels
from heft.systems.load_dynamics import regressor_with_offsets
from heft.systems.identification.excitation import (ExcitationSettings, JointLimits, SensorFrameMotion,
                                                    optimize_excitation)
from heft.systems.identification.periodic_differentiation import differentiate_periodic

say = logging.getLogger(__name__)
"""What this module reports, which `heft` shows (-v, -q)."""


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


class FitRefused(ValueError):
    """The fit's verdict (``analysis.fit_verdict``) found it untrustworthy and it was not accepted:
    estimate.yaml is not written."""


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


def kinematic_signals(scenario: Scenario, recording: Recording, base_frequency: float, harmonics: int,
                      source: str):
    """(a, α, ω, g) in S per sample for the estimators, and the encoder-derived set
    (the instruments of RIV). ``source``: "accelerometer" (its reading converted with the
    encoders' g and ω, ``accelerometer_reading``) or "encoders" for a and α."""
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
                                       encoders[2], scenario.accelerometer.convention())
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
    """Every method's estimate: {method: Estimate or recursive estimator}, the recursive ones'
    histories {method: (sample indices, θ (K, 16))}, and {method: why} for the batch methods that
    refused the data (the others still estimate)."""
    a, alpha, omega, g = signals
    results, histories, failed = {}, {}, {}
    for method in METHODS:
        try:
            results[method] = batch_estimate(wrench, a, alpha, omega, g, method=method, noise=noise)
        except ValueError as error:
            failed[method] = str(error)
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
    return results, histories, failed


def fit_residual(result, signals, wrench) -> np.ndarray:
    """wrench − [E₆ V]·[offsets; φ] per sample ((S, 6), [f; τ]; N, N·m)."""
    theta = np.concatenate((np.asarray(result.offsets, dtype=float), np.asarray(result.phi, dtype=float)))
    return wrench - regressor_with_offsets(*signals) @ theta


def residual_rms(result, signals, wrench) -> list[float]:
    """RMS over samples of ``fit_residual`` per axis ([f; τ]; N, N·m)."""
    return np.sqrt(np.mean(fit_residual(result, signals, wrench) ** 2, axis=0)).tolist()


def judge_fit(scenario: Scenario, recording: Recording, results: dict, method: str, signal_set, signals: str,
              trajectory) -> dict:
    """``fit_verdict`` of ``results[method]``'s fit to ``recording``: its residual against the noise
    floor the scenario's sensor model gives (the accelerometer's noise only when a and α come from
    it), beside the other methods' fits; the readings against the sensors' full scale, the
    encoders against the excitation ``trajectory`` (what the slave was commanded, in simulation
    and on hardware), the mass against the arm's payload."""
    ft, accelerometer = scenario.ft_sensor, scenario.accelerometer
    motion_rms = accelerometer.noise_rms if signals == "accelerometer" else np.zeros(6)

    def floor(result):
        return noise_floor(result.phi, ft.noise_rms, motion_rms, accelerometer.position)

    others = {m: float(np.max(residual_rms(r, signal_set, recording.wrench) / floor(r)))
              for m, r in results.items() if m != method}
    result = results[method]
    return fit_verdict(FitEvidence(
        residual=fit_residual(result, signal_set, recording.wrench), noise_floor=floor(result),
        sample_period=recording.t[1] - recording.t[0], wrench=recording.wrench, wrench_full_scale=ft.full_scale,
        acceleration=recording.accel_measured, acceleration_full_scale=accelerometer.full_scale,
        mass=float(result.phi[0]), payload_max=payload_max(slave_arm(scenario)),
        robot=arm_name(slave_arm(scenario)),
        q_measured=recording.q, q_commanded=trajectory.position(recording.t), other_methods=others))


def identify(scenario: Scenario, out_dir, record, method: str = "tls", signals: str = "accelerometer",
             settings: ExcitationSettings | None = None, periods: int = 1, accept_fit: bool = False,
             estimated=None) -> dict:
    """Sec. IV in one path for simulation and hardware: designs the excitation, has ``record``
    run it (``record(trajectory, duration)`` → (Recording, extra metrics): the simulated
    station's or the hardware's), estimates with every method, judges ``method``'s fit
    (``judge_fit``) and writes metrics.json (every method's estimate, residual RMS and the
    spread of the mass between methods, the verdict as "fit_verdict"; where the recording knows
    the truth, in simulation, each method's error and convergence.png) and estimate.yaml
    (``method``'s) if the fit is ok or ``accept_fit``; raises ``FitRefused`` otherwise. Returns
    the metrics. ``estimated``, if given, is called with ``method``'s ``estimate_record`` as soon as
    there is one, before the verdict (a live view shows it)."""
    if method not in ALL_METHODS:
        raise ValueError(f"method must be one of {', '.join(ALL_METHODS)}; got {method!r}")
    settings = settings or ExcitationSettings()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    excitation = design_excitation(scenario, settings)
    say.info(f"excitation: {settings.harmonics} harmonics of {settings.base_frequency:g} Hz, criterion "
             f"{excitation.criterion}, condition number {excitation.metrics.condition_number:.2f} "
             f"(random start {excitation.initial_metrics.condition_number:.1f})")
    duration = periods / settings.base_frequency
    recording, extra = record(excitation.trajectory, duration)
    signal_set, instruments = kinematic_signals(scenario, recording, settings.base_frequency,
                                                settings.harmonics, signals)
    results, histories, failed = estimate_all(recording.wrench, signal_set, instruments, noise_levels(scenario))
    for m, why in failed.items():
        say.info(f"{m}: no estimate: {why}")
    records = {m: estimate_record(r, m, signals, len(recording.t)) for m, r in results.items()}
    if estimated is not None and method in records:
        estimated(records[method])
    masses = [r["phi"][0] for r in records.values()]
    metrics = {"signals": signals, "samples": len(recording.t), "duration_s": duration,
               "excitation_condition_number": excitation.metrics.condition_number, "estimates": records,
               "residual_rms": {m: residual_rms(r, signal_set, recording.wrench) for m, r in results.items()},
               "mass_spread_kg": float(np.ptp(masses)), "failed": failed, **extra}
    say.info(f"{'method':8s}{'mass (kg)':>11s}{'σ (g)':>8s}{'COM (mm)':>26s}{'residual f (N)':>16s}{'τ (N·m)':>9s}")
    for m, r in records.items():
        com = 1e3 * np.asarray(r.get("com", [np.nan] * 3))
        rms = metrics["residual_rms"][m]
        say.info(f"{m:8s}{r['phi'][0]:11.4f}{1e3 * r['std_phi'][0]:8.2f}   "
                 f"[{com[0]:7.2f} {com[1]:7.2f} {com[2]:7.2f}]{max(rms[:3]):16.3f}{max(rms[3:]):9.4f}")
    if recording.phi_true is not None:  # simulation: the truth is known
        offsets_true = recording.offsets_true.mean(axis=0)
        errors = {m: estimate_errors(r.phi, r.offsets, recording.phi_true, offsets_true) for m, r in results.items()}
        metrics.update(phi_true=recording.phi_true.tolist(), offsets_true_mean=offsets_true.tolist(), errors=errors)
        convergence_figure(histories, recording.t[1] - recording.t[0], recording.phi_true, offsets_true,
                           out / "convergence.png")
        say.info(f"errors against the truth:\n{'method':8s}{'mass (g)':>10s}{'COM (mm)':>10s}{'I_S (%)':>9s}"
                 f"{'offsets f (N)':>15s}{'τ (N·m)':>10s}")
        for m, e in errors.items():
            say.info(f"{m:8s}{1e3 * e['mass_kg']:10.2f}{1e3 * e['com_m']:10.3f}{100 * e['inertia_relative']:9.2f}"
                     f"{e['force_offsets_N']:15.3f}{e['torque_offsets_Nm']:10.4f}")
    if method not in failed:
        verdict = judge_fit(scenario, recording, results, method, signal_set, signals, excitation.trajectory)
        metrics["fit_verdict"] = verdict
        say.info(verdict_report(verdict, method))
    metrics["wall_time_s"] = time.perf_counter() - started
    (out / "metrics.json").write_text(json.dumps(metrics, indent=2) + "\n")
    if method in failed:
        raise ValueError(f"the {method} estimate failed ({failed[method]}); the other methods' estimates are in "
                         f"{out / 'metrics.json'}: identify again with --method one of {', '.join(records)}")
    if not (verdict["ok"] or accept_fit):
        stale = out / "estimate.yaml"
        removed = " (an earlier one there removed)" if stale.exists() else ""
        stale.unlink(missing_ok=True)  # the folder describes this run: no controller loads an older estimate
        raise FitRefused(f"{verdict['message']}. estimate.yaml was not written{removed}; the estimates and the "
                         f"numbers behind this are in {out / 'metrics.json'}. To write it anyway, identify again "
                         "with --accept-fit")
    write_load_estimate(out / "estimate.yaml", records[method], verdict)
    return metrics
