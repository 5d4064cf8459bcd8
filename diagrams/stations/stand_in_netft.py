"""The stand-in's wrist sensor as an ATI Net F/T: its samples streamed over RDT (UDP) instead of LCM.

``NetFtResponder`` takes the place of the stand-in's FT outlet (``StandIn(ft_outlet=...)``): each
``heft_ft_samples`` the JR3 model makes becomes RDT records, byte for byte as a Net F/T sends them
(``hardware_interface.netft``): ``rdt_sequence`` from 1 for each start request, ``ft_sequence`` the
sample counter (mod 2³²), the status code, and the wrench in counts through the lab's calibration
(``lab.netft``), in the sensor's sign. It answers requests on (host, ``lab.netft.port``): a start
streams to the requester (buffered: one packet per message, the samples of an arm step; real-time:
one a record) until a stop or ``sample_count`` records; anything else is refused and counted.

A sample the JR3 model flags (a wrench axis saturated, NaN, error) carries ``STATUS_ERROR`` with counts 0 for what
is not finite. For the tests, ``NetFtInjection`` withholds every n-th packet (its ``rdt_sequence``
spent, as a packet lost on the way) and sets status bits on the records of a time window.
"""

from __future__ import annotations

import dataclasses
import math
import socket

from heft.hardware_interface.ft_messages import unpack_samples
from heft.hardware_interface.netft import (START_BUFFERED, START_REALTIME, STATUS_ERROR, STOP_STREAMING, pack_records,
                                           unpack_request)
from heft.hardware_interface.netft_params import NetFtParams

_INT32 = (-(1 << 31), (1 << 31) - 1)
_WRAP = 1 << 32
_WRENCH_AXES = 0x3F
"""The saturation flags of the wrench's six axes (``heft_ft_sample.saturated``; a Net F/T has no accelerometer)."""


@dataclasses.dataclass
class NetFtInjection:
    """Faults of the stand-in's Net F/T, for the tests."""

    drop_every: int = 0
    """Every n-th packet streamed is withheld, its records' ``rdt_sequence`` spent; 0: none."""
    status: int = 0
    """Status bits (uint32) every record sampled in [``status_at_s``, ``status_until_s``) carries."""
    status_at_s: float = math.inf
    status_until_s: float = math.inf

    def validate(self) -> None:
        if self.drop_every < 0:
            raise ValueError(f"--netft-drop-every must be >= 0; got {self.drop_every}")
        if not 0 <= self.status < 1 << 32:
            raise ValueError(f"--netft-status must be a uint32 of status bits; got {self.status}")


class NetFtResponder:
    """The Net F/T's RDT server on (``host``, ``params.port``; ValueError if it cannot listen there) and
    the stand-in's FT outlet (``name``, ``count``: packets sent, ``lost``, ``send``); ``summary()``
    counts what it did."""

    def __init__(self, params: NetFtParams, host: str, injection: NetFtInjection | None = None,
                 name: str = "NETFT_RDT"):
        params.validate()
        self.injection = injection = injection or NetFtInjection()
        injection.validate()
        self.name, self.count = name, 0
        self.address = (host, params.port)
        self._per_unit = params.counts_per_unit().tolist()
        self._socket = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            self._socket.bind(self.address)
        except OSError as error:  # the port taken, an address not this machine's
            self._socket.close()
            raise ValueError(f"--netft {host}: cannot answer on UDP port {params.port}: {error}") from None
        self._socket.setblocking(False)
        self._client, self._buffered, self._remaining, self._rdt = None, True, math.inf, 0
        self.requests, self.refused, self.records, self.packets, self.withheld, self.flagged = 0, 0, 0, 0, 0, 0

    def serve(self) -> None:
        """Answers the requests waiting: a start streams to its sender from ``rdt_sequence`` 1, a stop
        ends the stream; a datagram that is not a known request is refused and counted."""
        while True:
            try:
                datagram, sender = self._socket.recvfrom(512)
            except (BlockingIOError, ConnectionRefusedError):
                return
            request = unpack_request(datagram)
            if request is None or request[0] not in (STOP_STREAMING, START_REALTIME, START_BUFFERED):
                self.refused += 1
                continue
            self.requests += 1
            command, sample_count = request
            if command == STOP_STREAMING:
                self._client = None
            else:
                self._client, self._buffered, self._rdt = sender, command == START_BUFFERED, 0
                self._remaining = sample_count or math.inf

    def lost(self, tick: int, t: float) -> bool:
        """The stand-in's own losses do not apply: a Net F/T's are ``NetFtInjection.drop_every``'s."""
        return False

    def send(self, tick: int, payload: bytes) -> None:
        """Streams the samples of a ``heft_ft_samples`` to the client, if one asked."""
        self.serve()
        if self._client is None:
            return
        count, record, (utime, counter, wrench, _, saturated, error) = unpack_samples(payload)
        count = int(min(count, self._remaining))
        injection, rows = self.injection, []
        for k in range(count):
            values = record[wrench + 6 * k:wrench + 6 * k + 6]
            status = 0
            if all(map(math.isfinite, values)):
                counts = [min(max(round(value * per_unit), _INT32[0]), _INT32[1])
                          for value, per_unit in zip(values, self._per_unit)]
            else:
                counts, status = [0] * 6, STATUS_ERROR
            if record[saturated + k] & _WRENCH_AXES or record[error + k]:
                status |= STATUS_ERROR
            if injection.status_at_s <= record[utime + k] * 1e-6 < injection.status_until_s:
                status |= injection.status
            self.flagged += status != 0
            self._rdt += 1
            rows.append((self._rdt % _WRAP, record[counter + k] % _WRAP, status, *counts))
        step = count if self._buffered else 1
        for first in range(0, count, step):
            self.packets += 1
            if injection.drop_every and self.packets % injection.drop_every == 0:
                self.withheld += 1
                continue
            try:  # a device streams on whether or not its client still listens
                self._socket.sendto(pack_records(rows[first:first + step]), self._client)
            except OSError:
                pass
            self.count += 1
            self.records += min(step, count - first)
        self._remaining -= count
        if self._remaining <= 0:
            self._client = None

    def summary(self) -> dict:
        """What it served: requests taken and refused, packets streamed and withheld, records sent, and
        records sampled with status bits set."""
        return {"address": f"{self.address[0]}:{self.address[1]}", "requests": self.requests,
                "refused": self.refused, "packets": self.packets, "withheld": self.withheld,
                "sent": self.count, "records": self.records, "flagged": self.flagged}

    def close(self) -> None:
        self._socket.close()
