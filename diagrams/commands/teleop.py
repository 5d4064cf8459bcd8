"""`heft teleop --hardware`: the controller on the lab's LCM channels, at real time."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from heft.diagrams.commands.options import (add_lcm_urls, add_set, lcm_channels, require_lab_settings, scenario_from,
                                            station_params)

HELP = ("the teleoperation controller on the lab's LCM channels")


def add_arguments(parser) -> None:
    parser.add_argument("--hardware", action="store_true", help="run against the lab's LCM channels (required)")
    parser.add_argument("--scenario", default="fig6", help="controller settings from this scenario (default fig6)")
    add_set(parser)
    add_lcm_urls(parser)
    parser.add_argument("--estimate", help="estimate.yaml from `heft identify` (default: φ̂ = 0)")
    parser.add_argument("--duration", type=float, default=10.0, help="seconds (default 10)")
    parser.add_argument("--out", help="also write the summary as JSON here")
    parser.add_argument("--watchdog-timeout", type=float, help="stale-channel timeout (s, default 0.02)")
    parser.add_argument("--rate", type=float, help="controller rate (Hz; default: the scenario's, 2000)")
    parser.add_argument("--record", help="record the LCM traffic to this file (lcm-logger format, for lcm-logplayer)")
    parser.add_argument("--rt-priority", type=int, default=50,
                        help="SCHED_FIFO priority of the control loop, pinned to the last CPU (default 50; 0: normal)")


def run(args) -> int:
    from heft.diagrams.running.hardware_teleop import format_summary, run_hardware_teleop
    from heft.diagrams.load_estimate import LoadEstimate, read_load_estimate

    if not args.hardware:
        raise ValueError("only --hardware is supported here; use `heft simulate` for the simulated station")
    scenario = scenario_from(args)  # first: it names a malformed file or --set
    require_lab_settings(args, "accelerometer.position", "controller.force.mount_notch")
    rate = 1.0 / scenario.controller_period if args.rate is None else args.rate
    if not (math.isfinite(rate) and rate > 0):
        raise ValueError(f"--rate must be a positive number of Hz; got {rate}")
    estimate = args.estimate or scenario.controller.load_estimate
    if estimate:
        load = read_load_estimate(estimate, scenario.ft_sensor.full_scale)
    else:
        print("teleop: no load estimate given: φ̂ = 0, offsets 0 (nothing is eliminated)", flush=True)
        load = LoadEstimate(phi=np.zeros(10), offsets=np.zeros(6))
    channels = lcm_channels(args)
    print(f"teleop: controller on {channels.lcm_url} (commands on {channels.command_lcm_url()}) at {rate:g} Hz for "
          f"{args.duration:g} s of wall time", flush=True)
    summary = run_hardware_teleop(scenario, load, channels, args.duration, rate, record=args.record,
                                  params=station_params(args.watchdog_timeout), priority=args.rt_priority)
    print(format_summary(summary, channels.lcm_url), flush=True)
    if args.out:
        Path(args.out).write_text(json.dumps(summary, indent=2) + "\n")
    return 0
