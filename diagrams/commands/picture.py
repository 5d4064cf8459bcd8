"""A picture of heft's Diagram as Drake draws it: ``GetGraphvizString`` rendered by Graphviz.

The architecture picture ``docs/teleop_controller.svg`` is made by ``heft picture --out docs``: the
controller Diagram of Fig. 4, every block a LeafSystem. ``--what simulation`` draws it closed around
the simulated station (``teleop_simulation.svg``).
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

from heft.diagrams.commands.options import add_out, add_scenario, out_file

from heft.diagrams.commands.console import logger

say = logger(__name__)

WHAT = ("controller", "simulation")
FORMATS = ("svg", "png", "dot")
HELP = "draw the controller Diagram (or the whole simulation) as Drake sees it (Graphviz)"


def teleop_graphviz(what: str = "controller", scenario_name: str = "fig6", depth: int = 1) -> str:
    """The DOT text of the controller Diagram, or of the ``simulation`` (controller closed around
    the simulated station), with ``depth`` levels of subsystems drawn."""
    from heft.diagrams.running.simulation import true_load
    from heft.diagrams.scenario import resolve_scenario
    from heft.diagrams.teleop import MakeTeleopController
    from heft.diagrams.teleop_simulation import MakeTeleopSimulation

    if what not in WHAT:
        raise ValueError(f"draw one of {', '.join(WHAT)}; got {what!r}")
    scenario = resolve_scenario(scenario_name)
    load = true_load(scenario)[0]
    if what == "controller":
        diagram = MakeTeleopController(scenario.controller, load, scenario.robot, scenario.controller_period,
                                       scenario.slave_initial_q,
                                       accelerometer=scenario.accelerometer.convention())
    else:
        diagram, _ = MakeTeleopSimulation(scenario, load)
    return diagram.GetGraphvizString(max_depth=depth)


def picture_name(what: str, form: str) -> str:
    """The file a picture of ``what`` in format ``form`` is written to, in the ``--out`` folder."""
    return f"teleop_{what}.{form}"


def write_picture(out, what: str = "controller", scenario_name: str = "fig6", depth: int = 1) -> Path:
    """Writes the picture to the file ``out``: SVG or PNG by its suffix (needs Graphviz's ``dot``), or the
    DOT text for a ``.dot`` path. Returns the path written."""
    out = Path(out)
    if out.suffix[1:] not in FORMATS:
        raise ValueError(f"{out}: the picture is written as .svg, .png or .dot")
    text = teleop_graphviz(what, scenario_name, depth)
    out.parent.mkdir(parents=True, exist_ok=True)
    if out.suffix == ".dot":
        out.write_text(text)
        return out
    dot = shutil.which("dot")
    if dot is None:
        raise ValueError("Graphviz's `dot` is not installed (apt-get install graphviz); "
                         f"write {out.with_suffix('.dot')} instead and render it elsewhere")
    subprocess.run([dot, f"-T{out.suffix[1:]}", "-o", str(out)], input=text.encode(), check=True)
    return out


def add_arguments(parser) -> None:
    parser.add_argument("--what", default="controller", choices=WHAT,
                        help="the controller alone (default) or closed around the simulated station")
    parser.add_argument("--format", default="svg", choices=FORMATS,
                        help="svg (default) or png, rendered by Graphviz's `dot`; dot: the DOT text")
    add_out(parser, "teleop_controller.FORMAT or teleop_simulation.FORMAT", default="out/picture")
    add_scenario(parser)
    parser.add_argument("--depth", type=int, default=1, help="levels of subsystems drawn (default 1)")


def run(args) -> int:
    path = out_file(args, picture_name(args.what, args.format))
    say.info(f"wrote {write_picture(path, args.what, args.scenario, args.depth)}")
    return 0
