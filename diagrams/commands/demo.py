"""`heft demo`: identify the paper's tool, then replay Fig. 6 with σ = 1, 0.5, 0."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from heft.diagrams.commands.console import logger
from heft.diagrams.commands.options import add_out

say = logger(__name__)

HELP = ("identify the paper's tool, then replay its Fig. 6 (about a minute)")


def add_arguments(parser) -> None:
    add_out(parser, "identify/ (the estimate) and fig6/ (logs, metrics, figure)", default="out/demo")


def run(args) -> int:
    """Identify the paper's tool, then replay Fig. 6 with σ = 1, 0.5, 0."""
    from heft.diagrams.running.sim_identification import identify_in_simulation
    from heft.diagrams.scenario import resolve_scenario
    from heft.diagrams.running.simulation import PAPER_SIGMAS, simulate
    from heft.systems.identification.excitation import ExcitationSettings

    out = Path(args.out)
    scenario = resolve_scenario("fig6")
    say.info("1/2 identifying the 3.13 kg tool and the sensor offsets from a 4 s excitation (Sec. IV)")
    settings = dataclasses.replace(ExcitationSettings.quick(), base_frequency=0.25, duration=4.0)
    load = identify_in_simulation(scenario, out / "identify", settings)
    say.info("2/2 fast vertical motion (Fig. 6): feeding back σ = 1, 0.5, 0 of the non-contact force")
    metrics = simulate(scenario, load, out / "fig6", PAPER_SIGMAS, name="fig6")
    k_f = scenario.controller.feedback.force_scale
    say.info(f"non-contact force at the slave up to {metrics['noncontact_peak_N']:.1f} N "
             f"({metrics['master_noncontact_peak_N']:.2f} N at the operator's hand); after elimination "
             f"{metrics['residual_peak_N']:.2f} N remain ({100 * metrics['residual_ratio']:.1f} %, "
             f"{metrics['residual_peak_N'] * k_f:.3f} N at the hand). Simulated at "
             f"{metrics['realtime_factor']:.2f}× real time.")
    say.info(f"figure: {out / 'fig6' / 'figure.png'}; logs, metrics and the estimate under {out}/")
    return 0
