"""The Net F/T's RDT codec against bytes packed by hand with ``struct`` in the layout of ATI's manual
(request: >HHI with header 0x1234; record: >III6i, 36 bytes), the stream's checks, and the FT
messages the driver makes of the records."""

import struct

import numpy as np
import pytest

from heft.hardware_interface.ft_messages import MAX_SAMPLES, decode_samples
from heft.hardware_interface.netft import (RECORD, START_BUFFERED, START_REALTIME, STATUS_ERROR, STOP_STREAMING,
                                           RdtStream, ft_messages_of, pack_records, pack_request, record_stamps,
                                           unpack_records, unpack_request)
from heft.hardware_interface.netft_params import NetFtParams


def _record(rdt, ft, status, *counts) -> bytes:
    return struct.pack(">III6i", rdt, ft, status, *counts)


def test_requests_are_the_manuals_eight_bytes():
    assert pack_request(START_REALTIME) == bytes([0x12, 0x34, 0x00, 0x02, 0, 0, 0, 0])
    assert pack_request(START_BUFFERED, 1000) == struct.pack(">HHI", 0x1234, 3, 1000)
    assert pack_request(STOP_STREAMING) == struct.pack(">HHI", 0x1234, 0, 0)
    assert unpack_request(struct.pack(">HHI", 0x1234, 2, 7)) == (2, 7)
    assert unpack_request(struct.pack(">HHI", 0x4321, 2, 0)) is None  # another header
    assert unpack_request(struct.pack(">HHI", 0x1234, 2, 0) + b"\0") is None  # another length
    assert unpack_request(b"") is None


def test_records_read_and_written_in_the_manuals_layout():
    assert RECORD.itemsize == 36
    packet = _record(1, 4_000_000_000, 0x80000001, -1, 2, -300, 4, 2**31 - 1, -2**31) + _record(2, 5, 0, *range(6))
    records = unpack_records(packet)
    assert records["rdt_sequence"].tolist() == [1, 2]
    assert records["ft_sequence"].tolist() == [4_000_000_000, 5]
    assert records["status"].tolist() == [0x80000001, 0]
    assert records["counts"].tolist() == [[-1, 2, -300, 4, 2**31 - 1, -2**31], list(range(6))]
    assert pack_records([(1, 4_000_000_000, 0x80000001, -1, 2, -300, 4, 2**31 - 1, -2**31),
                         (2, 5, 0, *range(6))]) == packet
    for length in (0, 1, 35, 37, 71):
        assert unpack_records(bytes(length)) is None


def test_the_stream_counts_gaps_stale_records_restarts_and_status_bits():
    stream = RdtStream()
    take = lambda *rows: stream.take(unpack_records(b"".join(_record(*row, 0, 0, 0, 0, 0, 0) for row in rows)))
    assert take((1, 100, 0), (2, 101, 0)) == ([0, 1], [100, 101])
    assert take((5, 120, 0x00010000)) == ([0], [120])  # records 3, 4 lost; ft_sequence steps as it does
    assert (stream.lost, stream.stale) == (2, 0)
    assert take((5, 120, 0), (4, 119, 0), (6, 121, STATUS_ERROR)) == ([2], [121])  # a duplicate, a late one
    assert (stream.stale, stream.errors, stream.records) == (2, 1, 4)
    assert stream.status_summary() == {"0x00010000": 1, "0x80000000": 1}
    # A new stream (rdt_sequence from 1, far behind) of a restarted device (ft_sequence from 0): counted, and
    # the counter still increases.
    assert take((100_000, 130, 0)) == ([0], [130])
    assert take((1, 0, 0)) == ([0], [131])
    assert (stream.restarts, stream.lost) == (1, 2 + 100_000 - 7)
    # Both sequences wrap after 2**32 - 1; the counter goes on past it.
    wrapping = RdtStream()
    rows = [(2**32 - 2, 2**32 - 2), (2**32 - 1, 2**32 - 1), (0, 0), (1, 1)]
    packet = b"".join(_record(rdt, ft, 0, 0, 0, 0, 0, 0, 0) for rdt, ft in rows)
    assert wrapping.take(unpack_records(packet))[1] == [2**32 - 2, 2**32 - 1, 2**32, 2**32 + 1]
    assert (wrapping.lost, wrapping.stale, wrapping.restarts) == (0, 0, 0)


def test_ft_messages_carry_the_calibrated_wrench_in_the_sensors_sign():
    params = NetFtParams(counts_per_force=1_000_000.0, counts_per_torque=500.0)
    records = unpack_records(_record(1, 10, 0, 1_500_000, -2_000_000, 0, 500, -250, 1)
                             + _record(2, 11, STATUS_ERROR | 1, 0, 0, 0, 0, 0, 0))
    stamps = record_stamps(2, 1_000_000, 125, 0)
    assert stamps == [999_875, 1_000_000]
    (message,) = ft_messages_of(records, [10, 11], stamps, params.counts_per_unit())
    first, second = decode_samples(message)
    assert first.wrench == pytest.approx([1.5, -2.0, 0.0, 1.0, -0.5, 0.002])  # the load on the sensor, unflipped
    assert (first.utime, first.sample_counter, first.error, first.saturated) == (999_875, 10, False, 0)
    assert first.acceleration == [0.0] * 6
    assert (second.utime, second.sample_counter, second.error) == (1_000_000, 11, True)
    many = unpack_records(b"".join(_record(k + 1, k, 0, 0, 0, 0, 0, 0, 0) for k in range(MAX_SAMPLES + 1)))
    split = ft_messages_of(many, list(range(MAX_SAMPLES + 1)), list(range(1, MAX_SAMPLES + 2)),
                           params.counts_per_unit())
    assert [len(decode_samples(m)) for m in split] == [MAX_SAMPLES, 1]


