"""The judge of the grasp on hardware (its targets: docs/hardware.md, "The grasp on hardware"), shared by
the in-process and the two-process test: from what the controller sent and learned, against the
stand-in's recorded truth.

Every time is on the stand-in's clock (s). ``judge`` takes

- ``truth``: the stand-in's ``TruthRecord`` arrays (``utime``, ``phi``, ``wrench_noncontact_object``,
  ``wrench_contact``, ``phi_gripper``, ``arm_late_steps``);
- ``phi_history``: (t, φ̂) the controller used, and ``phi_gripper`` the φ_gr it kept at the grasp;
- ``commands``: (t, master joint torques sent, enabled), ``master``/``slave``: (t, joint positions)
  as the drivers published them;

and returns, for the times after ``learned_by`` s, the object's mass error (fraction) and, per 10 ms
window, the distance between the stylus force the torques render at the driver's last positions
(Drake's Jacobian of the Phantom: τ = Jᵀ·[f; τ_E]) and −k_f·R_RS·(c + η·w_obj) of the truth
(c the contact, w_obj the object's non-contact wrench, both in S; R_BR = E), as a fraction of the
object's weight, split into the windows while the slave moves and while it holds still. A moving window
that overlaps a pause (``pauses_of_the_arm``: the arm stepped on late commands, the truth's
``arm_late_steps``) or the ``RING_SETTLE`` after it is judged apart, as "after_pause": the arm's held
setpoint rings the load on its mount (``test_grasp_lab.test_a_paused_loop_rings_the_mount``).
"""

from __future__ import annotations

import numpy as np

from heft.diagrams.plants import MakeArmPlant, MakeMasterPlant
from heft.hardware_interface.channels import LcmChannels
from drake_reference import pose_and_jacobian
from heft.systems.controller.master_kinematics import BASE_FRAME, STYLUS_FRAME

WINDOW = 0.01
"""s: the averages judged."""
GRAVITY = 9.81
ARM_PERIOD = 1.0 / LcmChannels().slave_status.rate
"""s: the stand-in's arm steps as its driver publishes its status (the lab's channels as both tests run it)."""
PAUSE_STEPS, PAUSE_SPAN = 3, 0.01
"""A pause: the arm stepped on late commands (the truth's ``arm_late_steps``), each within ``PAUSE_SPAN`` s
(half the mount's ring period) of the last, that lagged ``PAUSE_STEPS`` or more of its steps behind in all,
beyond the one step of a command on time (a command k steps old lags k − 1): as when the controller's loop
pauses, or its commands reach the arm after the arm's step. In one process, in the strokes, one tick
skipped (a lag of 1) or two a tick apart (2) keep every window within the bound (at most 4.1 %); two in a
row (3) miss it by up to 6 %, four (10) by 17 %, eight (36) by 45 %."""
RING_SETTLE = 0.4
"""s after a pause: the ring of the grasp scenario's load on its mount (rocking at 48 Hz, 4 % of critical
damping: its envelope falls e-fold in 83 ms) has fallen below the bound within 0.2 s of a 4 ms pause and
0.35 s of a 16 ms one in the strokes (in one process)."""


def pauses_of_the_arm(late_steps, arm_period: float) -> list[tuple[float, float, int]]:
    """The pauses (``PAUSE_STEPS``) in the arm's late steps ``late_steps`` (n, 2: time, age, s, by time) of
    an arm stepping every ``arm_period`` s: [(first, last, lag in steps)], each late step within
    ``PAUSE_SPAN`` of the last taken into one."""
    clusters = []
    for t, age in np.asarray(late_steps, dtype=float).reshape(-1, 2):
        lag = max(round(age / arm_period) - 1, 0)
        if clusters and t - clusters[-1][1] <= PAUSE_SPAN:
            clusters[-1] = (clusters[-1][0], float(t), clusters[-1][2] + lag)
        else:
            clusters.append((float(t), float(t), lag))
    return [cluster for cluster in clusters if cluster[2] >= PAUSE_STEPS]


def _latest(stamps, values, t):
    i = np.searchsorted(stamps, t, side="right") - 1
    return values[i] if i >= 0 else None


