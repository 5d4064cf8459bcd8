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

    A sample is accepted when both ``sample_counter`` and ``utime`` exceed those of the
    newest sample accepted at an earlier ``take``, or when ``utime`` is far older (the
    driver restarted: ``message_order``); one with ``utime`` ≤ 0 is "no sample yet".
    The same sample seen again changes nothing; any other sample that does not
    advance both is dropped and counted (``dropped``). The flags describe the newest
    accepted sample: if it is non-finite, saturated on any axis or flagged ``error``,
    the newest good one before it in the same ``take`` is passed on, else ``wrench`` and
    ``acceleration`` hold the last good sample. ``t_good`` is the station time (s) of
    the last good sample (−inf before the first).
    """

    def __init__(self):
        self.wrench = np.zeros(6)
        """[f; τ] the sensor exerts on the load, at S, in S (N, N·m)."""
        self.acceleration = np.zeros(6)
        """The accelerometer's reading as the driver reports it, in S (m/s², rad/s²): specific
        force a − g and α (``accelerometer_reading`` converts it where g_S is known)."""
        self.t_good = -math.inf
        self.non_finite = self.saturated = self.error = False
        self.dropped = 0
        self._last = (-1, 0)   # accepted (counter, utime)
        self._seen = (-1, 0)   # last (counter, utime) looked at

    def take(self, payloads, now: float) -> None:
        """Reads ``payloads`` (bytes, oldest first) at station time ``now`` (s), newest first:
        the newest sample that is accepted and good is kept and older ones are not decoded."""
        newest = None
        for payload in reversed(payloads):
            sample = heft_ft_sample.decode(payload)
            key = (sample.sample_counter, sample.utime)
            if sample.utime <= 0 or key == self._seen:
                continue
            counter, utime = key
            if (counter <= self._last[0] or utime <= self._last[1]) and not restarted(utime * 1e-6,
                                                                                     self._last[1] * 1e-6):
                self.dropped += 1
                continue
            wrench, acceleration = sample.wrench, sample.acceleration
            non_finite = not math.isfinite(sum(wrench) + sum(acceleration))
            if newest is None:
                newest = key
                self.non_finite, self.saturated, self.error = non_finite, sample.saturated != 0, bool(sample.error)
            if non_finite or sample.saturated != 0 or sample.error:
                continue
            self.t_good = now
            # The sign flip of DESIGN §4: sensor-on-load = −(load-on-sensor).
            for i in range(6):
                self.wrench[i] = -wrench[i]
                self.acceleration[i] = acceleration[i]
            break
        if newest is not None:
            self._last = self._seen = newest
