"""`heft teleop --hardware`: the controller on the lab's LCM channels, at real time.

The lab is the scenario's: its ``lab`` (LCM URLs and channels, the watchdog) and
``controller_period`` (the rate); ``--lcm-url``, ``--command-url``, ``--watchdog-timeout`` and
``--rate`` are laid over them, and ``--set`` over all, through ``layered``."""

from __future__ import annotations

import json

import numpy as np

from heft.diagrams.commands.options import (add_lcm_urls, add_out, add_scenario, add_set, out_file,
                                           require_lab_settings, scenario_from)
from heft.diagrams.running.realtime import LOOP_PRIORITY
from heft.diagrams.commands.console import logger
from heft.diagrams.commands.view_options import VIEW_HOWTO, add_view, view_from

say = logger(__name__)

HELP = ("the teleoperation controller on the lab's LCM channels")


def add_arguments(parser) -> None:
    parser.add_argument("--hardware", action="store_true",
                        help="against the lab's LCM channels: the only mode, so optional (`heft simulate` runs the "
                             "simulated station)")
    add_scenario(parser, more="the lab's: the controller's settings, rate, LCM URLs and watchdog")
    add_set(parser)
    add_lcm_urls(parser)
    parser.add_argument("--estimate", help="estimate.yaml from `heft identify` (default: φ̂ = 0)")
    parser.add_argument("--duration", type=float, default=10.0, help="seconds (default 10)")
    add_out(parser, f"{SUMMARY} (the run's summary)")
    parser.add_argument("--watchdog-timeout", type=float,
                        help="stale-channel timeout (s; default: the scenario's lab.station.watchdog.timeout, 0.02)")
    parser.add_argument("--rate", type=float, help="controller rate (Hz; default: the scenario's, 1/controller_period, "
                                                   "2000)")
    parser.add_argument("--record", help="record the LCM traffic to this file (lcm-logger format, for lcm-logplayer)")
    parser.add_argument("--record-mcap", metavar="FILE",
                        help="write every tick's row to this MCAP file, on the live view's topics (needs the view "
                             "extra; docs/live_view.md)")
    add_view(parser)
    parser.add_argument("--rt-priority", type=int, default=LOOP_PRIORITY,
                        help=f"SCHED_FIFO priority of the control loop, pinned to the last CPU, with the CPUs kept "
                             f"awake while it runs (default {LOOP_PRIORITY}; 0: normal scheduling, neither)")
    parser.add_argument("--busy-wait", type=float, default=0.0,
                        help="share of each period before a tick that the control loop waits busy instead of "
                             "asleep (0 to 0.8, default 0): a shorter tick tail where a sleeping CPU wakes late, "
                             "at the cost of that CPU time, which drivers on the same machine then lack")


SUMMARY = "teleop.json"
"""The file ``--out`` names."""


def run(args) -> int:
    from heft.diagrams.running.hardware_teleop import format_summary, run_hardware_teleop
    from heft.diagrams.running.realtime import check_busy_wait
    from heft.diagrams.load_estimate import LoadEstimate, read_load_estimate
    from heft.diagrams.plants import slave_arm
    from heft.diagrams.scenario import overrides_text
    from heft.systems.accelerometer_reading import PLAUSIBLE_BIAS

    check_busy_wait(args.busy_wait)
    scenario = scenario_from(args)  # first: it names a malformed file, flag or --set
    summary_path = out_file(args, SUMMARY)
    require_lab_settings(args, "accelerometer.position", "controller.force.mount_notch")
    estimate = args.estimate or scenario.controller.load_estimate
    if estimate:
        load = read_load_estimate(estimate, scenario.ft_sensor.full_scale)
        if load.accelerometer is not None:  # its calibration, under the flags and --set
            bias = np.abs(load.accelerometer.bias).max() * load.accelerometer.meters_per_second_squared
            if bias > PLAUSIBLE_BIAS:
                raise ValueError(f"{estimate}: its accelerometer bias of {bias / 9.80665:.3g} g is beyond any bias "
                                 f"({PLAUSIBLE_BIAS / 9.80665:g} g): the calibration's unit or R_SA is wrong; "
                                 "calibrate the accelerometer again from static poses")
            calibration = load.accelerometer.as_dict()
            scenario = scenario_from(args, overrides_text({f"accelerometer.{key}": value
                                                           for key, value in calibration.items()}))
            say.info(f"teleop: the accelerometer as {estimate} calibrated it (flags and --set still lay over it)")
    else:
        say.info("teleop: no load estimate given: φ̂ = 0, offsets 0 (nothing is eliminated)")
        load = LoadEstimate(phi=np.zeros(10), offsets=np.zeros(6))
    channels = scenario.lab.lcm
    say.info(f"teleop: controller on {channels.lcm_url} (commands on {channels.command_lcm_url()}) at "
             f"{1.0 / scenario.controller_period:g} Hz for {args.duration:g} s of wall time; watchdog timeout "
             f"{scenario.lab.station.watchdog.timeout:g} s")
    view = view_from(args, slave_arm(scenario), scenario.master)
    if args.record_mcap:
        from heft.analysis.run_export import foxglove_sdk

        foxglove_sdk()  # the recorder writes through it: the one-line install hint before the run
    if view is not None:
        say.info(f"teleop: live view on ws://localhost:{args.view_port}; {VIEW_HOWTO}")
    summary = run_hardware_teleop(scenario, load, args.duration, record=args.record, priority=args.rt_priority,
                                  busy_wait=args.busy_wait, view=view, record_mcap=args.record_mcap)
    say.info(format_summary(summary, channels.lcm_url))
    if summary_path is not None:
        summary_path.write_text(json.dumps(summary, indent=2) + "\n")
    return 0
