"""What a run on the lab shows while it goes on: the live view and the MCAP recorder fed by the hardware loop
against the stand-in, and the status line `heft teleop --hardware` writes each second."""

import json
import subprocess
import sys
import threading
import time

import lcm
import numpy as np
import pytest
from mcap.reader import make_reader

from heft.diagrams.live_view import LiveView, McapRecorder
from heft.diagrams.running.hardware_teleop import HardwareTeleop
from heft.diagrams.running.simulation import true_load
from heft.diagrams.scenario import resolve_scenario
from heft.diagrams.stations.stand_in import FaultInjection, StandIn
from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.lcmtypes import heft_load_command

from foxglove_client import FoxgloveClient, free_port, wait_for_channels

pytestmark = pytest.mark.slow


def test_the_hardware_loop_feeds_the_view_and_the_recorder(tmp_path):
    """A client sees the wrenches the controller computed, at the view's rate; the MCAP file holds one row a
    tick, each wrench the controller's of that tick, and as events the station's status at its rate, a load
    command heard and its answer."""
    scenario = resolve_scenario("fig6")
    port, path = free_port(), tmp_path / "run.mcap"
    bus = lcm.LCM("memq://")
    stand_in = StandIn(scenario, bus, LcmChannels(), FaultInjection(), clutch_at=0.1)
    view = LiveView(port)
    teleop = HardwareTeleop(scenario, true_load(scenario)[0], bus, LcmChannels(),
                            taps=[view, McapRecorder(path, scenario.robot)])
    client = FoxgloveClient(f"ws://127.0.0.1:{port}", timeout=30)
    listening = threading.Thread(target=client.receive, args=(time.monotonic() + 60,))
    listening.start()
    wait_for_channels(client, listening)
    period, now, contact = scenario.controller_period, 0.0, {}
    for k in range(1000):
        now = (k + 1) * period
        stand_in.step(now)
        if k == 600:  # an operator switches offset tracking off
            command = heft_load_command()
            command.utime, command.action = 1234, heft_load_command.TRACKING_OFF
            bus.publish(LcmChannels().load_command.name, command.encode())
        teleop.tick(now, period)
        contact[round(now / period)] = teleop.controller.wrench_contact.copy()
    stats = [tap.close() for tap in teleop.taps]
    listening.join()
    assert teleop.healthy_ticks > 500 and stats[1]["rows"] == 1000 and not stats[1]["dropped"]
    assert [tap["events_dropped"] for tap in stats] == [0, 0]
    seen = [(message["t"], message) for topic, _, message in client.messages if topic == "/wrench/contact"]
    assert 5 <= len(seen) <= 1000 * period * 100 + 1  # at most 100 a second of the loop's clock
    for t, message in seen:
        np.testing.assert_array_equal([message["force"][a] for a in "xyz"] + [message["torque"][a] for a in "xyz"],
                                      contact[round(t / period)])
    with path.open("rb") as file:
        recorded = [(channel.topic, message) for _, channel, message in make_reader(file).iter_messages()]
    assert sum(topic == "/wrench/contact" for topic, _ in recorded) == 1000
    assert {"/wrench/measured", "/hand/applied", "/estimate/phi", "/slave/joint_state", "/scene/frames"} <= \
        {topic for topic, _ in recorded}
    faults = [json.loads(message.data) for topic, message in recorded if topic == "/faults"]
    status_rate = LcmChannels().station_status.rate
    assert abs(len(faults) - 1000 * period * status_rate) <= 1
    assert faults[-1]["healthy"] and faults[-1]["channels"]["ft_sample"]["received"] > 0
    heard = [json.loads(message.data) for topic, message in recorded if topic == "/load/command"]
    answers = [json.loads(message.data) for topic, message in recorded if topic == "/load/status"]
    assert [command["action"] for command in heard] == [heft_load_command.TRACKING_OFF]
    assert [answer["command_utime"] for answer in answers] == [1234] and answers[0]["tracking"] is False


def test_the_status_line_is_written_each_second_to_a_stderr_that_is_not_a_terminal(tmp_path):
    """No lab on the bus: the forces stay off, and the line says so each second."""
    stderr = tmp_path / "stderr.txt"
    with stderr.open("w") as file:
        subprocess.run([sys.executable, "-m", "heft.diagrams.cli", "teleop", "--hardware", "--lcm-url", "memq://",
                        "--duration", "2.5", "--rt-priority", "0", "--set",
                        "{accelerometer: {position: [0, 0, 0]}, controller: {force: {mount_notch: 0}}}"],
                       stdout=subprocess.DEVNULL, stderr=file, timeout=300, check=True)
    lines = [line for line in stderr.read_text().splitlines() if line.startswith("teleop: ")]
    assert len(lines) == 2, lines
    for second, line in enumerate(lines, start=1):
        assert line.startswith(f"teleop: {second} s, ") and "FORCES OFF" in line and "φ̂ mass" in line, line
