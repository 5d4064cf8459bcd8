"""Stability rule, Llewellyn's criterion and the virtual-wall stiffness limit against
systems with known answers."""

import math

import numpy as np
import pytest

from heft.analysis.stability import (llewellyn_absolutely_stable, oscillation_growth,
                                     virtual_wall_stiffness_limit)


def simulate_virtual_wall(stiffness, mass=1.0, damping=10.0, period=1e-3, push=1.0, duration=3.0):
    """A mass m (kg) with physical damping b (N·s/m), pushed into a virtual wall at x = 0
    by a constant force (N) and held there by the sampled spring −K·x (zero-order hold,
    period T). Between samples the motion is integrated exactly. Returns (t, x)."""
    steps = round(duration / period)
    x, v = 0.0, 0.1
    decay = math.exp(-damping * period / mass)
    xs = np.empty(steps)
    for k in range(steps):
        xs[k] = x
        force = push - stiffness * x
        v_inf = force / damping
        x += v_inf * period + (v - v_inf) * mass / damping * (1.0 - decay)
        v = v_inf + (v - v_inf) * decay
    return np.arange(steps) * period, xs


def test_virtual_wall_limit():
    assert virtual_wall_stiffness_limit(10.0, 1e-3) == pytest.approx(2e4)
    assert virtual_wall_stiffness_limit(10.0, 1e-3, virtual_damping=-4.0) == pytest.approx(1.2e4)
    assert virtual_wall_stiffness_limit(1.0, 1e-3, virtual_damping=2.0) == 0.0
    with pytest.raises(ValueError):
        virtual_wall_stiffness_limit(1.0, 0.0)


@pytest.mark.parametrize("factor, stable", [(0.5, True), (2.0, False)])
def test_sampled_virtual_wall_verdict(factor, stable):
    limit = virtual_wall_stiffness_limit(10.0, 1e-3)
    t, x = simulate_virtual_wall(factor * limit)
    result = oscillation_growth(t, x)
    assert result.stable is stable
    assert result.verdict == ("decaying" if stable else "growing")
    # Effective damping b − K·T/2 (the hold's half-sample delay): envelope rate −(b − KT/2)/2m.
    expected_rate = -(10.0 - factor * limit * 1e-3 / 2) / 2.0
    assert result.growth_rate == pytest.approx(expected_rate, rel=0.15)


@pytest.mark.parametrize("rate, verdict", [(-1.0, "decaying"), (0.0, "sustained"), (1.0, "growing")])
def test_sinusoid_verdicts(rate, verdict):
    t = np.arange(0.0, 3.0, 1e-3)
    x = 0.5 + 0.2 * t + np.exp(rate * t) * np.sin(2 * np.pi * 7.3 * t)   # offset and drift are the trend
    result = oscillation_growth(t, x)
    assert result.verdict == verdict
    assert result.stable is (verdict != "growing")
    assert result.growth_rate == pytest.approx(rate, abs=0.05)


def test_quiet_floor_and_multichannel():
    t = np.arange(0.0, 3.0, 1e-3)
    assert oscillation_growth(t, np.full_like(t, 2.0)).verdict == "decaying"
    burst = np.where(t > 2.0, np.sin(2 * np.pi * 10 * t), 0.0)
    assert oscillation_growth(t, burst).verdict == "growing"
    noise = 1e-4 * np.sin(2 * np.pi * 50 * t) * np.exp(t)
    assert oscillation_growth(t, noise, quiet=1e-2).verdict == "decaying"
    both = np.stack((np.sin(2 * np.pi * 5 * t), np.exp(t) * np.cos(2 * np.pi * 5 * t)), axis=1)
    assert oscillation_growth(t, both).verdict == "growing"


def test_llewellyn_textbook_two_ports():
    n = 50
    zero, one = np.zeros(n), np.ones(n)
    # Ideal transparent teleoperator: f_h = f_e, v_e = −v_h → marginally absolutely stable.
    stable, per_frequency = llewellyn_absolutely_stable(zero, one, -one, zero)
    assert stable and per_frequency.all()
    # Negative input resistance: active at port 1.
    w = np.linspace(0.1, 100.0, n)
    assert not llewellyn_absolutely_stable(-1.0 + 1j * w, zero, zero, one)[0]
    # Passive ports but too much forward/backward gain: 2·1·1 − 4 − 4 < 0.
    assert not llewellyn_absolutely_stable(one, 2 * one, 2 * one, one)[0]
    # A series resistor between two ports (reciprocal, passive).
    assert llewellyn_absolutely_stable(one, one, -one, zero)[0]
    # Failing at one frequency only fails the grid, and the per-frequency flags show where.
    h11 = np.where(w > 50.0, -0.1, 1.0)
    stable, per_frequency = llewellyn_absolutely_stable(h11, zero, zero, one)
    assert not stable and per_frequency.tolist() == (w <= 50.0).tolist()
