"""FT sample reader: sign flip, hold-and-flag of bad samples, ordering, restarts, one sample or
several a message; the FT messages' codec held to lcm-gen's; and the committed LCM Python types
match lcm-gen's output."""

import math

import numpy as np
import pytest
from heft.hardware_interface.ft_messages import MAX_SAMPLES, decode_samples, pack_samples, unpack_samples
from heft.hardware_interface.ft_receiver import FtSampleReader
from heft.hardware_interface.message_checks import RANGE_MARGIN
from heft.hardware_interface.lcmtypes import heft_ft_sample, heft_ft_samples
from heft.hardware_interface.lcmtypes import regenerate as lcmtypes_regenerate

RAW = np.array([1.0, -2.0, 3.0, 0.1, -0.2, 0.3])
ACCEL = np.array([0.5, 0.0, -9.81, 0.01, 0.02, -0.03])
FULL_SCALE = [200.0] * 3 + [12.0] * 3 + [100.0] * 3 + [1000.0] * 3  # the JR3's (sensor_models)
SILENCE = 0.05


def new_reader() -> FtSampleReader:
    return FtSampleReader(FULL_SCALE, SILENCE)


def sample(counter, utime, wrench=RAW, acceleration=ACCEL, saturated=0, error=False) -> bytes:
    msg = heft_ft_sample()
    msg.sample_counter, msg.utime = counter, utime
    msg.wrench, msg.acceleration = list(wrench), list(acceleration)
    msg.saturated, msg.error = saturated, error
    return msg.encode()


def block(counters, utimes, wrenches, acceleration=ACCEL, saturated=None, errors=None) -> bytes:
    """A ``heft_ft_samples`` encoded by lcm-gen's own class: the samples given, oldest first."""
    msg = heft_ft_samples()
    count = len(counters)
    msg.num_samples, msg.sample_counter, msg.utime = count, list(counters), list(utimes)
    msg.wrench = [list(w) for w in wrenches]
    msg.acceleration = [list(acceleration)] * count
    msg.saturated, msg.error = saturated or [0] * count, errors or [False] * count
    return msg.encode()


def test_nothing_before_the_first_sample():
    reader = new_reader()
    reader.take([sample(0, 0)], now=1.0)  # utime 0: "no sample yet"
    assert math.isinf(reader.t_good) and reader.rejections.total == 0
    np.testing.assert_array_equal(reader.wrench, np.zeros(6))


def test_sign_flipped_to_sensor_on_load():
    reader = new_reader()
    reader.take([sample(1, 1000)], now=0.25)
    np.testing.assert_array_equal(reader.wrench, -RAW)
    np.testing.assert_array_equal(reader.acceleration, ACCEL)
    assert reader.t_good == 0.25 and not (reader.non_finite or reader.saturated or reader.error)


def test_all_samples_read_in_order_newest_kept():
    reader = new_reader()
    reader.take([sample(k, 1000 + 125 * k, wrench=k * RAW) for k in range(1, 5)], now=0.1)
    np.testing.assert_array_equal(reader.wrench, -4 * RAW)
    assert reader.rejections.total == 0


@pytest.mark.parametrize(("flag", "bad"), [
    ("non_finite", {"wrench": [np.nan, 0, 0, 0, 0, 0]}),
    ("non_finite", {"acceleration": [0, 0, 0, 0, np.inf, 0]}),
    ("saturated", {"saturated": 1 << 2}),
    ("saturated", {"saturated": 1 << 9}),
    ("error", {"error": True}),
])
def test_bad_sample_held_and_flagged(flag, bad):
    reader = new_reader()
    reader.take([sample(1, 1000)], now=0.1)
    reader.take([sample(2, 1125, **{"wrench": 5 * RAW, "acceleration": 5 * ACCEL, **bad})], now=0.2)
    np.testing.assert_array_equal(reader.wrench, -RAW)
    np.testing.assert_array_equal(reader.acceleration, ACCEL)
    assert getattr(reader, flag) and reader.t_good == 0.1  # a bad sample is not a fresh one
    reader.take([sample(3, 1250, wrench=2 * RAW)], now=0.3)
    np.testing.assert_array_equal(reader.wrench, -2 * RAW)
    assert not getattr(reader, flag) and reader.t_good == 0.3


