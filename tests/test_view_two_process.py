"""The live view of the lab's processes, watched by a client speaking the Foxglove WebSocket protocol
(``foxglove_listen.py``, ``foxglove_client.FoxgloveClient``): `heft teleop --hardware --view` against
`heft stand-in`, and `heft stand-in --view` alone. Every process, the client too, runs inside the test's
network namespace (the view listens on its 127.0.0.1; LCM on multicast that cannot leave it), as in
tests/test_two_process.py. The test waits on what the processes print, never on the clock: the client says
when it has seen enough, the test then stops the run with SIGTERM and the client reads until the server
closes. What the client saw is held against what the run logged: the controller's LCM recording and
summary, the stand-in's truth of every FT sample."""

import json
from pathlib import Path

import lcm
import numpy as np
import pytest
import yaml

from heft.diagrams.live_view import DEFAULT_RATE
from heft.diagrams.running.simulation import true_load
from heft.diagrams.scenario import overrides_text, resolve_scenario
from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.lcmtypes import heft_teleop_state

from foxglove_client import free_port
from test_two_process import FOREVER, STAND_IN_SENSOR, _Process, _stand_in, _stop_all, _summary, _teleop, layered_dict

pytestmark = pytest.mark.slow

LISTEN = Path(__file__).with_name("foxglove_listen.py")
ENOUGH = 300
"""Rows of the watched topic the client waits for: 3 s of the view's rate."""
ONLINE = yaml.safe_dump(layered_dict(yaml.safe_load(STAND_IN_SENSOR),
                                     yaml.safe_load(overrides_text({"controller.estimator.mode": "online"}))),
                        default_flow_style=True)
"""The stand-in's sensor, and φ̂ learned online (its uncertainty on the view)."""


def _listen(netns, folder, port: int, topic: str) -> _Process:
    """The client, subscribed to everything the view at ``port`` advertises, once it has."""
    client = _Process(netns, folder, "client", f"ws://127.0.0.1:{port}", str(folder / "seen.json"), "--enough", topic,
                      str(ENOUGH), script=str(LISTEN))
    client.wait_for("subscribed")
    return client


def _seen(client: _Process, folder) -> tuple[set, dict]:
    """(advertised topics, topic → messages in order) once the client has seen the server close."""
    assert client.wait() == 0 and "closed by the server: True" in client.text(), client.text()
    seen = json.loads((folder / "seen.json").read_text())
    by_topic = {}
    for topic, _, message in seen["messages"]:
        by_topic.setdefault(topic, []).append(message)
    return {channel["topic"] for channel in seen["channels"]}, by_topic


def _wrench(message: dict) -> list:
    return [message["force"][a] for a in "xyz"] + [message["torque"][a] for a in "xyz"]


def test_a_client_watches_the_controller_against_the_stand_in(netns, tmp_path):
    """The topics arrive at the view's rate; each wrench is the one the controller recorded for that tick, φ̂ the
    one its summary sampled, and φ̂'s standard deviations are the online estimator's, shrinking as it learns."""
    port, log = free_port(), tmp_path / "teleop.lcmlog"
    stand_in = teleop = client = None
    try:
        stand_in = _stand_in(netns, tmp_path, "--duration", FOREVER)
        teleop = _teleop(netns, tmp_path, "--view", "--view-port", str(port), "--record", str(log), settings=ONLINE)
        assert f"live view on ws://localhost:{port}" in teleop.text()
        client = _listen(netns, tmp_path, port, "/wrench/contact")
        client.wait_for(f"seen {ENOUGH} /wrench/contact")
        summary = _summary(teleop, tmp_path)
        topics, by_topic = _seen(client, tmp_path)
    finally:
        _stop_all(client, teleop, stand_in)
    assert {"/wrench/measured", "/wrench/contact", "/wrench/noncontact", "/wrench/feedback", "/hand/mapped",
            "/hand/applied", "/estimate/phi", "/estimate/offsets", "/passivity", "/master/joint_state",
            "/master/command", "/slave/joint_state", "/slave/command", "/loop", "/scene/frames",
            "/scene/wrenches"} <= topics
    # Every topic arrived but the load commands' (none was sent); the station's status at its rate, healthy.
    assert set(by_topic) == topics - {"/load/command", "/load/status"}, topics - set(by_topic)
    assert any(message["healthy"] and message["channels"]["ft_sample"]["received"] > 0
               for message in by_topic["/faults"])
    times = [message["t"] for message in by_topic["/wrench/contact"]]
    span = times[-1] - times[0]  # s of the loop's clock: at most 100 a second
    assert len(times) >= ENOUGH and len(times) - 1 <= DEFAULT_RATE * span + 1
    # The server leaves out what a client too slow to read (this one, on a busy machine) has not taken.
    print(f"the client read {(len(times) - 1) / span:.0f} rows a second of the view's {DEFAULT_RATE:g}")
    # Each tick's wrenches as the controller recorded them (heft_teleop_state, at the tick's utime).
    recorded = {}
    for event in lcm.EventLog(str(log), "r"):
        if event.channel == LcmChannels().teleop_state.name:
            state = heft_teleop_state.decode(event.data)
            recorded[state.utime] = state
    epoch, matched = summary["epoch"], 0
    for k, t in enumerate(times):
        state = recorded.get(round((epoch + t) * 1e6))
        if state is None:  # a tick before the controller was healthy: nothing recorded
            continue
        matched += 1
        assert _wrench(by_topic["/wrench/contact"][k]) == list(state.wrench_contact)
        assert _wrench(by_topic["/wrench/noncontact"][k]) == list(state.wrench_noncontact)
        assert _wrench(by_topic["/hand/mapped"][k]) == list(state.master_wrench)
    assert matched > 0.9 * len(times), (matched, len(times))
    # φ̂ as the summary sampled it, at the ticks both took; its uncertainty from the estimator's covariance.
    history = {round(t, 9): phi for t, phi in summary["estimator"]["phi_history"]}
    estimates = by_topic["/estimate/phi"]
    both = [(message, history[round(message["t"], 9)]) for message in estimates if round(message["t"], 9) in history]
    assert len(both) > 10
    for message, phi in both:
        assert message["mass"] == phi[0] and [message["first_moment"][a] for a in "xyz"] == phi[1:4]
    learned = [message for message in estimates if message["std"][0] is not None]
    assert learned, summary["estimator"]
    first, last = learned[0]["std"][0], learned[-1]["std"][0]
    # Far below the prior's 1 kg once the data come; with forgetting it may grow again as the strokes excite less.
    assert all(0.0 < message["std"][0] < 0.1 for message in learned)
    mass = true_load(resolve_scenario("fig6"))[0].phi[0]
    assert abs(learned[-1]["mass"] - mass) < 0.3  # learned from 0; the sensor's offsets are not zeroed here
    print(f"φ̂ mass {learned[-1]['mass']:.4f} ± {last:.2g} kg (σ first {first:.2g}; the load's {mass:g} kg); "
          f"{len(learned)} of {len(estimates)} messages with a standard deviation")


