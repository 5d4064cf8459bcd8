"""`heft identify --recording`: the load (and the accelerometer's calibration) from a lab's own
recording (``analysis.recording``) instead of an excitation heft drives.

Static poses (``recording.static_poses``) give m, m·c and the offsets (``systems.identification.static_calibration``;
the inertia is not identifiable from them) and, where they carry the accelerometer's readings, its
R_SA, bias and scale. A recording's streams, merged onto the wrench's timeline
(``analysis.recording_merge``; the accelerometer calibrated from the poses where the recording
leaves R_SA or its bias to ``estimate``, clock offsets left to ``estimate`` found from a first
fit), go through every estimator, the fit's verdict and the report of ``diagrams.identify``. The
sensors' noise and range, and the arm's payload, come from the scenario, which describes the lab's
instruments as it does on hardware.
"""

import dataclasses
import json
import logging
from pathlib import Path

import numpy as np

from heft.analysis.clock_offsets import estimate_clock_offsets
from heft.analysis.fit_verdict import AXES, RESIDUAL_RATIO_LIMIT, FitEvidence, fit_verdict, noise_floor
from heft.analysis.identification_report import estimate_history_figure, static_pose_figure, verdict_report
from heft.analysis.recording import ESTIMATE, load_recording
from heft.analysis.static_pose_table import read_static_poses
from heft.diagrams.identify import ALL_METHODS, FitRefused, estimate_all, fit_residual, residual_rms
from heft.diagrams.load_estimate import estimate_record, write_load_estimate
from heft.diagrams.plants import arm_name, payload_max, slave_arm
from heft.diagrams.recordings import open_recording
from heft.diagrams.recording_kinematics import recording_joint_orientation
from heft.diagrams.scenario import Scenario
from heft.systems.identification.batch_estimation import batch_estimate
from heft.systems.load_dynamics import PARAMETER_NAMES
from heft.systems.identification.regression_noise import NoiseLevels
from heft.systems.identification.static_calibration import (STATIC_NAMES, StaticCalibration, calibrate_static,
                                                            point_mass_phi)

say = logging.getLogger(__name__)
"""What this module reports, which `heft` shows (-v, -q)."""


SIGNALS = "recording"
"""The ``signals`` an estimate from a recording names in estimate.yaml."""

DERIVED_ALPHA_NOISE = 0.05
"""rad/s²: the noise assumed on α derived from a recorded orientation (a Savitzky–Golay derivative of
a smooth pose; the estimators that model noise need one above 0), a tenth of an accelerometer's."""


def _joints(recording):
    """The static poses' arm kinematics, where they give the orientation as joint angles."""
    poses = recording.static_poses
    if poses.orientation is None or poses.orientation_kind != "joint_positions":
        return None
    return recording_joint_orientation(recording, poses.robot, poses.orientation, "static_poses")


def recording_noise(scenario: Scenario, alpha_recorded: bool) -> NoiseLevels:
    """The noise the estimators and the verdict take: the scenario's sensor model (the lab's
    sensors), α's from the accelerometer if it measures α, else ``DERIVED_ALPHA_NOISE``."""
    ft, acc = scenario.ft_sensor, scenario.accelerometer
    return NoiseLevels(force=float(max(ft.noise_rms[:3])), torque=float(max(ft.noise_rms[3:])),
                       linear_acceleration=float(max(acc.noise_rms[:3])),
                       angular_acceleration=float(max(acc.noise_rms[3:])) if alpha_recorded else DERIVED_ALPHA_NOISE)


def static_report(static: StaticCalibration) -> tuple[dict, str]:
    """(metrics, printed lines) of a static calibration."""
    e = static.estimate
    std = dict(zip(STATIC_NAMES, e.std[:10].tolist()))
    metrics = {"poses": static.poses, "mass_kg": static.mass, "com_m": static.com.tolist(),
               "offsets": static.offsets.tolist(), "std": std, "residual_rms": e.residual_rms.tolist(),
               "inertia": "not identifiable from static poses; estimate.yaml holds a point mass's at the COM"}
    com = 1e3 * static.com
    lines = [f"static poses ({static.poses}): mass {static.mass:.4f} kg (σ {1e3 * std['m']:.2f} g), centre of mass "
             f"[{com[0]:.2f} {com[1]:.2f} {com[2]:.2f}] mm; the inertia is not identifiable from poses at rest",
             "  offsets " + " ".join(f"{n}={v:.4g}" for n, v in zip(AXES, static.offsets))
             + "; residual RMS " + " ".join(f"{n}={v:.3g}" for n, v in zip(AXES, e.residual_rms))]
    if static.accelerometer is not None:
        fit, cal = static.accelerometer, static.accelerometer.calibration
        metrics["accelerometer"] = {**cal.as_dict(), "residual_rms": fit.residual_rms,
                                    "gravity_spread": fit.gravity_spread}
        lines.append(f"  accelerometer: bias [{' '.join(f'{b:.4f}' for b in cal.bias)}] {cal.unit}, scale "
                     f"{cal.scale:.5f}, R_SA {np.round(cal.R_SA, 4).tolist()} (its residual {fit.residual_rms:.2g} "
                     f"{cal.unit} RMS)")
    return metrics, "\n".join(lines)


