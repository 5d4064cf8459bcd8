"""The wrist sensor's LCM samples → heft's wrench and acceleration.

The one place where the sensor's sign becomes docs/design.md §4's: a JR3 reports the
wrench the load exerts on it; heft carries the wrench the sensor exerts on the
load, [f; τ] at S, in S (N, N·m).
"""

from __future__ import annotations

import math

import numpy as np

from heft.hardware_interface.ft_messages import unpack_samples
from heft.hardware_interface.message_checks import RANGE_MARGIN, Rejections
from heft.hardware_interface.message_order import SourceClock


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
        self.t_good = -math.inf
        self.utime = 0
        self.non_finite = self.saturated = self.error = False
        self.rejections = Rejections()
        self.clock = SourceClock(silence)
        self._range = (RANGE_MARGIN * np.asarray(full_scale, dtype=float)).tolist()
        self._counter = -1  # the last accepted sample's counter
        self._newest = True  # no sample in order seen yet in this take

    def take(self, payloads, now: float) -> None:
        """Reads ``payloads`` (bytes, oldest first) at station time ``now`` (s), newest sample first:
        the newest sample that is in order and good is kept and older ones are not read."""
        self._newest = True
        for payload in reversed(payloads):
            unpacked = unpack_samples(payload)
            if unpacked is None:  # of another size or type, or a block of no or too many samples
                self.rejections.add("undecodable")
                continue
            count, record, (utime, counter, wrench, acceleration, saturated, error) = unpacked
            for k in range(count - 1, -1, -1):
                if self._kept(record[utime + k], record[counter + k], record[wrench + 6 * k:wrench + 6 * k + 6],
                              record[acceleration + 6 * k:acceleration + 6 * k + 6], record[saturated + k],
                              record[error + k], now):
                    return

    def _kept(self, utime, counter, wrench, acceleration, saturated, error, now: float) -> bool:
        """Whether one sample (its fields as ``heft_ft_sample``'s) is in order and good, and so kept;
        counts it if refused."""
        if utime <= 0:
            return False
        rejections, clock, stamp = self.rejections, self.clock, utime * 1e-6
        reason = clock.rejection(stamp, now)
        if reason is not None:
            rejections.add(reason)
            return False
        if counter <= self._counter and not clock.starts_source(now):
            clock.foreign(stamp, now)
            rejections.add("discontinuous")
            return False
        non_finite = not math.isfinite(sum(wrench) + sum(acceleration))
        if self._newest:
            self._newest = False
            self.non_finite, self.saturated, self.error = non_finite, saturated != 0, bool(error)
        if non_finite:
            rejections.add("non_finite")
            return False
        if error:
            rejections.add("driver_error")
            return False
        if not self._within_range(wrench, acceleration):
            rejections.add("out_of_range")
            return False
        if saturated != 0:
            return False
        clock.accept(stamp, now)
        self._counter, self.t_good, self.utime = counter, now, utime
        # The sign flip of docs/design.md §4: sensor-on-load = −(load-on-sensor).
        for i in range(6):
            self.wrench[i] = -wrench[i]
            self.acceleration[i] = acceleration[i]
        return True

    def _within_range(self, wrench, acceleration) -> bool:
        limits = self._range
        for i in range(6):
            if not (abs(wrench[i]) <= limits[i] and abs(acceleration[i]) <= limits[6 + i]):
                return False
        return True