def test_a_bad_newest_sample_passes_on_the_good_one_before_it_and_says_why():
    reader = new_reader()
    reader.take([sample(1, 1000, wrench=2 * RAW), sample(2, 1125, wrench=[np.nan] * 6)], now=0.1)
    np.testing.assert_array_equal(reader.wrench, -2 * RAW)
    assert reader.non_finite and reader.t_good == 0.1


def test_duplicate_and_late_samples_dropped_a_counter_going_back_is_another_publisher():
    reader = new_reader()
    reader.take([sample(5, 5000)], now=0.1)
    for late in (sample(5, 5000, wrench=7 * RAW),   # duplicate of the held sample
                 sample(6, 4000, wrench=7 * RAW),   # utime went back: a late packet
                 sample(4, 6000, wrench=7 * RAW)):  # counter went back, utime forward: not this source
        reader.take([late], now=0.1)
    np.testing.assert_array_equal(reader.wrench, -RAW)
    assert reader.rejections.nonzero() == {"out_of_order": 2, "discontinuous": 1}
    reader.take([sample(7, 7000, wrench=3 * RAW)], now=0.1)
    np.testing.assert_array_equal(reader.wrench, -3 * RAW)
    assert reader.rejections.total == 3


def test_restarted_sensor_driver_accepted():
    """Counter and clock from zero again after the driver was silent: a new source, not a late packet."""
    reader = new_reader()
    reader.take([sample(900, 2_000_000)], now=0.1)
    reader.take([sample(1, 1000, wrench=4 * RAW)], now=0.1 + 2 * SILENCE)
    np.testing.assert_array_equal(reader.wrench, -4 * RAW)
    reader.take([sample(2, 2000, wrench=5 * RAW)], now=0.1 + 2 * SILENCE + 0.001)
    np.testing.assert_array_equal(reader.wrench, -5 * RAW)
    assert reader.rejections.total == 0 and reader.clock.restarts == 1


T = 2_000_125  # µs: a driver running for 2 s


@pytest.mark.parametrize(("reason", "payload"), [
    ("undecodable", b"\x00" * 7),
    ("undecodable", sample(2, T)[:-9]),                               # truncated
    ("undecodable", bytes(range(256))),                                  # not this type
    ("out_of_range", sample(2, T, wrench=[0, 0, 1.1 * 200, 0, 0, 0])),
    ("out_of_range", sample(2, T, acceleration=[0, 0, 0, 0, 0, -1.1 * 1000])),
    ("stamped_ahead", sample(2, T + 10_000_000)),                     # 10 s ahead of its source
    ("stamped_behind", sample(2, T - 1_000_000)),                     # 1 s behind, the source alive
    ("driver_error", sample(2, T, error=True)),
])
def test_bad_sample_rejected_counted_and_the_good_one_kept(reason, payload):
    reader = new_reader()
    reader.take([sample(1, T - 125)], now=1.0)
    reader.take([sample(3, T + 125, wrench=2 * RAW), payload], now=1.0002)
    np.testing.assert_array_equal(reader.wrench, -2 * RAW)
    assert reader.rejections.nonzero() == {reason: 1} and reader.t_good == 1.0002


def test_full_scale_reading_accepted():
    """A saturating JR3 reads full scale: within the range (widened by RANGE_MARGIN), not rejected."""
    reader = new_reader()
    edge = [200.0, -200.0, 200.0 * RANGE_MARGIN, 12.0, -12.0, 0.0]
    reader.take([sample(1, 1000, wrench=edge)], now=1.0)
    np.testing.assert_array_equal(reader.wrench, -np.array(edge))


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


