"""Figures in the layout of the paper's Figs. 6–8."""

from heft.analysis.plotting import plt

from heft.analysis.experiment_metrics import plotted_axis

AXIS_NAMES = ("f_x", "f_y", "f_z", "τ_x", "τ_y", "τ_z")


def paper_figure(runs: dict, experiment: str, path, title: str = ""):
    """Stacked panels, one per σ (largest first: measured, …, eliminated), same y-scale:
    the fed-back wrench f′ along the plotted axis at the slave, with the true contact
    dashed. Writes a PNG to ``path``."""
    sigmas = sorted(runs, reverse=True)
    axis = plotted_axis(runs[sigmas[0]], experiment)
    unit = "N·m" if axis >= 3 else "N"
    figure, panels = plt.subplots(len(sigmas), 1, sharex=True, sharey=True, figsize=(7, 2.2 * len(sigmas) + 0.6),
                                  squeeze=False)
    for panel, sigma in zip(panels[:, 0], sigmas):
        run = runs[sigma]
        label = "measured (σ = 1)" if sigma == 1 else ("eliminated (σ = 0)" if sigma == 0 else f"σ = {sigma:g}")
        panel.plot(run["t"], run["wrench_feedback"][:, axis], lw=1.0, label=f"f′ {label}")
        panel.plot(run["t"], run["wrench_contact_true"][:, axis], "k--", lw=0.8, label="true contact")
        panel.set_ylabel(f"{AXIS_NAMES[axis]} ({unit})")
        panel.grid(alpha=0.3)
        panel.legend(loc="upper right", fontsize=8)
    panels[-1, 0].set_xlabel("t (s)")
    figure.suptitle(f"{title}: wrench fed back at the slave (÷17.5 at the master)" if title else "")
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)
