"""`heft simulate`: one of the paper's experiments, or a scenario file, in the simulated station."""

from __future__ import annotations

import json
import math
from pathlib import Path


from heft.diagrams.commands.options import (SCENARIO_HELP, add_noise, add_out, add_scenario, add_set, add_station,
                                           parse_numbers, scenario_from, stated_fields)
from heft.diagrams.commands.console import logger
from heft.diagrams.commands.view_options import VIEW_HOWTO, add_view, view_from

say = logger(__name__)

HELP = ("replay one of the paper's experiments (fig6, fig7, fig8) "
       "or a scenario file in the simulated station")


def add_arguments(parser) -> None:
    parser.add_argument("positional_scenario", nargs="?", metavar="SCENARIO", help=f"as --scenario: {SCENARIO_HELP}")
    add_scenario(parser, default=None, more="given here or as the first argument")
    add_set(parser)
    add_station(parser)
    parser.add_argument("--sigma", type=float, help="σ: non-contact scale, controller.force.sigma (one run)")
    parser.add_argument("--sigmas", help="σ values to compare, comma separated, one run each (default: the "
                                         "scenario's σ if it states one, else the paper's 1,0.5,0)")
    parser.add_argument("--gamma", type=float, help="γ: contact scale")
    parser.add_argument("--eta", type=float, help="η: share of the gripped object's non-contact wrench kept")
    add_noise(parser)
    parser.add_argument("--duration", type=float, help="simulated seconds")
    parser.add_argument("--estimate", help="estimate.yaml from `heft identify` (default: identify first)")
    add_out(parser, "log.npz, metrics.json, figure.png (and identify/ when it identifies first)",
            shown="out/SCENARIO")
    parser.add_argument("--meshcat", action="store_true", help="show the simulation live in a browser (URL printed)")
    add_view(parser)


def chosen_scenario(args) -> str:
    """The scenario given as the first argument or as ``--scenario`` (one of them, or both the same)."""
    given = {name for name in (args.positional_scenario, args.scenario) if name is not None}
    if len(given) != 1:
        raise ValueError("give the scenario once, e.g. `heft simulate fig6` or `heft simulate --scenario fig6`"
                         + (f"; got {' and '.join(sorted(given))}" if given else ""))
    return given.pop()


def run(args) -> int:
    from heft.diagrams.load_estimate import read_load_estimate
    from heft.diagrams.plants import slave_arm
    from heft.diagrams.scenario import NOISE_OFF, layered, overrides_text
    from heft.diagrams.running.simulation import simulate

    args.scenario = chosen_scenario(args)
    noise = {} if args.noise is None else {name: args.noise == "on" for name in NOISE_OFF}
    options = overrides_text({"controller.force.sigma": args.sigma, "controller.force.gamma": args.gamma,
                              "controller.force.eta": args.eta, **noise, "duration": args.duration})
    scenario = scenario_from(args, options)
    sigmas = compared_sigmas(args, scenario)
    view = view_from(args, slave_arm(scenario), scenario.master)  # before identifying: a missing extra is said at once
    out = Path(args.out or f"out/{Path(args.scenario).stem}")
    estimate = args.estimate or scenario.controller.load_estimate
    if estimate:
        load = read_load_estimate(estimate)
        say.info(f"load estimate from {estimate}")
    else:
        from heft.diagrams.running.sim_identification import identify_in_simulation
        say.info("no load estimate given: identifying the load in simulation first (Sec. IV)")
        load = identify_in_simulation(scenario, out / "identify")
    if math.isfinite(scenario.load.grasp_at) and scenario.controller.force.phi_gripper is None:
        # Before the grasp the gripper holds nothing: the estimate is the gripper's, Eq. 14's φ_gr.
        scenario = layered(scenario, overrides_text({"controller.force.phi_gripper": load.phi.tolist()}))
        say.info(f"gripper alone: m = {load.phi[0]:.4g} kg (φ_gr of Eq. 14); the object is learned after the grasp")
    meshcat = None
    if args.meshcat:
        from pydrake.geometry import Meshcat
        meshcat = Meshcat()
        say.info(f"live view: {meshcat.web_url()}")
    if view is not None:
        say.info(f"live view: ws://localhost:{args.view_port}; {VIEW_HOWTO}")
    try:
        metrics = simulate(scenario, load, out, sigmas, name=Path(args.scenario).stem, meshcat=meshcat, view=view)
    finally:
        if view is not None:
            view.close()
    say.info(json.dumps(metrics, indent=2))
    say.info(f"wrote {out}/log.npz, metrics.json, figure.png")
    return 0


SIGMA = "controller.force.sigma"


def compared_sigmas(args, scenario) -> list[float]:
    """The σ values to run, one run each. A σ stated by ``--sigma`` or ``--set`` is the run's own,
    and ``--sigmas`` beside it is an error (the one would silently undo the other); ``--sigmas``
    replaces, run by run, a σ the scenario file states, saying so; otherwise a σ the scenario
    states is the one run, and the paper's 1, 0.5, 0 (``PAPER_SIGMAS``) are compared."""
    from heft.diagrams.running.simulation import PAPER_SIGMAS
    from heft.diagrams.scenario import scenario_path

    on_command_line = args.sigma is not None or SIGMA in stated_fields(args.set or "")
    in_file = SIGMA in stated_fields(scenario_path(args.scenario).read_text())
    if args.sigmas is not None:
        if on_command_line:
            raise ValueError(f"--sigmas compares σ values, so it cannot go with a σ of its own (--sigma or --set "
                             f"{SIGMA}); give one or the other")
        sigmas = parse_numbers(args.sigmas, "--sigmas")
        if in_file:
            say.info(f"--sigmas {args.sigmas}: run by run in place of the scenario file's σ = "
                     f"{scenario.controller.force.sigma:g} ({SIGMA})")
        return sigmas
    return [scenario.controller.force.sigma] if on_command_line or in_file else list(PAPER_SIGMAS)
