"""How good an inertial-parameter estimate is: against a known truth, and the fit's verdict as
the report prints it."""

from heft.analysis.plotting import plt
import numpy as np

from heft.analysis.fit_verdict import AXES
from heft.systems.load_dynamics import inertia_matrix


def estimate_errors(phi, offsets, phi_true, offsets_true) -> dict:
    """Errors of an estimate: mass (kg), COM position (m), inertia about S relative to
    its norm, force and torque offsets (N, N·m), and ‖φ − φ_true‖/‖φ_true‖."""
    phi, phi_true = np.asarray(phi, dtype=float), np.asarray(phi_true, dtype=float)
    offsets, offsets_true = np.asarray(offsets, dtype=float), np.asarray(offsets_true, dtype=float)
    com = phi[1:4] / phi[0] if phi[0] > 0 else np.full(3, np.nan)
    inertia_error = np.linalg.norm(inertia_matrix(phi[4:]) - inertia_matrix(phi_true[4:]))
    return {"mass_kg": float(abs(phi[0] - phi_true[0])),
            "com_m": float(np.linalg.norm(com - phi_true[1:4] / phi_true[0])),
            "inertia_relative": float(inertia_error / np.linalg.norm(inertia_matrix(phi_true[4:]))),
            "force_offsets_N": float(np.linalg.norm(offsets[:3] - offsets_true[:3])),
            "torque_offsets_Nm": float(np.linalg.norm(offsets[3:] - offsets_true[3:])),
            "phi_relative": float(np.linalg.norm(phi - phi_true) / np.linalg.norm(phi_true))}


def convergence_figure(histories: dict, sample_period: float, phi_true, offsets_true, path):
    """Mass, COM and inertia errors of each recursive estimator over time (log scale). PNG."""
    figure, panels = plt.subplots(3, 1, sharex=True, figsize=(7, 7))
    for method, (steps, thetas) in histories.items():
        errors = [estimate_errors(theta[6:], theta[:6], phi_true, offsets_true) for theta in thetas]
        t = steps * sample_period
        for panel, key, scale in zip(panels, ("mass_kg", "com_m", "inertia_relative"), (1e3, 1e3, 100)):
            panel.semilogy(t, np.maximum([scale * e[key] for e in errors], 1e-12), label=method.upper())
    for panel, label in zip(panels, ("mass error (g)", "COM error (mm)", "inertia error (%)")):
        panel.set_ylabel(label)
        panel.grid(alpha=0.3, which="both")
    panels[0].legend()
    panels[-1].set_xlabel("t (s)")
    figure.suptitle("Recursive estimators during the excitation")
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)


def verdict_report(verdict: dict, method: str) -> str:
    """The fit's verdict (``fit_verdict.fit_verdict``) for the printed report: per axis the
    residual RMS against the noise floor, then the verdict in words."""
    lines = [f"fit of {method}: residual RMS / noise floor per axis ([f] N, [τ] N·m)"]
    for name, rms, floor, ratio in zip(AXES, verdict["residual_rms"], verdict["noise_floor"],
                                       verdict["residual_ratio"]):
        lines.append(f"  {name:3s}{rms:10.4f} /{floor:8.4f} = {ratio:5.2f}")
    lines.append(f"{'fit ok' if verdict['ok'] else 'FIT NOT OK (' + ', '.join(verdict['causes']) + ')'}: "
                 f"{verdict['message']}")
    return "\n".join(lines)
