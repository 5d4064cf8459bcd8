"""The online estimator's gate: samples of exciting motion out of contact only, contact not
judged right after a reset, never a faulted sample nor, while the prefilter still carries them,
the samples after contact or a fault; the excitation is the regressor's dynamic part, checked
against Eq. 5's closed form."""

import dataclasses
import math

import numpy as np
import pytest

from pydrake.systems.analysis import Simulator

from heft.systems.controller.contact_threshold import ContactThresholdParams
from heft.systems.controller.estimator_gate import EstimatorGate, excitation, gate_open, gate_settings
from heft.systems.load_dynamics import regressor
from heft.systems.controller.load_estimation_params import LoadEstimationParams
from heft.systems.station.sensor_params import AccelerometerParams

SPEC = LoadEstimationParams()
MOVING = np.array([3.0, 0.0, 0.0, 0.0, 0.0, 0.0])  # m/s² along x, no rotation
STILL = np.zeros(6)
FREE, PUSHED, TWISTED = np.zeros(6), np.array([0, 0, 2.5, 0, 0, 0.0]), np.array([0, 0, 0, 0.25, 0, 0.0])


def test_excitation_is_the_regressors_dynamic_part():
    """For a pure translation a the regressor's force rows are [a, 0…] and its torque rows
    −[a]ₓ on m·c: ‖V‖² = |a|² + 2|a|² (Eq. 5's closed form)."""
    assert excitation(MOVING, np.zeros(3)) == pytest.approx(np.sqrt(3) * 3.0)
    assert excitation(STILL, np.zeros(3)) == 0.0


@pytest.mark.parametrize("acceleration, contact, fault, since_reset, expected", [
    (MOVING, FREE, False, 10.0, True),
    (STILL, FREE, False, 10.0, False),       # at rest: statics only
    (MOVING, PUSHED, False, 10.0, False),    # contact force
    (MOVING, TWISTED, False, 10.0, False),   # contact torque
    (MOVING, PUSHED, False, 0.5, True),      # just reset: the residual is the new load
    (MOVING, FREE, True, 10.0, False),       # faulted sample
])
def test_gate(acceleration, contact, fault, since_reset, expected):
    settings = gate_settings(SPEC, ContactThresholdParams())
    assert gate_open(settings, acceleration, np.zeros(3), contact, fault, since_reset, math.inf, np.zeros(3),
                     np.empty((6, 10))) is expected


def test_after_contact_the_gate_waits_for_the_prefilter_to_forget_it():
    """The system: contact for 10 ticks, then free motion. The prefilter (10 Hz) still carries the
    contact for 2/10 s, so the gate opens 0.2 s after the last contact sample, not before."""
    spec = dataclasses.replace(SPEC, learning_window=0.0)
    period = 0.0005
    gate = EstimatorGate(spec, ContactThresholdParams(), period)
    context = gate.CreateDefaultContext()
    for name, value in (("acceleration", MOVING), ("omega", np.zeros(3)), ("fault", [0.0]), ("reset", [0.0])):
        gate.GetInputPort(name).FixValue(context, value)
    simulator = Simulator(gate, context)
    enabled = []
    for k in range(600):
        gate.GetInputPort("wrench_contact").FixValue(context, PUSHED if k < 10 else FREE)
        enabled.append(gate.GetOutputPort("enable").Eval(context)[0])
        simulator.AdvanceTo((k + 1) * period)
    first_open = int(np.argmax(np.array(enabled) > 0.5))
    assert not any(enabled[:first_open]) and all(enabled[first_open:])
    assert (first_open - 9) * period == pytest.approx(2.0 / spec.prefilter, abs=1.5 * period)


def test_bad_settings_are_named():
    for field, value, message in (("mode", "kalman", "mode"), ("method", "riv", "instruments"),
                                  ("forgetting", 1.5, "forgetting")):
        with pytest.raises(ValueError, match=message):
            dataclasses.replace(SPEC, **{field: value}).validate()


def test_at_rest_the_accelerometers_noise_does_not_open_the_gate():
    """The slave still, the accelerometer's reading heft's noise model's (``AccelerometerParams``: α's
    0.5 rad/s² RMS), the bias its drifted offsets: the raw motion's excitation passes ``min_excitation``
    often, the prefiltered motion's, which the controller's estimator learns from, never; φ̂ stays as it
    started."""
    from heft.diagrams.load_estimate import LoadEstimate
    from heft.diagrams.scenario import Scenario, layered, overrides_text
    from heft.diagrams.teleop_controller import TeleopController
    from heft.systems.accelerometer_reading import AT_S

    scenario = layered(Scenario(), overrides_text({"controller.estimator.mode": "online"}))
    period, rng = scenario.controller_period, np.random.default_rng(5)
    accelerometer = AccelerometerParams()
    noise, bias = np.array(accelerometer.noise_rms), np.array(accelerometer.drifted_offsets)
    phi = np.array([1.7, 0.0, 0.0, 0.15, 0.02, 0.0, 0.0, 0.02, 0.0, 0.003])
    controller = TeleopController(scenario.controller, LoadEstimate(phi, np.zeros(6)), scenario.robot, period,
                                  accelerometer=AT_S)
    q, q_M = np.array(scenario.slave_initial_q), np.array(scenario.master_initial_q)
    controller.start(q)
    gravity = controller.gravity_S.copy()  # at the start position
    assert np.linalg.norm(gravity) == pytest.approx(9.81)
    at_rest = regressor(np.zeros(3), np.zeros(3), np.zeros(3), gravity) @ phi
    raw_open, taken = 0, 0
    for _ in range(4000):
        motion = bias + rng.normal(0.0, noise)
        raw_open += excitation(motion, np.zeros(3)) >= SPEC.min_excitation
        reading = np.concatenate((motion[:3] - gravity, motion[3:]))  # a − g, α at S
        controller.step(period, q_M, np.zeros(6), q, np.zeros(6), at_rest + rng.normal(0.0, 0.1, 6), reading, False)
        taken += controller.program.calculation("estimator_gate", "enable")[0] > 0.5
    assert raw_open > 1000  # the noise alone would open it on a third of the ticks
    assert taken == 0 and controller.estimator.num_samples == 0
    np.testing.assert_array_equal(controller.phi, phi)
