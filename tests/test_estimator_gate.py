"""The online estimator's gate: samples of exciting motion out of contact only, contact not
judged right after a reset, never a faulted sample nor, while the prefilter still carries them,
the samples after contact or a fault; the excitation is the regressor's dynamic part, checked
against Eq. 5's closed form."""

import dataclasses
import math

import numpy as np
import pytest

from pydrake.systems.analysis import Simulator

from heft.systems.contact_threshold import ContactThresholdParams
from heft.systems.estimator_gate import EstimatorGate, excitation, gate_open, gate_settings
from heft.systems.load_estimation_params import LoadEstimationParams

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
