"""The wrist sensor's LCM samples → heft's wrench and acceleration.

The one place where the sensor's sign becomes docs/design.md §4's: a JR3 reports the
wrench the load exerts on it; heft carries the wrench the sensor exerts on the
load, [f; τ] at S, in S (N, N·m).
"""

from __future__ import annotations

import math

import numpy as np

from heft.hardware_interface.fixed_layout import FixedLayout
from heft.hardware_interface.lcmtypes import heft_ft_sample
from heft.hardware_interface.message_checks import RANGE_MARGIN, Rejections
from heft.hardware_interface.message_order import SourceClock


_LAYOUT = FixedLayout(heft_ft_sample)
"""A ``heft_ft_sample`` has one size: a payload of another, or of another type's fingerprint, is not one."""


class FtSampleReader:
    """Takes ``heft_ft_sample`` payloads and holds the newest good sample.

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
        self._at = tuple(_LAYOUT.field(name) for name in ("utime", "sample_counter", "wrench", "acceleration",
                                                          "saturated", "error"))

    def take(self, payloads, now: float) -> None:
        """Reads ``payloads`` (bytes, oldest first) at station time ``now`` (s), newest first:
        the newest sample that is in order and good is kept and older ones are not decoded."""
        rejections, clock, newest = self.rejections, self.clock, True
        at = self._at
        for payload in reversed(payloads):
            values = _LAYOUT.unpack(payload)  # the generated decoder raises on anything else
            if values is None:
                rejections.add("undecodable")
                continue
            utime, counter, saturated, error = values[at[0]], values[at[1]], values[at[4]], values[at[5]]
            if utime <= 0:
                continue
            stamp = utime * 1e-6
            reason = clock.rejection(stamp, now)
            if reason is not None:
                rejections.add(reason)
                continue
            if counter <= self._counter and not clock.starts_source(now):
                clock.foreign(stamp, now)
                rejections.add("discontinuous")
                continue
            wrench, acceleration = values[at[2]], values[at[3]]
            non_finite = not math.isfinite(sum(wrench) + sum(acceleration))
            if newest:
                newest = False
                self.non_finite, self.saturated, self.error = non_finite, saturated != 0, bool(error)
            if non_finite:
                rejections.add("non_finite")
                continue
            if error:
                rejections.add("driver_error")
                continue
            if not self._within_range(wrench, acceleration):
                rejections.add("out_of_range")
                continue
            if saturated != 0:
                continue
            clock.accept(stamp, now)
            self._counter, self.t_good, self.utime = counter, now, utime
            # The sign flip of docs/design.md §4: sensor-on-load = −(load-on-sensor).
            for i in range(6):
                self.wrench[i] = -wrench[i]
                self.acceleration[i] = acceleration[i]
            break

    def _within_range(self, wrench, acceleration) -> bool:
        limits = self._range
        for i in range(6):
            if not (abs(wrench[i]) <= limits[i] and abs(acceleration[i]) <= limits[6 + i]):
                return False
        return True
