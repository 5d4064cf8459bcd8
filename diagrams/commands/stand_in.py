"""`heft stand-in`: the lab's drivers on LCM, at real time, with fault injection."""

from __future__ import annotations

import json
import math


from heft.diagrams.commands.options import add_lcm_urls, add_out, add_scenario, add_set, out_file, scenario_from
from heft.diagrams.live_view import STAND_IN_PORT
from heft.diagrams.running.realtime import LAB_PRIORITY
from heft.diagrams.commands.console import logger
from heft.diagrams.commands.view_options import VIEW_HOWTO, add_view, view_from

say = logger(__name__)

HELP = ("a lightweight lab behind the drivers' LCM channels, at real time")


def add_arguments(parser) -> None:
    add_scenario(parser, more="the lab's LCM URLs too (lab.lcm)")
    add_set(parser)
    add_lcm_urls(parser)
    parser.add_argument("--duration", type=float, default=10.0, help="seconds (default 10)")
    parser.add_argument("--drop-rate", type=float, default=0.0, help="probability a loss starts at a message")
    parser.add_argument("--burst-loss", type=float, default=0.0, help="length of each loss (s; default 0: one)")
    parser.add_argument("--added-delay", type=float, default=0.0, help="FT samples reach the bus this late (s)")
    parser.add_argument("--nan-rate", type=float, default=0.0, help="probability an FT sample is NaN")
    parser.add_argument("--saturate-at", type=float, default=math.inf,
                          help="FT samples flag every wrench axis saturated from this time (s)")
    parser.add_argument("--die-at", type=float, default=math.inf, help="stop publishing and exit at this time (s)")
    parser.add_argument("--reorder-rate", type=float, default=0.0,
                          help="probability a message is sent after the next one of its channel")
    parser.add_argument("--seed", type=int, default=0, help="fault seed (default 0)")
    parser.add_argument("--clutch-at", type=float, default=0.0, help="clutch button pressed from (s, default 0)")
    parser.add_argument("--clutch-release-at", type=float, default=math.inf, help="clutch button released at (s)")
    parser.add_argument("--grasp-at", type=float, default=None,
                        help="a 'gripper_object' load's gripper closes on the object at this time (s; default the "
                             "scenario's load.grasp_at)")
    parser.add_argument("--release-at", type=float, default=math.inf, help="and opens, letting it go, at this time (s)")
    parser.add_argument("--rt-priority", type=int, default=LAB_PRIORITY,
                        help=f"SCHED_FIFO priority of the lab, off the CPU a controller here claims (default "
                             f"{LAB_PRIORITY}, below the controller's: a lab's drivers run real-time; 0: normal)")
    parser.add_argument("--netft", metavar="HOST", help="the wrist sensor answers as an ATI Net F/T on HOST (RDT over "
                                                        "UDP, port lab.netft.port) instead of on the FT channel, for "
                                                        "`heft driver netft`; its calibration is lab.netft's")
    parser.add_argument("--netft-drop-every", type=int, default=0, metavar="N",
                        help="with --netft: withhold every n-th packet (its rdt_sequence spent; default 0: none)")
    parser.add_argument("--netft-status", type=lambda text: int(text, 0), default=0, metavar="BITS",
                        help="with --netft: status bits (e.g. 0x80000000, the error bit) the records sampled in "
                             "[--netft-status-at, --netft-status-until) carry")
    parser.add_argument("--netft-status-at", type=float, default=math.inf, metavar="T", help="from this time (s)")
    parser.add_argument("--netft-status-until", type=float, default=math.inf, metavar="T",
                        help="until this time (s)")
    add_view(parser, STAND_IN_PORT, "the lab (its joints, the true wrench, the commands it receives)")
    add_out(parser, f"{SUMMARY} (what was published and received) and {TRUTH} (the truth of every FT sample)")


SUMMARY, TRUTH = "stand_in.json", "stand_in.truth.npz"
"""The files ``--out`` names: the run's summary and its truth."""


