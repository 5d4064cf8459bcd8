"""`heft analyze stability`: stability maps of the contact loop by simulation.

Sweeps one or two parameters (``stability_sweep.AXES``) over a grid, each point with
the passivity controller off and on, and writes stability_map.png and
stability_map.json (``analysis.stability_map``).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from heft.analysis.stability_map import draw_stability_map, stability_limits
from heft.diagrams.progress import ProgressBar
from heft.diagrams.scenario import layered, overrides_text, resolve_scenario
from heft.diagrams.studies.stability_sweep import AXES, point_scenario, sweep
from heft.diagrams.commands.console import logger
from heft.diagrams.commands.options import add_dask, add_out, add_scenario

say = logger(__name__)


def axis_values(axis: str, count: int, period: float) -> list[float]:
    """``count`` values of ``axis`` spanning its default range; periods and delays are whole
    multiples of the scenario's controller ``period`` (s)."""
    if count < 1:
        raise ValueError(f"--grid must be >= 1; got {count}")
    spans = {"stiffness": (3e2, 3e5), "damping": (1.0, 300.0), "force_scale": (1 / 70, 1 / 4)}
    if axis in spans:
        return [float(v) for v in np.geomspace(*spans[axis], count)]
    lines = {"sigma": (0.0, 1.0), "gamma": (0.25, 2.0), "motion_scale": (0.5, 4.0)}
    if axis in lines:
        return [float(v) for v in np.linspace(*lines[axis], count)]
    if axis == "period":
        return [period * 2.0 ** k for k in range(count)]
    if axis == "delay":
        return [period * float(k) for k in np.unique(np.round(np.linspace(0, 40, count)))]
    if axis == "passivity":
        return [0.0, 1.0]
    raise ValueError(f"unknown axis {axis!r}; known: {', '.join(AXES)}")


def add_arguments(parser) -> None:
    add_scenario(parser, default="stability_wall", more="one in contact")
    parser.add_argument("--axes", default="stiffness,force_scale",
                        help=f"one or two swept parameters, comma separated, of: {', '.join(AXES)} "
                             "(default stiffness,force_scale)")
    parser.add_argument("--grid", type=int, default=5, help="values per axis (default 5)")
    parser.add_argument("--passivity", choices=("both", "on", "off"), default="both",
                        help="passivity controller: maps side by side (both, default) or one")
    parser.add_argument("--duration", type=float, help="simulated seconds per point (default: the scenario's)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the points' sensor noise (default 0)")
    parser.add_argument("--workers", type=int, help="local worker processes (default: every core)")
    add_dask(parser)
    add_out(parser, "stability_map.png, stability_map.json", default="out/stability")


def run(args) -> int:
    base = resolve_scenario(args.scenario)
    if args.duration is not None:
        base = layered(base, overrides_text({"duration": args.duration}))
    names = [a.strip() for a in args.axes.split(",") if a.strip()]
    if not 1 <= len(names) <= 2 or "passivity" in names:
        raise ValueError(f"--axes takes one or two parameters other than passivity; got {args.axes!r}")
    axes = {name: axis_values(name, args.grid, base.controller_period) for name in names}
    axes["passivity"] = {"both": [0.0, 1.0], "on": [1.0], "off": [0.0]}[args.passivity]
    total = int(np.prod([len(v) for v in axes.values()]))
    say.info(f"stability sweep: {total} point(s) of {base.duration:g} s "
             f"({', '.join(f'{n} × {len(v)}' for n, v in axes.items())})")
    bar = ProgressBar(total, "stability sweep")
    results = sweep(base, axes, seed=args.seed, dask_address=args.dask, workers=args.workers, progress=bar.update)
    bar.close()
    units = {name: unit for name, (_, unit) in AXES.items()}
    y = names[1] if len(names) > 1 else None
    predicted = predicted_stiffness_limits(base, axes.get(y, [0.0]), y) if names[0] == "stiffness" else None
    png, document = draw_stability_map(results, names[0], y, Path(args.out), units=units, predicted=predicted)
    line = summary_line(results, names[0])
    if predicted:
        line += "; linear model's limit " + ", ".join(
            f"{value:.4g} N/m" + (f" at {y} = {level:.3g}" if y else "") for level, value in predicted.items())
    say.info(line + f"; wrote {png} and {document}")
    return 0


def predicted_stiffness_limits(base, levels, y: str | None) -> dict | None:
    """{level of ``y``: the linear model's stiffness limit (N/m)} (``linear_teleoperator``; no
    passivity controller); None where the model does not apply to the scenario."""
    from heft.analysis.linear_teleoperator import predicted_stiffness_limit
    from heft.diagrams.studies.linear_model_params import linear_model_params, operating_point

    try:
        point = operating_point(base)
        limits = {}
        for level in levels:
            scenario = point_scenario(base, {y: level}) if y else base
            reused = point if y not in ("period", "motion_scale") else None
            limits[level] = predicted_stiffness_limit(linear_model_params(scenario, point=reused))
        return limits
    except ValueError as error:
        say.warning(f"no linear prediction: {error}")
        return None


def summary_line(results: list[dict], x: str) -> str:
    """Counts per verdict, and per passivity setting the range of ``x`` that stayed stable in contact."""
    counts = {v: sum(r["verdict"] == v for r in results) for v in ("decaying", "sustained", "growing")}
    bouncing = sum(r["bouncing"] for r in results)
    parts = [", ".join(f"{n} {v}" for v, n in counts.items()) + f", {bouncing} bouncing"]
    for key, limit in stability_limits(results, x, "passivity").items():
        state = "on" if float(key) else "off"
        good = "none" if limit["last_good"] is None else f"{limit['last_good']:.4g}"
        bad = "none" if limit["first_bad"] is None else f"{limit['first_bad']:.4g}"
        parts.append(f"PC {state}: stable in contact up to {x} = {good}, first failure at {bad}")
    return f"{len(results)} point(s): " + "; ".join(parts)


if __name__ == "__main__":
    import argparse

    parser = argparse.ArgumentParser(prog="heft analyze stability")
    add_arguments(parser)
    sys.exit(run(parser.parse_args()))
