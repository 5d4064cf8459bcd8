"""``heft analyze linear``: the single-axis linear model of a scenario's loop, analysed.

Writes hybrid_parameters.png, llewellyn.png, z_width.png, eigenvalues.png and
linear.json to ``--out`` and prints a one-line summary.
"""

import json
from pathlib import Path

from heft.analysis.linear_teleoperator import analyze, write_figures
from heft.diagrams.studies.linear_model_params import linear_model_params
from heft.diagrams.scenario import resolve_scenario
from heft.diagrams.commands.console import logger
from heft.diagrams.commands.options import add_out, add_scenario

say = logger(__name__)


def add_arguments(parser) -> None:
    """The options of ``heft analyze linear``."""
    add_scenario(parser, default="fig8")
    parser.add_argument("--stiffness", type=float, default=None,
                        help="environment stiffness K_e (N/m) to analyse instead of the scenario's")
    add_out(parser, "linear.json and the figures", shown="out/linear/SCENARIO")


def _format(value, unit: str) -> str:
    return "none" if value is None else f"{value:.4g} {unit}"


def run(args) -> int:
    """Analyses the scenario's loop about its start pose; returns 0."""
    scenario = resolve_scenario(args.scenario)
    params = linear_model_params(scenario, args.stiffness)
    result = analyze(params)
    out = Path(args.out or f"out/linear/{Path(args.scenario).stem}")
    write_figures(result, out)
    summary = result.summary()
    (out / "linear.json").write_text(json.dumps(summary, indent=2))
    width = summary["z_width"]
    say.info(f"K_e = {params.environment_stiffness:.4g} N/m: max |z| = {summary['spectral_radius']:.5f} "
             f"(margin {summary['stability_margin']:.2e}), Llewellyn "
             f"{'absolutely stable' if summary['llewellyn_absolutely_stable'] else 'not absolutely stable'}, "
             f"Z-width: passive up to {_format(width['passive_stiffness_max_N_per_m'], 'N/m')} "
             f"({_format(width['passive_stiffness_max_with_grip_N_per_m'], 'N/m')} with the grip), "
             f"predicted stiffness limit {_format(summary['predicted_stiffness_limit_N_per_m'], 'N/m')}; "
             f"wrote {out}/linear.json and 4 figures")
    return 0
