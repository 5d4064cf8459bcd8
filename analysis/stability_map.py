"""Stability maps: a sweep's verdicts over one or two swept parameters, drawn side by
side for each value of a split parameter (by default the passivity controller off/on).

Input: a list of results, each ``{"point": {axis: value}, "verdict": str,
"growth_ratio": float, "bouncing": bool, ...}`` (as ``heft analyze stability`` makes).
Colour is the verdict of ``stability.oscillation_growth``; a cross marks a point
whose tool kept losing contact while pushed (a bouncing limit cycle).
"""

from __future__ import annotations

import json
from pathlib import Path

from heft.analysis.plotting import plt

VERDICT_COLOURS = {"decaying": "tab:green", "sustained": "tab:orange", "growing": "tab:red"}
LOG_SCALED = ("stiffness", "force_scale", "damping")


def _values(results, axis) -> list[float]:
    return sorted({r["point"][axis] for r in results})


def check_map_axes(results: list[dict], x: str, y: str | None, split: str | None) -> None:
    """ValueError unless every result has the map's axes, and they alone vary."""
    if not results:
        raise ValueError("no sweep results to draw")
    axes = [a for a in (x, y, split) if a]
    swept = set(results[0]["point"])
    missing = [a for a in axes if a not in swept]
    if missing:
        raise ValueError(f"map axis {', '.join(missing)} was not swept; swept: {', '.join(sorted(swept))}")
    extra = [a for a in swept - set(axes) if len(_values(results, a)) > 1]
    if extra:
        raise ValueError(f"swept axis {', '.join(extra)} varies but is not on the map; "
                         f"map at most two axes and one split (e.g. passivity)")


def stability_limits(results: list[dict], x: str, split: str | None = None) -> dict:
    """Per split value: the largest ``x`` up to which every point is stable and holds contact,
    and the smallest ``x`` at which some point is not (None where there is none)."""
    limits = {}
    for key in (_values(results, split) if split else [None]):
        rows = [r for r in results if split is None or r["point"][split] == key]
        good = [r for r in rows if r["stable"] and not r["bouncing"]]
        bad = [r["point"][x] for r in rows if r not in good]
        first_bad = min(bad) if bad else None
        below = [r["point"][x] for r in good if first_bad is None or r["point"][x] < first_bad]
        limits[str(key)] = {"last_good": max(below) if below else None, "first_bad": first_bad}
    return limits


def draw_stability_map(results: list[dict], x: str, y: str | None, out_dir, split: str | None = "passivity",
                       units: dict | None = None, predicted: dict | None = None) -> tuple[Path, Path]:
    """Writes stability_map.png and stability_map.json into ``out_dir``; returns their paths.
    ``predicted`` ({y value (0 without y): x limit}) draws a linear model's boundary on every panel."""
    if results and split not in results[0]["point"]:
        split = None
    check_map_axes(results, x, y, split)
    units = units or {}
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    keys = _values(results, split) if split else [None]
    figure, panels = plt.subplots(1, len(keys), figsize=(max(6.5, 5.2 * len(keys)), 4.6), sharey=True, squeeze=False)
    for panel, key in zip(panels[0], keys, strict=True):
        rows = [r for r in results if split is None or r["point"][split] == key]
        for r in rows:
            px, py = r["point"][x], r["point"][y] if y else 0.0
            panel.scatter(px, py, s=140, color=VERDICT_COLOURS[r["verdict"]], marker="X" if r["bouncing"] else "o",
                          edgecolors="black", linewidths=0.5)
            panel.annotate(f"{r['growth_ratio']:.2f}", (px, py), textcoords="offset points", xytext=(0, 9),
                           ha="center", fontsize=7)
        if predicted:
            levels = sorted(predicted)
            panel.plot([predicted[v] for v in levels], levels if y else [0.0] * len(levels), "k--", lw=1,
                       marker="|", markersize=14)
        if x in LOG_SCALED:
            panel.set_xscale("log")
        else:
            panel.tick_params(axis="x", labelrotation=30)
        if y in LOG_SCALED:
            panel.set_yscale("log")
        panel.set_xlabel(f"{x} ({units.get(x, '')})")
        if y:
            panel.set_ylabel(f"{y} ({units.get(y, '')})")
        else:
            panel.set_yticks([])
        if split:
            panel.set_title(f"passivity controller {'on' if key else 'off'}" if split == "passivity"
                            else f"{split} = {key:g}")
        panel.margins(x=0.08, y=0.15)
        panel.grid(alpha=0.3)
    handles = [plt.Line2D([], [], marker="o", ls="", color=c, label=v) for v, c in VERDICT_COLOURS.items()]
    handles.append(plt.Line2D([], [], marker="X", ls="", color="grey", label="tool bouncing off the wall"))
    if predicted:
        handles.append(plt.Line2D([], [], ls="--", color="black", label="linear model's limit (no PC)"))
    figure.legend(handles=handles, loc="lower center", ncol=4, fontsize=8)
    figure.suptitle("Oscillation growth of the master force\n(number: RMS ratio, last ÷ middle third)", fontsize=10)
    figure.tight_layout(rect=(0, 0.08, 1, 0.93))
    png = out / "stability_map.png"
    figure.savefig(png, dpi=110)
    plt.close(figure)
    document = {"x": x, "y": y, "split": split, "axes": {a: _values(results, a) for a in results[0]["point"]},
                "limits": stability_limits(results, x, split), "results": results,
                "predicted_limits": None if predicted is None else {str(k): v for k, v in predicted.items()}}
    path = out / "stability_map.json"
    path.write_text(json.dumps(document, indent=2) + "\n")
    return png, path