def static_verdict(static: StaticCalibration, scenario: Scenario) -> dict:
    """Whether the poses agree: the fit's residual per axis within ``RESIDUAL_RATIO_LIMIT`` × the
    sensor's noise of one sample (an averaged pose's is lower), no pose near full scale, a mass within
    the arm's payload. The shape of ``fit_verdict``'s (ok, causes, message)."""
    ft = scenario.ft_sensor
    ratio = static.estimate.residual_rms / np.asarray(ft.noise_rms, dtype=float)
    causes, words = [], []
    if (ratio > RESIDUAL_RATIO_LIMIT).any():
        causes.append("unmodelled_dynamics")
        worst = int(np.argmax(ratio))
        words.append(f"the poses disagree: residual {ratio[worst]:.1f}× the sensor's noise on {AXES[worst]}; a pose "
                     "not at rest, a cable pulling, the load touching something, or gravity given in another frame")
    payload = payload_max(slave_arm(scenario))
    if static.mass > payload:
        causes.append("payload")
        words.append(f"the mass {static.mass:.2f} kg exceeds the {arm_name(slave_arm(scenario)).upper()}'s payload "
                     f"of {payload:g} kg")
    message = ("the poses agree within the sensor's noise" if not causes else
               "the fit is not to be trusted: " + "; ".join(words))
    return {"ok": not causes, "causes": causes, "message": message, "residual_ratio": ratio.tolist()}


def _stream_fit(recording, source, scenario: Scenario, method: str, out: Path) -> tuple[dict, dict]:
    """Every estimator on the merged streams (clock offsets found first where asked): (metrics,
    the chosen method's estimate.yaml record with its verdict under "verdict")."""
    offsets, metrics = {}, {"choices": source.choices}
    alpha_recorded = len(recording.accelerometer.columns) == 6
    noise = recording_noise(scenario, alpha_recorded)
    if ESTIMATE in source.stated_offsets().values():
        first = source.merged({n: 0.0 for n, v in source.stated_offsets().items() if v == ESTIMATE})
        fit = batch_estimate(first.wrench, first.a, first.alpha, first.omega, first.g, method="wls",
                             weights=noise.wrench_weights())
        fits = estimate_clock_offsets(source, fit.phi, sensor_offsets=fit.offsets)
        offsets = {name: fit.offset for name, fit in fits.items()}
        metrics["clock_offsets"] = {name: fit.summary() for name, fit in fits.items()}
        for name, fit in fits.items():
            say.info(f"clock offset of the {name}: {1e3 * fit.offset:.3f} ms late against the wrench"
                     + ("" if fit.observable else f" (NOT observable: {fit.why_not()})"))
    merged = source.merged(offsets)
    signals = (merged.a, merged.alpha, merged.omega, merged.g)
    # No encoders in a recording: RIV's instruments are the measured signals themselves (it then is RLS).
    results, histories, failed = estimate_all(merged.wrench, signals, signals, noise)
    for m, why in failed.items():
        say.info(f"{m}: no estimate: {why}")
    records = {m: estimate_record(r, m, SIGNALS, len(merged)) for m, r in results.items()}
    period = float(np.median(np.diff(merged.t)))
    metrics.update(samples=len(merged), duration_s=float(merged.t[-1] - merged.t[0]), sample_period_s=period,
                   noise=dataclasses.asdict(noise), estimates=records,
                   residual_rms={m: residual_rms(r, signals, merged.wrench) for m, r in results.items()},
                   mass_spread_kg=float(np.ptp([r["phi"][0] for r in records.values()])), failed=failed)
    say.info(f"{'method':8s}{'mass (kg)':>11s}{'COM (mm)':>26s}{'I_S diagonal (kg·m²)':>30s}")
    for m, r in records.items():
        com = 1e3 * np.asarray(r.get("com", [np.nan] * 3))
        say.info(f"{m:8s}{r['phi'][0]:11.4f}   [{com[0]:7.2f} {com[1]:7.2f} {com[2]:7.2f}]   "
                 f"[{r['phi'][4]:.5f} {r['phi'][7]:.5f} {r['phi'][9]:.5f}]")
    unidentified = [n for n, ok in zip(PARAMETER_NAMES, records.get(method, {}).get("identifiable", [])) if not ok]
    metrics["unidentifiable"] = unidentified
    if unidentified:
        say.info(f"not identifiable from this motion ({method}): {', '.join(unidentified)}: the recording does not "
                 "excite them (rotation about several axes is needed for the inertia)")
    estimate_history_figure(histories, period, out / "convergence.png")
    if method in failed:
        raise ValueError(f"the {method} estimate failed ({failed[method]}); the other methods' estimates are in "
                         f"{out / 'metrics.json'}: identify again with --method one of {', '.join(records)}")
    acc = scenario.accelerometer
    motion_rms = np.concatenate((acc.noise_rms[:3], acc.noise_rms[3:] if alpha_recorded
                                 else np.full(3, DERIVED_ALPHA_NOISE)))

    def floor(result):
        return noise_floor(result.phi, scenario.ft_sensor.noise_rms, motion_rms, recording.accelerometer.p_SA)

    result = results[method]
    verdict = fit_verdict(FitEvidence(
        residual=fit_residual(result, signals, merged.wrench), noise_floor=floor(result), sample_period=period,
        wrench=merged.wrench, wrench_full_scale=scenario.ft_sensor.full_scale, acceleration=None,
        acceleration_full_scale=None, mass=float(result.phi[0]), payload_max=payload_max(slave_arm(scenario)),
        robot=arm_name(slave_arm(scenario)),
        other_methods={m: float(np.max(residual_rms(r, signals, merged.wrench) / floor(r)))
                       for m, r in results.items() if m != method}))
    metrics["fit_verdict"] = verdict
    say.info(verdict_report(verdict, method))
    return metrics, {**records[method], "verdict": verdict}


