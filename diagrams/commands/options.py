"""Options several `heft` subcommands share: ``--set`` and the scenario it makes, and the lab's
settings as flags (the LCM URLs, the watchdog timeout, the rate), each laid over the scenario's
``lab`` (or ``controller_period``) through ``layered``, the one override path, before ``--set``."""

from __future__ import annotations

import argparse
import functools
import importlib.util
import math
from pathlib import Path

from heft.analysis.yaml_tree import yaml_tree
from heft.diagrams.commands.console import logger
from heft.hardware_interface.channels import DEFAULT_LCM_URL

say = logger(__name__)


def add_lcm_urls(parser: argparse.ArgumentParser, when: str = "") -> None:
    """``--lcm-url`` (what the drivers and ``heft load`` send to the controller) and
    ``--command-url`` (what the controller sends back), over the scenario's ``lab.lcm``; ``when``: a
    note such as "with --hardware: "."""
    parser.add_argument("--lcm-url", help=f"{when}LCM URL of the drivers' messages to the controller (default: the "
                                          f"scenario's lab.lcm.lcm_url, by default {DEFAULT_LCM_URL})")
    parser.add_argument("--command-url", help=f"{when}LCM URL of the controller's commands to the drivers (default: "
                                              "the scenario's lab.lcm.command_url, by default --lcm-url's group one "
                                              "port up; a memq:// URL itself)")


def lab_options(args) -> dict:
    """The dotted scenario fields the lab's flags set (``overrides_text``): ``--lcm-url``,
    ``--command-url``, ``--watchdog-timeout`` and ``--rate`` (Hz, as ``controller_period``), those
    the command has and the user gave."""
    rate = getattr(args, "rate", None)
    if rate is not None and not (math.isfinite(rate) and rate > 0):
        raise ValueError(f"--rate must be a positive number of Hz; got {rate}")
    return {"lab.lcm.lcm_url": getattr(args, "lcm_url", None),
            "lab.lcm.command_url": getattr(args, "command_url", None),
            "lab.station.watchdog.timeout": getattr(args, "watchdog_timeout", None),
            "controller_period": None if rate is None else 1.0 / rate}


def parse_numbers(text: str, option: str) -> list[float]:
    """Comma-separated numbers ≥ 0 of ``option``; a ValueError names the bad one."""
    values = []
    for item in (part.strip() for part in text.split(",")):
        try:
            value = float(item)
        except ValueError:
            raise ValueError(f"{option} takes comma-separated numbers, e.g. 0,0.5,1; got {item!r}") from None
        if not value >= 0:
            raise ValueError(f"{option} values must be >= 0; got {item}")
        values.append(value)
    return values


SCENARIO_HELP = ("the scenario: fig6 | fig7 | fig8 | grasp | stability_wall (bundled) or a scenario YAML, such as "
                 "the lab.yaml `heft init lab` writes")
"""What ``--scenario`` means, in every command that has it."""
OUT_HELP = "output folder"
"""What ``--out`` is, in every command that has it: a folder, the files in it named by the command."""


def add_scenario(parser: argparse.ArgumentParser, default: str | None = "fig6", more: str = "") -> None:
    """``--scenario NAME|FILE`` (``SCENARIO_HELP``), ``default`` None: no default; ``more``: what else it gives."""
    shown = f" (default {default})" if default else ""
    parser.add_argument("--scenario", default=default, metavar="NAME|FILE",
                        help=f"{SCENARIO_HELP}{shown}{'; ' + more if more else ''}")


def add_out(parser: argparse.ArgumentParser, writes: str, default: str | None = None, shown: str | None = None) -> None:
    """``--out DIR`` (``OUT_HELP``), the folder the command writes ``writes`` into (created if need be);
    ``shown``: the default as the help names it (default ``default``)."""
    shown = shown or default
    parser.add_argument("--out", default=default, metavar="DIR",
                        help=f"{OUT_HELP}{f' (default {shown})' if shown else ''}: {writes}")


def out_file(args, name: str) -> Path | None:
    """The file ``name`` in the ``--out`` folder (created), or None without ``--out``."""
    if args.out is None:
        return None
    folder = Path(args.out)
    if folder.exists() and not folder.is_dir():
        raise ValueError(f"--out {folder}: is a file; --out names a folder, the files in it are named by the command")
    folder.mkdir(parents=True, exist_ok=True)
    return folder / name


def add_noise(parser: argparse.ArgumentParser, default: str | None = None, what: str = "") -> None:
    """``--noise on|off``: the sensor models' noise, offsets, drift and quantisation."""
    shown = f" (default {default})" if default else " (default: the scenario's)"
    parser.add_argument("--noise", choices=("on", "off"), default=default,
                        help=f"the sensor models' noise, offsets, drift and quantisation{what}{shown}")


