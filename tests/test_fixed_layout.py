"""``FixedLayout`` against the encoders lcm-gen wrote, on every fixed-size message heft sends per tick."""

import numpy as np
import pytest
from drake import lcmt_iiwa_command, lcmt_iiwa_status

from heft.hardware_interface.fixed_layout import (FixedLayout, of_layout, put_wire_double, put_wire_int, wire_double,
                                                  wire_int)
from heft.hardware_interface.lcmtypes import (heft_ft_sample, heft_gripper_state, heft_haptic_command,
                                               heft_haptic_state, heft_load_status, heft_teleop_state)

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
    with pytest.raises(ValueError, match="no length field num_torques"):
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
