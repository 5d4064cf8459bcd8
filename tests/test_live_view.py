"""The live view: a client speaking ``foxglove.websocket.v1`` (``foxglove_client.py``) connects to
`heft simulate fig6 --view`. It subscribes to every advertised topic and checks that
each arrives at the view's rate and that the wrenches equal the run's log.npz row for row; the
loop's hand-off (`LiveView.publish`) is timed against its budget; `McapRecorder` writes every row,
however fast they come.
"""

import json
import subprocess
import sys
import threading
import time

import numpy as np
import pytest
import yaml
from heft.diagrams.live_view import DEFAULT_RATE, LiveView, McapRecorder
from heft.diagrams.scenario import resolve_scenario
from heft.diagrams.stations.sim_station import MakeSimStation
from mcap.reader import make_reader

from foxglove_client import FoxgloveClient, free_port, wait_for_channels


def write_estimate(folder):
    station = MakeSimStation(resolve_scenario("fig6"))
    phi = station.GetOutputPort("truth.phi").Eval(station.CreateDefaultContext())
    path = folder / "estimate.yaml"
    path.write_text(yaml.safe_dump({"phi": np.asarray(phi).tolist(), "offsets": [0.0] * 6}))
    return path


@pytest.mark.slow
def test_a_client_sees_every_topic_at_its_rate_with_the_logs_wrenches(tmp_path):
    port = free_port()
    heft = subprocess.Popen([sys.executable, "-m", "heft.diagrams.cli", "simulate", "fig6", "--sigma", "1",
                             "--duration", "1.0", "--estimate", str(write_estimate(tmp_path)), "--out",
                             str(tmp_path / "run"), "--view", "--view-port", str(port)],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        client = FoxgloveClient(f"ws://127.0.0.1:{port}", timeout=300, server_alive=lambda: heft.poll() is None)
        while client.receive(time.monotonic() + 1.0):
            pass
        output, _ = heft.communicate(timeout=120)
    except Exception:
        heft.kill()
        raise AssertionError(heft.communicate()[0]) from None
    assert heft.returncode == 0, output
    topics = {channel["topic"] for channel in client.channels.values()}
    assert {"/wrench/measured", "/wrench/contact", "/wrench/noncontact", "/wrench/feedback", "/hand/applied",
            "/estimate/phi", "/passivity", "/master/joint_state", "/scene/frames", "/scene/wrenches",
            "/faults"} <= topics
    assert all(channel["encoding"] == "json" for channel in client.channels.values())
    log = np.load(tmp_path / "run" / "log.npz")
    by_topic = {}
    for topic, _, message in client.messages:
        by_topic.setdefault(topic, []).append(message)
    counts = {topic: len(messages) for topic, messages in by_topic.items()}
    assert set(by_topic) == topics - {"/faults", "/load/command", "/load/status"}, (counts, output)
    for topic in topics - {"/faults", "/load/command", "/load/status", "/scene/frames", "/scene/wrenches"}:
        steps = np.diff([message["t"] for message in by_topic[topic]])
        assert len(steps) > 20 and np.allclose(steps, 1 / DEFAULT_RATE, atol=1e-9), topic
    assert len(by_topic["/scene/frames"]) == len(by_topic["/wrench/contact"])
    for topic, key in (("/wrench/measured", "wrench_measured"), ("/wrench/contact", "wrench_contact"),
                       ("/wrench/noncontact", "wrench_noncontact"), ("/hand/applied", "master_force_applied")):
        messages = by_topic[topic]
        rows = np.searchsorted(log["t"], [m["t"] - 1e-9 for m in messages])  # the row of the same instant
        np.testing.assert_allclose(log["t"][rows], [m["t"] for m in messages], rtol=0, atol=1e-12)
        np.testing.assert_array_equal([[m["force"][a] for a in "xyz"] + [m["torque"][a] for a in "xyz"]
                                       for m in messages], log[key][rows], err_msg=topic)


WIDTHS = {"wrench_measured": 6, "wrench_contact": 6, "wrench_noncontact": 6, "master_force_applied": 6,
          "passivity_energy": 2, "passivity_damping": 2, "master_q": 6, "master_v": 6, "slave_q": 6, "hold": 1}


def rows(n: int, seed: int = 1) -> list[dict]:
    rng = np.random.default_rng(seed)
    return [{key: rng.normal(size=width) for key, width in WIDTHS.items()} for _ in range(n)]


def test_the_recorder_writes_every_row_handed_to_it(tmp_path):
    """Rows handed over at 10 kHz, faster than the worker encodes them (3 s of a 2 kHz loop in 0.6 s):
    none is lost."""
    data = rows(6000)
    with McapRecorder(tmp_path / "run.mcap") as recorder:
        recorder.open(WIDTHS, t0_ns=10**18)
        for k, row in enumerate(data):
            start = time.perf_counter()
            assert recorder.publish(k * 0.0005, row)
            while time.perf_counter() < start + 1e-4:
                pass
        stats = recorder.close()
    with open(tmp_path / "run.mcap", "rb") as file:
        written = sum(1 for _ in make_reader(file).iter_messages())
    assert stats == {"rows": len(data), "dropped": 0, "messages": written, "events_dropped": 0}
    with open(tmp_path / "run.mcap", "rb") as file:
        messages = [(channel.topic, message.log_time, json.loads(message.data))
                    for _, channel, message in make_reader(file).iter_messages(
                        topics=["/wrench/contact", "/loop", "/scene/frames"])]
    contact = [(t, m) for topic, t, m in messages if topic == "/wrench/contact"]
    assert [t for t, _ in contact] == [10**18 + round(k * 0.0005 * 1e9) for k in range(len(data))]
    np.testing.assert_array_equal([[m["force"][a] for a in "xyz"] for _, m in contact],
                                  [row["wrench_contact"][:3] for row in data])
    np.testing.assert_array_equal([m["hold"] for topic, _, m in messages if topic == "/loop"],
                                  [row["hold"][0] for row in data])
    assert [m["transforms"][0]["timestamp"] for topic, _, m in messages if topic == "/scene/frames"] == [
        dict(zip(("sec", "nsec"), divmod(round(k * 0.0005 * 1e9), 10**9), strict=True))
        for k in range(0, len(data), 20)]  # the scene at 100 Hz


def test_the_loop_hands_rows_over_at_the_views_rate(tmp_path):
    """`publish` at 2 kHz with the view's worker running: taken at the view's rate (what a call costs is printed;
    `heft bench lcm --view` measures the tick with it); with no client, the worker encodes none of them."""
    data = rows(2000)
    with LiveView(free_port()) as view:
        view.open(WIDTHS)
        taken, costs = 0, []
        for k, row in enumerate(data):
            start = time.perf_counter()
            taken += view.publish(k * 0.0005, row)
            costs.append(time.perf_counter() - start)
        view.event("/faults", {"healthy": True}, 0.1)
        stats = view.close()
    assert taken == pytest.approx(len(data) * 0.0005 * DEFAULT_RATE, abs=1)
    assert stats == {"rows": taken, "dropped": 0, "messages": 0, "events_dropped": 0}
    print(f"hand-off: median {1e6 * np.median(costs):.1f} µs, p99 {1e6 * np.percentile(costs, 99):.1f} µs")


@pytest.mark.slow
def test_a_client_sees_the_rows_a_loop_hands_over_at_the_views_rate():
    """Rows published by a 2 kHz loop reach a client at 100 Hz, values and scene as handed over."""
    data = rows(2000, seed=2)
    port = free_port()
    with LiveView(port) as view:
        view.open(WIDTHS)
        client = FoxgloveClient(f"ws://127.0.0.1:{port}", timeout=30)
        listening = threading.Thread(target=client.receive, args=(time.monotonic() + 120,))
        listening.start()
        wait_for_channels(client, listening)
        time.sleep(0.5)
        for k, row in enumerate(data):
            start = time.perf_counter()
            view.publish(k * 0.0005, row)
            while time.perf_counter() < start + 0.0005:
                pass
        view.event("/faults", {"healthy": True}, 0.1)
        stats = view.close()
    listening.join()
    assert 0 < len(client.messages) <= stats["messages"]
    by_topic = {}
    for topic, _, message in client.messages:
        by_topic.setdefault(topic, []).append(message)
    received = by_topic["/wrench/measured"]
    steps = [round(m["t"] / 0.0005) for m in received]  # taken every 10 ms of the loop's clock: every 20th row
    assert steps == list(range(steps[0], len(data), 20)) and steps[0] <= 200, steps
    taken = [data[k] for k in steps]
    np.testing.assert_array_equal([[m["force"][a] for a in "xyz"] + [m["torque"][a] for a in "xyz"]
                                   for m in by_topic["/wrench/measured"]], [row["wrench_measured"] for row in taken])
    np.testing.assert_array_equal([m["velocity"] for m in by_topic["/master/joint_state"]],
                                  [row["master_v"] for row in taken])
    assert len(by_topic["/scene/frames"]) == len(taken) and by_topic["/faults"] == [{"healthy": True}]
    assert [m["t"] for m in received] == [k * 0.0005 for k in steps]


def test_events_reach_the_file_converted_as_export_does_and_start_no_thread(tmp_path):
    """The loop's events (a station status and a load command as their LCM bytes, a dict) reach the MCAP on their
    topics, the LCM ones as ``heft export`` converts them (the fields set here; the status per channel), and sending
    them starts no thread in the loop's process."""
    from heft.hardware_interface.lcmtypes import heft_load_command, heft_station_status

    status = heft_station_status()
    status.utime, status.healthy, status.fault, status.gain = 7, True, 2, 0.5
    status.num_channels, status.num_reasons, status.channels, status.reasons = 1, 2, ["ft_sample"], ["nan", "range"]
    status.received, status.unread, status.rejected, status.restarts = [40], [1], [[3, 0]], [0]
    status.second_publisher = [True]
    command = heft_load_command()
    command.utime, command.action, command.phi, command.offsets = 9, 3, [0.5] + [0.0] * 9, [0.25] * 6
    path = tmp_path / "events.mcap"
    recorder = McapRecorder(path)
    recorder.open({"wrench_measured": 6})
    threads = threading.active_count()
    recorder.publish(0.0, {"wrench_measured": np.zeros(6)})
    recorder.event("/faults", status.encode(), 0.01)
    recorder.event("/load/command", command.encode(), 0.02)
    recorder.event("/faults", {"healthy": False}, 0.03)
    assert threading.active_count() == threads
    recorder.close()
    with open(path, "rb") as file:
        events = [(channel.topic, json.loads(message.data)) for _, channel, message in make_reader(file).iter_messages()
                  if channel.topic in ("/faults", "/load/command")]
    assert events == [
        ("/faults", {"utime": 7, "healthy": True, "fault": 2, "gain": 0.5,
                     "channels": {"ft_sample": {"received": 40, "unread": 1, "rejected": {"nan": 3, "range": 0},
                                                "restarts": 0, "second_publisher": True}}}),
        ("/load/command", {"utime": 9, "action": 3, "phi": [0.5] + [0.0] * 9, "offsets": [0.25] * 6}),
        ("/faults", {"healthy": False})]


def test_an_event_to_a_worker_gone_is_counted_not_raised(tmp_path):
    """The loop never fails for its view: with the worker killed, an event is dropped and counted; an LCM message's
    bytes on a row topic, which the worker could not convert, are refused at the call."""
    recorder = McapRecorder(tmp_path / "gone.mcap")
    recorder.open({"wrench_measured": 6}, topics=("/estimate/phi",))
    with pytest.raises(ValueError, match="/estimate/phi is a row topic"):
        recorder.event("/estimate/phi", b"\x00" * 8, 0.0)
    recorder._process.kill()
    recorder._process.join()
    recorder.event("/faults", {"healthy": True}, 0.1)
    recorder.event("/faults", b"\x00" * 8, 0.2)
    assert recorder.events_dropped == 2
    assert recorder.close()["events_dropped"] == 2
