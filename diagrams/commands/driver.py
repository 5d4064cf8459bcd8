"""`heft driver`: a lab's device behind heft's LCM channels. `heft driver netft`: an ATI Net F/T's RDT
stream (UDP) as the FT channel (docs/netft.md)."""

from __future__ import annotations

import json
import math

from heft.diagrams.commands.console import logger
from heft.diagrams.commands.options import add_lcm_urls, add_out, add_scenario, add_set, out_file, scenario_from
from heft.diagrams.running.realtime import LAB_PRIORITY

say = logger(__name__)

HELP = "a lab's device on heft's channels: netft (an ATI Net F/T over RDT as the FT channel)"


def add_arguments(parser) -> None:
    kinds = parser.add_subparsers(dest="device", metavar="DEVICE", required=True)
    netft = kinds.add_parser("netft", help="an ATI Net F/T's RDT stream (UDP) published as the FT channel",
                             description="Asks the Net F/T at --address to stream (RDT, UDP port lab.netft.port) "
                                         "and publishes its records on the FT channel (lab.lcm.ft_sample) in N and "
                                         "N*m through the calibration lab.netft.counts_per_force / counts_per_torque, "
                                         "which the scenario file, --set or the flags must state (docs/netft.md).")
    netft.add_argument("--address", required=True, help="the Net F/T's IP address or host name")
    netft.add_argument("--counts-per-force", type=float, metavar="CPF",
                       help="the calibration's counts per N (default: the scenario's lab.netft.counts_per_force)")
    netft.add_argument("--counts-per-torque", type=float, metavar="CPT",
                       help="the calibration's counts per N*m (default: the scenario's lab.netft.counts_per_torque)")
    add_scenario(netft, more="the lab's Net F/T and channels (lab.netft, lab.lcm)")
    add_set(netft)
    add_lcm_urls(netft)
    netft.add_argument("--duration", type=float, default=math.inf, help="seconds (default: until Ctrl-C or SIGTERM)")
    netft.add_argument("--rt-priority", type=int, default=LAB_PRIORITY,
                       help=f"SCHED_FIFO priority, off the CPU a controller here claims (default {LAB_PRIORITY}, as "
                            "the stand-in's drivers; 0: normal)")
    add_out(netft, f"{SUMMARY} (what was streamed, published, lost and refused)")


SUMMARY = "netft.json"
"""The file ``--out`` names: the driver's summary."""


def run(args) -> int:
    from heft.diagrams.running.netft_driver import run_netft_driver
    from heft.diagrams.running.realtime import StopOnSignal, claim_lab_realtime

    from heft.diagrams.scenario import overrides_text

    scenario = scenario_from(args, overrides_text({"lab.netft.counts_per_force": args.counts_per_force,
                                                   "lab.netft.counts_per_torque": args.counts_per_torque}))
    summary_path = out_file(args, SUMMARY)
    params, channels = scenario.lab.netft, scenario.lab.lcm
    params.validate()
    say.info(f"netft: asking {args.address}:{params.port} to stream ({'buffered' if params.buffered else 'real-time'}) "
             f"into {channels.ft_sample.name} on {channels.lcm_url}; {params.counts_per_force:g} counts per N, "
             f"{params.counts_per_torque:g} per N*m; no accelerometer (acceleration 0: state accelerometer."
             f"includes_gravity: false for the controller); {claim_lab_realtime(args.rt_priority)}")
    with StopOnSignal() as stop:
        summary = run_netft_driver(args.address, params, channels, args.duration, stop=lambda: stop.requested,
                                   ready=lambda: say.info("netft: publishing"))
    bits = ", ".join(f"{bit} in {n}" for bit, n in summary["status_bits"].items()) or "none"
    say.info(f"netft: stopped after {summary['duration_s']:.3f} s; {summary['packets']} packets, {summary['records']} "
             f"new records ({summary['samples_hz']:.0f} Hz) in {summary['published']} messages "
             f"({summary['published_hz']:.0f} Hz); lost {summary['lost']} (rdt_sequence gaps), stale "
             f"{summary['stale']}, stream restarts {summary['restarts']}; status bits: {bits}; flagged error "
             f"{summary['errors']}; datagrams refused: {summary['rejected']['length']} (length); start requests "
             f"{summary['start_requests']}; CPU {summary['cpu_s']:.2f} s")
    if summary_path is not None:
        summary_path.write_text(json.dumps(summary, indent=2) + "\n")
    return 0