def identify_recording(path, out_dir, scenario: Scenario, method: str = "tls", accept_fit: bool = False) -> dict:
    """Identifies from the recording at ``path`` (docs/recordings.md) and writes metrics.json,
    the figures and estimate.yaml into ``out_dir``: the streams' ``method`` estimate if the recording
    has streams, else the static poses' (φ's inertia a point mass's), with the accelerometer's
    calibration where the poses gave one. Raises ``FitRefused`` for a fit that is not ok unless
    ``accept_fit``. Returns the metrics."""
    if method not in ALL_METHODS:
        raise ValueError(f"method must be one of {', '.join(ALL_METHODS)}; got {method!r}")
    recording = load_recording(path)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    metrics, calibration, record, verdict = {"recording": str(path)}, None, None, None
    if recording.static_poses is not None:
        table = read_static_poses(recording, _joints(recording))
        unit = recording.accelerometer.unit if recording.accelerometer is not None else "m/s^2"
        static = calibrate_static(table.wrench, table.gravity_S, table.accelerometer, unit)
        metrics["static_poses"], lines = static_report(static)
        say.info(lines)
        verdict = static_verdict(static, scenario)
        metrics["static_poses"]["verdict"] = verdict
        say.info(f"static poses: {'fit ok' if verdict['ok'] else 'FIT NOT OK'}: {verdict['message']}")
        zeros = np.zeros_like(table.gravity_S)
        static_pose_figure(table.wrench, fit_residual(static.estimate, (zeros, zeros, zeros, table.gravity_S),
                                                      table.wrench), out / "static_poses.png")
        if static.accelerometer is not None:
            calibration = static.accelerometer.calibration
        estimate = dataclasses.replace(static.estimate, phi=point_mass_phi(static.mass, static.com))
        record = estimate_record(estimate, "ols", "static poses", static.poses)
    if recording.lcm_log is not None or (recording.wrench is not None and recording.wrench.file):
        stated = recording.accelerometer
        if calibration is None and stated is not None and ESTIMATE in (stated.R_SA, stated.bias):
            raise ValueError(f"{path}: the accelerometer's R_SA or bias is 'estimate', which needs static_poses "
                             "with the accelerometer's columns; add them or state R_SA and bias")
        source = open_recording(path, calibration=calibration, calibrated_by="the static poses")
        recording = source.recording
        metrics["streams"], record = _stream_fit(recording, source, scenario, method, out)
        verdict = record.pop("verdict")
    if calibration is not None:
        metrics["accelerometer_calibration"] = calibration.as_dict()
    (out / "metrics.json").write_text(json.dumps(metrics, indent=2, default=float) + "\n")
    if not (verdict["ok"] or accept_fit):
        stale = out / "estimate.yaml"
        removed = " (an earlier one there removed)" if stale.exists() else ""
        stale.unlink(missing_ok=True)
        raise FitRefused(f"{verdict['message']}. estimate.yaml was not written{removed}; the estimates and the "
                         f"numbers behind this are in {out / 'metrics.json'}. To write it anyway, identify again "
                         "with --accept-fit")
    write_load_estimate(out / "estimate.yaml", record, verdict, calibration)
    return metrics

