"""The stand-in's Net F/T on loopback, stepped with explicit times beside the same lab on LCM: its RDT
records carry the LCM stand-in's samples in counts, byte for byte in ATI's layout; it answers only
well-formed requests; injected gaps and status bits show in the records."""

import os
import struct

import lcm
import numpy as np
import pytest

from heft.diagrams.scenario import Scenario
from heft.diagrams.stations.stand_in import FaultInjection, StandIn
from heft.diagrams.stations.stand_in_netft import NetFtInjection, NetFtResponder
from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.ft_messages import decode_samples
from heft.hardware_interface.netft import (START_BUFFERED, START_REALTIME, STATUS_ERROR, STOP_STREAMING, NetFtClient,
                                           unpack_records)
from heft.hardware_interface.netft_params import NetFtParams

CHANNELS = LcmChannels(lcm_url="memq://")
PARAMS = NetFtParams(counts_per_force=1_000_000.0, counts_per_torque=1_000_000.0,
                     port=20000 + os.getpid() % 20000)  # loopback outside a namespace: a port of this test's own
STEP = 0.0005  # s: the arm's step


def _run(lab: StandIn, until: float, start: float = 0.0) -> None:
    t = start
    while t < until - 1e-9:
        t += STEP
        lab.step(t)


def _lcm_samples(until: float):
    """The LCM stand-in's FT samples up to ``until`` (s)."""
    bus, samples = lcm.LCM("memq://"), []
    bus.subscribe(CHANNELS.ft_sample.name, lambda _, data: samples.extend(decode_samples(data)))
    lab = StandIn(Scenario(), bus, CHANNELS)
    t = 0.0
    while t < until - 1e-9:
        t += STEP
        lab.step(t)
        while bus.handle_timeout(0) > 0:
            pass
    return samples


@pytest.fixture
def netft():
    """(lab, responder, client): the stand-in with its FT samples on a Net F/T, and a client of it."""
    responder = NetFtResponder(PARAMS, "127.0.0.1", NetFtInjection(drop_every=10, status=0x00010000,
                                                                   status_at_s=0.02, status_until_s=0.03))
    client = NetFtClient("127.0.0.1", PARAMS.port)
    yield StandIn(Scenario(), lcm.LCM("memq://"), CHANNELS, ft_outlet=responder), responder, client
    client.close()
    responder.close()


def test_records_carry_the_lcm_stand_ins_samples_in_counts(netft):
    lab, responder, client = netft
    _run(lab, 0.005)  # before any request nothing is sent
    assert responder.count == 0 and not client.receive(lambda: 0.0)
    client.request(START_BUFFERED)
    _run(lab, 0.05, 0.005)
    packets = [data for data, _ in client.receive(lambda: 0.0)]
    records = np.concatenate([unpack_records(data) for data in packets])
    assert {len(data) for data in packets} == {4 * 36}  # an arm step's 4 samples a packet
    by_counter = {s.sample_counter: s for s in _lcm_samples(0.05)}
    for record in records:
        sample = by_counter[int(record["ft_sequence"])]
        assert np.all(np.abs(record["counts"] - np.array(sample.wrench) * 1e6) <= 0.5)  # the sensor's sign, rounded
    # rdt_sequence from 1, every 10th packet withheld (its 4 numbers spent); the status bits on [0.02, 0.03) s.
    sent = records["rdt_sequence"].astype(int)
    assert sent[0] == 1 and set(np.diff(sent)) == {1, 5}
    assert responder.withheld == responder.packets // 10 and len(packets) == responder.count
    flagged = records["ft_sequence"][records["status"] != 0]
    assert records["status"][records["status"] != 0].tolist() == [0x00010000] * len(flagged)
    assert 0.02 <= flagged.min() / 8000 and flagged.max() / 8000 < 0.03 + 1e-9
    # Stop: nothing more.
    client.request(STOP_STREAMING)
    _run(lab, 0.06, 0.05)
    assert not client.receive(lambda: 0.0)


def test_real_time_streaming_sends_a_record_a_packet_and_counts_down(netft):
    lab, responder, client = netft
    client.request(START_REALTIME, 6)
    _run(lab, 0.01)
    packets = [data for data, _ in client.receive(lambda: 0.0)]
    assert [len(p) for p in packets] == [36] * 6
    assert [int(unpack_records(p)["rdt_sequence"][0]) for p in packets] == [1, 2, 3, 4, 5, 6]


def test_only_well_formed_requests_are_answered(netft):
    lab, responder, client = netft
    for request in (struct.pack(">HHI", 0x4321, 2, 0), struct.pack(">HHI", 0x1234, 0x42, 0), b"\x12\x34", b""):
        client._socket.send(request)
    _run(lab, 0.01)
    assert (responder.refused, responder.requests, responder.count) == (4, 0, 0)


def test_flagged_samples_carry_the_error_bit():
    responder = NetFtResponder(PARAMS, "127.0.0.1")
    client = NetFtClient("127.0.0.1", PARAMS.port)
    try:
        lab = StandIn(Scenario(), lcm.LCM("memq://"), CHANNELS, FaultInjection(nan_rate=0.5), ft_outlet=responder)
        client.request(START_BUFFERED)
        _run(lab, 0.01)
        records = np.concatenate([unpack_records(data) for data, _ in client.receive(lambda: 0.0)])
    finally:
        client.close()
        responder.close()
    errors = records["status"] == STATUS_ERROR
    assert 0 < errors.sum() < len(records) and not records["counts"][errors].any()  # NaN: 0 counts and the error bit


def test_a_taken_port_is_refused_in_one_line(netft):
    with pytest.raises(ValueError, match="--netft 127.0.0.1: cannot answer on UDP port"):
        NetFtResponder(PARAMS, "127.0.0.1")
