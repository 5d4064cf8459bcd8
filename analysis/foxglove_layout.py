"""The Foxglove layout for heft's topics (``analysis.topics``), shipped as ``heft_layout.json``
beside this module: the 3-D scene and the station's faults on the left; on the right, tabs of
plots (wrenches, the hand, φ̂ and the offsets, passivity, joints, the excitation, the loop) and the load
commands' answers. It is in Foxglove's classic layout format, which Foxglove and Lichtblick
both import (Layouts → Import from file). ``python -m heft.analysis.foxglove_layout`` writes it.
"""

from __future__ import annotations

import json
from pathlib import Path

from heft.analysis.topics import FRAME_IDS, SCENE_WRENCHES

LAYOUT_FILE = Path(__file__).with_name("heft_layout.json")
XYZ = "xyz"


def _series(path: str, label: str) -> dict:
    return {"value": path, "enabled": True, "timestampMethod": "receiveTime", "label": label}


def _plot(title: str, series: list) -> dict:
    return {"paths": series, "foxglovePanelTitle": title, "showLegend": True, "legendDisplay": "floating",
            "showXAxisLabels": True, "showYAxisLabels": True, "isSynced": True, "xAxisVal": "timestamp"}


def _forces(topics: dict, part: str = "force") -> list:
    return [_series(f"{topic}.{part}.{axis}", f"{label} {axis}") for topic, label in topics.items() for axis in XYZ]


def _column(ids: list) -> dict | str:
    """A mosaic of ``ids`` one above the other, equal heights."""
    if len(ids) == 1:
        return ids[0]
    return {"direction": "column", "first": ids[0], "second": _column(ids[1:]), "splitPercentage": 100 / len(ids)}


def layout() -> dict:
    """The layout as Foxglove's JSON."""
    plots = {
        "Wrenches": {
            "contact": _plot("contact force, at S in S (N)", _forces({"/wrench/contact": "contact"})),
            "noncontact": _plot("non-contact and measured force, at S in S (N)",
                                _forces({"/wrench/noncontact": "non-contact", "/wrench/measured": "measured",
                                         "/truth/noncontact": "true non-contact"})),
            "torques": _plot("contact torque, at S in S (N·m)", _forces({"/wrench/contact": "contact"}, "torque"))},
        "Hand": {
            "hand": _plot("force on the hand, at E in B (N)",
                          _forces({"/hand/applied": "applied", "/hand/mapped": "mapped"})),
            "feedback": _plot("force fed back, in S (N)", _forces({"/wrench/feedback": "fed back"}))},
        "Estimate": {
            "mass": _plot("φ̂: mass (kg)", [_series("/estimate/phi.mass", "m̂"), _series("/truth/phi.mass", "m")]),
            "mass_std": _plot("φ̂: the mass's standard deviation (kg)", [_series("/estimate/phi.std[0]", "σ(m̂)")]),
            "moment": _plot("φ̂: m·c (kg·m)", [_series(f"/estimate/phi.first_moment.{a}", f"m·c {a}") for a in XYZ]),
            "offsets": _plot("offsets, force (N)", _forces({"/estimate/offsets": "offset"}))},
        "Passivity": {
            "energy": _plot("observed energy (J)", [_series(f"/passivity.energy.{k}", k)
                                                    for k in ("translational", "rotational")]),
            "damping": _plot("damping applied", [_series(f"/passivity.damping.{k}", k)
                                                 for k in ("translational", "rotational")])},
        "Joints": {
            "master": _plot("master joints (rad)", [_series(f"/master/joint_state.position[{i}]", f"q{i + 1}")
                                                    for i in range(6)]),
            "slave": _plot("slave joints (rad)", [_series(f"/slave/joint_state.position[{i}]", f"q{i + 1}")
                                                  for i in range(6)] +
                           [_series(f"/slave/command.position[{i}]", f"q̄{i + 1}") for i in range(6)])},
        "Identify": {
            "excitation": _plot("the excitation: share played, phase",
                                [_series("/identify/excitation.done", "played"),
                                 _series("/identify/excitation.phase", "phase")])},
        "Loop": {
            "hold": _plot("tick (s)", [_series("/loop.hold", "hold"), _series("/loop.compute", "compute")]),
            "gain": _plot("watchdog gain", [_series("/loop.gain", "gain")])},
    }
    config = {}
    tabs = []
    for title, panels in plots.items():
        ids = [f"Plot!{name}" for name in panels]
        config.update({f"Plot!{name}": panel for name, panel in panels.items()})
        tabs.append({"title": title, "layout": _column(ids)})
    config["Tab!plots"] = {"activeTabIdx": 0, "tabs": tabs}
    config["3D!scene"] = {
        "followTf": FRAME_IDS["R"], "followMode": "follow-pose", "scene": {}, "transforms": {},
        "topics": {SCENE_WRENCHES: {"visible": True}},
        "layers": {"grid": {"layerId": "foxglove.Grid", "visible": True, "frameId": FRAME_IDS["R"], "size": 4,
                            "divisions": 8}},
        "cameraState": {"distance": 3.0, "perspective": True, "phi": 60, "thetaOffset": 45,
                        "targetOffset": [0, 0, 0], "target": [0, 0, 0], "targetOrientation": [0, 0, 0, 1],
                        "fovy": 45, "near": 0.01, "far": 1000}}
    for name, topic in (("faults", "/faults"), ("load", "/load/status")):
        config[f"RawMessages!{name}"] = {"topicPath": topic, "diffEnabled": False, "expansion": "all"}
    return {
        "configById": config, "globalVariables": {}, "userNodes": {}, "playbackConfig": {"speed": 1},
        "layout": {"direction": "row", "splitPercentage": 35,
                   "first": {"direction": "column", "first": "3D!scene", "second": "RawMessages!faults",
                             "splitPercentage": 70},
                   "second": {"direction": "column", "first": "Tab!plots", "second": "RawMessages!load",
                              "splitPercentage": 80}},
    }


def layout_text() -> str:
    return json.dumps(layout(), indent=2, ensure_ascii=False) + "\n"


if __name__ == "__main__":
    LAYOUT_FILE.write_text(layout_text())
    print(f"wrote {LAYOUT_FILE}")
