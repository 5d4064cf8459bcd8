"""`heft bench`: benchmarks, each printed beside a reference measured in the same run.

``regressor``: V·φ per sample and per batch against Drake; ``identify``: Monte Carlo accuracy
of every estimator against the Cramér–Rao bound, and update costs; ``lcm``: the controller
against a driver probe and the stand-in over LCM in two processes; ``step``: one controller tick,
the controller Diagram as its program and as Drake steps it; ``compensate``: rate and peak
memory of `heft compensate` on long recordings."""

from __future__ import annotations

import dataclasses
import json

import numpy as np

from heft.diagrams.commands.options import add_dask, add_lcm_urls, add_out, add_scenario, out_file, scenario_from
from heft.diagrams.commands.console import logger

say = logger(__name__)

HELP = "benchmarks, each printed beside a reference measured in the same run"


def _bench_regressor(args) -> int:
    from heft.analysis.bench_regressor import run
    from heft.diagrams.stations.load_on_sensor import LoadOnSensorPlant
    from heft.systems.load_dynamics import InertialParameters

    rng = np.random.default_rng(args.seed)
    load = InertialParameters.random(rng)
    reference = LoadOnSensorPlant(load)
    run(load.to_phi(), reference.reaction_wrench, reference.motion_in_S, reference.random_state, rng,
        batch_size=args.batch)
    return 0


def _bench_identify(args) -> int:
    from heft.analysis import bench_identify as bench
    from heft.diagrams.identify import ALL_METHODS, design_excitation, kinematic_signals
    from heft.diagrams.running.sim_identification import record_excitation
    from heft.diagrams.progress import ProgressBar
    from heft.diagrams.scenario import NOISE_OFF, Scenario, layered, overrides_text
    from heft.systems.load_dynamics import PARAMETER_NAMES
    from heft.systems.identification.regression_noise import NoiseLevels
    from heft.systems.identification.excitation import ExcitationSettings
    from heft.systems.load_dynamics import noncontact_wrench

    scenario = layered(Scenario(), overrides_text(NOISE_OFF))  # the paper's tool; noise is added per run below
    settings = dataclasses.replace(ExcitationSettings.quick(), base_frequency=0.5, duration=2.0)
    excitation = design_excitation(scenario, settings)
    recording = record_excitation(scenario, excitation.trajectory, settings.duration)
    (a, alpha, omega, g), _ = kinematic_signals(scenario, recording, settings.base_frequency,
                                                settings.harmonics, "accelerometer")
    theta_true = np.concatenate((np.zeros(6), recording.phi_true))
    # The exact wrench of these signals, so the spread measured is the estimators' alone
    # (the simulation's own model error is what `heft identify` reports with noise off).
    exact_wrench = noncontact_wrench(recording.phi_true, a, alpha, omega, g)
    noise = NoiseLevels()
    bounds = {"wrench": bench.cramer_rao_bound(a, alpha, omega, g, noise),
              "wrench+accelerometer": bench.cramer_rao_bound(a, alpha, omega, g, noise, recording.phi_true)}
    cost = np.sqrt(np.diag(bounds["wrench+accelerometer"]) / np.diag(bounds["wrench"]))
    say.info("the accelerometer's noise raises the bound's σ by " + ", ".join(
           f"{name} ×{cost[i]:.2f}" for i, name in enumerate(PARAMETER_NAMES) if name in bench.SHOWN))
    methods = args.methods or list(ALL_METHODS)
    say.info(f"{len(recording.t)} samples of a {settings.duration:g} s excitation; {args.runs} runs per noise model; "
             f"noise {noise}")
    results = {}
    for label, accelerometer_noise in (("wrench", False), ("wrench+accelerometer", True)):
        bar = ProgressBar(args.runs, label)
        estimates = bench.monte_carlo(exact_wrench, a, alpha, omega, g, noise, args.runs, methods, args.seed,
                                      accelerometer_noise, bar.update, workers=args.workers, dask_address=args.dask)
        bar.close()
        results[label] = bench.summarise(estimates, theta_true, bounds[label])
        kind = "errors-in-variables " if accelerometer_noise else ""
        bench.print_table(f"noise on {label}: bias / std / {kind}Cramér–Rao std (efficiency σ²_CR/MSE)",
                          results[label])
        bench.print_ratios(results[label], bench.TARGET_RATIO)
    costs = bench.update_costs(exact_wrench, a, alpha, omega, g, noise)
    say.info("\ncost per sample (µs): " + ", ".join(f"{m} {1e6 * c:.1f}" for m, c in costs.items()))
    say.info(f"a recursive RTLS update costs {costs['rtls'] / costs['tls']:.0f}× a batch TLS solve's share per sample, "
             f"and {costs['rtls'] / 500e-6:.1%} of a 2 kHz tick")
    _write(args, {"accuracy": results, "cost_per_sample_s": costs})
    return 0


def _bench_lcm(args) -> int:
    from heft.diagrams.commands.bench_lcm import run
    from heft.diagrams.running.realtime import check_busy_wait

    check_busy_wait(args.busy_wait)
    rates = [float(r) for r in args.rates.split(",")]
    results = run(rates, args.duration, args.scenario, scenario_from(args).lab.lcm, args.busy_wait, args.view)
    _write(args, results)
    return 0