def test_stamps_strictly_increase_across_packets():
    assert record_stamps(3, 1000, 125, 0) == [750, 875, 1000]
    assert record_stamps(3, 1000, 125, 900) == [901, 902, 1000]  # a packet bunched behind the last
    assert np.all(np.diff(record_stamps(4, 10, 125, 20)) > 0)


def test_the_calibration_must_be_stated():
    with pytest.raises(ValueError, match="state lab.netft.counts_per_force"):
        NetFtParams().validate()
    with pytest.raises(ValueError, match="counts_per_torque"):
        NetFtParams(counts_per_force=1e6, counts_per_torque=float("nan")).validate()
    with pytest.raises(ValueError, match="port"):
        NetFtParams(counts_per_force=1e6, counts_per_torque=1e6, port=0).validate()
    NetFtParams(counts_per_force=1e6, counts_per_torque=1e6).validate()


def test_the_driver_publishes_what_a_device_streams_and_counts_what_it_refuses():
    """A device played by a thread on loopback answers the driver's start request with hand-packed
    packets: two good ones, one of a wrong length, one after a gap, one repeated, one flagged error;
    the driver publishes the new records, counts the rest, asks to stop at the end, and runs on."""
    import socket
    import threading

    import lcm
    from heft.diagrams.running.netft_driver import run_netft_driver
    from heft.hardware_interface.channels import LcmChannels

    device = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    device.bind(("127.0.0.1", 0))
    device.settimeout(10.0)
    params = NetFtParams(counts_per_force=1000.0, counts_per_torque=100.0, port=device.getsockname()[1])
    heard, done = [], threading.Event()

    def play():
        request, client = device.recvfrom(64)
        heard.append(request)
        packets = [_record(1, 10, 0, 1000, 0, 0, 0, 0, 0) + _record(2, 11, 0, 2000, 0, 0, 0, 0, 0),
                   _record(3, 12, 0, 0, 0, 0, 0, 0, 0)[:35],  # a wrong length: refused
                   _record(5, 14, 0, 0, 0, 0, 100, 0, 0),  # record 3 (in the bad datagram) and 4 lost
                   _record(5, 14, 0, 0, 0, 0, 100, 0, 0),  # repeated: stale
                   _record(6, 15, STATUS_ERROR, 0, 0, 0, 0, 0, 0)]
        for packet in packets:
            device.sendto(packet, client)
        heard.append(device.recvfrom(64)[0])  # the stop request
        done.set()

    bus, samples = lcm.LCM("memq://"), []
    channels = LcmChannels(lcm_url="memq://")
    bus.subscribe(channels.ft_sample.name, lambda _, data: samples.extend(decode_samples(data)))
    thread = threading.Thread(target=play)
    thread.start()

    def all_four_heard() -> bool:
        while bus.handle_timeout(0) > 0:
            pass
        return len(samples) >= 4

    summary = run_netft_driver("127.0.0.1", params, channels, 10.0, stop=all_four_heard, bus=bus)
    thread.join(timeout=10.0)
    device.close()
    assert done.is_set() and heard == [pack_request(START_BUFFERED), pack_request(STOP_STREAMING)]
    assert [s.sample_counter for s in samples] == [10, 11, 14, 15]
    assert [s.wrench[0] for s in samples[:2]] == [1.0, 2.0] and samples[2].wrench[3] == 1.0
    assert [s.error for s in samples] == [False, False, False, True]
    assert np.all(np.diff([s.utime for s in samples]) > 0)
    assert (summary["rejected"], summary["lost"], summary["stale"], summary["errors"], summary["published"]) == (
        {"length": 1}, 2, 1, 1, 3)


def test_the_driver_refuses_to_start_without_the_calibration(capsys):
    from heft.diagrams.cli import main

    assert main(["driver", "netft", "--address", "127.0.0.1", "--duration", "0"]) == 2
    assert "state lab.netft.counts_per_force" in capsys.readouterr().err


def test_an_unreachable_device_is_refused_in_one_line(capsys):
    from heft.diagrams.cli import main

    assert main(["driver", "netft", "--address", "no-such-host.invalid", "--counts-per-force", "1e6",
                 "--counts-per-torque", "1e6", "--rt-priority", "0", "--duration", "0"]) == 2
    assert "the Net F/T at no-such-host.invalid:49152 cannot be reached" in capsys.readouterr().err


def test_a_datagram_read_late_is_dated_by_its_arrival():
    import socket
    import time

    from heft.hardware_interface.netft import NetFtClient

    device = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    device.bind(("127.0.0.1", 0))
    client = NetFtClient("127.0.0.1", device.getsockname()[1])
    try:
        client.request(START_REALTIME)
        _, address = device.recvfrom(64)
        # Linux turns receive stamps on for the whole stack a moment after the first socket asks (a
        # deferred static key); until then it stamps a datagram when it is read. Each try reads 0.1 s
        # late; the first whose stamp is the send's passes, and the feature never working fails.
        for sequence in range(1, 21):
            sent = time.time()
            device.sendto(_record(sequence, sequence, 0, 0, 0, 0, 0, 0, 0), address)
            time.sleep(0.1)  # the driver late to read
            ((_, arrival),) = client.receive(time.time)
            if arrival < sent + 0.05:
                break
    finally:
        client.close()
        device.close()
    assert sent <= arrival < sent + 0.05
