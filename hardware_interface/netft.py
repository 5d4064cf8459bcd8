"""ATI's Net F/T over its RDT protocol (UDP): the requests, the records, a stream's checks and the client.

The wire format, as ATI gives RDT (its Ethernet Axia manual's RDT request and record structures, the
protocol the Net F/T speaks), all big-endian:

* a request, 8 bytes: ``uint16 command_header = 0x1234``, ``uint16 command``, ``uint32 sample_count``
  (0: stream until stopped); ``command`` 0x0000 stops streaming, 0x0002 starts real-time streaming
  (one record a packet), 0x0003 buffered streaming (the device's RDT buffer size of records a packet);
* a record, 36 bytes: ``uint32 rdt_sequence`` (1 for a stream's first record, one more each record
  sent, wrapping after 2³² − 1), ``uint32 ft_sequence`` (the device's internal sample number),
  ``uint32 status`` (the system status code; bit 31: any error), then ``int32`` Fx, Fy, Fz, Tx, Ty, Tz
  in counts. A packet holds one or more records.

Counts become N and N·m through the lab's calibration (``NetFtParams``: counts per N, per N·m). The
wrench is what the sensor reports, the load's on the sensor: heft's FT channel's sign, flipped by
``ft_receiver`` alone (docs/design.md §4). Every datagram is untrusted: one of another length is
refused and counted (``unpack_records``), a record not newer than the stream's last is dropped as
stale, and a gap in ``rdt_sequence`` counts the records lost on the way (``RdtStream``).
"""

import socket
import struct

import numpy as np

from heft.hardware_interface.ft_messages import MAX_SAMPLES, pack_samples
from heft.hardware_interface.netft_params import RDT_PORT

COMMAND_HEADER = 0x1234
"""The first field of every RDT request."""
STOP_STREAMING, START_REALTIME, START_BUFFERED = 0x0000, 0x0002, 0x0003
"""RDT commands: stop streaming; stream one record a packet; stream the RDT buffer's records a packet."""
REQUEST = struct.Struct(">HHI")
"""An RDT request: command_header, command, sample_count."""
RECORD = np.dtype([("rdt_sequence", ">u4"), ("ft_sequence", ">u4"), ("status", ">u4"), ("counts", ">i4", (6,))])
"""An RDT record (36 bytes): the two sequence numbers, the status code, [Fx, Fy, Fz, Tx, Ty, Tz] in counts."""
_RECORD_STRUCT = struct.Struct(">III6i")
STATUS_ERROR = 1 << 31
"""The status code's error bit: a record that carries it is flagged ``error`` on the FT channel."""
REORDER_WINDOW = 1024
"""Records an ``rdt_sequence`` may fall behind the stream's newest and still be a late packet of the
same stream; further back it is a new stream (a restarted device or a new start request)."""
_WRAP = 1 << 32
_SO_TIMESTAMPNS = getattr(socket, "SO_TIMESTAMPNS", 35)
"""Linux's socket option for the kernel's receive time of each datagram (Python 3.11 does not name it)."""
_TIMESPEC = struct.Struct("@qq")
"""That time: s and ns since the epoch."""
_TIMESTAMP_BYTES = socket.CMSG_SPACE(_TIMESPEC.size)


def pack_request(command: int, sample_count: int = 0) -> bytes:
    """The 8 bytes of an RDT request."""
    return REQUEST.pack(COMMAND_HEADER, command, sample_count)


def unpack_request(datagram: bytes) -> tuple[int, int] | None:
    """(command, sample_count) of an RDT request; None if it is not 8 bytes starting with 0x1234."""
    if len(datagram) != REQUEST.size:
        return None
    header, command, sample_count = REQUEST.unpack(datagram)
    return (command, sample_count) if header == COMMAND_HEADER else None


def pack_records(rows) -> bytes:
    """One packet of records, each row (rdt_sequence, ft_sequence, status, Fx, Fy, Fz, Tx, Ty, Tz): three
    uint32 and six int32, in one ``struct`` call a record (a few records a packet: numpy costs more)."""
    return b"".join(_RECORD_STRUCT.pack(*row) for row in rows)


def unpack_records(datagram: bytes) -> np.ndarray | None:
    """The records of a packet (``RECORD``, oldest first); None if its length is not a positive
    multiple of 36 bytes."""
    if not datagram or len(datagram) % RECORD.itemsize:
        return None
    return np.frombuffer(datagram, dtype=RECORD)


def record_stamps(count: int, arrival: int, period: int, newest: int) -> list[int]:
    """Stamps (µs) of a packet's ``count`` records taken at ``arrival`` (µs): its newest there, each
    older one ``period`` (µs, the RDT output period) before the next, and each after ``newest`` (the
    last stamp given before) by at least 1 µs, so that a channel's stamps strictly increase."""
    stamps = []
    for k in range(count):
        newest = max(arrival - (count - 1 - k) * period, newest + 1)
        stamps.append(newest)
    return stamps


