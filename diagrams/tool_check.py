"""What the simulated station refuses to carry, before any simulation, each in one line that says
what was wrong and what to do: a custom tool no body could be, and a tool the force-torque sensor
or the arm cannot take even at rest.

Any body of mass m has J₁ + J₂ ≥ ∫|r − c|² dm ≥ (3/5)·m·R² for its two smallest principal moments
about its centre of mass (J₁ + J₂ = ∫|r − c|² dm + ∫(r − c)₃² dm along the largest one's axis): a given
mass spreads least as a ball of the densest matter, R = (3m / 4πρ)^(1/3). ρ is osmium's, the densest
element. An inertia below that is a typing or unit error (g·cm² is 10⁻⁷ kg·m²) or a point mass, which
no tool is; on the compliant mount it pivoted about its own centre of mass faster than any step.
"""

from __future__ import annotations

import math

import numpy as np

from heft.diagrams.scenario import LoadSpec, Scenario
from heft.systems.load_dynamics import GRAVITY_W, inertia_matrix

DENSEST = 22590.0
"""Osmium's density (kg/m³), the densest element (CRC Handbook of Chemistry and Physics, "Physical
constants of inorganic compounds": 22.59 g/cm³)."""


def least_moment_sum(mass: float) -> float:
    """The least sum of the two smallest principal moments about the centre of mass (kg·m²) that a
    body of ``mass`` (kg) can have: a ball of the densest element (see the module's notes)."""
    radius = (3 * mass / (4 * math.pi * DENSEST)) ** (1 / 3)
    return 0.6 * mass * radius ** 2


def check_inertia(load: LoadSpec) -> None:
    """Raises ValueError (one line) if the custom load's inertia about its centre of mass is smaller
    than any body of its mass has (``least_moment_sum``)."""
    principal = np.linalg.eigvalsh(inertia_matrix(load.inertia_com))
    least = least_moment_sum(load.mass)
    if principal[0] + principal[1] < least:
        raise ValueError(
            f"scenario field 'load.inertia_com' gives principal moments {np.array2string(principal, precision=3)} "
            f"kg·m² about the centre of mass, but no body of {load.mass:g} kg has its two smallest sum below "
            f"{least:.2g} kg·m² (a ball of osmium, the densest element): give the tool's inertia about its centre "
            f"of mass in kg·m², e.g. m·L²/12 across a rod of length L")


def check_carried(scenario: Scenario, phi, payload: float, arm: str) -> None:
    """Raises ValueError (one line) if the load of inertial parameters ``phi`` (Eq. 6, about S) is
    beyond what the scenario's force-torque sensor measures at rest (its weight m·|g| against the
    forces' full scale, its static moment m·|c|·|g| against the torques') or beyond the arm's rated
    ``payload`` (kg; ``arm`` its name)."""
    mass, com = phi[0], np.asarray(phi[1:4]) / phi[0]
    gravity = float(np.linalg.norm(GRAVITY_W))
    force_range, torque_range = min(scenario.ft_sensor.full_scale[:3]), min(scenario.ft_sensor.full_scale[3:])
    weight, moment = mass * gravity, mass * gravity * float(np.linalg.norm(com))
    if weight > force_range:
        raise ValueError(f"the {mass:.3g} kg load weighs {weight:.4g} N, beyond the force-torque sensor's "
                         f"{force_range:g} N range (ft_sensor.full_scale): it cannot carry it even at rest; "
                         f"choose a lighter tool or state a sensor of larger range")
    if moment > torque_range:
        raise ValueError(f"the {mass:.3g} kg load's static moment m·g·|c| = {moment:.3g} N·m (its centre of mass "
                         f"{1e3 * np.linalg.norm(com):.0f} mm from S) is beyond the force-torque sensor's "
                         f"{torque_range:g} N·m range (ft_sensor.full_scale): it cannot carry it even at rest; "
                         f"mount the tool nearer the sensor, choose a lighter one, or state a sensor of larger range")
    if mass > payload:
        raise ValueError(f"the {mass:.3g} kg load is beyond the {arm}'s rated payload of {payload:g} kg: "
                         f"choose a lighter tool or a stronger arm")
