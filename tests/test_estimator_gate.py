"""The online estimator's gate: samples of exciting motion out of contact only, contact not
judged right after a reset, and never a faulted sample; the excitation is the regressor's
dynamic part, checked against Eq. 5's closed form."""

import dataclasses

import numpy as np
import pytest

from heft.systems.estimator_gate import EstimatorSpec, excitation, gate_open

SPEC = EstimatorSpec()
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
    assert gate_open(SPEC, acceleration, np.zeros(3), contact, fault, since_reset) is expected


def test_bad_settings_are_named():
    for field, value, message in (("mode", "kalman", "mode"), ("method", "riv", "instruments"),
                                  ("forgetting", 1.5, "forgetting"), ("contact_force", -1.0, "contact_force")):
        with pytest.raises(ValueError, match=message):
            dataclasses.replace(SPEC, **{field: value}).validate()
