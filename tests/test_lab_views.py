"""What the live view shows of the lab besides the controller's run: φ̂'s uncertainty from the online
estimator's state, `heft identify --hardware`'s excitation and estimate, and the stand-in's lab. The rows
go through a real recorder process (``McapRecorder``, read back with the ``mcap`` reader) or a real
server; the lab is the stand-in on a memq:// bus, stepped on one clock."""

import json
import threading
import time
from pathlib import Path

import lcm
import numpy as np
import pytest
from mcap.reader import make_reader

from heft.analysis.topics import ESTIMATOR_PRIOR, ESTIMATOR_STATE, TOPIC_BY_NAME, phi_hat_std, row_messages
from heft.diagrams.cli import main
from heft.diagrams.device_limits import device_limits
from heft.diagrams.live_view import LiveView, McapRecorder
from heft.diagrams.running.hardware_identify import HardwareIdentification, show_estimate
from heft.diagrams.scenario import resolve_scenario
from heft.diagrams.stations.stand_in import FaultInjection, StandIn
from heft.hardware_interface.channels import LcmChannels
from heft.systems.identification.excitation_commander import Phase
from heft.systems.identification.recursive_estimation import RecursiveLeastSquares
from heft.systems.load_dynamics import regressor

from foxglove_client import FoxgloveClient, free_port, wait_for_channels
from test_hardware_identify import TRAJECTORY

EXAMPLE = Path(__file__).resolve().parents[1] / "docs" / "example_recording"


def read_mcap(path) -> dict:
    """topic → [(log time (ns), message)] of an MCAP file."""
    topics = {}
    with open(path, "rb") as file:
        for _, channel, message in make_reader(file).iter_messages():
            topics.setdefault(channel.topic, []).append((message.log_time, json.loads(message.data)))
    return topics


def test_phi_hat_std_is_the_online_estimators_covariance():
    """From the state alone: null before the data say anything, then the estimator's own standard deviations."""
    rng = np.random.default_rng(4)
    phi = np.array([3.13, 0.0, 0.0, 0.6, 0.03, 0.0, 0.0, 0.03, 0.0, 0.01])
    estimator = RecursiveLeastSquares(offsets=False, forgetting=0.9995, initial_covariance=1.0)
    estimator.start_from(phi)
    row = {"phi_hat": phi, ESTIMATOR_STATE: estimator.state_vector(), ESTIMATOR_PRIOR: [1.0]}
    [(_, before)] = row_messages(0.0, row, ["/estimate/phi"])
    assert before["std"] == [None] * 10 and before["mass"] == 3.13
    for _ in range(400):
        a, alpha, omega = rng.normal(scale=3.0, size=(3, 3))
        g = np.array([0.0, 0.0, -9.81])
        estimator.update(regressor(a, alpha, omega, g) @ phi + rng.normal(scale=0.05, size=6), a, alpha, omega, g)
    row[ESTIMATOR_STATE] = estimator.state_vector()
    [(_, after)] = row_messages(0.5, row, ["/estimate/phi"])
    expected = np.sqrt(np.diag(estimator.covariance))
    np.testing.assert_array_equal(after["std"], expected)
    np.testing.assert_array_equal(phi_hat_std(estimator.state_vector(), 1.0), expected)
    assert 0 < after["std"][0] < 0.01  # 400 samples of 0.05 N noise pin the mass down