def ft_messages_of(records: np.ndarray, counters, stamps, counts_per_unit: np.ndarray) -> list[bytes]:
    """``heft_ft_samples`` of ``records`` (oldest first), at most ``MAX_SAMPLES`` a message: utime
    ``stamps`` (µs), sample_counter ``counters``, the wrench in N and N·m (counts over
    ``counts_per_unit``: the load's on the sensor, as the device reports it), no acceleration (a Net
    F/T has no accelerometer: 0), nothing saturated, ``error`` where the status has ``STATUS_ERROR``."""
    wrenches = (records["counts"] / counts_per_unit).ravel().tolist()
    errors = ((records["status"] & STATUS_ERROR) != 0).tolist()
    messages = []
    for first in range(0, len(records), MAX_SAMPLES):
        last = min(first + MAX_SAMPLES, len(records))
        n = last - first
        messages.append(pack_samples(stamps[first:last], counters[first:last], wrenches[6 * first:6 * last],
                                     [0.0] * 6 * n, [0] * n, errors[first:last]))
    return messages


class RdtStream:
    """The client's view of the records it received: which are new, the records lost on the way,
    the status bits seen. ``take`` returns the new records' index in the packet and heft's sample
    counter for each: ``ft_sequence`` unwrapped to 64 bits, strictly increasing (a step of 0 or back,
    a restarted device, counts 1).

    Counts: ``records`` (new), ``lost`` (``rdt_sequence`` gaps), ``stale`` (a record not newer than
    the newest: a duplicate or a late packet), ``restarts`` (a stream begun anew: ``rdt_sequence``
    back by more than ``REORDER_WINDOW``), ``status_bits`` (32: new records with each bit set),
    ``errors`` (new records with ``STATUS_ERROR``)."""

    def __init__(self):
        self.records = self.lost = self.stale = self.restarts = self.errors = 0
        self.status_bits = np.zeros(32, dtype=np.int64)
        self._rdt = self._ft = None  # the newest record's sequence numbers
        self._counter = 0

    def take(self, records: np.ndarray) -> tuple[list[int], list[int]]:
        """(indices, counters) of the new records among ``records`` (a packet's, oldest first)."""
        indices, counters = [], []
        for k, (rdt, ft, status) in enumerate(zip(records["rdt_sequence"].tolist(), records["ft_sequence"].tolist(),
                                                  records["status"].tolist())):
            if self._rdt is not None:
                ahead = (rdt - self._rdt) % _WRAP
                if ahead == 0 or ahead >= _WRAP - REORDER_WINDOW:
                    self.stale += 1
                    continue
                if ahead < _WRAP // 2:
                    self.lost += ahead - 1
                else:
                    self.restarts += 1
                step = (ft - self._ft) % _WRAP
                self._counter += step if 0 < step < _WRAP // 2 else 1
            else:
                self._counter = ft
            self._rdt, self._ft = rdt, ft
            self.records += 1
            if status:
                self.status_bits += (status >> np.arange(32)) & 1
                self.errors += bool(status & STATUS_ERROR)
            indices.append(k)
            counters.append(self._counter)
        return indices, counters

    def status_summary(self) -> dict[str, int]:
        """Each status bit seen: ``"0x80000000"`` → the new records that carried it."""
        return {f"0x{1 << bit:08x}": int(n) for bit, n in enumerate(self.status_bits) if n}


class NetFtClient:
    """A UDP socket connected to a Net F/T at (``address``, ``port``; ValueError if it cannot be): the
    kernel passes on only its datagrams, and keeps up to ``receive_buffer`` bytes of them (as much as
    ``net.core.rmem_max`` grants; 4 MiB: seconds of packets) while the driver is kept off the CPU.
    ``request`` sends an RDT request; ``receive`` the datagrams waiting, each with its arrival."""

    def __init__(self, address: str, port: int = RDT_PORT, receive_buffer: int = 4 << 20):
        self._socket = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._socket.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, receive_buffer)
        try:
            self._socket.connect((address, port))
        except OSError as error:  # an unknown host name, no route
            self._socket.close()
            raise ValueError(f"the Net F/T at {address}:{port} cannot be reached: {error}") from None
        self._socket.setblocking(False)
        self._socket.setsockopt(socket.SOL_SOCKET, _SO_TIMESTAMPNS, 1)

    def fileno(self) -> int:
        return self._socket.fileno()

    def request(self, command: int, sample_count: int = 0) -> None:
        """Sends an RDT request, again if the first send only reported an earlier one refused (nothing
        listened then); a send that fails is left to the caller's retries."""
        for _ in range(2):
            try:
                self._socket.send(pack_request(command, sample_count))
                return
            except OSError:
                pass

    def receive(self, clock) -> list[tuple[bytes, float]]:
        """Every datagram waiting (at most 64 kB each), with the wall time (s since the epoch) the kernel
        received it at (``clock()`` at its taking if the kernel gave none): a driver late to read its
        socket still dates the packets by their arrival."""
        taken = []
        while True:
            try:
                datagram, ancillary, _, _ = self._socket.recvmsg(65536, _TIMESTAMP_BYTES)
            except (BlockingIOError, ConnectionRefusedError):
                return taken
            arrival = next((seconds + 1e-9 * nanoseconds for level, kind, data in ancillary
                            if (level, kind) == (socket.SOL_SOCKET, _SO_TIMESTAMPNS)
                            for seconds, nanoseconds in [_TIMESPEC.unpack(data)]), None)
            taken.append((datagram, clock() if arrival is None else arrival))

    def close(self) -> None:
        self._socket.close()
