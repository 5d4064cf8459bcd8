"""The wrist sensor's LCM samples → heft's wrench and acceleration.

The one place where the sensor's sign becomes docs/design.md §4's: a JR3 reports the
wrench the load exerts on it; heft carries the wrench the sensor exerts on the
load, [f; τ] at S, in S (N, N·m).
"""

from __future__ import annotations

import math

import numpy as np

from heft.systems.compiled import compiled

from heft.hardware_interface.fixed_layout import PAYLOAD, wire_double, wire_int
from heft.hardware_interface.ft_messages import BLOCK_FINGERPRINT, OFFSETS, ONE_FINGERPRINT, SAMPLE_BYTES, samples_in
from heft.hardware_interface.message_checks import (ACCEPT, DISCONTINUOUS, DRIVER_ERROR, NON_FINITE, OUT_OF_RANGE,
                                                    RANGE_MARGIN, UNDECODABLE, Rejections)
from heft.hardware_interface.message_order import (SourceClock, clock_accept, clock_foreign, clock_rejection,
                                                   clock_starts_source)


# The reader's memory: the last good sample's utime (µs on the driver's clock) and counter, the flags of
# the newest sample in order of the last take (non-finite, saturated, error), and whether this take has
# yet to meet a sample in order.
UTIME, COUNTER, NON_FINITE_FLAG, SATURATED_FLAG, ERROR_FLAG, NEWEST = range(6)


class FtSampleReader:
    """Takes FT payloads (``heft_ft_sample`` or ``heft_ft_samples``: ``ft_messages``) and holds the
    newest good sample.

    A sample is in order when it comes from the channel's source and is newer
    (``message_order``: its ``utime`` on the source's clock, after the last accepted) and
    its ``sample_counter`` exceeds the last accepted one's (one that goes back comes from
    another publisher: ``discontinuous``); one with ``utime`` ≤ 0 is "no sample yet". A
    sample is good if, besides, it is finite, within ``full_scale`` (12: the wrench's 6 in
    N, N·m, then the acceleration's in m/s², rad/s², widened by ``RANGE_MARGIN``), not
    saturated and not flagged ``error``. The flags describe the newest sample in order; if
    it is not good, the newest good one before it in the same ``take`` is passed on, else
    ``wrench`` and ``acceleration`` hold the last good sample. ``t_good`` is the station
    time (s) of the last good sample (−inf before the first), ``utime`` its stamp (µs on the
    driver's clock; 0 before the first); ``rejections`` counts what was
    refused and why (a saturated sample is a reading, held but not counted); a source
    silent for ``silence`` s gives way to the next (``SourceClock``).
    """

    def __init__(self, full_scale, silence: float):
        self.wrench = np.zeros(6)
        """[f; τ] the sensor exerts on the load, at S, in S (N, N·m)."""
        self.acceleration = np.zeros(6)
        """The accelerometer's reading as the driver reports it, in S (m/s², rad/s²): specific
        force a − g and α (``accelerometer_reading`` converts it where g_S is known)."""
        self.rejections = Rejections()
        self.clock = SourceClock(silence)
        self._memory = np.array([0.0, -1.0, 0.0, 0.0, 0.0, 1.0])
        self._arguments = (ONE_FINGERPRINT, BLOCK_FINGERPRINT, OFFSETS, SAMPLE_BYTES, self.clock.state, self._memory,
                           RANGE_MARGIN * np.asarray(full_scale, dtype=float), self.wrench, self.acceleration,
                           np.zeros(12), self.rejections.by_code)

    @property
    def t_good(self) -> float:
        return self.clock.last_accept

    @property
    def utime(self) -> int:
        return int(self._memory[UTIME])

    @property
    def non_finite(self) -> bool:
        return bool(self._memory[NON_FINITE_FLAG])

    @property
    def saturated(self) -> bool:
        return bool(self._memory[SATURATED_FLAG])

    @property
    def error(self) -> bool:
        return bool(self._memory[ERROR_FLAG])

    def take(self, payloads, now: float) -> None:
        """Reads ``payloads`` (bytes, oldest first) at station time ``now`` (s), newest sample first:
        the newest sample that is in order and good is kept and older ones are not read."""
        self._memory[NEWEST] = 1.0
        for payload in reversed(payloads):
            if ft_payload_kept(payload, now, *self._arguments):
                return


