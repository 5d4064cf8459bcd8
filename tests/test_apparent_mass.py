"""Apparent mass: the estimator on signals with known answers, and the closed loop's
rendered mass against k_f·s·σ·m."""

import numpy as np
import pytest

from heft.analysis.apparent_mass import estimate_apparent_mass, fit_apparent_mass, hand_mass

T = 5e-4


def test_fit_matches_closed_form_regression_statistics():
    rng = np.random.default_rng(1)
    t = np.arange(0.0, 4.0, T)
    acceleration = 8.0 * np.sin(2 * np.pi * 2.5 * t) + 3.0 * np.sin(2 * np.pi * 7.5 * t + 0.3)
    mass, offset, noise = 0.357, -1.75, 0.2
    force = -mass * acceleration + offset + noise * rng.normal(size=t.size)
    fit = fit_apparent_mass(force, acceleration, correlated=False)
    spread = acceleration - acceleration.mean()
    standard_error = noise / np.sqrt(spread @ spread)  # σ_e / √Σ(a − ā)², exact for white noise
    assert abs(fit.mass - mass) < 4 * standard_error
    half_width = 0.5 * (fit.interval[1] - fit.interval[0])
    assert half_width == pytest.approx(1.959964 * standard_error, rel=0.05)
    assert fit.offset == pytest.approx(offset, abs=4 * noise / np.sqrt(t.size))
    assert fit.residual_rms == pytest.approx(noise, rel=0.05)
    # White residuals: the autocorrelation correction barely widens the interval.
    correlated = fit_apparent_mass(force, acceleration)
    assert correlated.interval[1] - correlated.interval[0] == pytest.approx(2 * half_width, rel=0.1)


@pytest.mark.parametrize("smoothing", [0.005, 0.03])
def test_estimate_from_quantized_positions(smoothing):
    """Position quantized to 10 µm, force noisy: the same zero-phase filter on both sides
    keeps m_a unbiased even where it visibly attenuates the motion (smoothing 0.03 s)."""
    rng = np.random.default_rng(2)
    t = np.arange(0.0, 3.0, T)
    w1, w2 = 2 * np.pi * 2.5, 2 * np.pi * 6.0
    position = 0.014 * np.sin(w1 * t) + 0.002 * np.cos(w2 * t)
    acceleration = -0.014 * w1 ** 2 * np.sin(w1 * t) - 0.002 * w2 ** 2 * np.cos(w2 * t)
    mass = 0.7154
    force = -mass * acceleration - 3.5 + 0.05 * rng.normal(size=t.size)
    fit = estimate_apparent_mass(t, force, np.round(position / 1e-5) * 1e-5, smoothing=smoothing)
    assert fit.mass == pytest.approx(mass, rel=0.005)
    assert fit.interval[0] < mass < fit.interval[1]
    assert fit.offset == pytest.approx(-3.5, abs=0.02)


def test_bad_input_is_refused():
    t = np.arange(0.0, 1.0, T)
    with pytest.raises(ValueError, match="does not vary"):
        fit_apparent_mass(np.ones(t.size), np.full(t.size, 2.0))
    with pytest.raises(ValueError, match="one length"):
        fit_apparent_mass(np.ones(5), np.ones(4))
    with pytest.raises(ValueError, match="uniformly"):
        estimate_apparent_mass(t[::-1], np.sin(t), np.sin(t))
    with pytest.raises(ValueError, match="too few"):
        estimate_apparent_mass(t[:20], t[:20], t[:20])


@pytest.fixture(scope="module")
def fig6():
    from heft.diagrams.scenario import NOISE_OFF, overrides_text, resolve_scenario
    return resolve_scenario("fig6", overrides_text(NOISE_OFF))


def test_short_sigma_one_run_renders_the_scaled_mass(fig6):
    """One 0.8 s closed-loop run, σ = 1: the force at the handle over the sensor's true
    acceleration mapped back (÷ s) is k_f·s·m to 1 %; over the handle's own acceleration
    (slave tracking lag included) to 10 %."""
    from heft.diagrams.scenario import layered
    from heft.diagrams.studies.apparent_mass import fit_run
    from heft.diagrams.running.simulation import true_load
    from heft.diagrams.running.simulation import run_teleop, with_sigma
    scenario = layered(fig6, "{duration: 0.8, operator: {amplitude: [0.0, 0.0, 0.028]}}")
    load, _ = true_load(scenario)
    fits = fit_run(scenario, run_teleop(with_sigma(scenario, 1.0), load, quiet=True))
    expected = hand_mass(1.0, 3.13, 1 / 17.5, 2.0)
    assert fits["slave"]["mass_kg"] == pytest.approx(expected, rel=0.01)
    assert fits["hand"]["mass_kg"] == pytest.approx(expected, rel=0.10)


@pytest.mark.slow
def test_rendered_mass_follows_sigma_and_eta(fig6, tmp_path):
    from heft.diagrams.studies.apparent_mass import apparent_mass_study, write_study
    study = apparent_mass_study(fig6, sigmas=(0.5, 1.0, 2.0), etas=(0.0, 1.0))
    k_f, s = 1 / 17.5, 2.0
    for row in study["sigma_runs"]:
        expected = hand_mass(row["sigma"], 3.13, k_f, s)
        assert row["fits"]["peak_force_N"] < study["max_force_N"]
        if row["sigma"] > 0:
            assert row["measured_kg"]["hand"] == pytest.approx(expected, rel=0.05)
            assert row["measured_kg"]["slave"] == pytest.approx(expected, rel=0.01)
    m_gripper, m_object = study["gripper_mass_kg"], study["object_mass_kg"]
    assert m_gripper == pytest.approx(1.73710386) and m_object == pytest.approx(0.5024)
    # The controller's parameters were identified (the gripper alone, then with the object), not given.
    assert study["gripper_mass_identified_kg"] == pytest.approx(m_gripper, rel=0.01)
    assert study["gripper_mass_identified_kg"] != m_gripper
    assert study["load_with_object_identified_kg"] == pytest.approx(m_gripper + m_object, rel=0.01)
    assert study["load_mass_identified_kg"] == pytest.approx(3.13, rel=0.01)
    eta0, eta1 = study["split_runs"]
    assert eta0["measured_kg"]["hand"] == pytest.approx(hand_mass(1.0, m_gripper, k_f, s), rel=0.05)
    assert eta1["measured_kg"]["hand"] == pytest.approx(hand_mass(1.0, m_gripper + m_object, k_f, s), rel=0.05)
    png, document = write_study(study, tmp_path)
    assert png.stat().st_size > 0 and document.stat().st_size > 0


@pytest.mark.parametrize("robot", ["rx60", "ur5e", "iiwa14"])
def test_the_sensors_orientation_is_drakes_on_every_bundled_arm(robot):
    from heft.diagrams.plants import MakeArmPlant
    from heft.diagrams.studies.apparent_mass import sensor_rotations

    plant, S = MakeArmPlant(robot)
    q = np.random.default_rng(2).uniform(-1, 1, (3, plant.num_positions()))
    context = plant.CreateDefaultContext()
    for q_k, R_RS in zip(q, sensor_rotations(robot, q), strict=True):
        plant.SetPositions(context, q_k)
        np.testing.assert_allclose(R_RS, S.CalcPoseInWorld(context).rotation().matrix(), atol=1e-14)
