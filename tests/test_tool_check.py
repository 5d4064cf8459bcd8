"""Tools the simulated station refuses before any simulation, in one line: an inertia no body of
that mass has, a tool the sensor cannot carry at rest (``diagrams/tool_check.py``); and that no
tool of the family (``tests/tool_family.py``) is refused by the first."""

import numpy as np
import pytest
import yaml
from pydrake.multibody.tree import SpatialInertia

from heft.diagrams.cli import main
from heft.diagrams.commands import exit_status
from heft.diagrams.scenario import LoadSpec
from heft.diagrams.tool_check import DENSEST, check_inertia, least_moment_sum
from tool_family import TOOLS

POINT_LIKE_ROD = {"kind": "custom", "mass": 0.72, "com": [0.0, 0.0, 0.18],
                  "inertia_com": [1.0e-6, 0.0, 0.0, 1.0e-6, 0.0, 1.0e-6]}
"""A 0.72 kg 'thin rod' given as a point mass 0.18 m from S: on the compliant mount it crashed
`heft identify` in Drake's step ("mass matrix … not positive-definite")."""


def moment_sum(inertia) -> float:
    """The sum of the two smallest principal moments of a 3×3 inertia (kg·m²)."""
    principal = np.linalg.eigvalsh(inertia)
    return principal[0] + principal[1]


def test_the_least_moments_are_those_of_the_densest_ball_spread_least():
    """A ball of osmium has J₁ + J₂ = 0.8·m·R², above the bound's 0.6·m·R² (∫|r|² dm); a tungsten ball,
    a thin rod of that mass and every tool of the family lie above it too."""
    for mass in (0.1, 0.72, 10.0):
        radius = (3 * mass / (4 * np.pi * DENSEST)) ** (1 / 3)
        ball = SpatialInertia.SolidSphereWithDensity(DENSEST, radius)
        assert ball.get_mass() == pytest.approx(mass, rel=1e-12)
        inertia = ball.CalcRotationalInertia().CopyToFullMatrix3()
        assert moment_sum(inertia) == pytest.approx(least_moment_sum(mass) * 0.8 / 0.6, rel=1e-12)
        tungsten = SpatialInertia.SolidSphereWithMass(mass, (3 * mass / (4 * np.pi * 19250.0)) ** (1 / 3))
        assert moment_sum(tungsten.CalcRotationalInertia().CopyToFullMatrix3()) > least_moment_sum(mass)
    for tool in TOOLS:
        assert moment_sum(tool.inertia_com) > least_moment_sum(tool.mass), tool
        I = tool.inertia_com
        check_inertia(LoadSpec(kind="custom", mass=tool.mass, com=tool.com.tolist(),
                               inertia_com=[I[0, 0], I[0, 1], I[0, 2], I[1, 1], I[1, 2], I[2, 2]]))


def test_an_inertia_no_body_has_is_refused_in_one_line_before_any_simulation(tmp_path, capsys):
    scenario = tmp_path / "rod.yaml"
    scenario.write_text(yaml.safe_dump({"load": POINT_LIKE_ROD}))
    code = main(["identify", "--scenario", str(scenario), "--quick", "--out", str(tmp_path / "out")])
    error = capsys.readouterr().err.strip()
    assert code == exit_status.USAGE and "\n" not in error and "Traceback" not in error, error
    assert "load.inertia_com" in error and "0.72 kg" in error and "kg·m²" in error, error
    assert not (tmp_path / "out" / "metrics.json").exists()  # refused before the excitation ran


def test_a_tool_the_sensor_cannot_carry_is_refused_in_one_line_before_any_simulation(tmp_path, capsys):
    """The family's heaviest tool far off S: 24 N·m of static moment on a 12 N·m sensor."""
    (tool,) = [t for t in TOOLS if t.name == "heavy offset block"]
    I = tool.inertia_com
    load = {"kind": "custom", "mass": float(tool.mass), "com": tool.com.tolist(),
            "inertia_com": [float(I[i, j]) for i, j in ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))]}
    scenario = tmp_path / "heavy.yaml"
    scenario.write_text(yaml.safe_dump({"load": load}))
    code = main(["simulate", str(scenario), "--sigma", "0", "--out", str(tmp_path / "out")])
    error = capsys.readouterr().err.strip()
    assert code == exit_status.USAGE and "\n" not in error and "Traceback" not in error, error
    assert "static moment" in error and "12 N·m" in error and "ft_sensor.full_scale" in error, error
    assert not (tmp_path / "out" / "identify" / "metrics.json").exists()