def test_a_block_is_read_newest_first_and_its_bad_newest_passes_on_the_good_one_before():
    reader = new_reader()
    reader.take([block([1, 2, 3, 4], [1000, 1125, 1250, 1375], [k * RAW for k in (1, 2, 3, 4)])], now=0.1)
    np.testing.assert_array_equal(reader.wrench, -4 * RAW)
    assert reader.utime == 1375 and reader.rejections.total == 0
    reader.take([block([5, 6], [1500, 1625], [5 * RAW, [np.nan] * 6])], now=0.2)
    np.testing.assert_array_equal(reader.wrench, -5 * RAW)
    assert reader.non_finite and reader.rejections.nonzero() == {"non_finite": 1} and reader.t_good == 0.2


def test_blocks_and_single_samples_of_one_source_interleave_and_another_source_is_seen():
    reader = new_reader()
    reader.take([block([1, 2], [1000, 1125], [RAW, 2 * RAW]), sample(3, 1250, wrench=3 * RAW)], now=0.1)
    np.testing.assert_array_equal(reader.wrench, -3 * RAW)
    reader.take([block([2, 4], [1375, 1500], [7 * RAW, 7 * RAW])], now=0.1)  # read newest first: 4 is in order
    np.testing.assert_array_equal(reader.wrench, -7 * RAW)
    reader.take([block([1, 2], [1625, 1750], [9 * RAW, 9 * RAW])], now=0.1)  # counters back: another publisher
    np.testing.assert_array_equal(reader.wrench, -7 * RAW)
    assert reader.rejections.nonzero() == {"discontinuous": 2}


@pytest.mark.parametrize("payload", [
    block([1, 2], [1000, 1125], [RAW, RAW])[:-1],                              # truncated
    block([1, 2], [1000, 1125], [RAW, RAW]) + b"\x00",                          # a byte too many
    heft_ft_samples().encode(),                                                # no samples
    block(range(1, MAX_SAMPLES + 2), range(1000, 1000 + MAX_SAMPLES + 1), [RAW] * (MAX_SAMPLES + 1)),
])
def test_a_malformed_block_is_undecodable(payload):
    reader = new_reader()
    reader.take([payload], now=0.1)
    assert unpack_samples(payload) is None and reader.rejections.nonzero() == {"undecodable": 1}
    with pytest.raises(ValueError, match="not a heft_ft_sample or a heft_ft_samples"):
        decode_samples(payload)


def test_the_ft_codec_is_lcm_gens():
    """Blocks packed here decode with lcm-gen's class, and lcm-gen's encode with ``decode_samples``,
    field by field, for every size a message may have."""
    rng = np.random.default_rng(5)
    for count in (1, 2, 4, MAX_SAMPLES):
        utimes, counters = rng.integers(1, 2**62, count).tolist(), rng.integers(1, 2**62, count).tolist()
        wrenches, accelerations = rng.normal(size=(count, 6)), rng.normal(size=(count, 6))
        saturated, errors = rng.integers(0, 1 << 12, count).tolist(), (rng.random(count) < 0.5).tolist()
        packed = pack_samples(utimes, counters, wrenches.ravel().tolist(), accelerations.ravel().tolist(),
                              saturated, errors)
        theirs = heft_ft_samples.decode(packed)
        assert (theirs.num_samples, list(theirs.utime), list(theirs.sample_counter)) == (count, utimes, counters)
        np.testing.assert_array_equal(theirs.wrench, wrenches)
        np.testing.assert_array_equal(theirs.acceleration, accelerations)
        assert list(theirs.saturated) == saturated and list(theirs.error) == errors
        assert theirs.encode() == packed
        ours = decode_samples(packed)
        assert [(m.utime, m.sample_counter, m.saturated, m.error) for m in ours] == list(
            zip(utimes, counters, saturated, errors, strict=True))
        np.testing.assert_array_equal([m.wrench for m in ours], wrenches)
        np.testing.assert_array_equal([m.acceleration for m in ours], accelerations)
    one = heft_ft_sample.decode(sample(3, 1000))
    (again,) = decode_samples(one.encode())
    assert again.encode() == one.encode()
    with pytest.raises(ValueError, match="1 to 64 samples"):
        pack_samples([], [], [], [], [], [])
