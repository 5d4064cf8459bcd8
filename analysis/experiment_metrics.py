"""Numbers that summarise a replay of the paper's experiments (Sec. VI).

``runs`` maps σ to a run's log (keys as log.npz). The run with the largest σ
stands for the measured signal (σ = 1 feeds back f − o), the one with the
smallest for elimination (σ = 0). Forces are at the slave, in S, in N (N·m).
"""

import numpy as np

CONTACT_ONSET_N = 0.5          # true contact: |f_c| above this (N)
DETECTION_THRESHOLD_N = 5.0    # slave side; ÷17.5 ≈ 0.29 N at the master, near human force-change thresholds


def plotted_axis(run: dict, experiment: str) -> int:
    """The wrench component the paper plots: the force along the vertical (the S axis
    most aligned with gravity) for fig6/fig8, the torque with the largest non-contact
    peak for fig7."""
    if experiment == "fig7":
        return 3 + int(np.argmax(np.abs(run["wrench_noncontact_true"][:, 3:]).max(axis=0)))
    return int(np.argmax(np.abs(run["gravity_S"].mean(axis=0))))


def first_time(t, mask):
    """The first t where mask holds, or None."""
    hits = np.flatnonzero(mask)
    return float(t[hits[0]]) if hits.size else None


def experiment_metrics(experiment: str, runs: dict, force_scale: float) -> dict:
    measured, eliminated = runs[max(runs)], runs[min(runs)]
    axis = plotted_axis(measured, experiment)
    unit = "Nm" if axis >= 3 else "N"
    metrics = {"experiment": experiment, "axis": int(axis), "sigmas": sorted(float(s) for s in runs),
               "force_scale": force_scale}
    noncontact_peak = float(np.abs(measured["wrench_noncontact_true"][:, axis]).max())
    residual = eliminated["wrench_feedback"][:, axis] - eliminated["wrench_contact_true"][:, axis]
    residual_peak = float(np.abs(residual).max())
    metrics[f"noncontact_peak_{unit}"] = noncontact_peak
    metrics[f"master_noncontact_peak_{unit}"] = noncontact_peak * force_scale
    metrics[f"residual_peak_{unit}"] = residual_peak
    metrics[f"residual_rms_{unit}"] = float(np.sqrt(np.mean(residual ** 2)))
    metrics["residual_ratio"] = residual_peak / noncontact_peak if noncontact_peak > 0 else None
    if experiment == "fig8":
        t = eliminated["t"]
        onset = first_time(t, np.linalg.norm(eliminated["wrench_contact_true"][:, :3], axis=1) > CONTACT_ONSET_N)
        metrics["contact_onset_s"] = onset
        metrics["detection_rule"] = (f"first t where the plotted force departs from its value at t = 0 by more "
                                     f"than {DETECTION_THRESHOLD_N} N (slave side); earlier than the true onset "
                                     "is a false alarm")
        for name, run in (("raw", measured), ("eliminated", eliminated)):
            signal = run["wrench_feedback"][:, axis]
            detected = first_time(run["t"], np.abs(signal - signal[0]) > DETECTION_THRESHOLD_N)
            metrics[f"contact_detected_s_{name}"] = detected
            metrics[f"false_alarm_{name}"] = bool(detected is not None and onset is not None and detected < onset)
    return metrics
