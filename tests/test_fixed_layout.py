"""``FixedLayout`` and the kernels that encode into its buffers against the encoders lcm-gen wrote, on every
fixed-size message heft sends per tick."""

import numpy as np
import pytest
from drake import lcmt_iiwa_command, lcmt_iiwa_status

from heft.hardware_interface.fixed_layout import (FixedLayout, of_layout, put_wire_double, put_wire_int, wire_double,
                                                  wire_int)
from heft.hardware_interface.hardware_station import (CHECKED_CHANNELS, RECEIVED, RESTARTS, STATUS_FIELDS, UNREAD,
                                                      encode_station_status)
from heft.hardware_interface.lcmtypes import (heft_ft_sample, heft_gripper_state, heft_haptic_command,
                                               heft_haptic_state, heft_load_status, heft_station_status,
                                               heft_teleop_state)
from heft.hardware_interface.message_checks import REASONS
from heft.hardware_interface.teleop_state import (DT, FT_UTIME, GAIN, MASTER_UTIME, SLAVE_UTIME, STARTS, STATE_FIELDS,
                                                  UTIME, encode_teleop_state)

_RANDOM = {"int8_t": lambda rng: int(rng.integers(-128, 128)), "int16_t": lambda rng: int(rng.integers(-2**15, 2**15)),
           "int32_t": lambda rng: int(rng.integers(-2**31, 2**31)),
           "int64_t": lambda rng: int(rng.integers(-2**62, 2**62)), "double": lambda rng: float(rng.normal(0, 1e3)),
           "boolean": lambda rng: bool(rng.integers(2))}


_BYTES = {"int8_t": 1, "int16_t": 2, "int32_t": 4, "int64_t": 8, "double": 8, "boolean": 1}
"""Bytes per value on the wire (the LCM type specification)."""
MESSAGES = pytest.mark.parametrize("message_type,lengths", [
    (heft_ft_sample, {}), (heft_gripper_state, {}), (heft_teleop_state, {}), (heft_haptic_state, {"num_joints": 6}),
    (heft_haptic_command, {"num_joints": 6}), (lcmt_iiwa_status, {"num_joints": 6}),
    (lcmt_iiwa_command, {"num_joints": 6, "num_torques": 0})])


def random_message(message_type, layout: FixedLayout, lengths: dict, rng) -> tuple:
    """(msg, values): a message of ``layout`` with random values, and its values as ``pack`` takes them."""
    msg, values = message_type(), []
    for (name, count), typename, dimensions in zip(layout.fields, message_type.__typenames__,
                                                   message_type.__dimensions__):
        if name in lengths:
            value = lengths[name]
        elif dimensions:
            value = [_RANDOM[typename](rng) for _ in range(count)]
        else:
            value = _RANDOM[typename](rng)
        setattr(msg, name, value)
        values.extend(value if dimensions else [value])
    return msg, values


@MESSAGES
def test_pack_is_the_generated_encoding(message_type, lengths):
    layout = FixedLayout(message_type, **lengths)
    rng = np.random.default_rng(7)
    for _ in range(20):
        msg, values = random_message(message_type, layout, lengths, rng)
        payload = layout.pack(*values)
        assert payload == msg.encode() and len(payload) == layout.size
        assert message_type.decode(payload).utime == msg.utime


@MESSAGES
def test_kernels_read_and_write_every_value_where_the_generated_encoder_puts_it(message_type, lengths):
    layout = FixedLayout(message_type, **lengths)
    rng = np.random.default_rng(8)
    for _ in range(5):
        msg, _ = random_message(message_type, layout, lengths, rng)
        payload = msg.encode()
        assert of_layout(payload, layout.fingerprint, layout.size)
        assert not of_layout(payload + b"\0", layout.fingerprint, layout.size)
        assert not of_layout(bytes(8) + payload[8:], layout.fingerprint, layout.size)
        written = np.zeros(layout.size, dtype=np.uint8)
        written[:8] = np.frombuffer(layout.fingerprint, dtype=np.uint8)
        for (name, _), typename in zip(layout.fields, message_type.__typenames__):
            value = getattr(msg, name)
            for i, item in enumerate(value if isinstance(value, (list, tuple)) else [value]):
                at = layout.offset(name) + _BYTES[typename] * i
                if typename == "double":
                    assert wire_double(payload, at) == item
                    put_wire_double(written, at, item)
                else:
                    assert wire_int(payload, at, _BYTES[typename]) == int(item)
                    put_wire_int(written, at, _BYTES[typename], int(item))
        assert written.tobytes() == payload


def test_a_type_it_cannot_lay_out_is_refused_with_the_reason():
    with pytest.raises(ValueError, match="sized by num_joints: give FixedLayout"):
        FixedLayout(heft_haptic_state)
    with pytest.raises(ValueError, match="primitive fields only"):
        FixedLayout(heft_load_status)
    with pytest.raises(ValueError, match="no field num_torques"):
        FixedLayout(heft_haptic_state, num_joints=6, num_torques=1)


