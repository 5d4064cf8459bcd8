"""The FT channel's two message types, read alike.

A wrist sensor's driver publishes each sample as one ``heft_ft_sample`` (a datagram per sample:
8 000 a second at the paper's rate) or, buffered, the samples since its last message as one
``heft_ft_samples`` (as ATI's NetFT streams several RDT records in one packet: a datagram per
controller tick). The payload's fingerprint tells which. ``unpack_samples`` reads either into
one flat record and where each field starts in it, so that sample k of n is read the same way
from both (``heft_ft_samples`` holds each field's values for all samples, oldest first);
``decode_samples`` gives one ``heft_ft_sample`` per sample, for readers of recordings;
``pack_samples`` encodes a block, as the stand-in's driver sends it.
"""

from __future__ import annotations

import numpy as np

from heft.systems.compiled import compiled

from heft.hardware_interface.fixed_layout import PAYLOAD, FixedLayout, of_layout, of_type, wire_int
from heft.hardware_interface.lcmtypes import heft_ft_sample, heft_ft_samples

MAX_SAMPLES = 64
"""The most samples one ``heft_ft_samples`` may hold: 8 ms at 8 kHz, 16 ticks of a 2 kHz controller
(a buffered driver sends one message a tick: 4 samples); a message claiming more is refused as
undecodable."""
FIELDS = ("utime", "sample_counter", "wrench", "acceleration", "saturated", "error")
"""The fields of a sample, in the order of ``unpack_samples``'s starts."""

_ONE = FixedLayout(heft_ft_sample)
_BLOCKS = {count: FixedLayout(heft_ft_samples, num_samples=count) for count in range(1, MAX_SAMPLES + 1)}
"""num_samples → the layout of a ``heft_ft_samples`` holding that many."""
ONE_FINGERPRINT, BLOCK_FINGERPRINT = _ONE.fingerprint, heft_ft_samples._get_packed_fingerprint()
SIZE = 0
OFFSETS = np.array([[layout.size] + [layout.offset(name) for name in FIELDS]
                    for layout in (_ONE, *_BLOCKS.values())], dtype=np.int64)
"""Row 0 for a ``heft_ft_sample``, row n for a ``heft_ft_samples`` of n: the message's size (``SIZE``),
then the byte at which each of ``FIELDS`` starts (sample k's values follow its first's: ``SAMPLE_BYTES``)."""
SAMPLE_BYTES = np.array([8, 8, 48, 48, 2, 1], dtype=np.int64)
"""Bytes per sample of each of ``FIELDS`` (LCM's int64, int64, double[6] twice, int16, boolean)."""
_STARTS = [tuple(at.start if isinstance(at, slice) else at for at in map(layout.field, FIELDS))
           for layout in (_ONE, *_BLOCKS.values())]
"""Per row of ``OFFSETS``, where each of ``FIELDS`` starts in the layout's unpacked record."""


@compiled(f"UniTuple(int64, 2)({PAYLOAD}, {PAYLOAD}, {PAYLOAD}, int64[:, :])")
def samples_in(payload, one_fingerprint, block_fingerprint, offsets) -> tuple[int, int]:
    """(n, row): the samples an FT message holds and its row of ``offsets`` (``OFFSETS``); (0, 0) if
    ``payload`` is neither type's, of another size than its count implies, or holds 0 or more
    than ``MAX_SAMPLES``."""
    if of_layout(payload, one_fingerprint, offsets[0, SIZE]):
        return 1, 0
    if not of_type(payload, block_fingerprint) or len(payload) < len(block_fingerprint) + 4:
        return 0, 0
    count = wire_int(payload, len(block_fingerprint), 4)  # num_samples
    if 1 <= count < offsets.shape[0] and len(payload) == offsets[count, SIZE]:
        return count, count
    return 0, 0


def unpack_samples(payload: bytes) -> tuple[int, tuple, tuple[int, ...]] | None:
    """(n, record, starts) of an FT message: its sample count, its values in one flat record, and
    where each of ``FIELDS`` starts in it (sample k's utime is ``record[starts[0] + k]``, its wrench
    ``record[starts[2] + 6k : starts[2] + 6k + 6]``, oldest first); None if ``samples_in`` finds none."""
    count, row = samples_in(payload, ONE_FINGERPRINT, BLOCK_FINGERPRINT, OFFSETS)
    if count == 0:
        return None
    return count, (_ONE if row == 0 else _BLOCKS[count]).unpack(payload), _STARTS[row]


def decode_samples(payload: bytes) -> list[heft_ft_sample]:
    """Each sample of an FT message as a ``heft_ft_sample``, oldest first; ValueError if it is not
    one (``unpack_samples``)."""
    unpacked = unpack_samples(payload)
    if unpacked is None:
        raise ValueError(f"not a heft_ft_sample or a heft_ft_samples of 1 to {MAX_SAMPLES} samples "
                         f"({len(payload)} bytes)")
    count, record, (utime, counter, wrench, acceleration, saturated, error) = unpacked
    samples = []
    for k in range(count):
        msg = heft_ft_sample()
        msg.utime, msg.sample_counter = record[utime + k], record[counter + k]
        msg.wrench = list(record[wrench + 6 * k:wrench + 6 * k + 6])
        msg.acceleration = list(record[acceleration + 6 * k:acceleration + 6 * k + 6])
        msg.saturated, msg.error = record[saturated + k], bool(record[error + k])
        samples.append(msg)
    return samples


def pack_samples(utimes, counters, wrenches, accelerations, saturated, errors) -> bytes:
    """One ``heft_ft_samples`` of the n samples given field by field, oldest first: ``utimes`` and
    ``counters`` (n ints), ``wrenches`` and ``accelerations`` (6n floats, sample by sample),
    ``saturated`` (n flag words) and ``errors`` (n booleans)."""
    count = len(utimes)
    if not 1 <= count <= MAX_SAMPLES:
        raise ValueError(f"a heft_ft_samples holds 1 to {MAX_SAMPLES} samples; got {count}")
    return _BLOCKS[count].pack(count, *utimes, *counters, *wrenches, *accelerations, *saturated, *errors)
