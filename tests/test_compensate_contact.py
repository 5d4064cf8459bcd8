"""`heft compensate`'s default contact threshold when the recording does not start quiet: in contact
from its first sample, to its last, or most of the time; the accelerometer's clock offset found from
what is out of contact, or said not to be observable. Recordings of Drake's motion of the paper's tool
(``recording_layouts``) with the JR3's noise and a push put in by hand; the push's samples are known, so
what the contact intervals cover is counted against them."""

import json

import numpy as np
import pytest
import yaml
from drake_motion import PAPER_TOOL
from recording_layouts import EPOCH_US, LATE, write_recording

from heft.analysis.compensation import MIN_THRESHOLD, quiet_threshold
from heft.diagrams.cli import main

NOISE = 0.1  # N RMS per axis, the JR3's


def push(start, end, force=10.0):
    """A push on the load (N along S's z, with a 0.5 N tremor at 3 Hz) over [start, end] s."""
    def wrench(t):
        on = (t >= start) & (t <= end)
        out = np.zeros((len(t), 6))
        out[:, 2] = on * (force + 0.5 * np.sin(2 * np.pi * 3.0 * t))
        out[:, 3] = on * 0.02 * force  # its moment about S
        return out
    return wrench


def _compensate(folder, contact, duration, residual_rms=None):
    write_recording(folder, contact=contact, noise=NOISE, duration=duration)  # the clock offset left to estimate
    estimate = {"phi": PAPER_TOOL.to_phi().tolist(), "offsets": [0.0] * 6}
    if residual_rms is not None:
        estimate["residual_rms"] = residual_rms
    (folder / "estimate.yaml").write_text(yaml.safe_dump(estimate))
    assert main(["compensate", "--recording", str(folder / "rec.yaml"), "--estimate", str(folder / "estimate.yaml"),
                 "--out", str(folder / "out")]) == 0
    return json.loads((folder / "out" / "metrics.json").read_text())


def _covered(metrics, start, end) -> tuple[float, float]:
    """(share of [start, end] inside contact intervals, s of intervals outside it), on the run's clock."""
    inside = outside = 0.0
    for interval in metrics["intervals"]:
        a, b = interval["start_s"] - EPOCH_US * 1e-6, interval["end_s"] - EPOCH_US * 1e-6
        overlap = max(0.0, min(b, end) - max(a, start))
        inside += overlap
        outside += (b - a) - overlap
    return inside / (end - start), outside


@pytest.mark.parametrize("duration, start, end", [
    (2.0, 0.0, 1.2),    # the issue's: mostly contact, from the first sample
    (2.0, 0.8, 2.0),    # to the last sample
    (6.0, 0.6, 4.2),    # the 6 s run, a push over most of it
    (3.0, 0.0, 2.7),    # 90 % contact
])
def test_contact_from_the_first_sample_to_the_last_or_most_of_the_time_is_found(tmp_path, duration, start, end):
    metrics = _compensate(tmp_path, push(start, end), duration)
    covered, outside = _covered(metrics, start, end)
    print(f"{duration} s, push {start}-{end} s: threshold {metrics['threshold_N']:.3g} N, covered "
          f"{100 * covered:.1f} %, {outside:.3f} s outside; {metrics['threshold_reason']}")
    assert covered >= 0.8 and outside < 0.02
    assert MIN_THRESHOLD <= metrics["threshold_N"] < 5.0
    assert "quietest" in metrics["threshold_reason"]
    offset = metrics["choices"]["clock_offsets_s"]["accelerometer"]  # where the free motion tells it, it is right
    print(f"clock offset {1e3 * offset['offset_s']:.3f} ms, σ {1e3 * offset['std_s']:.3f} ms")
    assert abs(offset["offset_s"] - LATE) < 2e-4 or not offset["observable"]
    assert offset["observable"] or (end - start) / duration > 0.55


def test_a_recording_in_contact_throughout_takes_the_estimates_own_residual(tmp_path):
    metrics = _compensate(tmp_path, push(0.0, 2.0), 2.0, residual_rms=[NOISE] * 3 + [NOISE / 20] * 3)
    covered, _ = _covered(metrics, 0.0, 2.0)
    assert covered >= 0.8
    assert metrics["threshold_N"] == pytest.approx(6 * np.sqrt(3) * NOISE)
    assert "in contact throughout" in metrics["threshold_reason"]


def test_a_quiet_start_keeps_a_threshold_from_the_noise():
    """Free samples only: |c_f| of three axes of Gaussian noise σ (a Maxwell distribution). The threshold
    lies beyond nearly all of it and under any push of a few newtons."""
    rng = np.random.default_rng(0)
    t = np.arange(0, 4.0, 1 / 700)
    force = np.linalg.norm(rng.normal(scale=0.3, size=(len(t), 3)), axis=1)
    threshold = quiet_threshold(t, force)
    assert (force > threshold.value).mean() < 1e-3
    assert threshold.value < 2.5
