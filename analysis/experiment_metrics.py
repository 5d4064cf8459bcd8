"""Numbers that summarise a replay of the paper's experiments (Sec. VI).

``runs`` maps σ to a run's log (keys as log.npz). The run with the largest σ
stands for the measured signal (σ = 1 feeds back f − o), the one with the
smallest for elimination (σ = 0). Forces are at the slave, in S, in N (N·m).
``strokes`` are the operator's strokes as (start, end) in s
(``operator_hand.stroke_windows``).
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


def experiment_metrics(experiment: str, runs: dict, force_scale: float, strokes=()) -> dict:
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
        metrics["strokes"] = [stroke_metrics(runs, axis, start, end) for start, end in strokes]
    return metrics


def stroke_metrics(runs: dict, axis: int, start: float, end: float) -> dict:
    """One stroke [start, end) (s): the largest true contact force |f_c| (N) in any run, and
    how far the plotted force of the measured (largest σ) and the eliminated (smallest σ)
    feedback swings, peak to peak (N): a stroke without contact shows what the non-contact
    force alone does to the measurement."""
    window = {sigma: (run["t"] >= start) & (run["t"] < end) for sigma, run in runs.items()}

    def swing(sigma):
        return float(np.ptp(runs[sigma]["wrench_feedback"][window[sigma], axis]))

    contact = [np.linalg.norm(run["wrench_contact_true"][window[sigma], :3], axis=1).max()
               for sigma, run in runs.items()]
    return {"start_s": start, "end_s": end, "contact_peak_N": float(max(contact)),
            "raw_swing_N": swing(max(runs)), "eliminated_swing_N": swing(min(runs))}


GRASP_SETTLE_TOLERANCE = 0.02   # the object's mass in φ̂ within this share of the true one
GRASP_WINDOW_S = 1.5            # what is judged starts this long after the grasp
GRASP_SMOOTHING_S = 0.01        # the deviation also averaged over this long: above the hand's force bandwidth


def grasp_metrics(run: dict, grasp_at: float) -> dict:
    """Eq. 14 end to end after a grasp at ``grasp_at`` (s): when the object's mass in φ̂ − φ_gr
    settles within 2 % of the truth, and from ``GRASP_WINDOW_S`` after the grasp how far the
    fed-back force is from γ·c + σ·(gripper's share) + η·(object's share) of the true wrenches
    (the law of ``force_scaling`` with the scales in effect), against the object's weight: per
    sample (the sensors' white noise included: 0.1 N on the wrench, 0.05 m/s² times the load's
    mass on the accelerometer) and averaged over ``GRASP_SMOOTHING_S``."""
    t = run["t"]
    after = t >= grasp_at
    m_object = run["phi_true"][-1, 0] - run["phi_gripper_true"][0]
    m_hat = run["phi_hat"][:, 0] - run["phi_gripper_hat"][0]
    off = np.flatnonzero(after & (np.abs(m_hat - m_object) > GRASP_SETTLE_TOLERANCE * m_object))
    settled = float(t[off[-1] + 1] - grasp_at) if off.size and off[-1] + 1 < len(t) else (
        0.0 if not off.size else None)
    sigma, gamma, eta = (run["scales"][:, i:i + 1] for i in range(3))
    obj, whole = run["wrench_noncontact_object_true"], run["wrench_noncontact_true"]
    expected = gamma * run["wrench_contact_true"] + sigma * (whole - obj) + eta * obj
    judged = t >= grasp_at + GRASP_WINDOW_S
    error = (run["wrench_feedback"] - expected)[judged, :3]
    deviation = np.linalg.norm(error, axis=1)
    width = max(1, round(GRASP_SMOOTHING_S / (t[1] - t[0])))
    kernel = np.ones(width) / width
    smoothed = np.linalg.norm(np.column_stack([np.convolve(e, kernel, mode="valid") for e in error.T]), axis=1)
    weight = 9.81 * m_object
    return {"grasp_at_s": grasp_at, "object_mass_kg": float(m_object), "object_mass_hat_kg": float(m_hat[-1]),
            "object_mass_settled_after_s": settled, "eta": float(eta[-1, 0]),
            "force_deviation_peak_N": float(deviation.max()), "force_deviation_rms_N": float(
                np.sqrt(np.mean(deviation ** 2))), "force_deviation_peak_of_weight": float(deviation.max() / weight),
            "force_deviation_rms_of_weight": float(np.sqrt(np.mean(deviation ** 2)) / weight),
            "force_deviation_smoothed_peak_of_weight": float(smoothed.max() / weight)}
