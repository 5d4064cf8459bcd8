"""Port energy and passivity-controller summaries on signals with known answers."""

import numpy as np
import pytest

from heft.analysis.passivity_analysis import (active_intervals, passivity_controller_summary,
                                              passivity_figure, passivity_summary, port_energy,
                                              stylus_twist)

T = 5e-4


def damper_log(b=3.0, b_rot=0.01, duration=1.0):
    """Stylus moving sinusoidally against a pure damper wrench −b·v, −b_rot·ω."""
    t = np.arange(0.0, duration, T)
    twist = np.zeros((t.size, 6))
    twist[:, 0] = 0.2 * np.sin(2 * np.pi * 2 * t)
    twist[:, 1] = 0.1 * np.cos(2 * np.pi * 3 * t)
    twist[:, 5] = 1.5 * np.sin(2 * np.pi * 1 * t)
    wrench = np.concatenate((-b * twist[:, :3], -b_rot * twist[:, 3:]), axis=1)
    return t, wrench, twist


def test_damper_port_energy_is_dissipated_energy():
    b, b_rot = 3.0, 0.01
    t, wrench, twist = damper_log(b, b_rot)
    rectangle = port_energy(t, wrench, twist)
    assert (np.diff(rectangle, axis=0) >= 0).all() and (rectangle >= 0).all()
    speed2 = np.stack(((twist[:, :3] ** 2).sum(1), (twist[:, 3:] ** 2).sum(1)), axis=1)
    np.testing.assert_allclose(rectangle[-1], np.array((b, b_rot)) * speed2.sum(0) * T, rtol=1e-12)
    # ∫ b v² dt over whole periods: b·(0.2²/2 + 0.1²/2)·1 s and b_rot·1.5²/2·1 s.
    exact = np.array((b * (0.02 + 0.005), b_rot * 1.125))
    np.testing.assert_allclose(port_energy(t, wrench, twist, method="trapezoid")[-1], exact, rtol=2e-3)
    np.testing.assert_allclose(rectangle[-1], exact, rtol=2e-3)
    assert port_energy(t, wrench, twist, period=T)[-1] == pytest.approx(rectangle[-1])


def test_active_wrench_shows_negative_energy_and_bad_method():
    t, wrench, twist = damper_log()
    assert (port_energy(t, -wrench, twist)[-1] < 0).all()
    with pytest.raises(ValueError):
        port_energy(t, wrench, twist, method="simpson")


def test_stylus_twist_from_jacobians():
    rng = np.random.default_rng(0)
    jacobians, qdot = rng.normal(size=(4, 6, 6)), rng.normal(size=(4, 6))
    expected = np.stack([j @ q for j, q in zip(jacobians, qdot)])
    np.testing.assert_allclose(stylus_twist(jacobians.reshape(4, 36), qdot), expected)


def test_active_intervals():
    t = np.arange(10) * 0.1
    active = np.array([0, 1, 1, 0, 0, 1, 0, 0, 1, 1], dtype=bool)
    np.testing.assert_allclose(active_intervals(t, active), [(0.1, 0.3), (0.5, 0.6), (0.8, 1.0)])
    assert active_intervals(t, np.zeros(10, bool)) == []


def test_pc_summary_on_synthetic_damping():
    t = np.arange(2000) * T
    damping = np.zeros((t.size, 2))
    on = (np.arange(t.size) >= 400) & (np.arange(t.size) < 600)       # 0.2 s to 0.3 s
    damping[on, 0] = 2.0
    damping[500:520, 0] = 5.0                                          # 0.25 s to 0.26 s
    energy = np.zeros((t.size, 2))
    energy[:, 0] = np.where(on, -1e-3, 1e-3)
    energy[:, 1] = 0.5
    twist = np.zeros((t.size, 6))
    twist[:, 0] = 0.1
    twist[:, 4] = 2.0
    summary = passivity_controller_summary(t, damping, energy, twist)
    np.testing.assert_allclose(summary["translational_intervals"], [(0.2, 0.3)])
    assert summary["translational_first_active_s"] == pytest.approx(0.2)
    assert summary["translational_active_s"] == pytest.approx(0.1)
    assert summary["translational_active_fraction"] == pytest.approx(0.1)
    assert summary["translational_peak_damping"] == 5.0
    # Σ α|v|²T: 0.09 s at 2 N·s/m and 0.01 s at 5 N·s/m, |v|² = 0.01 m²/s².
    assert summary["translational_dissipated_J"] == pytest.approx((2.0 * 0.09 + 5.0 * 0.01) * 0.01)
    assert summary["translational_min_energy_J"] == pytest.approx(-1e-3)
    assert summary["rotational_intervals"] == [] and summary["rotational_first_active_s"] is None
    assert summary["rotational_dissipated_J"] == 0.0 and summary["rotational_final_energy_J"] == 0.5
    assert "translational_dissipated_J" not in passivity_controller_summary(t, damping, energy)


def test_log_summary_and_figure(tmp_path):
    t, wrench, twist = damper_log()
    log = {"t": t, "master_force": wrench, "passivity_energy": port_energy(t, wrench, twist),
           "passivity_damping": np.zeros((t.size, 2))}
    summary = passivity_summary(log, twist)
    assert summary["translational_port_energy_final_J"] == pytest.approx(
        summary["translational_final_energy_J"])
    assert summary["rotational_port_energy_min_J"] >= 0.0
    path = tmp_path / "passivity.png"
    passivity_figure(log, path, twist, title="damper")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