def dask_address(address: str) -> str:
    """``--dask``'s value, once Dask's distributed scheduler client is installed (the ``cluster`` extra)."""
    if importlib.util.find_spec("distributed") is None:
        raise argparse.ArgumentTypeError("needs Dask: pip install 'heft-teleop[cluster]' (or, in a clone, "
                                         "pip install '.[cluster]')")
    return address


def add_dask(parser: argparse.ArgumentParser) -> None:
    """``--dask ADDRESS``: the work on a Dask cluster (the ``cluster`` extra)."""
    parser.add_argument("--dask", metavar="ADDRESS", type=dask_address,
                        help="run on this Dask scheduler (tcp://host:port; needs the cluster extra)")


def add_set(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--set", metavar="YAML", help="scenario fields laid over it, nested as in a scenario file, "
                                                      "e.g. '{controller: {force: {gamma: 0.5}}}' (applied last)")


def add_station(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--station", choices=("realistic", "ideal"),
                        help="the simulated station: realistic (default: a compliant tool mount, the sensor's "
                             "low-pass filter, the accelerometer off S, velocities from the encoders) or ideal "
                             "(the paper's rigid, co-located, lag-free model)")


def scenario_from(args, options: str = ""):
    """The scenario of ``--scenario`` with ``--station ideal`` (``IDEAL_STATION``), the command's own
    ``options`` (YAML text), the lab's flags it has (``lab_options``) and then ``--set`` laid over it
    (``scenario.layered``: the one override path)."""
    from heft.diagrams.scenario import IDEAL_STATION, layered, overrides_text, resolve_scenario

    ideal = getattr(args, "station", None) == "ideal"
    scenario = resolve_scenario(args.scenario, overrides_text(IDEAL_STATION) if ideal else "")
    say.debug(f"scenario {args.scenario}{' in the ideal station' if ideal else ''}")
    for text in (options, overrides_text(lab_options(args)), getattr(args, "set", None)):
        if text:
            scenario = layered(scenario, text)
            say.debug(f"laid over it: {text.strip()}")
    return scenario


LAB_SETTINGS = {
    "accelerometer.position": ("where the sensor's accelerometer sits in S (m), from its manual; [0, 0, 0] if its "
                               "driver reports the reading at S", [0.0, 0.0, 0.0]),
    "controller.force.mount_notch": ("the tool's rocking mode on its mount (Hz): the frequency it rings at in the "
                                     "wrench when tapped; 0 for a rigid mount", 0.0),
}
"""Fields whose defaults describe the simulated lab: how a real lab finds its value, and an example."""


def stated_fields(text: str) -> set[str]:
    """The dotted names of the leaves a scenario YAML ``text`` sets."""
    def leaves(node, prefix):
        if not isinstance(node, dict):
            return {prefix}
        return set().union(*(leaves(value, f"{prefix}.{key}" if prefix else str(key)) for key, value in node.items()))
    tree = yaml_tree(text)
    return leaves(tree, "") if isinstance(tree, dict) and tree else set()


def require_lab_settings(args, *fields: str) -> None:
    """On hardware the ``LAB_SETTINGS`` ``fields`` must be stated, in the ``--scenario`` file or
    ``--set``: their defaults are the simulated lab's. Raises ValueError naming what is missing,
    how to find it, and how to give it."""
    from heft.diagrams.scenario import overrides_text, scenario_path

    stated = stated_fields(scenario_path(args.scenario).read_text()) | stated_fields(args.set or "")
    missing = [name for name in fields if name not in stated]
    if missing:
        example = overrides_text({name: LAB_SETTINGS[name][1] for name in missing})
        raise ValueError("on hardware, state " + "; and ".join(f"{name}: {LAB_SETTINGS[name][0]}" for name in missing)
                         + f". Put them in the scenario file or give them with --set, e.g. --set '{example}' "
                         "(otherwise the simulated lab's values would be used)")


def lab_settings_text(scenario, more: dict | None = None) -> str:
    """``--set`` YAML stating ``scenario``'s own values of the ``LAB_SETTINGS``: for a stand-in lab,
    whose sensor is the scenario's; ``more``: further dotted fields (``overrides_text``'s) in the same text."""
    from heft.diagrams.scenario import overrides_text

    return overrides_text({**{name: functools.reduce(getattr, name.split("."), scenario) for name in LAB_SETTINGS},
                           **(more or {})})
