"""Identification of the tool family (``tests/tool_family.py``) in the default, realistic
station: every tool the sensor and the arm carry comes out as well as the paper's tool does
with the same excitation, the errors scaled to the tool; a tool beyond them is refused in one
line, by the station before any simulation (beyond the sensor's range at rest) or by the fit's
verdict (saturating it in the excitation); none ends in a traceback."""

import json

import numpy as np
import pytest

from heft.diagrams.identify import identify
from heft.diagrams.running.sim_identification import simulated_recorder
from heft.diagrams.scenario import Scenario, layered, overrides_text
from heft.systems.identification.excitation import ExcitationSettings
from tool_family import TOOLS

# How far a tool's errors may exceed the paper tool's, scaled to the tool (see ``allowed``): the
# spread of one 2 s noisy excitation's errors is about that wide.
MARGIN = 5.0


def excitation() -> ExcitationSettings:
    """A short excitation (2 s), as tests/test_identify.py runs."""
    settings = ExcitationSettings.quick()
    settings.base_frequency, settings.duration = 0.5, 2.0
    return settings


def run(scenario, out):
    """(metrics, refused): ``identify`` with TLS; refused is the ValueError of a refused fit or of a
    tool refused before the simulation (metrics None), if any."""
    try:
        return identify(scenario, out, simulated_recorder(scenario), method="tls", settings=excitation()), None
    except ValueError as error:
        written = out / "metrics.json"
        return (json.loads(written.read_text()) if written.exists() else None), error


def allowed(reference, phi_reference, phi) -> dict:
    """The errors a tool of inertial parameters ``phi`` may have, from the paper tool's (``reference``).
    Each of m, m·c and I_S comes out to an absolute error set by the sensors' noise and by the
    mount's rocking, which grows with the load's weight and its static moment m·|c|: that error
    may be ``MARGIN`` times the paper tool's, times the larger of those two ratios (at least 1).
    The COM (m·c / m) and the relative inertia (ΔI_S / |I_S|) then grow for a lighter tool."""
    norm = lambda p: np.linalg.norm([p[4], p[7], p[9], p[5], p[6], p[8]])
    load = max(1.0, phi[0] / phi_reference[0],
               np.linalg.norm(phi[1:4]) / np.linalg.norm(phi_reference[1:4]))
    return {"mass_kg": MARGIN * reference["mass_kg"] * load,
            "com_m": MARGIN * reference["com_m"] * load * phi_reference[0] / phi[0],
            "inertia_relative": MARGIN * reference["inertia_relative"] * load * norm(phi_reference) / norm(phi)}


@pytest.mark.slow
def test_the_family_identifies_in_the_default_station(tmp_path):
    reference, _ = run(Scenario(), tmp_path / "paper_tool")
    phi_reference = np.array(reference["phi_true"])
    rows, failures = [], []
    for i, tool in enumerate(TOOLS):
        metrics, refused = run(layered(Scenario(), overrides_text(tool.overrides())), tmp_path / f"tool{i}")
        if refused is not None and "\n" in str(refused):
            failures.append(f"{tool}: refused in more than one line: {refused}")
        if metrics is None:  # refused before the simulation
            rows.append(f"{str(tool):50s} refused before the simulation: {refused}")
            if tool.within_ranges():
                failures.append(f"{tool} is within the ranges and was refused before the simulation: {refused}")
            continue
        verdict = metrics.get("fit_verdict")
        errors = metrics["errors"]["tls"]
        rows.append(f"{str(tool):50s} {1e3 * errors['mass_kg']:7.2f} g {1e3 * errors['com_m']:7.3f} mm "
                    f"{100 * errors['inertia_relative']:6.2f} %  {'refused' if refused else 'accepted'}")
        if tool.within_ranges():
            limits = allowed(reference["errors"]["tls"], phi_reference, np.array(metrics["phi_true"]))
            if refused or any(errors[k] > limits[k] for k in limits):
                failures.append(f"{tool}: errors {errors}, allowed {limits}, refused: {refused}")
        elif verdict is not None and (verdict["ok"] or refused is None):
            failures.append(f"{tool} is beyond the sensor's range and was accepted: {verdict}")
    e = reference["errors"]["tls"]
    print(f"paper's tool: {1e3 * e['mass_kg']:.2f} g {1e3 * e['com_m']:.3f} mm {100 * e['inertia_relative']:.2f} %")
    print("\n".join(rows))
    assert not failures, "\n".join(failures)
