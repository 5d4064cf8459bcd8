"""A family of tools a lab would mount on the wrist sensor: rods, handles, blocks and discs of
steel and aluminium, 0.1–10 kg, centres of mass up to 0.25 m from S, each composed of
homogeneous solids in closed form (``diagrams/models/make_tool_inertia.py``: box
m(b² + c²)/12, cylinder m r²/2 about its axis and m(3r² + L²)/12 across it, the parallel-axis
theorem; the tables of e.g. Meriam & Kraige, Engineering Mechanics: Dynamics, Appendix B).
Densities are SOURCES.md's standard values (steel 7850, aluminium 2700 kg/m³), and tungsten's
19 250 kg/m³ (CRC Handbook of Chemistry and Physics, "Physical constants of inorganic compounds")
for the dense end masses of balancing and impact tools. Geometry starts
at the sensor's tool face, 17.5 mm below S along z (``JR3_S_TO_TOOL_FACE``). A tilted tool is its
parts' composite turned about S's y axis (I' = R·I·Rᵀ), so that it has products of inertia.

``within_ranges`` says which tools the JR3 and the RX90 can carry through an excitation.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from pydrake.math import RotationMatrix

from heft.diagrams.models.make_tool_inertia import ALUMINIUM, JR3_S_TO_TOOL_FACE, STEEL, Solid, compose

Z0 = JR3_S_TO_TOOL_FACE  # m, the sensor's tool face below S
TUNGSTEN = 19250.0  # kg/m³ (CRC Handbook; see the module's notes)
GRAVITY = 9.81  # m/s²
# The JR3 200N12's range (systems/station/sensor_models.py: 200 N, 12 N·m); the RX90's payload
# (diagrams/models/SOURCES.md: 6 kg nominal, 12 kg max).
FT_TORQUE_RANGE = 12.0  # N·m
RX90_PAYLOAD_MAX = 12.0  # kg
# Of the sensor's torque range, the share a tool's weight may take at rest in the worst
# orientation (m·g·|c|): the excitation's inertial wrench needs the rest (the paper's tool
# peaks at about 2.3 times its static moment).
STATIC_MOMENT_SHARE = 0.5


@dataclasses.dataclass(frozen=True)
class Tool:
    """One tool: its solids in S (m), and a turn about S's y axis (rad) applied to the whole."""
    name: str
    shape: str                  # "rod", "handle", "block" or "disc"
    parts: tuple
    tilt: float = 0.0

    def _composite(self):
        mass, com, inertia = compose(self.parts)
        R = RotationMatrix.MakeYRotation(self.tilt).matrix()
        return mass, R @ com, R @ inertia @ R.T

    @property
    def mass(self) -> float:
        return self._composite()[0]

    @property
    def com(self) -> np.ndarray:
        """p_SC_S (m)."""
        return self._composite()[1]

    @property
    def inertia_com(self) -> np.ndarray:
        """About the COM, in S's axes (kg·m², 3×3)."""
        return self._composite()[2]

    def overrides(self) -> dict:
        """For ``overrides_text``: this tool as the scenario's custom load."""
        I = self.inertia_com
        return {"load.kind": "custom", "load.mass": self.mass, "load.com": self.com.tolist(),
                "load.inertia_com": [float(I[i, j]) for i, j in ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))]}

    def static_moment(self) -> float:
        """The largest moment of its weight about S, in the worst orientation (N·m)."""
        return self.mass * GRAVITY * float(np.linalg.norm(self.com))

    def within_ranges(self) -> bool:
        """Whether the JR3 and the RX90 carry it through an excitation (see the module's constants)."""
        return (self.static_moment() <= STATIC_MOMENT_SHARE * FT_TORQUE_RANGE
                and self.mass <= RX90_PAYLOAD_MAX)

    def __str__(self) -> str:
        return f"{self.name} ({self.mass:.2f} kg, COM {1e3 * np.linalg.norm(self.com):.0f} mm from S)"


def _rod(name, material, diameter, length, axis="z", at=(0.0, 0.0)):
    """A cylinder of ``diameter``×``length`` starting at the tool face: along z, on S's axis
    (``at``: its x, y), or lying across along x (``axis`` "x") from the axis outwards."""
    r = diameter / 2
    if axis == "z":
        return Solid(name, "cylinder", (r, length), (at[0], at[1], Z0 + length / 2), density=material)
    return Solid(name, "cylinder", (r, length), (length / 2, 0.0, Z0 + r), density=material, axis="x")


def _box(name, material, size, center):
    return Solid(name, "box", tuple(size), tuple(center), density=material)