def test_unpack_reads_what_the_generated_encoder_wrote_and_refuses_anything_else():
    layout = FixedLayout(heft_haptic_state, num_joints=6)
    msg = heft_haptic_state()
    msg.utime, msg.num_joints, msg.buttons, msg.error = 123456, 6, 1, True
    msg.position, msg.velocity, msg.torque_applied = [0.1 * i for i in range(6)], [-1.0] * 6, [2.5] * 6
    values = layout.unpack(msg.encode())
    assert values[layout.field("utime")] == 123456 and values[layout.field("buttons")] == 1
    assert list(values[layout.field("position")]) == msg.position and values[layout.field("error")] == 1
    assert layout.unpack(bytes(8) + msg.encode()[8:]) is None  # of the right size, another type's fingerprint
    msg.num_joints, msg.position, msg.velocity, msg.torque_applied = 5, [0.0] * 5, [0.0] * 5, [0.0] * 5
    assert layout.unpack(msg.encode()) is None  # another joint count: another size
    assert layout.unpack(b"") is None


def test_strings_are_constants_of_the_layout_encoded_as_the_generated_encoder_does():
    channels, reasons = ("master_state", "ft_sample"), ("undecodable", "non_finite", "driver_error")
    layout = FixedLayout(heft_station_status, strings={"channels": channels, "reasons": reasons}, num_channels=2,
                         num_reasons=3)
    assert [name for name, _ in layout.fields] == [name for name in heft_station_status.__slots__
                                                    if name not in ("channels", "reasons")]
    msg = heft_station_status()
    msg.utime, msg.healthy, msg.fault, msg.gain, msg.num_channels, msg.num_reasons = 123, True, 5, 0.25, 2, 3
    msg.channels, msg.reasons = list(channels), list(reasons)
    msg.received, msg.unread, msg.rejected = [7, 8], [1, 0], [[1, 2, 3], [4, 5, 6]]
    msg.restarts, msg.second_publisher = [0, 2], [False, True]
    payload = layout.pack(123, True, 5, 0.25, 2, 3, 7, 8, 1, 0, 1, 2, 3, 4, 5, 6, 0, 2, False, True)
    assert payload == msg.encode() and len(payload) == layout.size
    values = layout.unpack(payload)
    assert values[layout.field("channels")] == (len("master_state") + 1, b"master_state\0", len("ft_sample") + 1,
                                                 b"ft_sample\0")
    assert list(values[layout.field("rejected")]) == [1, 2, 3, 4, 5, 6] and values[layout.field("gain")] == 0.25
    buffer, at = layout.buffer(("gain",))
    assert heft_station_status.decode(buffer.tobytes()).channels == list(channels)  # the constants are in place
    assert at[0] == layout.offset("gain")
    with pytest.raises(ValueError, match="holds 2 string"):
        FixedLayout(heft_station_status, strings={"channels": channels[:1], "reasons": reasons}, num_channels=2,
                    num_reasons=3)
    with pytest.raises(ValueError, match="strings given as constants"):
        FixedLayout(heft_station_status, num_channels=2, num_reasons=3)


def test_the_status_and_state_kernels_write_what_the_generated_encoders_write():
    rng = np.random.default_rng(9)
    layout = FixedLayout(heft_station_status, strings={"channels": CHECKED_CHANNELS, "reasons": REASONS},
                         num_channels=len(CHECKED_CHANNELS), num_reasons=len(REASONS))
    buffer, at = layout.buffer(STATUS_FIELDS)
    for _ in range(5):
        counts = rng.integers(0, 2**40, size=(len(CHECKED_CHANNELS), 3))
        counts[:, RESTARTS] %= 2**31
        rejected = rng.integers(0, 2**40, size=(len(CHECKED_CHANNELS), len(REASONS)))
        conflicts, gain, fault = int(rng.integers(0, 16)), float(rng.random()), int(rng.integers(0, 128))
        encode_station_status(buffer, at, 1_700_000_000_000_000, bool(conflicts & 1), fault, gain, conflicts, counts,
                              rejected)
        msg = heft_station_status()
        msg.utime, msg.healthy, msg.fault, msg.gain = 1_700_000_000_000_000, bool(conflicts & 1), fault, gain
        msg.num_channels, msg.num_reasons = len(CHECKED_CHANNELS), len(REASONS)
        msg.channels, msg.reasons = list(CHECKED_CHANNELS), list(REASONS)
        msg.received, msg.unread = counts[:, RECEIVED].tolist(), counts[:, UNREAD].tolist()
        msg.rejected, msg.restarts = rejected.tolist(), counts[:, RESTARTS].tolist()
        msg.second_publisher = [bool(conflicts >> i & 1) for i in range(len(CHECKED_CHANNELS))]
        assert buffer.tobytes() == msg.encode()
    buffer, at = FixedLayout(heft_teleop_state).buffer(STATE_FIELDS)
    for _ in range(5):
        stamps, scalars = rng.integers(-2**40, 2**40, size=5), rng.normal(size=2)
        stamps[STARTS] %= 2**31
        arrays = [rng.normal(size=size) for size in (6, 6, 2, 2, 6, 6)]
        encode_teleop_state(buffer, at, stamps, scalars, *arrays)
        msg = heft_teleop_state()
        msg.utime, msg.starts = int(stamps[UTIME]), int(stamps[STARTS])
        msg.master_utime, msg.slave_utime, msg.ft_utime = (int(stamps[i]) for i in (MASTER_UTIME, SLAVE_UTIME,
                                                                                      FT_UTIME))
        msg.dt, msg.gain = float(scalars[DT]), float(scalars[GAIN])
        (msg.master_wrench, msg.applied_wrench, msg.energy, msg.damping, msg.wrench_contact,
         msg.wrench_noncontact) = (a.tolist() for a in arrays)
        assert buffer.tobytes() == msg.encode()
