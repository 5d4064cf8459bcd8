"""`heft identify` end to end on a short excitation, and its output files."""

import json

import numpy as np
import pytest
import yaml

from heft.diagrams.identify import ALL_METHODS, FitRefused, identify
from heft.diagrams.running.sim_identification import simulated_recorder
from heft.diagrams.scenario import IDEAL_STATION, NOISE_OFF, Scenario, layered, overrides_text
from heft.diagrams.load_estimate import read_load_estimate
from heft.systems.identification.excitation import ExcitationSettings


# A 5 kg steel bar, 460 × 60 × 23 mm, lying across the sensor's axis from 0.23 m out: its static
# moment, 5 kg × 9.81 m/s² × 0.23 m = 11.3 N·m, is within the JR3's 12 N·m (a tool beyond it the
# station refuses before any run, tests/test_tool_check.py), but the excitation's motion takes it beyond.
BAR = (5.0, 0.46, 0.06, 0.023)  # kg, m along x, y, z
HEAVY_OFF_AXIS_TOOL = {"load.kind": "custom", "load.mass": BAR[0], "load.com": [0.23, 0.0, 0.03],
                       "load.inertia_com": [BAR[0] / 12 * (BAR[2] ** 2 + BAR[3] ** 2), 0.0, 0.0,
                                            BAR[0] / 12 * (BAR[1] ** 2 + BAR[3] ** 2), 0.0,
                                            BAR[0] / 12 * (BAR[1] ** 2 + BAR[2] ** 2)]}


def short_excitation() -> ExcitationSettings:
    settings = ExcitationSettings.quick()
    settings.base_frequency, settings.duration = 0.5, 2.0
    return settings


@pytest.fixture(scope="module")
def identified(tmp_path_factory):
    """A noisy 2 s excitation of the paper's tool, identified with every method."""
    out = tmp_path_factory.mktemp("identify")
    metrics = identify(Scenario(), out, simulated_recorder(Scenario()), method="tls", settings=short_excitation())
    return out, metrics


def test_every_method_recovers_the_tool(identified):
    _, metrics = identified
    assert set(metrics["errors"]) == set(ALL_METHODS)
    phi_true = np.array(metrics["phi_true"])
    assert phi_true[0] == pytest.approx(3.13)
    for method in ("tls", "riv", "rtls"):  # the errors-in-variables methods
        errors = metrics["errors"][method]
        assert errors["mass_kg"] < 0.005 and errors["com_m"] < 0.001 and errors["inertia_relative"] < 0.03
    # The accelerometer's own bias (0.1 m/s² class) times the mass is not separable from the
    # FT force offsets: the offset error is that size, not the noise level.
    assert metrics["errors"]["tls"]["force_offsets_N"] < 0.6


def test_estimate_file_is_what_the_controller_loads(identified):
    out, metrics = identified
    record = yaml.safe_load((out / "estimate.yaml").read_text())
    assert record["method"] == "tls" and record["signals"] == "accelerometer"
    assert all(record["identifiable"]) and not record["physical_violations"]
    assert record["mass"] == pytest.approx(3.13, abs=0.005)
    assert record["fit"] == {"ok": True, "accepted": False, "causes": []}
    verdict = metrics["fit_verdict"]
    assert max(verdict["residual_ratio"]) < 1.1 and verdict["saturated_samples"] == 0
    load = read_load_estimate(out / "estimate.yaml")
    np.testing.assert_allclose(load.phi, record["phi"])
    assert json.loads((out / "metrics.json").read_text())["samples"] == 4000
    assert (out / "convergence.png").stat().st_size > 10_000


def test_noise_free_identification_is_exact_to_the_encoder_resolution(tmp_path):
    scenario = layered(Scenario(), overrides_text({**NOISE_OFF, **IDEAL_STATION}))
    metrics = identify(scenario, tmp_path, simulated_recorder(scenario), method="ols", settings=short_excitation())
    errors = metrics["errors"]["ols"]
    assert errors["mass_kg"] < 5e-4 and errors["inertia_relative"] < 5e-3 and errors["force_offsets_N"] < 0.01


def test_bad_estimate_file_says_what_to_do(tmp_path):
    path = tmp_path / "estimate.yaml"
    path.write_text("phi: [1, 2, 3]\noffsets: [0, 0, 0, 0, 0, 0]\n")
    with pytest.raises(ValueError, match="needs 10 finite φ entries"):
        read_load_estimate(path)
    with pytest.raises(ValueError, match="heft identify"):
        read_load_estimate(tmp_path / "missing.yaml")


