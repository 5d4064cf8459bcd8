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


def estimate_history_figure(histories: dict, sample_period: float, path):
    """Mass, centre of mass and the inertia's diagonal about S of each recursive estimator over time,
    where no truth is known (a recording). PNG."""
    figure, panels = plt.subplots(3, 1, sharex=True, figsize=(7, 7))
    for method, (steps, thetas) in histories.items():
        t, phi = steps * sample_period, thetas[:, 6:]
        with np.errstate(divide="ignore", invalid="ignore"):
            com = 1e3 * phi[:, 1:4] / phi[:, :1]
        panels[0].plot(t, phi[:, 0], label=method.upper())
        panels[1].plot(t, com, color=panels[0].lines[-1].get_color())
        panels[2].plot(t, phi[:, [4, 7, 9]], color=panels[0].lines[-1].get_color())
    for panel, label in zip(panels, ("mass (kg)", "COM x, y, z (mm)", "I_xx, I_yy, I_zz (kg·m²)")):
        panel.set_ylabel(label)
        panel.grid(alpha=0.3)
    panels[0].legend()
    panels[-1].set_xlabel("t (s)")
    figure.suptitle("Recursive estimators along the recording")
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)


def static_pose_figure(wrench, residual, path):
    """Per static pose the measured wrench and what the fit leaves of it (``residual``), (P, 6) [f; τ]
    in N, N·m. PNG."""
    wrench, residual = np.asarray(wrench, dtype=float), np.asarray(residual, dtype=float)
    figure, panels = plt.subplots(2, 1, sharex=True, figsize=(7, 6))
    poses = np.arange(1, len(wrench) + 1)
    for panel, columns, unit in zip(panels, (slice(0, 3), slice(3, 6)), ("N", "N·m")):
        for k, name in zip(range(columns.start, columns.stop), AXES[columns]):
            line, = panel.plot(poses, wrench[:, k], "o-", ms=3, label=f"{name} measured")
            panel.plot(poses, 100 * residual[:, k], "x:", color=line.get_color(), label=f"{name} residual × 100")
        panel.set_ylabel(unit)
        panel.grid(alpha=0.3)
        panel.legend(fontsize=7, ncol=3)
    panels[-1].set_xlabel("pose")
    figure.suptitle("Static poses: the measured wrench and the fit's residual (× 100)")
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
