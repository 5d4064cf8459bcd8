"""The `heft` command line."""

from __future__ import annotations

import argparse
import sys
from importlib.metadata import version

import numpy as np


def _check(args) -> int:
    """Eq. 4 against Drake's own dynamics along a simulated random motion."""
    from heft.diagrams.load_on_sensor import simulate_random_motion
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
    from heft.diagrams.load_on_sensor import LoadOnSensorPlant
    from heft.systems.load_dynamics import InertialParameters

    rng = np.random.default_rng(args.seed)
    load = InertialParameters.random(rng)
    reference = LoadOnSensorPlant(load)
    run(load.to_phi(), reference.reaction_wrench, reference.motion_in_S, reference.random_state, rng,
        batch_size=args.batch)
    return 0


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

    bench = commands.add_parser("bench", help="benchmarks, each printed beside a reference measured in the same run")
    benches = bench.add_subparsers(dest="bench", metavar="BENCH", required=True)
    regressor = benches.add_parser("regressor", help="cost of V·φ per sample and per batch, against Drake")
    regressor.add_argument("--seed", type=int, default=0)
    regressor.add_argument("--batch", type=int, default=100_000, help="batch size (default 100000)")
    regressor.set_defaults(run=_bench_regressor)
    return parser


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    return args.run(args)


if __name__ == "__main__":
    sys.exit(main())