def test_a_client_watches_the_stand_ins_lab(netns, tmp_path):
    """`heft stand-in --view`: its joints, the commands it holds and the truth it simulates; the true wrench and φ
    are those it recorded for the sensor's sample at the arm's step each row shows, the measured wrench that
    truth with its offsets and noise."""
    port = free_port()
    stand_in = client = None
    try:
        stand_in = _stand_in(netns, tmp_path, "--duration", FOREVER, "--view", "--view-port", str(port), "--out",
                             str(tmp_path))
        assert f"live view on ws://localhost:{port}" in stand_in.text()
        client = _listen(netns, tmp_path, port, "/truth/noncontact")
        client.wait_for(f"seen {ENOUGH} /truth/noncontact")
        assert stand_in.finish() == 0, stand_in.text()
        topics, by_topic = _seen(client, tmp_path)
    finally:
        _stop_all(client, stand_in)
    expected = {"/slave/joint_state", "/slave/command", "/master/joint_state", "/master/command", "/truth/noncontact",
                "/truth/phi", "/wrench/measured", "/scene/frames", "/scene/wrenches"}
    assert expected <= topics and expected <= set(by_topic), topics
    assert not {"/wrench/contact", "/estimate/phi", "/hand/applied"} & topics  # the lab has no controller
    scenario = resolve_scenario("fig6")
    truth = np.load(tmp_path / "stand_in.truth.npz")
    channels = LcmChannels()
    arm_rate, ft_rate = channels.slave_status.rate, channels.ft_sample.rate
    row_of = {counter: k for k, counter in enumerate(truth["sample_counter"])}
    measured_at = {message["t"]: message for message in by_topic["/wrench/measured"]}
    phi_at = {message["t"]: message for message in by_topic["/truth/phi"]}
    compared = 0
    for true in by_topic["/truth/noncontact"]:
        t = true["t"]
        measured, phi = measured_at[t], phi_at[t]
        step = int(np.floor((t + 1e-9) * arm_rate))  # the arm's latest step by then; its first FT sample
        while (step + 1) / arm_rate <= t + 1e-9:
            step += 1
        k = row_of.get(round(step * ft_rate / arm_rate))
        if k is None:  # past the truth written at the end
            continue
        compared += 1
        assert _wrench(true) == truth["wrench_noncontact"][k].tolist(), t
        assert phi["mass"] == truth["phi"][k][0]
        residual = np.subtract(_wrench(measured), truth["wrench_noncontact"][k] + truth["ft_offsets"][k])
        assert np.abs(residual[:3]).max() < 2.0, residual  # N: the sensor's noise and filter, no more
    assert compared > 0.9 * len(by_topic["/truth/noncontact"])
    # No controller: the arm holds its start, as commanded; the operator moves the Phantom, which no torque acts on.
    for message in by_topic["/slave/command"] + by_topic["/slave/joint_state"]:
        np.testing.assert_allclose(message["position"], scenario.slave_initial_q, rtol=0, atol=1e-9)
    assert all(message["torque"] == [0.0] * 6 for message in by_topic["/master/command"])
    positions = np.array([message["position"] for message in by_topic["/master/joint_state"]])
    assert np.ptp(positions, axis=0).max() > 0.01