def run(args) -> int:
    from heft.diagrams.plants import arm_name, slave_arm
    from heft.diagrams.running.realtime import StopOnSignal, claim_lab_realtime
    from heft.diagrams.stations.stand_in import FaultInjection, run_stand_in
    from heft.diagrams.stations.stand_in_wrist import GraspTimes

    scenario = scenario_from(args)
    summary_path, truth_path = out_file(args, SUMMARY), out_file(args, TRUTH)
    grasp = None
    if args.grasp_at is not None or math.isfinite(args.release_at):
        grasp = GraspTimes(scenario.load.grasp_at if args.grasp_at is None else args.grasp_at, args.release_at)
    faults = FaultInjection(drop_rate=args.drop_rate, burst_loss_s=args.burst_loss, added_delay_s=args.added_delay,
                            nan_rate=args.nan_rate, saturate_at_s=args.saturate_at, die_at_s=args.die_at,
                            seed=args.seed, reorder_rate=args.reorder_rate)
    channels = scenario.lab.lcm
    view = view_from(args, slave_arm(scenario), scenario.master)
    netft = None
    if args.netft is not None:
        from heft.diagrams.stations.stand_in_netft import NetFtInjection, NetFtResponder
        netft = NetFtResponder(scenario.lab.netft, args.netft, NetFtInjection(
            args.netft_drop_every, args.netft_status, args.netft_status_at, args.netft_status_until))
        say.info(f"stand-in: the wrist sensor answers as a Net F/T on {args.netft}:{scenario.lab.netft.port} (RDT), "
                 f"not on {channels.ft_sample.name}")
    say.info(f"stand-in: {args.scenario} on {channels.lcm_url} (commands on {channels.command_lcm_url()}) for "
             f"{args.duration:g} s at real time; the arm: {arm_name(slave_arm(scenario))}, "
             f"{len(scenario.slave_initial_q)} joints; the master: {scenario.master}; "
             f"{claim_lab_realtime(args.rt_priority)}")
    if view is not None:
        say.info(f"stand-in: live view on ws://localhost:{args.view_port}; {VIEW_HOWTO}")
    with StopOnSignal() as stop:
        summary = run_stand_in(scenario, channels, args.duration, faults, args.clutch_at, args.clutch_release_at,
                               ready=lambda epoch: say.info(f"stand-in: publishing; its stamps count from "
                                                            f"{epoch:.6f} s (wall clock, since the Unix epoch)"),
                               stop=lambda: stop.requested, grasp=grasp, ft_outlet=netft,
                               truth_path=truth_path, view=view)
    if netft is not None:
        netft.close()
        summary["netft"] = served = netft.summary()
        say.info(f"stand-in: Net F/T on {served['address']}: {served['requests']} requests ({served['refused']} "
                 f"refused); {served['packets']} packets streamed, {served['withheld']} withheld, {served['sent']} "
                 f"sent with {served['records']} records; {served['flagged']} records sampled with status bits")
    rates = "; ".join(f"{kind} Hz " + ", ".join(f"{name} {hz:.0f}" for name, hz in summary[f"{kind}_hz"].items())
                      for kind in ("published", "received"))
    died = " (died, as injected)" if summary["died"] else ""
    refused = "; ".join(f"{name}: " + ", ".join(f"{count} {reason}" for reason, count in reasons.items())
                        for name, reasons in summary["refused"].items() if reasons)
    say.info(f"stand-in: stopped at t = {summary['duration_s']:.3f} s{died}; {rates}; CPU {summary['cpu_s']:.2f} s; "
             f"max lateness {summary['max_lateness_ms']:.2f} ms; largest force rendered on the stylus "
             f"{summary['stylus_force_peak']:.4g} N; arm steps that took two commands after one that took none "
             f"{summary['arm_steps_after_a_held_one']}; commands refused: {refused or 'none'}")
    if summary_path is not None:
        summary["truth"] = TRUTH
        summary_path.write_text(json.dumps(summary, indent=2) + "\n")
    return 0
