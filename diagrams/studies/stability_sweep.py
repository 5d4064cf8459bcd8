"""Stability of the closed loop in contact, point by point over swept parameters.

Each point is a short simulation of a contact scenario (by default
``scenarios/stability_wall.yaml``: the operator pushes the slave's tool into the
sheet spring and holds it there) with some parameters replaced, classified by
``analysis.stability.oscillation_growth`` on the force the master renders.
Because an unstable contact loop saturates within a few tenths of a second into a
bouncing limit cycle (which that rule calls "sustained"), each point also reports
how much of the last third the tool spent out of contact while pushed.
"""

from __future__ import annotations

import functools
import itertools

import numpy as np

from heft.analysis.parallel import run_points
from heft.analysis.stability import oscillation_growth
from heft.diagrams.scenario import Scenario, layered, overrides_text
from heft.diagrams.running.simulation import run_teleop, true_load


# Swept parameter → (scenario field it sets, units).
AXES = {
    "stiffness": ("environment.stiffness", "N/m"),
    "damping": ("environment.damping", "N·s/m"),
    "force_scale": ("controller.feedback.force_scale", "master N per slave N"),
    "sigma": ("controller.force.sigma", "1"),
    "gamma": ("controller.force.gamma", "1"),
    "motion_scale": ("controller.motion.translation_scale", "slave m per master m"),
    "period": ("controller_period", "s"),
    "delay": ("controller.delay", "s, one way"),
    "passivity": ("controller.passivity.enabled", "0 off / 1 on"),
}
CONTACT_FORCE_HELD = 1.0
"""Contact force magnitude (N) at the slave below which the tool counts as out of contact."""
BOUNCING_FRACTION = 0.1
"""Share of the last third out of contact beyond which a pushed tool counts as bouncing."""
MASTER_FORCE_QUIET = 1e-3
"""Oscillation RMS (N) of the master force below which it counts as quiet (noise-free runs)."""


def grid(axes: dict[str, list[float]]) -> list[dict]:
    """Every combination of the swept values, the last axis varying fastest."""
    unknown = sorted(set(axes) - set(AXES))
    if unknown:
        raise ValueError(f"unknown sweep axis {', '.join(unknown)}; known: {', '.join(AXES)}")
    names = list(axes)
    return [dict(zip(names, values, strict=True)) for values in itertools.product(*(axes[n] for n in names))]


def point_scenario(base: Scenario, point: dict) -> Scenario:
    """A validated copy of ``base`` with the point's parameters set (``scenario.layered``); a
    value for a switch (``passivity``) counts as on when non-zero."""
    values = {}
    for name, value in point.items():
        path = AXES[name][0]
        current = functools.reduce(getattr, path.split("."), base)
        values[path] = bool(value) if isinstance(current, bool) else float(value)
    try:
        return layered(base, overrides_text(values))
    except ValueError as error:
        raise ValueError(f"sweep point {point}: {error}") from None


def classify(log: dict, max_force: float) -> dict:
    """The verdict of ``oscillation_growth`` on the master force (N, in B), the same rule on
    the contact force at the slave, the share of the last third with the tool out of contact,
    and the share with the master force at the device's limit ``max_force`` (N)."""
    t, master, contact = log["t"], log["master_force"][:, :3], log["wrench_contact_true"][:, :3]
    verdict = oscillation_growth(t, master, quiet=MASTER_FORCE_QUIET)
    contact_verdict = oscillation_growth(t, contact, quiet=MASTER_FORCE_QUIET / 0.05)
    last = slice(len(t) - len(t) // 3, len(t))
    out_of_contact = float(np.mean(np.linalg.norm(contact[last], axis=1) < CONTACT_FORCE_HELD))
    saturated = float(np.mean(np.linalg.norm(master[last], axis=1) >= 0.99 * max_force))
    return {"verdict": verdict.verdict, "stable": verdict.stable, "growth_ratio": float(verdict.ratio),
            "growth_rate": float(verdict.growth_rate), "master_rms_last": verdict.rms_last,
            "contact_verdict": contact_verdict.verdict, "contact_growth_ratio": float(contact_verdict.ratio),
            "out_of_contact": out_of_contact, "bouncing": out_of_contact > BOUNCING_FRACTION,
            "saturated": saturated, "master_force_peak": float(np.linalg.norm(master, axis=1).max()),
            "contact_force_peak": float(np.linalg.norm(contact, axis=1).max())}


def simulate_point(base: Scenario, point: dict, seed_sequence: np.random.SeedSequence) -> dict:
    """One point: simulate ``base`` with the point's parameters, return the point and its
    classification. The sensor noise (when the scenario has it on) is seeded from
    ``seed_sequence``. Module-level, so worker processes can run it."""
    noise_seed = int(seed_sequence.generate_state(1, dtype=np.uint64)[0])
    scenario = layered(point_scenario(base, point),
                       overrides_text({"ft_sensor.seed": noise_seed, "accelerometer.seed": noise_seed}))
    load, _ = true_load(scenario)
    log = run_teleop(scenario, load, quiet=True)
    result = classify(log, scenario.controller.feedback.max_force)
    result["realtime_factor"] = float(log["realtime_factor"])
    return {"point": dict(point), **result}


def sweep(base: Scenario, axes: dict[str, list[float]], seed: int = 0, dask_address: str | None = None,
          workers: int | None = None, progress=None) -> list[dict]:
    """``simulate_point`` over the grid of ``axes`` (``analysis.parallel.run_points``)."""
    return run_points(functools.partial(simulate_point, base), grid(axes), seed, dask_address=dask_address,
                      workers=workers, label="stability sweep", progress=progress)
