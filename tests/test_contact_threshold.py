"""The estimator's gate and offset tracking judge contact alike, by ``ContactThresholdParams``:
against the norms of c taken here with numpy."""

import numpy as np
import pytest

from heft.systems.controller.contact_threshold import ContactThresholdParams
from heft.systems.controller.estimator_gate import gate_settings, spoiled
from heft.systems.controller.load_estimation_params import LoadEstimationParams
from heft.systems.controller.offset_tracking import OFFSETS, OffsetTrackingParams, initial_state, offsets_update

STILL = np.zeros(6)


def _tracked(threshold: ContactThresholdParams, contact) -> bool:
    """Whether one tick at rest with ``contact`` moves the tracked offsets."""
    params = OffsetTrackingParams()
    state = initial_state(np.zeros(6), params)
    offsets_update(state, contact, False, STILL, 0.001, params, threshold, 0)
    return bool(np.any(state[OFFSETS] != 0.0))


@pytest.mark.parametrize("threshold", [ContactThresholdParams(), ContactThresholdParams(force=0.7, torque=0.05)])
def test_gate_and_tracking_agree_on_contact(threshold):
    rng = np.random.default_rng(3)
    contacts = rng.normal(size=(400, 6)) * np.repeat([threshold.force, threshold.torque], 3) * 0.45
    judged = [bool(np.linalg.norm(c[:3]) > threshold.force or np.linalg.norm(c[3:]) > threshold.torque)
              for c in contacts]
    assert 0.2 < np.mean(judged) < 0.8  # both sides of the thresholds are sampled
    settings = gate_settings(LoadEstimationParams(), threshold)
    for c, contact in zip(contacts, judged):
        assert spoiled(settings, c, False, np.inf) is contact
        assert _tracked(threshold, c) is not contact


def test_one_setting_judges_contact_for_both():
    """``controller.contact`` is the one setting: the scenario has no other, and a bad value is named."""
    from heft.diagrams.scenario import Scenario, layered, overrides_text

    scenario = layered(Scenario(), overrides_text({"controller.contact.force": 0.7}))
    assert scenario.controller.contact.force == 0.7
    for old in ("controller.offsets.contact.force", "controller.estimator.contact.force"):
        with pytest.raises(ValueError, match="unknown field"):
            layered(Scenario(), overrides_text({old: 0.7}))
    with pytest.raises(ValueError, match="controller.contact.torque"):
        ContactThresholdParams(torque=np.nan).validate()
