"""Options several `heft` subcommands share: the LCM URL, ``--set`` and the scenario it makes,
the hardware station's watchdog timeout."""

from __future__ import annotations

import argparse
import math

from heft.hardware_interface.channels import LcmChannels

DEFAULT_LCM_URL = LcmChannels.lcm_url
"""Multicast that cannot leave the machine (ttl=0); the lab's drivers use the same."""


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
    ``options`` (YAML text) and then ``--set`` laid over it (``scenario.layered``: the one override path)."""
    from heft.diagrams.scenario import IDEAL_STATION, layered, overrides_text, resolve_scenario

    ideal = getattr(args, "station", None) == "ideal"
    scenario = resolve_scenario(args.scenario, overrides_text(IDEAL_STATION) if ideal else "")
    if options:
        scenario = layered(scenario, options)
    return layered(scenario, args.set) if args.set else scenario


def station_params(timeout):
    """HardwareStationParams with the watchdog ``timeout`` (s) if given."""
    from heft.hardware_interface.hardware_station import HardwareStationParams
    from heft.hardware_interface.watchdog import WatchdogParams

    if timeout is None:
        return HardwareStationParams()
    if not (math.isfinite(timeout) and timeout > 0):
        raise ValueError(f"--watchdog-timeout must be a positive number of seconds; got {timeout}")
    return HardwareStationParams(watchdog=WatchdogParams(timeout=timeout))
