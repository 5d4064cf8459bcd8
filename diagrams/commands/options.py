"""Options several `heft` subcommands share: the LCM URLs, ``--set`` and the scenario it makes,
the hardware station's watchdog timeout."""

from __future__ import annotations

import argparse
import math

from heft.hardware_interface.channels import DEFAULT_LCM_URL, LcmChannels


def add_lcm_urls(parser: argparse.ArgumentParser, when: str = "") -> None:
    """``--lcm-url`` (what the drivers and ``heft load`` send to the controller) and
    ``--command-url`` (what the controller sends back); ``when``: a note such as "with --hardware: "."""
    parser.add_argument("--lcm-url", default=DEFAULT_LCM_URL,
                        help=f"{when}LCM URL of the drivers' messages to the controller (default {DEFAULT_LCM_URL})")
    parser.add_argument("--command-url", default="",
                        help=f"{when}LCM URL of the controller's commands to the drivers (default: --lcm-url's "
                             "group one port up; a memq:// URL itself)")


def lcm_channels(args) -> LcmChannels:
    """The ``LcmChannels`` of ``--lcm-url`` and ``--command-url``."""
    return LcmChannels(lcm_url=args.lcm_url, command_url=args.command_url)


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