def judge(truth, phi_history, phi_gripper, commands, master, slave, *, robot: str, eta: float, force_scale: float,
          learned_by: float, still_from: float, end: float) -> dict:
    """The module docstring's results: "object_mass" (kg), "mass_error_max", "mass_learned_at_start",
    "stylus_force_peak" (N), the window errors "still", "moving" and "after_pause" (fractions of the
    object's weight), "pauses" (``pauses_of_the_arm``) and "still_expected_force" (N)."""
    m_object = float(truth["phi"][-1, 0] - truth["phi_gripper"][0])
    weight = m_object * GRAVITY
    learned = [(t, phi[0] - phi_gripper[0]) for t, phi in phi_history if learned_by <= t <= end]
    mass_errors = np.array([abs(m - m_object) / m_object for _, m in learned])

    plant = MakeMasterPlant()
    context, B, E = plant.CreateDefaultContext(), plant.GetFrameByName(BASE_FRAME), plant.GetFrameByName(STYLUS_FRAME)
    arm, _ = MakeArmPlant(robot)
    arm_context = arm.CreateDefaultContext()
    R, S = arm.GetFrameByName(f"{robot}_base"), arm.GetFrameByName("S")
    master_t, master_q = np.array([t for t, _ in master]), [q for _, q in master]
    slave_t, slave_q = np.array([t for t, _ in slave]), [q for _, q in slave]
    stamps = truth["utime"] * 1e-6
    wrench = truth["wrench_contact"][:, :3] + eta * truth["wrench_noncontact_object"][:, :3]
    times, measured, expected, peak = [], [], [], 0.0
    pauses = [pause for pause in pauses_of_the_arm(truth["arm_late_steps"] * 1e-6, ARM_PERIOD) if pause[0] <= end]
    for t, torque, enabled in commands:
        q_M = _latest(master_t, master_q, t)
        if q_M is None or not enabled:
            continue
        _, J = pose_and_jacobian(plant, context, B, E, q_M)
        force = np.linalg.solve(J.T, torque)[:3]
        peak = max(peak, float(np.linalg.norm(force)))
        i = np.searchsorted(stamps, t, side="right") - 1
        q_S = _latest(slave_t, slave_q, t)
        if not learned_by <= t <= end or i < 0 or q_S is None:
            continue
        arm.SetPositions(arm_context, q_S)
        R_RS = arm.CalcRelativeTransform(arm_context, R, S).rotation().matrix()
        times.append(t)
        measured.append(force)
        expected.append(-force_scale * R_RS @ wrench[i])
    times, measured, expected = np.array(times), np.array(measured), np.array(expected)
    bins = np.floor(times / WINDOW).astype(int)
    result = {"object_mass": m_object, "mass_error_max": float(mass_errors.max()) if mass_errors.size else np.inf,
              "mass_learned_at_start": learned[0][1] if learned else None, "stylus_force_peak": peak,
              "still": [], "moving": [], "after_pause": [], "pauses": pauses, "still_expected_force": None}
    for b in np.unique(bins):
        inside = bins == b
        if inside.sum() < 3:
            continue
        start = b * WINDOW
        phase = "still" if start >= still_from + 0.5 else "moving" if start + WINDOW <= still_from else None
        if phase == "moving" and any(first <= start + WINDOW and start <= last + RING_SETTLE
                                     for first, last, _ in pauses):
            phase = "after_pause"
        if phase is not None:
            error = np.linalg.norm(measured[inside].mean(axis=0) - expected[inside].mean(axis=0)) / weight
            result[phase].append(float(error))
    still = times >= still_from + 0.5
    if still.any():
        result["still_expected_force"] = float(np.linalg.norm(expected[still].mean(axis=0)))
    return result


def report(result: dict) -> str:
    lines = [f"object {result['object_mass']:.4f} kg: learned {result['mass_learned_at_start']:.4f} kg as the judged "
             f"span starts, worst since {100 * result['mass_error_max']:.2f} %; stylus force peak "
             f"{result['stylus_force_peak']:.3f} N"]
    pauses = [f"{first:.4f}–{last:.4f} s ({lag})" for first, last, lag in result["pauses"]]
    lines.append(f"pauses (the arm's commands {PAUSE_STEPS}+ steps late in all, {1e3 * PAUSE_SPAN:g} ms apart at "
                 f"most; s, lag): {', '.join(pauses) or 'none'}")
    for phase in ("still", "moving", "after_pause"):
        errors = np.array(result[phase])
        if errors.size:
            lines.append(f"{phase}: |stylus force − (contact + η·object's non-contact)|, 10 ms averages, of the "
                         f"object's weight: p50 {100 * np.median(errors):.2f} %, max {100 * errors.max():.2f} % "
                         f"({errors.size} windows)")
    return "\n".join(lines)
