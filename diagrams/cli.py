"""The `heft` command line."""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
from importlib.metadata import version
from pathlib import Path

import numpy as np

from heft.hardware_interface.channels import LcmChannels


DEFAULT_LCM_URL = LcmChannels.lcm_url
"""Multicast that cannot leave the machine (ttl=0); the lab's drivers use the same."""


def _check(args) -> int:
    """Eq. 4 against Drake's own dynamics along a simulated random motion."""
    from heft.diagrams.stations.load_on_sensor import simulate_random_motion
    from heft.systems.load_dynamics import InertialParameters, noncontact_wrench

    rng = np.random.default_rng(args.seed)
    load = InertialParameters.random(rng)
    print(f"load: m = {load.mass:.3f} kg, c = {np.round(load.com, 4)} m, "
          f"principal inertia about C = {np.round(np.linalg.eigvalsh(load.inertia_com), 5)} kg·m²")
    print(f"simulating {args.duration:g} s of random motion of sensor + load in Drake ...")
    t, wrench_drake, a, alpha, omega, g = simulate_random_motion(load, rng, duration=args.duration)
    wrench_eq4 = noncontact_wrench(load.to_phi(), a, alpha, omega, g)
    error = np.abs(wrench_eq4 - wrench_drake)
    peak = np.abs(wrench_drake).max(axis=0)
    print(f"{len(t)} samples; peak |ω| {np.abs(omega).max():.1f} rad/s, "
          f"|α| {np.abs(alpha).max():.1f} rad/s², |a − g| {np.abs(a - g).max():.1f} m/s²")
    print(f"peak wrench:            force {peak[:3].max():9.3f} N      torque {peak[3:].max():9.4f} N·m")
    print(f"max |Eq. 4 − Drake|:    force {error[:, :3].max():9.2e} N      torque {error[:, 3:].max():9.2e} N·m")
    relative = error.max() / np.abs(wrench_drake).max()
    ok = relative < 1e-8
    print(f"relative error {relative:.1e}: {'Eq. 4 matches' if ok else 'MISMATCH with'} Drake's dynamics")
    return 0 if ok else 1


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


def _scenario(args, options: str = ""):
    """The scenario of ``--scenario`` with the command's own ``options`` (YAML text) and then
    ``--set`` laid over it (``scenario.layered``: the one override path)."""
    from heft.diagrams.scenario import layered, resolve_scenario

    scenario = resolve_scenario(args.scenario, options)
    return layered(scenario, args.set) if args.set else scenario


def _simulate(args) -> int:
    from heft.diagrams.load_estimate import read_load_estimate
    from heft.diagrams.scenario import NOISE_OFF, overrides_text
    from heft.diagrams.running.simulation import simulate

    noise = {} if args.noise is None else {name: args.noise == "on" for name in NOISE_OFF}
    options = overrides_text({"controller.force.gamma": args.gamma, "controller.force.eta": args.eta, **noise,
                              "duration": args.duration,
                              "controller.sigmas": None if args.sigma is None else [args.sigma]})
    scenario = _scenario(args, options)
    out = Path(args.out or f"out/{Path(args.scenario).stem}")
    estimate = args.estimate or scenario.controller.load_estimate
    if estimate:
        load = read_load_estimate(estimate)
        print(f"load estimate from {estimate}")
    else:
        from heft.diagrams.identify import identify_in_simulation
        print("no load estimate given: identifying the load in simulation first (Sec. IV)")
        load = identify_in_simulation(scenario, out / "identify")
    sigmas = scenario.controller.sigmas
    meshcat = None
    if args.meshcat:
        from pydrake.geometry import Meshcat
        meshcat = Meshcat()
        print(f"live view: {meshcat.web_url()}", flush=True)
    metrics = simulate(scenario, load, out, sigmas, name=Path(args.scenario).stem, meshcat=meshcat)
    print(json.dumps(metrics, indent=2))
    print(f"wrote {out}/log.npz, metrics.json, figure.png")
    return 0


