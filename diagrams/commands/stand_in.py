"""`heft stand-in`: the lab's drivers on LCM, at real time, with fault injection."""

from __future__ import annotations

import json
import math
from pathlib import Path


from heft.diagrams.commands.options import add_lcm_urls, add_set, scenario_from
from heft.diagrams.running.realtime import LAB_PRIORITY

HELP = ("a lightweight lab behind the drivers' LCM channels, at real time")


def add_arguments(parser) -> None:
    parser.add_argument("--scenario", default="fig6", help="fig6 | fig7 | fig8 | path to a scenario YAML (the lab's "
                                                           "LCM URLs too: lab.lcm)")
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
    parser.add_argument("--out", help="also write the summary as JSON here, and the truth of every FT sample beside "
                                      "it (its name with .truth.npz)")


def truth_path(out: str) -> Path:
    """Where the truth of a run whose summary goes to ``out`` is written: beside it, ``NAME.truth.npz``."""
    return Path(out).with_suffix(".truth.npz")


def run(args) -> int:
    from heft.diagrams.running.realtime import StopOnSignal, claim_lab_realtime
    from heft.diagrams.stations.stand_in import FaultInjection, run_stand_in
    from heft.diagrams.stations.stand_in_wrist import GraspTimes

    scenario = scenario_from(args)
    grasp = None
    if args.grasp_at is not None or math.isfinite(args.release_at):
        grasp = GraspTimes(scenario.load.grasp_at if args.grasp_at is None else args.grasp_at, args.release_at)
    faults = FaultInjection(drop_rate=args.drop_rate, burst_loss_s=args.burst_loss, added_delay_s=args.added_delay,
                            nan_rate=args.nan_rate, saturate_at_s=args.saturate_at, die_at_s=args.die_at,
                            seed=args.seed, reorder_rate=args.reorder_rate)
    channels = scenario.lab.lcm
    print(f"stand-in: {args.scenario} on {channels.lcm_url} (commands on {channels.command_lcm_url()}) for "
          f"{args.duration:g} s at real time; {claim_lab_realtime(args.rt_priority)}", flush=True)
    with StopOnSignal() as stop:
        summary = run_stand_in(scenario, channels, args.duration, faults, args.clutch_at, args.clutch_release_at,
                               ready=lambda epoch: print(f"stand-in: publishing; its stamps count from {epoch:.6f} s "
                                                         "(wall clock, since the Unix epoch)", flush=True),
                               stop=lambda: stop.requested, grasp=grasp,
                               truth_path=truth_path(args.out) if args.out else None)
    rates = "; ".join(f"{kind} Hz " + ", ".join(f"{name} {hz:.0f}" for name, hz in summary[f"{kind}_hz"].items())
                      for kind in ("published", "received"))
    print(f"stand-in: stopped at t = {summary['duration_s']:.3f} s{' (died, as injected)' if summary['died'] else ''}"
          f"; {rates}; CPU {summary['cpu_s']:.2f} s; max lateness {summary['max_lateness_ms']:.2f} ms; largest force "
          f"rendered on the stylus {summary['stylus_force_peak']:.4g} N; arm steps that took two commands after one "
          f"that took none {summary['arm_steps_after_a_held_one']}", flush=True)
    if args.out:
        summary["truth"] = truth_path(args.out).name
        Path(args.out).write_text(json.dumps(summary, indent=2) + "\n")
    return 0
