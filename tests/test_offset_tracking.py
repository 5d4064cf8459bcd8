"""Offsets at run time: tracking holds the residual against the simulated JR3's thermal drift,
at a bounded rate and only at rest out of contact; a re-zero measures the offsets at rest and
is refused, keeping them, while the slave moves, touches or a sample is faulted."""

import dataclasses

import numpy as np
import pytest

from heft.systems.controller.offset_tracking import (
    DONE, OFFSETS, REFUSED_CONTACT, REFUSED_FAULT, REFUSED_MOVING, STATUS, OffsetTrackingParams, initial_state,
    offsets_update)
from heft.systems.controller.contact_threshold import ContactThresholdParams
from heft.systems.station.sensor_models import FORCE_TORQUE_STREAM, ForceTorqueSensorParams, SixAxisMeasurement

CONTACT = ContactThresholdParams()
"""The default contact thresholds (``controller.contact``)."""

STILL = np.zeros(6)
MOVING = np.array([0.0, 0.05, 0.0, 0.0, 0.0, 0.0])  # rad/s on joint 2


def drifting_sensor(duration: float, period: float):
    """(times, true offsets, offsets + white noise) of the simulated JR3 at rest, from power-on."""
    model = SixAxisMeasurement(ForceTorqueSensorParams(), FORCE_TORQUE_STREAM, period)
    t = np.arange(round(duration / period)) * period
    offsets, noisy, _ = model.disturbance(t, model.normals(np.arange(len(t))), np.zeros(6))
    return t, offsets, noisy


@pytest.mark.parametrize("tracking", [True, False])
def test_tracking_bounds_the_residual_against_thermal_drift(tracking):
    """15 minutes at rest from power-on, with the offsets identified at power-on: the eliminated
    wrench (c = f − ô − V·φ̂, here f − ô) grows with the drift without tracking (1.5 N towards
    the warm offsets on f_z); with it, it stays within what a first-order tracker allows: the
    lag r·τ behind the fastest warm-up drift r, plus 4σ of the random walk's and the noise's
    tracking error (q·√(τ/2), σ_n·√(dt/2τ))."""
    period = 0.01
    t, offsets, measured = drifting_sensor(900.0, period)
    params = OffsetTrackingParams(tracking=tracking)
    state = initial_state(offsets[0], params)
    residual = np.empty_like(offsets)
    for k in range(len(t)):
        contact = measured[k] - state[OFFSETS]
        residual[k] = offsets[k] - state[OFFSETS]
        offsets_update(state, contact, False, STILL, period, params, CONTACT, 0)
    drift = np.abs(offsets[-1] - offsets[0])
    assert drift[2] > 0.8  # the sensor really drifted
    if tracking:
        sensor, tau = ForceTorqueSensorParams(), params.time_constant
        drift_rate = np.abs(np.subtract(sensor.drifted_offsets, sensor.initial_offsets)) / sensor.drift_time_constant
        bound = (drift_rate * tau + 4 * np.array(sensor.offset_random_walk) * np.sqrt(tau / 2)
                 + 4 * np.array(sensor.noise_rms) * np.sqrt(period / (2 * tau)))
        np.testing.assert_array_less(np.abs(residual).max(axis=0), bound)
        assert bound[2] < 0.1 * drift[2]  # a tenth of what it would be untracked
    else:
        np.testing.assert_allclose(np.abs(residual[-1]), drift, rtol=1e-12)


def test_tracking_moves_at_most_its_rate_and_pauses_in_motion_and_contact():
    params = OffsetTrackingParams()
    dt, state = 0.001, initial_state(np.zeros(6), params)
    light = np.array([1.5, 0.0, 0.0, 0.0, 0.0, 0.15])  # a light contact held still: within the gates
    for _ in range(10_000):
        offsets_update(state, light - state[OFFSETS], False, STILL, dt, params, CONTACT, 0)
    expected = [params.max_force_rate * 10.0, 0, 0, 0, 0, params.max_torque_rate * 10.0]
    np.testing.assert_allclose(state[OFFSETS], expected, rtol=1e-9)
    before = state.copy()
    for contact, velocity in ((light, MOVING), (np.array([2.5, 0, 0, 0, 0, 0]), STILL),
                              (np.array([0, 0, 0, 0.25, 0, 0]), STILL)):
        offsets_update(state, contact, False, velocity, dt, params, CONTACT, 0)
    offsets_update(state, light, True, STILL, dt, params, CONTACT, 0)  # faulted sample
    np.testing.assert_array_equal(state, before)


def test_rezero_measures_the_offsets_at_rest():
    """Offsets 3 N off on f_z, the sensor noisy: a re-zero over 0.5 s lands within 3σ/√n."""
    params = OffsetTrackingParams(tracking=False)
    dt, rng = 0.0005, np.random.default_rng(1)
    true = np.array([2.0, -1.5, 3.0, 0.04, -0.03, 0.02])
    state = initial_state(true - [0, 0, 3.0, 0, 0, 0], params)
    noise = np.array([0.1, 0.1, 0.1, 0.005, 0.005, 0.005])
    requests = 1
    while True:
        measured = true + noise * rng.standard_normal(6)
        offsets_update(state, measured - state[OFFSETS], False, STILL, dt, params, CONTACT, requests)
        if state[STATUS] == DONE:
            break
    samples = round(params.rezero_window / dt)
    np.testing.assert_array_less(np.abs(state[OFFSETS] - true), 3 * noise / np.sqrt(samples))


@pytest.mark.parametrize("contact, velocity, fault, refusal", [
    (np.zeros(6), MOVING, False, REFUSED_MOVING),
    (np.array([0.0, 6.0, 0.0, 0.0, 0.0, 0.0]), STILL, False, REFUSED_CONTACT),
    (np.array([0.0, 0.0, 0.0, 0.0, 0.6, 0.0]), STILL, False, REFUSED_CONTACT),
    (np.zeros(6), STILL, True, REFUSED_FAULT)])
def test_rezero_is_refused_and_keeps_the_offsets(contact, velocity, fault, refusal):
    params = OffsetTrackingParams(tracking=False)
    offsets = np.array([2.0, -1.5, 3.0, 0.04, -0.03, 0.02])
    state = initial_state(offsets, params)
    for k in range(100):  # at rest and out of contact, then one bad tick
        bad = k == 50
        offsets_update(state, contact if bad else np.zeros(6), fault and bad, velocity if bad else STILL,
                       0.0005, params, CONTACT, 1)
    assert state[STATUS] == refusal
    np.testing.assert_array_equal(state[OFFSETS], offsets)


def test_settings_out_of_range_are_named():
    with pytest.raises(ValueError, match="time_constant"):
        dataclasses.replace(OffsetTrackingParams(), time_constant=0.0).validate()
