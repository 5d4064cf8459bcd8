"""`heft export` of the LCM log of a real two-process run: `heft teleop --hardware --record`
against `heft stand-in` over UDP multicast in a private network namespace (the recording of
tests/test_hardware_log_analysis.py). Read back with the `mcap` reader: every channel's every
message, and one message per controller tick on the run's topics, with the values of the
messages decoded here."""

import collections

import lcm
import numpy as np
import pytest
from heft.diagrams.cli import main
from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.lcmtypes import heft_haptic_state, heft_teleop_state
from test_export import HARDWARE_TOPICS, read_mcap, wrench_of
from test_hardware_log_analysis import recording  # noqa: F401 (the fixture)

pytestmark = pytest.mark.slow


def test_a_two_process_recording_as_mcap(recording, tmp_path):  # noqa: F811
    assert main(["export", str(recording), "--out", str(tmp_path)]) == 0
    topics = read_mcap(tmp_path / f"{recording.stem}.mcap")
    channels = LcmChannels()
    events = collections.defaultdict(list)
    for event in lcm.EventLog(str(recording), "r"):
        events[event.channel].append(event)
    assert {channels.teleop_state.name, channels.master_state.name, channels.ft_sample.name,
            channels.station_status.name} <= set(events)
    for name, logged in events.items():  # read back in time order; two loggers' merged log is nearly so
        assert [time for time, _ in topics[f"/lcm/{name}"]] == sorted(1000 * e.timestamp for e in logged), name
    by_utime = {}
    for event in events[channels.teleop_state.name]:
        tick = heft_teleop_state.decode(event.data)
        by_utime[tick.utime] = tick
    ticks = [by_utime[utime] for utime in sorted(by_utime)]
    assert len(ticks) > 1000
    for topic in HARDWARE_TOPICS:
        assert len(topics[topic]) == len(ticks), topic
    np.testing.assert_array_equal([time for time, _ in topics["/wrench/contact"]], [1000 * t.utime for t in ticks])
    np.testing.assert_array_equal(wrench_of(topics["/wrench/contact"]), [t.wrench_contact for t in ticks])
    np.testing.assert_array_equal(wrench_of(topics["/hand/mapped"]), [t.master_wrench for t in ticks])
    masters = collections.defaultdict(list)
    for event in events[channels.master_state.name]:
        msg = heft_haptic_state.decode(event.data)
        masters[msg.utime].append(msg)
    read = [(k, masters[t.master_utime][0]) for k, t in enumerate(ticks) if len(masters[t.master_utime]) == 1]
    assert len(read) > 0.9 * len(ticks)
    positions = [m["position"] for _, m in topics["/master/joint_state"]]
    np.testing.assert_array_equal([positions[k] for k, _ in read], [msg.position for _, msg in read])
    assert len(topics["/faults"]) == len(events[channels.station_status.name])
