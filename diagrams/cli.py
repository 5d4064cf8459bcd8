"""The `heft` command line: parses and dispatches to one module per subcommand
(``heft.diagrams.commands``, each with ``HELP``, ``add_arguments`` and ``run``)."""

from __future__ import annotations

import argparse
import sys
from importlib import import_module
from importlib.metadata import version

from heft.diagrams.commands import console, exit_status

COMMANDS = (
    ("check", "check"),
    ("demo", "demo"),
    ("init", "init"),
    ("simulate", "simulate"),
    ("identify", "identify"),
    ("compensate", "compensate"),
    ("bench", "bench"),
    ("stand-in", "stand_in"),
    ("driver", "driver"),
    ("teleop", "teleop"),
    ("load", "load"),
    ("picture", "picture"),
    ("export", "export"),
)
"""``heft`` subcommands: name, module under ``heft.diagrams.commands`` (``heft analyze`` has its own)."""


def add_verbosity(parser: argparse.ArgumentParser) -> None:
    """``-v`` and ``-q``, which every parser lists; ``verbosity`` reads them wherever they stand."""
    group = parser.add_argument_group("output")
    group.add_argument("-v", "--verbose", action="count", default=argparse.SUPPRESS,
                       help="say more (debug lines); -q says less")
    group.add_argument("-q", "--quiet", action="count", default=argparse.SUPPRESS,
                       help="only warnings and errors, no progress")


def verbosity(argv: list[str]) -> tuple[int, list[str]]:
    """(-v count − -q count, the other arguments): the global options taken out wherever they stand."""
    parser = argparse.ArgumentParser(add_help=False, allow_abbrev=False)
    parser.add_argument("-v", "--verbose", action="count", default=0)
    parser.add_argument("-q", "--quiet", action="count", default=0)
    known, rest = parser.parse_known_args(argv)
    return known.verbose - known.quiet, rest


def _shared(parser: argparse.ArgumentParser) -> None:
    """A command's parser and those of its own subcommands (``heft bench lcm``): ``-v``/``-q`` and the
    exit statuses in their help."""
    parser.epilog, parser.formatter_class = exit_status.epilog(), argparse.RawDescriptionHelpFormatter
    add_verbosity(parser)
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                _shared(sub)


def _parser(prog: str, description: str, **kwargs) -> argparse.ArgumentParser:
    return argparse.ArgumentParser(prog=prog, description=description, epilog=exit_status.epilog(),
                                   formatter_class=argparse.RawDescriptionHelpFormatter, **kwargs)


def build_parser() -> argparse.ArgumentParser:
    parser = _parser("heft", "Bilateral teleoperation that feeds back what the slave touches, "
                             "not what it carries (Kubus & Wahl, IROS 2009), on Drake.")
    parser.add_argument("--version", action="version", version=f"heft {version('heft-teleop')}")
    add_verbosity(parser)
    commands = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name, module_name in COMMANDS:
        module = import_module(f"heft.diagrams.commands.{module_name}")
        command = commands.add_parser(name, help=module.HELP, description=module.HELP)
        module.add_arguments(command)
        _shared(command)
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
    parser = _parser("heft analyze", "analyses writing PNG/HTML and JSON, each with a one-line summary")
    add_verbosity(parser)
    kinds = parser.add_subparsers(dest="analysis", required=True, metavar="ANALYSIS")
    for name, module_name, help_text in ANALYSES:
        module = import_module(module_name)
        kind = kinds.add_parser(name, help=help_text, description=help_text)
        module.add_arguments(kind)
        _shared(kind)
        kind.set_defaults(run=module.run)
    return parser


def main(argv=None) -> int:
    """Runs one command; returns its exit status (``exit_status``)."""
    level, argv = verbosity(sys.argv[1:] if argv is None else list(argv))
    console.configure(level)
    if argv[:1] == ["analyze"]:
        args = build_analyze_parser().parse_args(argv[1:])
        args.command = f"analyze {args.analysis}"
    else:
        args = build_parser().parse_args(argv)
    log = console.logger("heft.cli")
    try:
        return args.run(args)
    except ValueError as error:  # bad input or a refused fit: say what was wrong, no traceback
        refused = _raised(error, "heft.diagrams.identify", "FitRefused")
        log.error(f"heft {args.command}: {'fit refused' if refused else 'error'}: {error}")
        return exit_status.FIT_REFUSED if refused else exit_status.USAGE
    except TimeoutError as error:
        log.error(f"heft {args.command}: timeout: {error}")
        return exit_status.TIMEOUT
    except RuntimeError as error:
        if not _raised(error, "heft.diagrams.running.realtime", "HardwareRunFailed"):
            raise
        log.error(f"heft {args.command}: stopped: {error}")  # the arm is held, nothing written
        return exit_status.HARDWARE_FAULT


def _raised(error: Exception, module: str, name: str) -> bool:
    """Whether ``error`` is ``module.name``'s, without importing it: had it been raised, it is loaded."""
    loaded = sys.modules.get(module)
    return loaded is not None and isinstance(error, getattr(loaded, name))


if __name__ == "__main__":
    sys.exit(main())