def _identify(args) -> int:
    from heft.diagrams.identify import identify
    from heft.systems.excitation import ExcitationSettings

    scenario = _scenario(args)
    settings = ExcitationSettings.quick() if args.quick else ExcitationSettings()
    if args.hardware:
        from heft.diagrams.running.hardware_identify import identify_on_hardware
        identify_on_hardware(scenario, args.out, args.lcm_url, method=args.method, signals=args.signals,
                             settings=settings, periods=args.periods, record=args.record,
                             params=_station_params(args.watchdog_timeout), priority=args.rt_priority)
        print(f"wrote {args.out}/estimate.yaml, metrics.json{f', {args.record}' if args.record else ''}")
        return 0
    if args.record:
        raise ValueError("--record records LCM traffic: it needs --hardware")
    identify(scenario, args.out, method=args.method, signals=args.signals, settings=settings, periods=args.periods)
    print(f"wrote {args.out}/estimate.yaml, metrics.json, convergence.png")
    return 0


def _demo(args) -> int:
    """Identify the paper's tool, then replay Fig. 6 with σ = 1, 0.5, 0."""
    from heft.diagrams.identify import identify_in_simulation
    from heft.diagrams.scenario import resolve_scenario
    from heft.diagrams.running.simulation import simulate
    from heft.systems.excitation import ExcitationSettings

    out = Path(args.out)
    scenario = resolve_scenario("fig6")
    print("1/2 identifying the 3.13 kg tool and the sensor offsets from a 4 s excitation (Sec. IV)")
    settings = dataclasses.replace(ExcitationSettings.quick(), base_frequency=0.25, duration=4.0)
    load = identify_in_simulation(scenario, out / "identify", settings)
    print("2/2 fast vertical motion (Fig. 6): feeding back σ = 1, 0.5, 0 of the non-contact force")
    metrics = simulate(scenario, load, out / "fig6", scenario.controller.sigmas, name="fig6")
    k_f = scenario.controller.feedback.force_scale
    print(f"non-contact force at the slave up to {metrics['noncontact_peak_N']:.1f} N "
          f"({metrics['master_noncontact_peak_N']:.2f} N at the operator's hand); after elimination "
          f"{metrics['residual_peak_N']:.2f} N remain ({100 * metrics['residual_ratio']:.1f} %, "
          f"{metrics['residual_peak_N'] * k_f:.3f} N at the hand). Simulated at "
          f"{metrics['realtime_factor']:.2f}× real time.")
    print(f"figure: {out / 'fig6' / 'figure.png'}; logs, metrics and the estimate under {out}/")
    return 0


def _bench_identify(args) -> int:
    from heft.analysis import bench_identify as bench
    from heft.diagrams.identify import ALL_METHODS, design_excitation, kinematic_signals, record_excitation
    from heft.diagrams.running.progress import ProgressBar
    from heft.diagrams.scenario import Scenario
    from heft.systems.estimators import NoiseLevels
    from heft.systems.excitation import ExcitationSettings
    from heft.systems.load_dynamics import noncontact_wrench

    scenario = Scenario()  # the paper's tool, ideal sensors: noise is added per run below
    scenario.ft_sensor.noise = scenario.accelerometer.noise = False
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
    bound = bench.cramer_rao_bound(a, alpha, omega, g, noise)
    methods = args.methods or list(ALL_METHODS)
    print(f"{len(recording.t)} samples of a {settings.duration:g} s excitation; {args.runs} runs per noise model; "
          f"noise {noise}")
    results = {}
    for label, accelerometer_noise in (("wrench", False), ("wrench+accelerometer", True)):
        bar = ProgressBar(args.runs, label)
        estimates = bench.monte_carlo(exact_wrench, a, alpha, omega, g, noise, args.runs, methods, args.seed,
                                      accelerometer_noise, bar.update, workers=args.workers, dask_address=args.dask)
        bar.close()
        results[label] = bench.summarise(estimates, theta_true, bound)
        bench.print_table(f"noise on {label}: bias / std / Cramér–Rao std (efficiency σ²_CR/MSE)", results[label])
    costs = bench.update_costs(exact_wrench, a, alpha, omega, g, noise)
    print("\ncost per sample (µs): " + ", ".join(f"{m} {1e6 * c:.1f}" for m, c in costs.items()))
    print(f"a recursive RTLS update costs {costs['rtls'] / costs['tls']:.0f}× a batch TLS solve's share per sample, "
          f"and {costs['rtls'] / 500e-6:.1%} of a 2 kHz tick")
    if args.out:
        Path(args.out).write_text(json.dumps({"accuracy": results, "cost_per_sample_s": costs}, indent=2) + "\n")
    return 0


def _bench_lcm(args) -> int:
    from heft.diagrams.commands.bench_lcm import run

    rates = [float(r) for r in args.rates.split(",")]
    results = run(rates, args.duration, args.scenario, args.lcm_url)
    if args.out:
        Path(args.out).write_text(json.dumps(results, indent=2) + "\n")
    return 0


