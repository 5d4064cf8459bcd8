"""`heft check`: Eq. 4 against Drake's own dynamics along a random motion."""

from __future__ import annotations


import numpy as np

from heft.diagrams.commands.console import logger
from heft.diagrams.commands.exit_status import CHECK_FAILED, OK

say = logger(__name__)


HELP = ("compare Eq. 4 with Drake's dynamics along a random motion")


def add_arguments(parser) -> None:
    parser.add_argument("--seed", type=int, default=0, help="random load and motion (default 0)")
    parser.add_argument("--duration", type=float, default=2.0, help="simulated seconds (default 2)")


def run(args) -> int:
    """Eq. 4 against Drake's own dynamics along a simulated random motion."""
    from heft.diagrams.stations.load_on_sensor import simulate_random_motion
    from heft.systems.load_dynamics import InertialParameters, noncontact_wrench

    rng = np.random.default_rng(args.seed)
    load = InertialParameters.random(rng)
    say.info(f"load: m = {load.mass:.3f} kg, c = {np.round(load.com, 4)} m, "
             f"principal inertia about C = {np.round(np.linalg.eigvalsh(load.inertia_com), 5)} kg·m²")
    say.info(f"simulating {args.duration:g} s of random motion of sensor + load in Drake ...")
    t, wrench_drake, a, alpha, omega, g = simulate_random_motion(load, rng, duration=args.duration)
    wrench_eq4 = noncontact_wrench(load.to_phi(), a, alpha, omega, g)
    error = np.abs(wrench_eq4 - wrench_drake)
    peak = np.abs(wrench_drake).max(axis=0)
    say.info(f"{len(t)} samples; peak |ω| {np.abs(omega).max():.1f} rad/s, "
             f"|α| {np.abs(alpha).max():.1f} rad/s², |a − g| {np.abs(a - g).max():.1f} m/s²")
    say.info(f"peak wrench:            force {peak[:3].max():9.3f} N      torque {peak[3:].max():9.4f} N·m")
    say.info(f"max |Eq. 4 − Drake|:    force {error[:, :3].max():9.2e} N      torque {error[:, 3:].max():9.2e} N·m")
    relative = error.max() / np.abs(wrench_drake).max()
    ok = relative < 1e-8
    say.info(f"relative error {relative:.1e}: {'Eq. 4 matches' if ok else 'MISMATCH with'} Drake's dynamics")
    return OK if ok else CHECK_FAILED
