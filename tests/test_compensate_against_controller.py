"""`heft compensate` on a lab's export of a contact-free closed-loop run against what heft's controller
left on the same run (within 1.5× per axis, the accelerometer's clock offset within 0.2 ms).

The run: 3 s of `fig7` (a fast horizontal free-space motion of the paper's tool, `environment: none`,
σ = 1) in the default (realistic) station, heft's controller holding the load's true φ and the sensor's
starting offsets (``true_load``). The controller's residual is its contact estimate ``wrench_contact``
(Eq. 13, the log's c before the mount notch), RMS per axis over the wrench samples `heft compensate`
kept (it leaves out the ends within half its differentiation window; the controller's filters have
settled by then). The export (``foreign_recording.export_teleop_run``, the csv module): every 2 kHz
sample, the wrench in µs on the sensor's sign, the accelerometer in g in axes of its own, biased and
stamped 6 ms late, the arm's joint angles; the clock offset is left to estimate.

The issue's short case: 2 s of the same run exported with the wrench at 700 Hz and the accelerometer at
250 Hz (linear axes, α from the joint angles through the differentiation window `heft compensate` finds,
the recording stating none): the clock offset within 0.2 ms, the residual within 1.5× the controller's.
"""

import json

import numpy as np
import pyarrow.csv as pa_csv
import pytest
import yaml
from foreign_recording import ACCELEROMETER_CLOCK_LATE, EPOCH_US, export_teleop_run

from heft.diagrams.cli import main
from heft.diagrams.running.simulation import run_teleop, true_load, with_sigma
from heft.diagrams.scenario import overrides_text, resolve_scenario

AXES = ("fx", "fy", "fz", "tx", "ty", "tz")
# The lab's accelerometer either reports the JR3's angular channels (α measured, as the controller
# had it) or only its linear ones (α from the joint angles, differentiated over a stated 20 ms window,
# which their 2 kHz allow; 50 ms, for 100 Hz poses, would smooth this swing's α).
VARIANTS = {"alpha_measured": {"angular": True}, "alpha_from_joints": {"angular": False, "window": 0.02}}


def _run(folder, duration):
    scenario = resolve_scenario("fig7", overrides_text({"duration": duration}))
    load, _ = true_load(scenario)
    log = run_teleop(with_sigma(scenario, 1.0), load, quiet=True)
    estimate = folder / "estimate.yaml"
    estimate.write_text(yaml.safe_dump({"phi": load.phi.tolist(), "offsets": load.offsets.tolist()}))
    return scenario, log, estimate, folder


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    return _run(tmp_path_factory.mktemp("controller_run"), 3.0)


def _side_by_side(out, log, title):
    """(controller's RMS per axis, compensate's outside contact, compensate's over every sample, the
    clock offset's entry) on the samples `heft compensate` kept, printed."""
    metrics = json.loads((out / "metrics.json").read_text())
    table = pa_csv.read_csv(out / "compensated.csv")
    rows = np.round((table.column("t").to_numpy() - EPOCH_US * 1e-6) * 2000).astype(int)  # the log's 2 kHz rows
    controller = np.sqrt((log["wrench_contact"][rows] ** 2).mean(axis=0))
    compensate = np.array([metrics["residual_rms_without_contact"][a] for a in AXES])
    every_sample = np.sqrt(np.mean([table.column(f"contact_{a}").to_numpy() ** 2 for a in AXES], axis=1))
    offset = metrics["choices"]["clock_offsets_s"]["accelerometer"]
    print(f"\n{title}: residual RMS per axis (N, N·m) over {len(rows)} samples")
    print("axis   controller  compensate  ratio")
    for axis, a, b in zip(AXES, controller, compensate):
        print(f"{axis:6} {a:10.4f}  {b:10.4f}  {b / a:5.2f}")
    print(f"accelerometer clock offset: {1e3 * offset['offset_s']:.3f} ms found (σ {1e3 * offset['std_s']:.3f} ms), "
          f"{1e3 * ACCELEROMETER_CLOCK_LATE:.2f} ms put in")
    assert metrics["intervals"] == []
    return controller, compensate, every_sample, offset


@pytest.mark.slow
@pytest.mark.parametrize("variant", VARIANTS)
def test_compensate_leaves_what_the_controller_leaves(run, variant):
    scenario, log, estimate, folder = run
    assert not np.any(log["wrench_contact_true"]), "the run must touch nothing"
    settings = VARIANTS[variant]
    recording = export_teleop_run(folder / variant, scenario, log, angular=settings["angular"])
    if "window" in settings:
        document = yaml.safe_load(recording.read_text())
        document["differentiation"] = {"window": settings["window"], "order": 2}
        recording.write_text(yaml.safe_dump(document, sort_keys=False))
    out = folder / variant / "out"
    assert main(["compensate", "--recording", str(recording), "--estimate", str(estimate), "--out", str(out)]) == 0
    controller, compensate, every_sample, offset = _side_by_side(out, log, variant)
    assert (compensate <= 1.5 * controller).all(), compensate / controller
    assert (every_sample <= 1.5 * controller).all(), every_sample / controller
    assert offset["how"] == "estimated" and abs(offset["offset_s"] - ACCELEROMETER_CLOCK_LATE) < 2e-4
    assert offset["observable"]


@pytest.mark.slow
def test_the_two_second_case_at_700_and_250_hz(tmp_path):
    scenario, log, estimate, folder = _run(tmp_path, 2.0)
    recording = export_teleop_run(folder / "lab", scenario, log, wrench_rate=700.0, accelerometer_rate=250.0)
    out = folder / "lab" / "out"
    assert main(["compensate", "--recording", str(recording), "--estimate", str(estimate), "--out", str(out)]) == 0
    controller, compensate, _, offset = _side_by_side(out, log, "2 s, wrench 700 Hz, accelerometer 250 Hz")
    assert abs(offset["offset_s"] - ACCELEROMETER_CLOCK_LATE) < 2e-4 and offset["observable"]
    assert (compensate <= 1.5 * controller).all(), compensate / controller