@compiled(f"boolean({PAYLOAD}, int64, float64, int64[:], int64[:], float64[:], float64[:], float64[:], "
          "float64[:], float64[:], float64[:], int64[:])")
def _kept(payload, k, now, row, sample_bytes, clock, memory, limits, wrench_out, acceleration_out, scratch,
          rejected) -> bool:
    """Whether sample ``k`` of the payload (its fields at ``row``, ``sample_bytes`` each) is in order and good,
    and so kept; counts it if refused."""
    utime = wire_int(payload, row[1] + sample_bytes[0] * k, 8)
    if utime <= 0:
        return False
    stamp = utime * 1e-6
    code = clock_rejection(clock, stamp, now)
    if code != ACCEPT:
        rejected[code] += 1
        return False
    counter = wire_int(payload, row[2] + sample_bytes[1] * k, 8)
    if counter <= memory[COUNTER] and not clock_starts_source(clock, now):
        clock_foreign(clock, stamp, now)
        rejected[DISCONTINUOUS] += 1
        return False
    total = 0.0
    for i in range(6):
        scratch[i] = wire_double(payload, row[3] + sample_bytes[2] * k + 8 * i)
        scratch[6 + i] = wire_double(payload, row[4] + sample_bytes[3] * k + 8 * i)
        total += scratch[i] + scratch[6 + i]
    non_finite = not math.isfinite(total)
    saturated = wire_int(payload, row[5] + sample_bytes[4] * k, 2)
    error = payload[row[6] + sample_bytes[5] * k] != 0
    if memory[NEWEST] > 0.5:
        memory[NEWEST] = 0.0
        memory[NON_FINITE_FLAG], memory[SATURATED_FLAG], memory[ERROR_FLAG] = non_finite, saturated != 0, error
    if non_finite:
        rejected[NON_FINITE] += 1
        return False
    if error:
        rejected[DRIVER_ERROR] += 1
        return False
    for i in range(12):
        if not abs(scratch[i]) <= limits[i]:
            rejected[OUT_OF_RANGE] += 1
            return False
    if saturated != 0:
        return False
    clock_accept(clock, stamp, now)
    memory[COUNTER], memory[UTIME] = counter, utime
    for i in range(6):  # the sign flip of docs/design.md §4: sensor-on-load = −(load-on-sensor)
        wrench_out[i] = -scratch[i]
        acceleration_out[i] = scratch[6 + i]
    return True


@compiled(f"boolean({PAYLOAD}, float64, {PAYLOAD}, {PAYLOAD}, int64[:, :], int64[:], float64[:], float64[:], "
          "float64[:], float64[:], float64[:], float64[:], int64[:])")
def ft_payload_kept(payload, now, one_fingerprint, block_fingerprint, offsets, sample_bytes, clock, memory, limits,
                    wrench, acceleration, scratch, rejected) -> bool:
    """``FtSampleReader.take`` of one payload, its samples newest first: whether one was kept (the
    reader's ``wrench``, ``acceleration`` and ``memory`` then hold it). ``offsets`` and ``sample_bytes``
    are ``ft_messages``', ``clock`` the source's (``message_order``), ``limits`` (12) the full scale
    widened, ``scratch`` 12 floats; what is refused is counted in ``rejected`` (per code)."""
    count, row = samples_in(payload, one_fingerprint, block_fingerprint, offsets)
    if count == 0:  # of another size or type, or a block of no or too many samples
        rejected[UNDECODABLE] += 1
        return False
    for k in range(count - 1, -1, -1):
        if _kept(payload, k, now, offsets[row], sample_bytes, clock, memory, limits, wrench, acceleration,
                 scratch, rejected):
            return True
    return False
