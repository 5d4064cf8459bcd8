"""The `heft` command line: parses and dispatches to one module per subcommand
(``heft.diagrams.commands``, each with ``HELP``, ``add_arguments`` and ``run``)."""

from __future__ import annotations

import argparse
import sys
from importlib import import_module
from importlib.metadata import version

COMMANDS = (
    ("check", "check"),
    ("demo", "demo"),
    ("simulate", "simulate"),
    ("identify", "identify"),
    ("compensate", "compensate"),
    ("bench", "bench"),
    ("stand-in", "stand_in"),
    ("teleop", "teleop"),
    ("load", "load"),
    ("picture", "picture"),
)
"""``heft`` subcommands: name, module under ``heft.diagrams.commands`` (``heft analyze`` has its own)."""


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="heft",
        description="Bilateral teleoperation that feeds back what the slave touches, "
                    "not what it carries (Kubus & Wahl, IROS 2009), on Drake.")
    parser.add_argument("--version", action="version", version=f"heft {version('heft-teleop')}")
    commands = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name, module_name in COMMANDS:
        module = import_module(f"heft.diagrams.commands.{module_name}")
        command = commands.add_parser(name, help=module.HELP, description=module.HELP)
        module.add_arguments(command)
        command.set_defaults(run=module.run)
    commands.add_parser("analyze", help="analyses: " + ", ".join(name for name, _, _ in ANALYSES) +
                        " (`heft analyze --help`)", add_help=False)
    return parser


ANALYSES = (
    ("passivity", "heft.diagrams.commands.analyze_passivity",
     "port energies, the passivity observer and what the passivity controller dissipated, from a run's log"),
    ("stability", "heft.diagrams.commands.analyze_stability",
     "stability maps by simulation sweeps (stiffness, damping, scales, rate, delay; with/without the PC)"),
    ("linear", "heft.diagrams.commands.analyze_linear",
     "the loop linearised: eigenvalues, hybrid parameters H(jω), Llewellyn, Z-width, transparency"),
    ("apparent-mass", "heft.diagrams.commands.analyze_apparent_mass",
     "the mass the operator feels for σ from 0 to 2 and the gripper/object split (Sec. V: m_a = σ·m)"),
    ("replay", "heft.diagrams.commands.replay", "a run's log as a self-contained HTML replay (Meshcat)"),
)
"""``heft analyze`` subcommands: name, module (with ``add_arguments`` and ``run``), help."""


def build_analyze_parser() -> argparse.ArgumentParser:
    """``heft analyze``'s own parser; imports the analyses (Drake), so built only when asked for."""
    parser = argparse.ArgumentParser(prog="heft analyze", description="analyses writing PNG/HTML and JSON, "
                                                                      "each with a one-line summary")
    kinds = parser.add_subparsers(dest="analysis", required=True, metavar="ANALYSIS")
    for name, module_name, help_text in ANALYSES:
        module = import_module(module_name)
        kind = kinds.add_parser(name, help=help_text, description=help_text)
        module.add_arguments(kind)
        kind.set_defaults(run=module.run)
    return parser


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv[:1] == ["analyze"]:
        args = build_analyze_parser().parse_args(argv[1:])
        args.command = f"analyze {args.analysis}"
    else:
        args = build_parser().parse_args(argv)
    try:
        return args.run(args)
    except ValueError as error:  # bad input: say what was wrong, no traceback
        print(f"heft {args.command}: error: {error}", file=sys.stderr)
        return 2
    except RuntimeError as error:
        from heft.diagrams.running.realtime import HardwareRunFailed
        if not isinstance(error, HardwareRunFailed):
            raise
        print(f"heft {args.command}: stopped: {error}", file=sys.stderr)  # the arm is held, nothing written
        return 3


if __name__ == "__main__":
    sys.exit(main())
