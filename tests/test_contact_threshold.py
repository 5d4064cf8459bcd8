"""The estimator's gate and offset tracking judge contact alike, by ``ContactThresholdParams``:
against the norms of c taken here with numpy."""

import dataclasses

import numpy as np
import pytest

from heft.systems.contact_threshold import ContactThresholdParams
from heft.systems.estimator_gate import spoiled
from heft.systems.load_estimation_params import LoadEstimationParams
from heft.systems.offset_tracking import OFFSETS, OffsetTrackingParams, initial_state, offsets_update

STILL = np.zeros(6)


def _tracked(params: OffsetTrackingParams, contact) -> bool:
    """Whether one tick at rest with ``contact`` moves the tracked offsets."""
    state = initial_state(np.zeros(6), params)
    offsets_update(state, contact, False, STILL, 0.001, params, 0)
    return bool(np.any(state[OFFSETS] != 0.0))


@pytest.mark.parametrize("threshold", [ContactThresholdParams(), ContactThresholdParams(force=0.7, torque=0.05)])
def test_gate_and_tracking_agree_on_contact(threshold):
    estimator = dataclasses.replace(LoadEstimationParams(), contact=threshold)
    offsets = dataclasses.replace(OffsetTrackingParams(), contact=threshold)
    rng = np.random.default_rng(3)
    contacts = rng.normal(size=(400, 6)) * np.repeat([threshold.force, threshold.torque], 3) * 0.45
    judged = [bool(np.linalg.norm(c[:3]) > threshold.force or np.linalg.norm(c[3:]) > threshold.torque)
              for c in contacts]
    assert 0.2 < np.mean(judged) < 0.8  # both sides of the thresholds are sampled
    for c, contact in zip(contacts, judged):
        assert spoiled(estimator, c, False, since_reset=np.inf) is contact
        assert _tracked(offsets, c) is not contact


def test_a_bad_threshold_names_its_owner():
    with pytest.raises(ValueError, match="offsets.contact.torque"):
        dataclasses.replace(OffsetTrackingParams(), contact=ContactThresholdParams(torque=np.nan)).validate()
    with pytest.raises(ValueError, match="estimator.contact.force"):
        dataclasses.replace(LoadEstimationParams(), contact=ContactThresholdParams(force=-1.0)).validate()
