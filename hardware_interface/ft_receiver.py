"""The wrist sensor's LCM samples → heft's wrench and acceleration.

The one place where the sensor's sign becomes DESIGN §4's: a JR3 reports the
wrench the load exerts on it; heft carries the wrench the sensor exerts on the
load, [f; τ] at S, in S (N, N·m).
"""

from __future__ import annotations

import math

import numpy as np

from .lcmtypes import heft_ft_sample
from .message_order import restarted


class FtSampleReader:
    """Takes ``heft_ft_sample`` payloads and holds the newest good sample.

    A sample is accepted when both ``sample_counter`` and ``utime`` exceed the last
    accepted ones, or when ``utime`` is far older than the last accepted one (the
    driver restarted: ``message_order``); one with ``utime`` ≤ 0 is "no sample yet".
    The same sample seen again changes nothing; any other sample that does not
    advance both is dropped and counted (``dropped``). An accepted sample that is
    non-finite, saturated on any axis or flagged ``error`` is not passed on: ``wrench``
    and ``acceleration`` hold the last good sample and the flags say why until the
    next good one. ``t_good`` is the station time (s) of the last good sample
    (−inf before the first).
    """

    def __init__(self):
        self.wrench = np.zeros(6)
        """[f; τ] the sensor exerts on the load, at S, in S (N, N·m)."""
        self.acceleration = np.zeros(6)
        """[a; α] of S, in S (m/s², rad/s²), as the sensor's accelerometer reports it."""
        self.t_good = -math.inf
        self.non_finite = self.saturated = self.error = False
        self.dropped = 0
        self._last = (-1, 0)   # accepted (counter, utime)
        self._seen = (-1, 0)   # last (counter, utime) looked at

    def take(self, payloads, now: float) -> None:
        """Reads ``payloads`` (bytes, oldest first) at station time ``now`` (s)."""
        for payload in payloads:
            self._take_one(heft_ft_sample.decode(payload), now)

    def _take_one(self, sample, now: float) -> None:
        key = (sample.sample_counter, sample.utime)
        if sample.utime <= 0 or key == self._seen:
            return
        self._seen = key
        counter, utime = key
        if (counter <= self._last[0] or utime <= self._last[1]) and not restarted(utime * 1e-6, self._last[1] * 1e-6):
            self.dropped += 1
            return
        self._last = key
        wrench, acceleration = sample.wrench, sample.acceleration
        self.non_finite = not math.isfinite(sum(wrench) + sum(acceleration))
        self.saturated = sample.saturated != 0
        self.error = bool(sample.error)
        if self.non_finite or self.saturated or self.error:
            return
        self.t_good = now
        # The sign flip of DESIGN §4: sensor-on-load = −(load-on-sensor).
        for i in range(6):
            self.wrench[i] = -wrench[i]
            self.acceleration[i] = acceleration[i]
