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

from heft.hardware_interface.fixed_layout import FixedLayout
from heft.hardware_interface.lcmtypes import heft_ft_sample, heft_ft_samples

MAX_SAMPLES = 64
"""The most samples one ``heft_ft_samples`` may hold: 8 ms at 8 kHz, 16 ticks of a 2 kHz controller
(a buffered driver sends one message a tick: 4 samples); a message claiming more is refused as
undecodable."""
FIELDS = ("utime", "sample_counter", "wrench", "acceleration", "saturated", "error")
"""The fields of a sample, in the order of ``unpack_samples``'s starts."""

_ONE = FixedLayout(heft_ft_sample)
_BLOCK_FINGERPRINT = heft_ft_samples._get_packed_fingerprint()
_HEADER = len(_BLOCK_FINGERPRINT) + 4  # the fingerprint, then num_samples (int32)


def _starts(layout: FixedLayout) -> tuple[int, ...]:
    """Where each of ``FIELDS`` starts in ``layout``'s unpacked record."""
    return tuple(at.start if isinstance(at, slice) else at for at in map(layout.field, FIELDS))


_ONE_STARTS = _starts(_ONE)
_BLOCKS = {}
"""num_samples → the layout of a ``heft_ft_samples`` holding that many, and its starts."""
for _count in range(1, MAX_SAMPLES + 1):
    _layout = FixedLayout(heft_ft_samples, num_samples=_count)
    _BLOCKS[_count] = (_layout, _starts(_layout))


def unpack_samples(payload: bytes) -> tuple[int, tuple, tuple[int, ...]] | None:
    """(n, record, starts) of an FT message: its sample count, its values in one flat record, and
    where each of ``FIELDS`` starts in it (sample k's utime is ``record[starts[0] + k]``, its wrench
    ``record[starts[2] + 6k : starts[2] + 6k + 6]``, oldest first); None if ``payload`` is neither
    type's, of another size than its count implies, or holds 0 or more than ``MAX_SAMPLES``."""
    record = _ONE.unpack(payload)
    if record is not None:
        return 1, record, _ONE_STARTS
    if len(payload) < _HEADER or not payload.startswith(_BLOCK_FINGERPRINT):
        return None
    count = int.from_bytes(payload[_HEADER - 4:_HEADER], "big", signed=True)
    block = _BLOCKS.get(count)
    if block is None:
        return None
    layout, starts = block
    record = layout.unpack(payload)
    return None if record is None else (count, record, starts)


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
    return _BLOCKS[count][0].pack(count, *utimes, *counters, *wrenches, *accelerations, *saturated, *errors)