def test_identification_shows_its_excitation_and_then_its_estimate(tmp_path):
    """Each tick's measured wrench and progress, as the station read them; the estimate once it comes, to a
    client that connected during the excitation too."""
    scenario = resolve_scenario("fig6")
    bus = lcm.LCM("memq://")
    stand_in = StandIn(scenario, bus, LcmChannels(), FaultInjection())
    period, now, duration, port = scenario.controller_period, 0.0, 1.0, free_port()
    recorder = McapRecorder(tmp_path / "identify.mcap", scenario.robot)
    run = HardwareIdentification(TRAJECTORY, duration, period, bus, LcmChannels(), device_limits(scenario),
                                 taps=[recorder, LiveView(port, robot=scenario.robot)])
    client = FoxgloveClient(f"ws://127.0.0.1:{port}", timeout=30)
    listening = threading.Thread(target=client.receive, args=(time.monotonic() + 120,))
    listening.start()
    wait_for_channels(client, listening)
    run.start()
    wrenches, progress, done = [], [], False
    while not done:
        now += period
        stand_in.step(now)
        done = run.tick(now, period)
        wrenches.append(run.station.wrench.copy())
        progress.append((run.commander.phase, run.commander.excitation_time))
    record = {"phi": list(stand_in.phi_true), "std_phi": [0.001] * 10, "offsets": [0.5] * 6}
    for tap in run.taps:
        show_estimate(tap, record)
    assert [tap.close()["dropped"] for tap in run.taps] == [0, 0]
    listening.join()
    [live] = [message for topic, _, message in client.messages if topic == "/estimate/phi"]
    assert live["mass"] == stand_in.phi_true[0] and live["std"] == [0.001] * 10
    topics = read_mcap(tmp_path / "identify.mcap")
    assert {"/wrench/measured", "/slave/joint_state", "/slave/command", "/identify/excitation", "/scene/frames",
            "/estimate/phi", "/estimate/offsets"} <= set(topics)
    shown = [message for _, message in topics["/identify/excitation"]]
    assert len(shown) == len(progress)
    assert [m["phase"] for m in shown] == [float(phase) for phase, _ in progress]
    assert shown[-1]["phase"] == Phase.DONE and shown[-1]["done"] == 1.0
    exciting = [m for m in shown if m["phase"] == Phase.EXCITING]
    assert exciting and all(0.0 <= m["done"] <= 1.0 for m in exciting)
    assert np.all(np.diff([m["done"] for m in exciting]) > 0)
    np.testing.assert_array_equal([[m["force"][a] for a in "xyz"] + [m["torque"][a] for a in "xyz"]
                                   for _, m in topics["/wrench/measured"]], wrenches)
    [(log_time, estimate)] = topics["/estimate/phi"]
    assert estimate["mass"] == stand_in.phi_true[0] and estimate["std"] == [0.001] * 10
    assert log_time == round(run.epoch * 1e9) + round(estimate["t"] * 1e9)  # on the loop's clock, from its zero
    assert topics["/estimate/offsets"][0][1]["force"] == {"x": 0.5, "y": 0.5, "z": 0.5}


def test_the_stand_ins_row_is_its_lab():
    """What the stand-in's view is handed: its true joints and the true wrench, the setpoint it obeys."""
    scenario = resolve_scenario("fig6")
    bus = lcm.LCM("memq://")
    stand_in = StandIn(scenario, bus, LcmChannels(), FaultInjection())
    for k in range(1, 201):
        stand_in.step(k * 0.0005)
    row = stand_in.view_row()
    np.testing.assert_array_equal(row["slave_q"], stand_in.slave_position)
    np.testing.assert_array_equal(row["slave_q_commanded"], scenario.slave_initial_q)  # no command received
    np.testing.assert_array_equal(row["master_q"], stand_in.master_position)
    np.testing.assert_array_equal(row["phi_true"], stand_in.phi_true)
    # At rest the true wrench is the load's weight; the sample measured adds offsets and noise to it.
    assert row["wrench_noncontact_true"][:3] @ row["wrench_noncontact_true"][:3] == pytest.approx(
        (9.81 * stand_in.phi_true[0]) ** 2, rel=0.01)
    assert np.abs(row["wrench_measured"] - row["wrench_noncontact_true"] - stand_in.offsets).max() < 1.0
    names = [name for name, _ in row_messages(0.1, row, [topic.name for topic in TOPIC_BY_NAME.values()
                                                         if topic.present(row)])]
    assert names == ["/wrench/measured", "/truth/noncontact", "/truth/phi", "/master/joint_state",
                     "/master/command", "/slave/joint_state", "/slave/command"]


def test_the_views_options_are_refused_where_nothing_runs_on_the_lab(capsys):
    """One line each: the view belongs to the lab's excitation, not to a simulated or recorded one."""
    assert main(["identify", "--scenario", "fig6", "--view"]) == 2
    assert "--view shows the excitation on the lab: it needs --hardware" in capsys.readouterr().err
    assert main(["identify", "--recording", str(EXAMPLE / "poses.yaml"), "--view"]) == 2
    assert "--view belongs to an excitation heft drives" in capsys.readouterr().err
