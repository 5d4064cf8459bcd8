"""LCM messages of a fixed size, encoded in one ``struct`` call.

lcm-gen's Python classes encode and decode field by field, through a ``BytesIO`` and one ``struct``
call per field. Once its length fields are fixed (``lengths``), and its string fields are constants
(``strings``: names that never change, such as the channels a status reports on), a message's wire
format is one big-endian record: the type's 8-byte fingerprint, then every field in declaration order,
arrays flattened row-major, a string as its length (with its terminating NUL) and its bytes.
``FixedLayout`` reads that record off the generated class itself (``__slots__``, ``__typenames__``,
``__dimensions__``), so the two cannot disagree, and packs a message from its values in one call, or unpacks
one into them (docs/benchmarks.md, "Simulation and kernels": the arm's status in 1.8 and 0.9 µs against 6.0
and 4.8 µs), for the drivers and loops that send and read at kHz rates. A payload of another size or
fingerprint is not of the layout: ``unpack`` says so with None, and the generated decoder can tell what else
it is. Kernels read a payload in place: ``of_layout`` (or ``of_type``), then ``wire_int`` and
``wire_double`` at a field's ``offset``; and write one into the layout's ``buffer`` with ``put_wire_int`` and
``put_wire_double``, which a loop then publishes without building a message object.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence

import numpy as np

from heft.systems.compiled import compiled

_CODES = {"int8_t": "b", "int16_t": "h", "int32_t": "i", "int64_t": "q", "float": "f", "double": "d",
          "boolean": "b", "byte": "B"}
"""``struct`` codes of LCM's primitive types (LCM type specification: big-endian, booleans as int8)."""