def _bench_step(args) -> int:
    import numpy as np

    from heft.diagrams.commands import bench_step as bench
    from heft.diagrams.running.simulation import true_load
    from heft.diagrams.teleop_controller import TeleopController

    scenario = scenario_from(args)
    load, _ = true_load(scenario)
    period, convention = scenario.controller_period, scenario.accelerometer.convention()
    sequence = bench.readings(scenario, args.ticks, period)
    program, by_kernel = (TeleopController(scenario.controller, load, scenario.robot, period, accelerometer=convention,
                                           compile=compile) for compile in (True, False))
    torques = {"program": [], "by_kernel": [], "drake": []}
    results = {"ticks": args.ticks, "compiled": program.program.compiled,
               "program": bench.time_controller(program, sequence, period, torques["program"]),
               "by_kernel": bench.time_controller(by_kernel, sequence, period, torques["by_kernel"]),
               "drake": bench.time_controller(bench.DrakeStepping(program.diagram), sequence, period,
                                              torques["drake"])}
    results["torque_difference"] = float(max(np.abs(np.array(torques[name]) - np.array(torques["drake"])).max()
                                             for name in ("program", "by_kernel")))
    bench.report(results, period)
    _write(args, results)
    return 0


def _bench_compensate(args) -> int:
    import tempfile

    from heft.analysis.bench_compensate import bench

    durations = [float(d) for d in args.durations.split(",")]
    formats = ["csv", "parquet"] if args.format == "both" else [args.format]
    if args.folder:
        results = bench(durations, formats, args.folder, args.cpu, keep=True)
    else:
        with tempfile.TemporaryDirectory(prefix="heft_bench_compensate_") as folder:
            results = bench(durations, formats, folder, args.cpu)
    _write(args, results)
    return 0


def add_arguments(parser) -> None:
    benches = parser.add_subparsers(dest="bench_name", metavar="BENCH", required=True)
    regressor_parser = benches.add_parser("regressor", help="cost of V·φ per sample and per batch, against Drake")
    regressor_parser.add_argument("--seed", type=int, default=0)
    regressor_parser.add_argument("--batch", type=int, default=100_000, help="batch size (default 100000)")
    regressor_parser.set_defaults(bench=_bench_regressor)
    identify_parser = benches.add_parser("identify", help="Monte Carlo accuracy of every estimator against the "
                                                         "Cramér–Rao bound, and update costs")
    identify_parser.add_argument("--runs", type=int, default=100, help="noise realisations per model (default 100)")
    identify_parser.add_argument("--seed", type=int, default=0)
    identify_parser.add_argument("--methods", nargs="+", choices=("ols", "wls", "tls", "eiv_ml", "rls", "riv", "rtls"))
    add_out(identify_parser, "bench_identify.json (every number)")
    identify_parser.add_argument("--workers", type=int, help="local worker processes (default: every core)")
    add_dask(identify_parser)
    identify_parser.set_defaults(bench=_bench_identify)
    lcm_parser = benches.add_parser("lcm", help="the controller against a driver probe over LCM in two processes: "
                                                "sensor-to-torque latency and the loop rate sustained")
    lcm_parser.add_argument("--rates", default="2000,4000", help="controller rates to try (Hz, default 2000,4000)")
    lcm_parser.add_argument("--duration", type=float, default=5.0, help="controller seconds per rate (default 5)")
    add_scenario(lcm_parser, more="the controller's settings")
    lcm_parser.add_argument("--busy-wait", type=float, default=0.0,
                            help="the controller's `heft teleop --busy-wait` (default 0)")
    add_lcm_urls(lcm_parser)
    add_out(lcm_parser, "bench_lcm.json (every number)")
    lcm_parser.add_argument("--view", action="store_true",
                            help="the controller feeds the live view too (`heft teleop --view`; needs the view extra)")
    lcm_parser.set_defaults(bench=_bench_lcm)
    step_parser = benches.add_parser("step", help="one controller tick in one process: the Diagram's program "
                                                  "against Drake's stepping of the same Diagram")
    add_scenario(step_parser, more="the controller's settings")
    step_parser.add_argument("--ticks", type=int, default=4000, help="ticks timed (default 4000)")
    add_out(step_parser, "bench_step.json (every number)")
    step_parser.set_defaults(bench=_bench_step)
    compensate_parser = benches.add_parser(
        "compensate", help="`heft compensate` on synthetic 8 kHz recordings written to a temporary folder: rate and "
                           "peak memory on one CPU, the hour extrapolated from the two longest")
    compensate_parser.add_argument("--durations", default="60,240",
                                   help="recording lengths (s, default 60,240; 3600 writes the whole hour, ~2.3 GB)")
    compensate_parser.add_argument("--format", choices=("csv", "parquet", "both"), default="both")
    compensate_parser.add_argument("--cpu", type=int, default=0, help="the CPU the command is pinned to (default 0)")
    compensate_parser.add_argument("--folder", help="write the recordings here and keep them (default: a temporary "
                                                    "folder, removed run by run)")
    add_out(compensate_parser, "bench_compensate.json (every number)")
    compensate_parser.set_defaults(bench=_bench_compensate)


def _write(args, results: dict) -> None:
    """Every number of a bench as ``bench_NAME.json`` in the ``--out`` folder, if given."""
    path = out_file(args, f"bench_{args.bench_name}.json")
    if path is not None:
        path.write_text(json.dumps(results, indent=2) + "\n")


def run(args) -> int:
    return args.bench(args)