def _on_stem(material, stem_diameter, stem_length, end):
    """(a stem of ``material`` along z from the tool face, a compact mass at its end): ``end`` makes
    that mass's Solid from the z (m, in S) where the stem ends."""
    return _rod("stem", material, stem_diameter, stem_length), end(Z0 + stem_length)


def _ball(material, radius):
    """A ball of ``material`` whose surface touches the stem's end at z (m): for ``_on_stem``."""
    return lambda z: Solid("ball", "sphere", (radius,), (0.0, 0.0, z + radius), density=material)


def _slug(material, diameter, length):
    """A cylinder along z (a hammer's head) starting at the stem's end: for ``_on_stem``."""
    return lambda z: Solid("slug", "cylinder", (diameter / 2, length), (0.0, 0.0, z + length / 2), density=material)


def _family() -> list[Tool]:
    stem = _rod("stem", ALUMINIUM, 0.020, 0.150)
    offset_arm = _box("arm", ALUMINIUM, (0.25, 0.03, 0.02), (0.125, 0.0, Z0 + 0.01))
    return [
        Tool("thin rod", "rod", (_rod("rod", ALUMINIUM, 0.0105, 0.46),)),
        # Compact masses far out on light stems: with the mount's compliance at S they pivoted
        # about their own centre of mass beyond the step (docs/scenarios.md, "Any tool on the mount").
        Tool("tungsten ball on a stem", "block", _on_stem(ALUMINIUM, 0.006, 0.21, _ball(TUNGSTEN, 0.012))),
        Tool("steel block on a stem", "block", _on_stem(ALUMINIUM, 0.008, 0.20, lambda z: _box(
            "block", STEEL, (0.04, 0.04, 0.04), (0.0, 0.0, z + 0.02)))),
        Tool("steel ball on a stem", "block", _on_stem(STEEL, 0.010, 0.16, _ball(STEEL, 0.025))),
        Tool("thin rod with a tungsten end", "rod", _on_stem(STEEL, 0.008, 0.15,
                                                             _slug(TUNGSTEN, 0.030, 0.0485))),
        # As a lab writes it down having weighed the ball alone: 0.1 kg a quarter metre out, its
        # stem left out. With the compliance at S this crashed Drake's step.
        Tool("tungsten ball, its stem left out", "block",
             (Solid("ball", "sphere", (0.0108,), (0.0, 0.0, 0.25), density=TUNGSTEN),)),
        Tool("crosswise rod", "rod", (_rod("rod", ALUMINIUM, 0.013, 0.30, axis="x"),)),
        Tool("T-handle", "handle", (stem, Solid("grip", "cylinder", (0.015, 0.12), (0.0, 0.0, Z0 + 0.165),
                                                density=ALUMINIUM, axis="y"))),
        Tool("tilted T-handle", "handle", (stem, Solid("grip", "cylinder", (0.015, 0.12), (0.0, 0.0, Z0 + 0.165),
                                                       density=ALUMINIUM, axis="y")), tilt=math.radians(30)),
        Tool("aluminium disc", "disc", (_rod("disc", ALUMINIUM, 0.10, 0.010),)),
        Tool("L-handle", "handle", (_rod("stem", STEEL, 0.016, 0.10),
                                    Solid("grip", "cylinder", (0.016, 0.14), (0.07, 0.0, Z0 + 0.116),
                                          density=STEEL, axis="x"))),
        Tool("offset block", "block", (offset_arm, _box("block", ALUMINIUM, (0.05, 0.05, 0.05),
                                                        (0.225, 0.0, Z0 + 0.025)))),
        Tool("aluminium block", "block", (_box("block", ALUMINIUM, (0.12, 0.08, 0.10), (0.0, 0.0, Z0 + 0.05)),)),
        Tool("steel disc", "disc", (_rod("disc", STEEL, 0.20, 0.010),)),
        Tool("aluminium rod", "rod", (_rod("rod", ALUMINIUM, 0.040, 0.40),)),
        Tool("steel cube", "block", (_box("block", STEEL, (0.08, 0.08, 0.08), (0.0, 0.0, Z0 + 0.04)),)),
        Tool("offset steel block", "block", (offset_arm, _box("block", STEEL, (0.06, 0.06, 0.08),
                                                              (0.22, 0.0, Z0 + 0.04)))),
        Tool("steel block", "block", (_box("block", STEEL, (0.10, 0.10, 0.10), (0.0, 0.0, Z0 + 0.05)),)),
        Tool("large steel disc", "disc", (_rod("disc", STEEL, 0.25, 0.026),)),
        Tool("heavy offset block", "block", (offset_arm, _box("block", STEEL, (0.10, 0.10, 0.125),
                                                              (0.23, 0.0, Z0 + 0.0625)))),
    ]


TOOLS = sorted(_family(), key=lambda tool: tool.mass)
"""The family, lightest first."""