def _stand_in(args) -> int:
    from heft.diagrams.stations.stand_in import FaultInjection, run_stand_in
    from heft.hardware_interface.channels import LcmChannels

    scenario = _scenario(args)
    faults = FaultInjection(drop_rate=args.drop_rate, burst_loss_s=args.burst_loss, added_delay_s=args.added_delay,
                            nan_rate=args.nan_rate, saturate_at_s=args.saturate_at, die_at_s=args.die_at,
                            seed=args.seed, reorder_rate=args.reorder_rate)
    channels = LcmChannels(lcm_url=args.lcm_url)
    print(f"stand-in: {args.scenario} on {args.lcm_url} for {args.duration:g} s at real time", flush=True)
    summary = run_stand_in(scenario, channels, args.lcm_url, args.duration, faults, args.clutch_at,
                           args.clutch_release_at)
    rates = "; ".join(f"{kind} Hz " + ", ".join(f"{name} {hz:.0f}" for name, hz in summary[f"{kind}_hz"].items())
                      for kind in ("published", "received"))
    print(f"stand-in: stopped at t = {summary['duration_s']:.3f} s{' (died, as injected)' if summary['died'] else ''}"
          f"; {rates}; CPU {summary['cpu_s']:.2f} s; max lateness {summary['max_lateness_ms']:.2f} ms", flush=True)
    if args.out:
        Path(args.out).write_text(json.dumps(summary, indent=2) + "\n")
    return 0


def _station_params(timeout):
    """HardwareStationParams with the watchdog ``timeout`` (s) if given."""
    from heft.hardware_interface.hardware_station import HardwareStationParams
    from heft.hardware_interface.watchdog import WatchdogParams

    if timeout is None:
        return HardwareStationParams()
    if not (math.isfinite(timeout) and timeout > 0):
        raise ValueError(f"--watchdog-timeout must be a positive number of seconds; got {timeout}")
    return HardwareStationParams(watchdog=WatchdogParams(timeout=timeout))


def _teleop(args) -> int:
    from heft.diagrams.running.hardware_teleop import format_summary, run_hardware_teleop
    from heft.diagrams.load_estimate import LoadEstimate, read_load_estimate

    if not args.hardware:
        raise ValueError("only --hardware is supported here; use `heft simulate` for the simulated station")
    scenario = _scenario(args)
    rate = 1.0 / scenario.controller_period if args.rate is None else args.rate
    if not (math.isfinite(rate) and rate > 0):
        raise ValueError(f"--rate must be a positive number of Hz; got {rate}")
    estimate = args.estimate or scenario.controller.load_estimate
    if estimate:
        load = read_load_estimate(estimate)
    else:
        print("teleop: no load estimate given: φ̂ = 0, offsets 0 (nothing is eliminated)", flush=True)
        load = LoadEstimate(phi=np.zeros(10), offsets=np.zeros(6))
    print(f"teleop: controller on {args.lcm_url} at {rate:g} Hz for {args.duration:g} s of wall time", flush=True)
    summary = run_hardware_teleop(scenario, load, args.lcm_url, args.duration, rate, record=args.record,
                                  params=_station_params(args.watchdog_timeout), priority=args.rt_priority)
    print(format_summary(summary), flush=True)
    if args.out:
        Path(args.out).write_text(json.dumps(summary, indent=2) + "\n")
    return 0


def _load(args) -> int:
    from heft.diagrams.load_estimate import read_load_estimate
    from heft.hardware_interface.channels import LcmChannels
    from heft.hardware_interface.load_commands import send_load_command

    chosen = [name for name, given in (("rezero", args.rezero), ("tracking", args.tracking),
                                       ("estimate", args.estimate)) if given]
    if len(chosen) != 1:
        raise ValueError("give exactly one of --rezero, --tracking on|off, --estimate FILE")
    channels = LcmChannels(lcm_url=args.lcm_url)
    try:
        if args.estimate:
            load = read_load_estimate(args.estimate)
            answers = send_load_command(args.lcm_url, channels, "new_estimate", load.phi, load.offsets, args.timeout)
        else:
            action = "rezero" if args.rezero else f"tracking_{args.tracking}"
            answers = send_load_command(args.lcm_url, channels, action, timeout=args.timeout)
    except TimeoutError as error:
        print(f"heft load: {error}", file=sys.stderr)
        return 5
    for answer in answers:
        print(f"heft load: {answer.message}")
    final = answers[-1]
    print("heft load: offsets in use [" + ", ".join(f"{x:.4g}" for x in final.offsets)
          + f"] (N, N·m); m = {final.phi[0]:.4g} kg; tracking {'on' if final.tracking else 'off'}")
    return 0 if final.accepted else 4