class FixedLayout:
    """The wire record of ``message_type`` (an lcm-gen Python class) with its length fields set to
    ``lengths`` (e.g. ``num_joints=6``) and its string fields to the constants ``strings`` (name: the
    field's strings, as many as its length field says). ``fields`` names the values ``pack`` takes, in
    order, each with its count (an array's values are passed flattened; the strings are the layout's own)."""

    def __init__(self, message_type, strings: dict[str, Sequence[str]] | None = None, **lengths: int):
        strings = strings or {}
        self.fields: list[tuple[str, int]] = []
        self._slices: dict[str, slice] = {}
        self._offsets: dict[str, int] = {}
        self._constants: list[tuple[int, tuple]] = []  # (where in the record's values, the strings' values)
        codes, start = ">8s", 1  # the values after the fingerprint
        for name, typename, dimensions in zip(message_type.__slots__, message_type.__typenames__,
                                              message_type.__dimensions__, strict=True):
            if typename not in _CODES and not (typename == "string" and name in strings):
                raise ValueError(f"{message_type.__name__}.{name} is a {typename}: a FixedLayout takes primitive "
                                 "fields only" + (", and strings given as constants (strings=)"
                                                  if typename == "string" else ""))
            count = 1
            for dimension in dimensions or ():
                if isinstance(dimension, str) and dimension not in lengths:
                    raise ValueError(f"{message_type.__name__}.{name} is sized by {dimension}: give "
                                     f"FixedLayout({message_type.__name__}, {dimension}=...)")
                count *= lengths[dimension] if isinstance(dimension, str) else dimension
            self._offsets[name] = struct.calcsize(codes)
            if typename == "string":
                values = [strings[name]] if not dimensions else list(strings[name])
                if len(values) != count:
                    raise ValueError(f"{message_type.__name__}.{name} holds {count} string(s); got {len(values)}")
                encoded = [value.encode("utf-8") + b"\0" for value in values]
                self._constants.append((start, tuple(item for data in encoded for item in (len(data), data))))
                codes += "".join(f"i{len(data)}s" for data in encoded)
                self._slices[name] = slice(start, start + 2 * count)  # (length, bytes) per string
                start += 2 * count
                continue
            self.fields.append((name, count))
            self._slices[name] = slice(start, start + count) if dimensions else start
            codes += f"{count}{_CODES[typename]}"
            start += count
        unused = (set(lengths) | set(strings)) - set(message_type.__slots__)
        if unused:
            raise ValueError(f"{message_type.__name__} has no field {', '.join(sorted(unused))}")
        self._record = struct.Struct(codes)
        self._lengths = lengths
        self.fingerprint = message_type._get_packed_fingerprint()
        """The type's 8 bytes that start each message."""
        self.size = self._record.size
        """Bytes per message."""

    def pack(self, *values) -> bytes:
        """The encoded message of ``values``: every field of ``fields`` in order, arrays flattened."""
        if not self._constants:
            return self._record.pack(self.fingerprint, *values)
        record = [self.fingerprint, *values]
        for start, constant in self._constants:
            record[start:start] = constant
        return self._record.pack(*record)

    def unpack(self, payload: bytes) -> tuple | None:
        """The fingerprint and every value of ``payload`` (index them with ``field``), or None if it is
        not a message of this layout (another size or type)."""
        if len(payload) != self.size or not payload.startswith(self.fingerprint):
            return None
        return self._record.unpack(payload)

    def buffer(self, fields: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
        """(buffer, at): a message of this layout with its length fields and strings set and every other
        value zero, as bytes for a kernel to write the rest into, and the byte offsets of ``fields`` in it."""
        values = []
        for name, count in self.fields:
            values += [self._lengths.get(name, 0)] * count
        return (np.frombuffer(bytearray(self.pack(*values)), dtype=np.uint8),
                np.array([self.offset(name) for name in fields], dtype=np.int64))

    def field(self, name: str) -> int | slice:
        """Where field ``name`` lies in ``unpack``'s tuple: an index, or a slice for an array (for strings,
        each string's length and bytes)."""
        return self._slices[name]

    def offset(self, name: str) -> int:
        """The byte at which field ``name`` starts in a message (its first value, for an array)."""
        return self._offsets[name]


PAYLOAD = "Bytes(uint8, 1, 'C')"
"""numba's type of a payload (``bytes``) in a kernel's signature."""


@compiled(f"boolean({PAYLOAD}, {PAYLOAD})")
def of_type(payload, fingerprint) -> bool:
    """Whether ``payload`` starts with a type's ``fingerprint`` (8 bytes)."""
    if len(payload) < len(fingerprint):
        return False
    for i in range(len(fingerprint)):
        if payload[i] != fingerprint[i]:
            return False
    return True


@compiled(f"boolean({PAYLOAD}, {PAYLOAD}, int64)")
def of_layout(payload, fingerprint, size) -> bool:
    """Whether ``payload`` is a message of the ``FixedLayout`` of that ``fingerprint`` and ``size``."""
    return len(payload) == size and of_type(payload, fingerprint)


@compiled(f"int64({PAYLOAD}, int64, int64)")
def wire_int(payload, at, size) -> int:
    """The big-endian two's-complement integer of ``size`` bytes (1, 2, 4 or 8) at byte ``at``."""
    value = payload[at] - 256 if payload[at] >= 128 else payload[at]  # the sign is the first byte's
    for i in range(1, size):
        value = value * 256 + payload[at + i]
    return value


@compiled(f"float64({PAYLOAD}, int64)")
def wire_double(payload, at) -> float:
    """The big-endian IEEE 754 double at byte ``at``."""
    return np.int64(wire_int(payload, at, 8)).view(np.float64)


@compiled("void(uint8[:], int64, int64, int64)")
def put_wire_int(buffer, at, size, value) -> None:
    """Writes ``value`` as a big-endian two's-complement integer of ``size`` bytes at byte ``at``."""
    for i in range(size):
        buffer[at + size - 1 - i] = (value >> (8 * i)) & 0xFF


@compiled("void(uint8[:], int64, float64)")
def put_wire_double(buffer, at, value) -> None:
    """Writes ``value`` as a big-endian IEEE 754 double at byte ``at``."""
    put_wire_int(buffer, at, 8, np.float64(value).view(np.int64))