def test_estimate_file_keeps_the_accelerometer_calibration(tmp_path):
    from scipy.spatial.transform import Rotation

    from heft.diagrams.load_estimate import write_load_estimate
    from heft.systems.accelerometer_calibration import AccelerometerCalibration
    from heft.systems.identification.static_calibration import point_mass_phi

    calibration = AccelerometerCalibration(R_SA=Rotation.from_rotvec([0.2, -0.4, 1.0]).as_matrix(),
                                           bias=[0.0, 0.08, 0.01], scale=0.99, unit="g")
    record = {"phi": point_mass_phi(3.13, [0.0, 0.0, 0.063]).tolist(), "offsets": [1.0, 2, 3, 0.01, 0.02, 0.03]}
    path = tmp_path / "estimate.yaml"
    write_load_estimate(path, record, {"ok": True, "causes": []}, calibration)
    load = read_load_estimate(path)
    np.testing.assert_allclose(load.accelerometer.R_SA, calibration.R_SA, atol=1e-12)
    np.testing.assert_allclose(load.accelerometer.bias, calibration.bias)
    assert load.accelerometer.scale == 0.99 and load.accelerometer.unit == "g"
    write_load_estimate(path, record, {"ok": True, "causes": []})
    assert read_load_estimate(path).accelerometer is None
    text = path.read_text() + "accelerometer: {R_SA: [[1, 0, 0], [0, 1, 0], [0, 0, -1]], bias: [0, 0, 0], " \
                              "scale: 1.0, unit: g}\n"
    path.write_text(text)
    with pytest.raises(ValueError, match="estimate.yaml: the accelerometer's R_SA is not a rotation"):
        read_load_estimate(path)


def test_unknown_method_is_rejected(tmp_path):
    with pytest.raises(ValueError, match="method must be one of"):
        identify(Scenario(), tmp_path, simulated_recorder(Scenario()), method="magic")


def test_a_method_that_refuses_the_data_leaves_the_others_their_estimates():
    """Motion far below the accelerometer's noise: eiv_ml refuses it by name, and every other
    method still estimates (identification on hardware must not lose a recording to one method)."""
    from test_estimators import smooth_record

    from heft.diagrams.identify import estimate_all
    from heft.systems.identification.regression_noise import NoiseLevels
    from heft.systems.load_dynamics import regressor

    rng = np.random.default_rng(5)
    phi, bias, (a, alpha, omega, g) = smooth_record(rng, 500)
    a, alpha, omega = 0.01 * a, 0.01 * alpha, 0.01 * omega
    noise = NoiseLevels()
    wrench = regressor(a, alpha, omega, g) @ phi + bias + rng.normal(size=(500, 6)) * np.repeat([0.1, 0.005], 3)
    measured = (a + rng.normal(scale=noise.linear_acceleration, size=a.shape),
                alpha + rng.normal(scale=noise.angular_acceleration, size=alpha.shape), omega, g)
    results, _, failed = estimate_all(wrench, measured, (a, alpha, omega, g), noise)
    assert set(failed) == {"eiv_ml"} and "accelerometer's noise" in failed["eiv_ml"]
    assert set(results) == set(ALL_METHODS) - {"eiv_ml"}


@pytest.mark.slow
def test_a_tool_that_saturates_the_sensor_is_refused_unless_accepted(tmp_path):
    """One recording of the heavy off-axis tool, identified twice: refused, with the saturation
    named and an earlier estimate.yaml removed; then written with accept_fit (--accept-fit)."""
    scenario = layered(Scenario(), overrides_text({**IDEAL_STATION, **HEAVY_OFF_AXIS_TOOL}))
    recordings = []

    def record_once(trajectory, duration):
        if not recordings:
            recordings.append(simulated_recorder(scenario)(trajectory, duration))
        return recordings[0]

    (tmp_path / "estimate.yaml").write_text("an earlier run's estimate\n")
    with pytest.raises(FitRefused, match="full scale") as refused:
        identify(scenario, tmp_path, record_once, settings=short_excitation())
    assert "--accept-fit" in str(refused.value) and "earlier one there removed" in str(refused.value)
    assert not (tmp_path / "estimate.yaml").exists()
    verdict = json.loads((tmp_path / "metrics.json").read_text())["fit_verdict"]
    assert not verdict["ok"] and "saturation" in verdict["causes"] and verdict["saturated_samples"] > 0
    assert max(verdict["peak_share_of_full_scale"]["wrench"][3:]) == pytest.approx(1.0)  # clipped at 12 N·m
    assert max(verdict["residual_ratio"]) > 3

    metrics = identify(scenario, tmp_path, record_once, settings=short_excitation(), accept_fit=True)
    record = yaml.safe_load((tmp_path / "estimate.yaml").read_text())
    assert record["fit"] == {"ok": False, "accepted": True, "causes": metrics["fit_verdict"]["causes"]}
    assert record["phi"] == metrics["estimates"]["tls"]["phi"]