def _picture(args) -> int:
    from heft.diagrams.commands.picture import write_picture

    print(f"wrote {write_picture(args.out, args.what, args.scenario, args.depth)}")
    return 0


def _add_set(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--set", metavar="YAML", help="scenario fields laid over it, nested as in a scenario file, "
                                                      "e.g. '{controller: {force: {gamma: 0.5}}}' (applied last)")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="heft",
        description="Bilateral teleoperation that feeds back what the slave touches, "
                    "not what it carries (Kubus & Wahl, IROS 2009), on Drake.")
    parser.add_argument("--version", action="version", version=f"heft {version('heft-teleop')}")
    commands = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    check = commands.add_parser("check", help="compare Eq. 4 with Drake's dynamics along a random motion")
    check.add_argument("--seed", type=int, default=0, help="random load and motion (default 0)")
    check.add_argument("--duration", type=float, default=2.0, help="simulated seconds (default 2)")
    check.set_defaults(run=_check)

    demo = commands.add_parser("demo", help="identify the paper's tool, then replay its Fig. 6 (about a minute)")
    demo.add_argument("--out", default="out/demo", help="output folder (default out/demo)")
    demo.set_defaults(run=_demo)

    simulate = commands.add_parser("simulate", help="replay one of the paper's experiments (fig6, fig7, fig8) "
                                                    "or a scenario file in the simulated station")
    simulate.add_argument("scenario", help="fig6 | fig7 | fig8 | path to a scenario YAML")
    _add_set(simulate)
    simulate.add_argument("--sigma", type=float, help="σ: non-contact scale (default: the scenario's set)")
    simulate.add_argument("--gamma", type=float, help="γ: contact scale")
    simulate.add_argument("--eta", type=float, help="η: share of the gripped object's non-contact wrench kept")
    simulate.add_argument("--noise", choices=("on", "off"), help="sensor noise, offsets, drift, quantisation")
    simulate.add_argument("--duration", type=float, help="simulated seconds")
    simulate.add_argument("--estimate", help="estimate.yaml from `heft identify` (default: identify first)")
    simulate.add_argument("--out", help="output folder (default out/SCENARIO)")
    simulate.add_argument("--meshcat", action="store_true", help="show the simulation live in a browser (URL printed)")
    simulate.set_defaults(run=_simulate)

    identify = commands.add_parser("identify", help="identify the load's inertial parameters and the sensor "
                                                    "offsets from an excitation motion (Sec. IV)")
    identify.add_argument("--scenario", required=True, help="fig6 | fig7 | fig8 | path to a scenario YAML")
    _add_set(identify)
    identify.add_argument("--out", required=True, help="output folder")
    identify.add_argument("--method", default="tls", choices=("ols", "wls", "tls", "rls", "riv", "rtls"),
                          help="the estimate written to estimate.yaml (all are reported; default tls)")
    identify.add_argument("--signals", default="accelerometer", choices=("accelerometer", "encoders"),
                          help="where a and α come from (ω and g always from the encoders)")
    identify.add_argument("--periods", type=int, default=1, help="excitation periods recorded (default 1)")
    identify.add_argument("--quick", action="store_true", help="a short, quickly optimised excitation")
    identify.add_argument("--hardware", action="store_true",
                          help="excite the real arm over LCM (the scenario gives the robot, start pose and load "
                               "model's settings); the arm first moves slowly to the excitation's start")
    identify.add_argument("--lcm-url", default=DEFAULT_LCM_URL, help=f"with --hardware (default {DEFAULT_LCM_URL})")
    identify.add_argument("--record", help="with --hardware: record the LCM traffic to this file (lcm-logger format)")
    identify.add_argument("--watchdog-timeout", type=float,
                          help="with --hardware: stale-channel timeout (s, default 0.02)")
    identify.add_argument("--rt-priority", type=int, default=50,
                          help="with --hardware: SCHED_FIFO priority of the loop, pinned to the last CPU "
                               "(default 50; 0: normal)")
    identify.set_defaults(run=_identify)

    bench = commands.add_parser("bench", help="benchmarks, each printed beside a reference measured in the same run")
    benches = bench.add_subparsers(dest="bench", metavar="BENCH", required=True)
    regressor = benches.add_parser("regressor", help="cost of V·φ per sample and per batch, against Drake")
    regressor.add_argument("--seed", type=int, default=0)
    regressor.add_argument("--batch", type=int, default=100_000, help="batch size (default 100000)")
    regressor.set_defaults(run=_bench_regressor)
    identification = benches.add_parser("identify", help="Monte Carlo accuracy of every estimator against the "
                                                         "Cramér–Rao bound, and update costs")
    identification.add_argument("--runs", type=int, default=100, help="noise realisations per model (default 100)")
    identification.add_argument("--seed", type=int, default=0)
    identification.add_argument("--methods", nargs="+", choices=("ols", "wls", "tls", "rls", "riv", "rtls"))
    identification.add_argument("--out", help="write every number as JSON here")
    identification.add_argument("--workers", type=int, help="local worker processes (default: every core)")
    identification.add_argument("--dask", metavar="ADDRESS", help="run on this Dask scheduler (tcp://host:port)")
    identification.set_defaults(run=_bench_identify)

    default_url = DEFAULT_LCM_URL
    commands.add_parser("analyze", help="analyses: " + ", ".join(name for name, _, _ in ANALYSES) +
                        " (`heft analyze --help`)", add_help=False)
    lcm_bench = benches.add_parser("lcm", help="the controller against a driver probe over LCM in two processes: "
                                               "sensor-to-torque latency and the loop rate sustained")
    lcm_bench.add_argument("--rates", default="2000,4000", help="controller rates to try (Hz, default 2000,4000)")
    lcm_bench.add_argument("--duration", type=float, default=5.0, help="controller seconds per rate (default 5)")
    lcm_bench.add_argument("--scenario", default="fig6", help="controller settings (default fig6)")
    lcm_bench.add_argument("--lcm-url", default=default_url, help=f"LCM URL (default {default_url})")
    lcm_bench.add_argument("--out", help="write every number as JSON here")
    lcm_bench.set_defaults(run=_bench_lcm)
    stand_in = commands.add_parser("stand-in", help="a lightweight lab behind the drivers' LCM channels, at real time")
    stand_in.add_argument("--scenario", default="fig6", help="fig6 | fig7 | fig8 | path to a scenario YAML")
    _add_set(stand_in)
    stand_in.add_argument("--lcm-url", default=default_url, help=f"LCM URL (default {default_url})")
    stand_in.add_argument("--duration", type=float, default=10.0, help="seconds (default 10)")
    stand_in.add_argument("--drop-rate", type=float, default=0.0, help="probability a loss starts at a message")
    stand_in.add_argument("--burst-loss", type=float, default=0.0, help="length of each loss (s; default 0: one)")
    stand_in.add_argument("--added-delay", type=float, default=0.0, help="FT samples reach the bus this late (s)")
    stand_in.add_argument("--nan-rate", type=float, default=0.0, help="probability an FT sample is NaN")
    stand_in.add_argument("--saturate-at", type=float, default=math.inf,
                          help="FT samples flag every wrench axis saturated from this time (s)")
    stand_in.add_argument("--die-at", type=float, default=math.inf, help="stop publishing and exit at this time (s)")
    stand_in.add_argument("--reorder-rate", type=float, default=0.0,
                          help="probability a message is sent after the next one of its channel")
    stand_in.add_argument("--seed", type=int, default=0, help="fault seed (default 0)")
    stand_in.add_argument("--clutch-at", type=float, default=0.0, help="clutch button pressed from (s, default 0)")
    stand_in.add_argument("--clutch-release-at", type=float, default=math.inf, help="clutch button released at (s)")
    stand_in.add_argument("--out", help="also write the summary as JSON here")
    stand_in.set_defaults(run=_stand_in)

    teleop = commands.add_parser("teleop", help="the teleoperation controller on the lab's LCM channels")
    teleop.add_argument("--hardware", action="store_true", help="run against the lab's LCM channels (required)")
    teleop.add_argument("--scenario", default="fig6", help="controller settings from this scenario (default fig6)")
    _add_set(teleop)
    teleop.add_argument("--lcm-url", default=default_url, help=f"LCM URL (default {default_url})")
    teleop.add_argument("--estimate", help="estimate.yaml from `heft identify` (default: φ̂ = 0)")
    teleop.add_argument("--duration", type=float, default=10.0, help="seconds (default 10)")
    teleop.add_argument("--out", help="also write the summary as JSON here")
    teleop.add_argument("--watchdog-timeout", type=float, help="stale-channel timeout (s, default 0.02)")
    teleop.add_argument("--rate", type=float, help="controller rate (Hz; default: the scenario's, 2000)")
    teleop.add_argument("--record", help="record the LCM traffic to this file (lcm-logger format, for lcm-logplayer)")
    teleop.add_argument("--rt-priority", type=int, default=50,
                        help="SCHED_FIFO priority of the control loop, pinned to the last CPU (default 50; 0: normal)")
    teleop.set_defaults(run=_teleop)

    load = commands.add_parser("load", help="re-zero the sensor, switch offset tracking or change the tool "
                                            "of a running `heft teleop --hardware`")
    load.add_argument("--rezero", action="store_true",
                      help="measure the offsets now (hold the slave still, out of contact)")
    load.add_argument("--tracking", choices=("on", "off"), help="slow offset tracking at rest")
    load.add_argument("--estimate", help="a new tool's estimate.yaml from `heft identify`")
    load.add_argument("--lcm-url", default=default_url, help=f"LCM URL (default {default_url})")
    load.add_argument("--timeout", type=float, default=5.0, help="seconds to wait for the answers (default 5)")
    load.set_defaults(run=_load)

    picture = commands.add_parser("picture", help="draw the controller Diagram (or the whole simulation) "
                                                  "as Drake sees it (Graphviz)")
    picture.add_argument("--what", default="controller", choices=("controller", "simulation"),
                         help="the controller alone (default) or closed around the simulated station")
    picture.add_argument("--out", default="teleop_controller.svg", help="an .svg, .png or .dot file")
    picture.add_argument("--scenario", default="fig6", help="fig6 | fig7 | fig8 | path to a scenario YAML")
    picture.add_argument("--depth", type=int, default=1, help="levels of subsystems drawn (default 1)")
    picture.set_defaults(run=_picture)
    return parser


