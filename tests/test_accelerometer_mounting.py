"""An accelerometer mounted at an angle, reporting in g with a bias, wherever it is read: the stand-in
publishes in its axes and unit, the real-time controller and the identification take it back to S."""

import numpy as np
from scipy.spatial.transform import Rotation
from test_identify import short_excitation
from test_stand_in import Lab, quiet_scenario

from heft.diagrams.identify import identify
from heft.diagrams.running.sim_identification import simulated_recorder
from heft.diagrams.running.simulation import true_load
from heft.diagrams.scenario import IDEAL_STATION, NOISE_OFF, Scenario, layered, overrides_text
from heft.diagrams.teleop_controller import TeleopController
from heft.systems.accelerometer_calibration import AccelerometerCalibration

R_SA = Rotation.from_rotvec([0.5, -0.9, 1.7]).as_matrix()
MOUNTING = {"accelerometer.R_SA": R_SA.tolist(), "accelerometer.unit": "g",
            "accelerometer.bias": [0.01, -0.08, 0.03], "accelerometer.scale": 1.02}
CALIBRATION = AccelerometerCalibration(R_SA, np.array(MOUNTING["accelerometer.bias"]), 1.02, "g")


def mounted(scenario: Scenario) -> Scenario:
    return layered(scenario, overrides_text(MOUNTING))


def test_the_stand_in_publishes_in_the_accelerometers_axes_and_unit():
    """The same moving arm, with the accelerometer aligned with S and mounted: the mounted one's samples
    are the calibration model's reading of the aligned one's, α turned into its axes."""
    readings = []
    for scenario in (quiet_scenario(), mounted(quiet_scenario())):
        lab = Lab(scenario)
        lab.command_slave(np.array(scenario.slave_initial_q) + 0.3)
        lab.run(0.3)
        readings.append(np.array([msg.acceleration for msg in lab.messages(lab.stand_in._outlets[2].name)]))
    aligned, reading = readings
    assert len(aligned) > 2000 and np.ptp(aligned[:, :3], axis=0).max() > 1.0  # the arm moved
    np.testing.assert_allclose(reading[:, :3], CALIBRATION.reading_of(aligned[:, :3]), rtol=0, atol=1e-9)
    np.testing.assert_allclose(reading[:, 3:], aligned[:, 3:] @ R_SA, rtol=0, atol=1e-9)


def test_the_controller_takes_a_mounted_reading_back_to_S():
    """Two controllers on the same station readings but the accelerometer's, one aligned with S and one
    mounted (fed the mounted instrument's reading): every tick's torque and contact wrench agree."""
    scenario = Scenario()
    load, _ = true_load(scenario)
    period, rng = scenario.controller_period, np.random.default_rng(4)
    controllers = [TeleopController(s.controller, load, s.robot, period, accelerometer=s.accelerometer.convention())
                   for s in (scenario, mounted(scenario))]
    for controller in controllers:
        controller.start(np.array(scenario.slave_initial_q))
    for k in range(200):
        q_M = np.array(scenario.master_initial_q) + 0.05 * np.sin(0.01 * k + np.arange(6))
        q_S = np.array(scenario.slave_initial_q) + 0.02 * np.sin(0.02 * k + np.arange(6))
        v = rng.normal(0, 0.2, 6)
        wrench = np.array([0.5, -0.3, 31.0, 0.1, -0.05, 0.02]) + rng.normal(0, 0.5, 6)
        at_S = np.array([0.2, -0.1, 9.9, 0.5, -0.3, 0.2]) + rng.normal(0, 0.3, 6)  # what S's axes would read
        reading = at_S.copy()
        reading[:3] = CALIBRATION.reading_of(at_S[:3])
        reading[3:] = at_S[3:] @ R_SA
        for controller, acceleration in zip(controllers, (at_S, reading)):
            controller.step(period, q_M, v, q_S, v, wrench, acceleration, True)
        np.testing.assert_allclose(controllers[1].torque, controllers[0].torque, rtol=0, atol=1e-9)
        np.testing.assert_allclose(controllers[1].wrench_contact, controllers[0].wrench_contact, rtol=0, atol=1e-9)
    assert np.abs(controllers[0].wrench_contact).max() > 0.1


def test_identification_reads_a_mounted_accelerometer(tmp_path):
    """In the ideal station without noise, the tool identified from a mounted accelerometer's samples is
    as exact as from an aligned one's (the mounting undone before the regressor)."""
    scenario = mounted(layered(Scenario(), overrides_text({**NOISE_OFF, **IDEAL_STATION})))
    metrics = identify(scenario, tmp_path, simulated_recorder(scenario), method="ols", settings=short_excitation())
    errors = metrics["errors"]["ols"]
    assert errors["mass_kg"] < 5e-4 and errors["inertia_relative"] < 5e-3 and errors["force_offsets_N"] < 0.01
