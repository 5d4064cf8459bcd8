"""`heft driver netft`'s loop: an ATI Net F/T's RDT stream published as heft's FT channel.

It asks the device to stream (``lab.netft.buffered``: buffered or real-time), asking again every
``RETRY_S`` while none of its records arrive (a lost request, a device not yet up or restarted; not
while it reads what waited in its socket, which a driver late to read finds older than that),
and publishes each packet's new records as one ``heft_ft_samples`` on ``lab.lcm.ft_sample`` (its
name, on ``lab.lcm.lcm_url``): the wrench in N and N·m through the calibration, in the sensor's
sign; the records' stamps on the wall clock (``record_stamps``: the newest at the packet's arrival
at the kernel, the older ``1 / ft_sample.rate`` apart); no acceleration (the Net F/T has none);
``error`` where the status code has its error bit. What it refused, lost and saw in the status is
counted (``RdtStream``) and summarised; it never stops on a datagram.
"""

from __future__ import annotations

import select
import time

import lcm

from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.netft import (START_BUFFERED, START_REALTIME, STOP_STREAMING, NetFtClient, RdtStream,
                                           ft_messages_of, record_stamps, unpack_records)
from heft.hardware_interface.netft_params import NetFtParams

RETRY_S = 0.1
"""s without a record after which the start request is sent again."""
_WAIT_S = 0.05
"""The longest wait (s) for a datagram, so that a stop request is seen soon."""


def run_netft_driver(address: str, params: NetFtParams, channels: LcmChannels, duration: float, stop=None,
                     ready=None, clock=time.time, bus: lcm.LCM | None = None) -> dict:
    """Streams from the Net F/T at ``address`` for ``duration`` s (wall time) or until ``stop()``
    returns True; ``ready()`` is called at the first record. ``clock``: wall time (s since the epoch);
    ``bus``: where to publish (default: one on ``channels.lcm_url``).

    Returns {"duration_s", "cpu_s" (this process's CPU time over the run), "streamed_s" (from the first
    new record's packet to the last's), "packets", "records", "published", "published_hz" (messages a
    second streamed), "samples_hz", "rejected" ({"length": datagrams of another size}), "lost",
    "stale", "restarts", "errors", "status_bits" (``RdtStream``'s), "start_requests"}."""
    params.validate()
    bus = lcm.LCM(channels.lcm_url) if bus is None else bus
    client = NetFtClient(address, params.port)
    stream, per_unit = RdtStream(), params.counts_per_unit()
    period_us = round(1e6 / channels.ft_sample.rate)
    start_command = START_BUFFERED if params.buffered else START_REALTIME
    begin, cpu = clock(), time.process_time()
    first = last_record = None
    newest_us, packets, rejected, published, requests, asked = 0, 0, 0, 0, 0, -float("inf")
    try:
        while True:
            taken = client.receive(clock)
            for datagram, arrival in taken:
                records = unpack_records(datagram)
                if records is None:
                    rejected += 1
                    continue
                packets += 1
                indices, counters = stream.take(records)
                if not indices:
                    continue
                if first is None:
                    first = arrival
                    if ready is not None:
                        ready()
                last_record = arrival
                stamps = record_stamps(len(indices), round(arrival * 1e6), period_us, newest_us)
                newest_us = stamps[-1]
                for message in ft_messages_of(records[indices], counters, stamps, per_unit):
                    bus.publish(channels.ft_sample.name, message)
                    published += 1
            now = clock()
            if now - begin >= duration or (stop is not None and stop()):
                break
            if not taken and now - max(asked, last_record or -float("inf")) >= RETRY_S:  # silent, not just read late
                client.request(start_command)
                requests, asked = requests + 1, now
            select.select([client], [], [], min(_WAIT_S, max(0.0, begin + duration - now)))
    finally:
        client.request(STOP_STREAMING)
        client.close()
    end = clock()
    streamed = max(last_record - first, 1e-9) if first is not None else None
    return {"duration_s": end - begin, "cpu_s": time.process_time() - cpu, "streamed_s": streamed or 0.0,
            "packets": packets, "records": stream.records, "published": published,
            "published_hz": published / streamed if streamed else 0.0,
            "samples_hz": stream.records / streamed if streamed else 0.0, "rejected": {"length": rejected},
            "lost": stream.lost, "stale": stream.stale, "restarts": stream.restarts, "errors": stream.errors,
            "status_bits": stream.status_summary(), "start_requests": requests}