ANALYSES = (
    ("passivity", "heft.diagrams.commands.analyze_passivity",
     "port energies, the passivity observer and what the passivity controller dissipated, from a run's log"),
    ("stability", "heft.diagrams.commands.analyze_stability",
     "stability maps by simulation sweeps (stiffness, damping, scales, rate, delay; with/without the PC)"),
    ("linear", "heft.diagrams.commands.analyze_linear",
     "the loop linearised: eigenvalues, hybrid parameters H(jω), Llewellyn, Z-width, transparency"),
    ("apparent-mass", "heft.diagrams.commands.analyze_apparent_mass",
     "the mass the operator feels for σ from 0 to 2 and the gripper/object split (Sec. V: m_a = σ·m)"),
    ("replay", "heft.diagrams.commands.replay", "a run's log as a self-contained HTML replay (Meshcat)"),
)
"""``heft analyze`` subcommands: name, module (with ``add_arguments`` and ``run``), help."""


def build_analyze_parser() -> argparse.ArgumentParser:
    """``heft analyze``'s own parser; imports the analyses (Drake), so built only when asked for."""
    from importlib import import_module

    parser = argparse.ArgumentParser(prog="heft analyze", description="analyses writing PNG/HTML and JSON, "
                                                                      "each with a one-line summary")
    kinds = parser.add_subparsers(dest="analysis", required=True, metavar="ANALYSIS")
    for name, module_name, help_text in ANALYSES:
        module = import_module(module_name)
        kind = kinds.add_parser(name, help=help_text, description=help_text)
        module.add_arguments(kind)
        kind.set_defaults(run=module.run)
    return parser


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv[:1] == ["analyze"]:
        args = build_analyze_parser().parse_args(argv[1:])
        args.command = f"analyze {args.analysis}"
    else:
        args = build_parser().parse_args(argv)
    try:
        return args.run(args)
    except ValueError as error:  # bad input: say what was wrong, no traceback
        print(f"heft {args.command}: error: {error}", file=sys.stderr)
        return 2
    except RuntimeError as error:
        from heft.diagrams.running.realtime import HardwareRunFailed
        if not isinstance(error, HardwareRunFailed):
            raise
        print(f"heft {args.command}: stopped: {error}", file=sys.stderr)  # the arm is held, nothing written
        return 3


if __name__ == "__main__":
    sys.exit(main())
