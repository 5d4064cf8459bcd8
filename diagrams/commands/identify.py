"""`heft identify`: the load's inertial parameters and the sensor offsets from an excitation,
in simulation or on the hardware, or from a lab's recording."""

from __future__ import annotations

import contextlib
import functools

from heft.diagrams.commands.options import (add_lcm_urls, add_out, add_scenario, add_set, add_station,
                                           require_lab_settings, scenario_from)
from heft.diagrams.running.realtime import LOOP_PRIORITY
from heft.diagrams.commands.console import logger
from heft.diagrams.commands.view_options import VIEW_HOWTO, add_view, view_from

say = logger(__name__)

HELP = ("identify the load's inertial parameters and the sensor "
       "offsets from an excitation motion (Sec. IV)")


def add_arguments(parser) -> None:
    add_scenario(parser, default=None, more="required unless --recording; with it, the lab's sensors' noise and "
                                             "range (default heft's JR3 model)")
    parser.add_argument("--recording", help="identify from a recording (YAML, docs/recordings.md): its static "
                                            "poses and/or its streams, instead of an excitation heft drives")
    add_set(parser)
    add_station(parser)
    add_out(parser, "estimate.yaml (unless the fit is refused), metrics.json, convergence.png "
                    "(static_poses.png from a recording)", default="out/identify")
    parser.add_argument("--method", default="tls", choices=("ols", "wls", "tls", "eiv_ml", "rls", "riv", "rtls"),
                          help="the estimate written to estimate.yaml (all are reported; default tls)")
    parser.add_argument("--signals", default="accelerometer", choices=("accelerometer", "encoders"),
                          help="where a and α come from (ω and g always from the encoders)")
    parser.add_argument("--periods", type=int, default=1, help="excitation periods recorded (default 1)")
    parser.add_argument("--quick", action="store_true", help="a short, quickly optimised excitation")
    parser.add_argument("--accept-fit", action="store_true",
                        help="write estimate.yaml even if the fit's verdict finds it untrustworthy (the residual "
                             "above the sensor's noise, saturated readings, the arm not following, a load beyond "
                             "the arm's payload); without it such an estimate is refused with the verdict's reasons")
    parser.add_argument("--hardware", action="store_true",
                          help="excite the real arm over LCM (the scenario gives the robot, start pose and load "
                               "model's settings); the arm first moves slowly to the excitation's start")
    add_lcm_urls(parser, "with --hardware: ")
    parser.add_argument("--record", help="with --hardware: record the LCM traffic to this file (lcm-logger format)")
    parser.add_argument("--watchdog-timeout", type=float,
                          help="with --hardware: stale-channel timeout (s; default: the scenario's "
                               "lab.station.watchdog.timeout, 0.02)")
    parser.add_argument("--rt-priority", type=int, default=LOOP_PRIORITY,
                          help="with --hardware: SCHED_FIFO priority of the loop, pinned to the last CPU, with the "
                               f"CPUs kept awake while it runs (default {LOOP_PRIORITY}; 0: normal scheduling, "
                               "neither)")
    add_view(parser, what="with --hardware: the excitation (the measured wrench, its progress, the estimate)")


def run(args) -> int:
    if args.recording:
        return _from_recording(args)
    if not args.scenario:
        raise ValueError("identify needs --scenario (the excitation heft drives) or --recording (a lab's recording)")
    from heft.diagrams.identify import identify
    from heft.diagrams.plants import slave_arm
    from heft.systems.identification.excitation import ExcitationSettings

    if args.hardware and args.station:
        raise ValueError("--station chooses the simulated station; on hardware describe the lab's sensor instead, "
                         "e.g. --set '{accelerometer: {position: [0, 0, 0]}}' where its accelerometer sits (m, in S)")
    scenario = scenario_from(args)  # first: it names a malformed file or --set
    if args.hardware:
        require_lab_settings(args, "accelerometer.position")
    settings = ExcitationSettings.quick() if args.quick else ExcitationSettings()
    view = shown = None
    if args.hardware:
        from heft.diagrams.running.hardware_identify import hardware_recorder, show_estimate
        say.info(f"identify: {scenario.accelerometer.convention()}")
        view = view_from(args, slave_arm(scenario), scenario.master)
        if view is not None:
            say.info(f"identify: live view on ws://localhost:{args.view_port}; {VIEW_HOWTO}")
            shown = functools.partial(show_estimate, view)
        recorder = hardware_recorder(scenario, scenario.lab.lcm, args.record, scenario.lab.station, args.rt_priority,
                                     view)
        wrote = f"estimate.yaml, metrics.json{f', {args.record}' if args.record else ''}"
    else:
        from heft.diagrams.running.sim_identification import simulated_recorder
        if args.record:
            raise ValueError("--record records LCM traffic: it needs --hardware")
        if args.view:
            raise ValueError("--view shows the excitation on the lab: it needs --hardware")
        recorder, wrote = simulated_recorder(scenario), "estimate.yaml, metrics.json, convergence.png"
    with contextlib.nullcontext() if view is None else view:
        identify(scenario, args.out, recorder, method=args.method, signals=args.signals, settings=settings,
                 periods=args.periods, accept_fit=args.accept_fit, estimated=shown)
    say.info(f"wrote {args.out}/{wrote}")
    return 0


def _from_recording(args) -> int:
    from heft.diagrams.identify_recording import identify_recording
    from heft.diagrams.scenario import Scenario, layered

    for option in ("hardware", "station", "record", "quick", "view"):
        if getattr(args, option):
            raise ValueError(f"--{option} belongs to an excitation heft drives; a --recording is already recorded")
    if args.periods != 1:
        raise ValueError("--periods belongs to an excitation heft drives; a --recording is already recorded")
    scenario = scenario_from(args) if args.scenario else (layered(Scenario(), args.set) if args.set else Scenario())
    identify_recording(args.recording, args.out, scenario, method=args.method, accept_fit=args.accept_fit)
    say.info(f"wrote {args.out}/estimate.yaml, metrics.json and the figures")
    return 0
