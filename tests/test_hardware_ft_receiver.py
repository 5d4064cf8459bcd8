"""FT sample reader: sign flip, hold-and-flag of bad samples, ordering, restarts; and the
committed LCM Python types match lcm-gen's output."""

import math

import numpy as np
import pytest
from heft.hardware_interface.ft_receiver import FtSampleReader
from heft.hardware_interface.lcmtypes import heft_ft_sample
from heft.hardware_interface.lcmtypes import regenerate as lcmtypes_regenerate

RAW = np.array([1.0, -2.0, 3.0, 0.1, -0.2, 0.3])
ACCEL = np.array([0.5, 0.0, -9.81, 0.01, 0.02, -0.03])


def sample(counter, utime, wrench=RAW, acceleration=ACCEL, saturated=0, error=False) -> bytes:
    msg = heft_ft_sample()
    msg.sample_counter, msg.utime = counter, utime
    msg.wrench, msg.acceleration = list(wrench), list(acceleration)
    msg.saturated, msg.error = saturated, error
    return msg.encode()


def test_nothing_before_the_first_sample():
    reader = FtSampleReader()
    reader.take([sample(0, 0)], now=1.0)  # utime 0: "no sample yet"
    assert math.isinf(reader.t_good) and reader.dropped == 0
    np.testing.assert_array_equal(reader.wrench, np.zeros(6))


def test_sign_flipped_to_sensor_on_load():
    reader = FtSampleReader()
    reader.take([sample(1, 1000)], now=0.25)
    np.testing.assert_array_equal(reader.wrench, -RAW)
    np.testing.assert_array_equal(reader.acceleration, ACCEL)
    assert reader.t_good == 0.25 and not (reader.non_finite or reader.saturated or reader.error)


def test_all_samples_read_in_order_newest_kept():
    reader = FtSampleReader()
    reader.take([sample(k, 1000 + 125 * k, wrench=k * RAW) for k in range(1, 5)], now=0.1)
    np.testing.assert_array_equal(reader.wrench, -4 * RAW)
    assert reader.dropped == 0


@pytest.mark.parametrize(("flag", "bad"), [
    ("non_finite", {"wrench": [np.nan, 0, 0, 0, 0, 0]}),
    ("non_finite", {"acceleration": [0, 0, 0, 0, np.inf, 0]}),
    ("saturated", {"saturated": 1 << 2}),
    ("saturated", {"saturated": 1 << 9}),
    ("error", {"error": True}),
])
def test_bad_sample_held_and_flagged(flag, bad):
    reader = FtSampleReader()
    reader.take([sample(1, 1000)], now=0.1)
    reader.take([sample(2, 1125, **{"wrench": 5 * RAW, "acceleration": 5 * ACCEL, **bad})], now=0.2)
    np.testing.assert_array_equal(reader.wrench, -RAW)
    np.testing.assert_array_equal(reader.acceleration, ACCEL)
    assert getattr(reader, flag) and reader.t_good == 0.1  # a bad sample is not a fresh one
    reader.take([sample(3, 1250, wrench=2 * RAW)], now=0.3)
    np.testing.assert_array_equal(reader.wrench, -2 * RAW)
    assert not getattr(reader, flag) and reader.t_good == 0.3


def test_a_bad_newest_sample_passes_on_the_good_one_before_it_and_says_why():
    reader = FtSampleReader()
    reader.take([sample(1, 1000, wrench=2 * RAW), sample(2, 1125, wrench=[np.nan] * 6)], now=0.1)
    np.testing.assert_array_equal(reader.wrench, -2 * RAW)
    assert reader.non_finite and reader.t_good == 0.1


def test_duplicate_and_out_of_order_dropped():
    reader = FtSampleReader()
    reader.take([sample(5, 5000)], now=0.1)
    for late in (sample(5, 5000, wrench=7 * RAW),   # duplicate of the held sample
                 sample(4, 6000, wrench=7 * RAW),   # counter went back
                 sample(6, 4000, wrench=7 * RAW)):  # utime went back
        reader.take([late], now=0.1)
    np.testing.assert_array_equal(reader.wrench, -RAW)
    assert reader.dropped == 2
    reader.take([sample(7, 7000, wrench=3 * RAW)], now=0.2)
    np.testing.assert_array_equal(reader.wrench, -3 * RAW)
    assert reader.dropped == 2


def test_restarted_sensor_driver_accepted():
    """Counter and clock from zero again, far behind the last sample: a restart, not a late packet."""
    reader = FtSampleReader()
    reader.take([sample(900, 2_000_000)], now=0.1)
    reader.take([sample(1, 1000, wrench=4 * RAW)], now=0.2)
    np.testing.assert_array_equal(reader.wrench, -4 * RAW)
    reader.take([sample(2, 2000, wrench=5 * RAW)], now=0.3)
    np.testing.assert_array_equal(reader.wrench, -5 * RAW)
    assert reader.dropped == 0


def test_committed_lcm_types_are_regenerated_byte_for_byte(tmp_path):
    names = lcmtypes_regenerate.regenerate(tmp_path)
    committed = {p.name for p in lcmtypes_regenerate.HERE.glob("*.py")} - {"regenerate.py"}
    assert set(names) == committed
    for name in names:
        assert (tmp_path / name).read_bytes() == (lcmtypes_regenerate.HERE / name).read_bytes(), name


def test_lcm_type_round_trip():
    msg = heft_ft_sample()
    msg.utime, msg.sample_counter, msg.saturated, msg.wrench = 12, 3, 1 << 11, list(RAW)
    decoded = heft_ft_sample.decode(msg.encode())
    assert (decoded.utime, decoded.sample_counter, decoded.saturated) == (12, 3, 1 << 11)
    assert list(decoded.wrench) == list(RAW)
