"""The wrist sensor's LCM samples → ``ft.wrench_measured``, ``ft.acceleration_measured``.

The one place where the sensor's sign becomes DESIGN §4's: a JR3 reports the
wrench the load exerts on it; heft's ports carry the wrench the sensor exerts
on the load, [f; τ] at S, in S (N, N·m).
"""

import dataclasses
import math

import numpy as np
from pydrake.lcm import DrakeLcmInterface
from pydrake.systems.framework import BasicVector, DiagramBuilder, LeafSystem

from .lcm_mailbox import LcmMailbox
from .message_order import restarted
from .lcmtypes import heft_ft_sample

STATUS_FIELDS = ("stale", "non_finite", "saturated", "error", "age", "dropped")
"""Entries of the ``status`` output: 0/1 flags, then the age of the held sample
(s; inf before the first good one) and the count of out-of-order samples dropped."""

# Bookkeeping state: the last accepted (counter, utime), the last pair seen in
# the mailbox, diagram time of the last good sample, flags of the last accepted
# sample, dropped count, mailbox arrivals taken.
(_LAST_COUNTER, _LAST_UTIME, _SEEN_COUNTER, _SEEN_UTIME, _T_GOOD, _NON_FINITE, _SATURATED, _ERROR, _DROPPED,
 _TAKEN) = range(10)
_BOOK_INITIAL = (-1.0, 0.0, -1.0, 0.0, -math.inf, 0.0, 0.0, 0.0, 0.0, 0.0)


@dataclasses.dataclass
class FtReceiverParams:
    """Sampling of the receiver; loadable with ``yaml_load_typed``."""

    period: float = 1.0 / 2000.0
    """Update period (s); the controller's rate."""
    stale_after: float = 0.005
    """The held sample is stale when older than this (s, diagram time)."""


class FtSampleReceiver(LeafSystem):
    """Samples the latest ``heft_ft_sample`` in ``mailbox`` every ``period`` and holds it.

    A sample is accepted when both ``sample_counter`` and ``utime`` exceed the
    last accepted ones, or when ``utime`` is far older than the last accepted one
    (the driver restarted: ``message_order``); one with ``utime`` ≤ 0 is "no sample yet". The same
    sample seen again (a duplicate is indistinguishable from a re-read) changes
    nothing; any other sample that does
    not advance both is dropped and counted. An accepted sample that is
    non-finite, saturated on any axis or flagged ``error`` is not passed on:
    the outputs hold the last good sample and ``status`` flags it until the
    next good one. Outputs are state, so the system has no direct feedthrough.

    .. pydrake_system::

        name: FtSampleReceiver
        output_ports:
        - wrench_measured
        - acceleration_measured
        - status
    """

    def __init__(self, mailbox: LcmMailbox, params: FtReceiverParams | None = None):
        super().__init__()
        self._params = params or FtReceiverParams()
        self._mailbox = mailbox
        self._wrench = self.DeclareDiscreteState(6)
        self._acceleration = self.DeclareDiscreteState(6)
        self._book = self.DeclareDiscreteState(BasicVector(np.array(_BOOK_INITIAL)))
        self.DeclareStateOutputPort("wrench_measured", self._wrench)
        self.DeclareStateOutputPort("acceleration_measured", self._acceleration)
        self.DeclareVectorOutputPort("status", len(STATUS_FIELDS), self._calc_status,
                                     prerequisites_of_calc={self.time_ticket(), self.xd_ticket()})
        self.DeclarePeriodicDiscreteUpdateEvent(self._params.period, 0.0, self._update)

    def _update(self, context, discrete_state):
        book = discrete_state.get_mutable_vector(self._book).get_mutable_value()
        payload = self._mailbox.newer_than(book[_TAKEN])
        if payload is None:
            return
        book[_TAKEN] = self._mailbox.count
        sample = heft_ft_sample.decode(payload)
        counter, utime = float(sample.sample_counter), float(sample.utime)
        if utime <= 0.0 or (counter == book[_SEEN_COUNTER] and utime == book[_SEEN_UTIME]):
            return
        book[_SEEN_COUNTER], book[_SEEN_UTIME] = counter, utime
        stale = counter <= book[_LAST_COUNTER] or utime <= book[_LAST_UTIME]
        if stale and not restarted(utime * 1e-6, book[_LAST_UTIME] * 1e-6):
            book[_DROPPED] += 1.0
            return
        book[_LAST_COUNTER], book[_LAST_UTIME] = counter, utime
        wrench_sensor = np.asarray(sample.wrench, dtype=float)
        acceleration = np.asarray(sample.acceleration, dtype=float)
        non_finite = not (np.all(np.isfinite(wrench_sensor)) and np.all(np.isfinite(acceleration)))
        saturated = sample.saturated != 0
        error = bool(sample.error)
        book[_NON_FINITE], book[_SATURATED], book[_ERROR] = non_finite, saturated, error
        if non_finite or saturated or error:
            return
        book[_T_GOOD] = context.get_time()
        # The sign flip of DESIGN §4: sensor-on-load = −(load-on-sensor).
        discrete_state.get_mutable_vector(self._wrench).SetFromVector(-wrench_sensor)
        discrete_state.get_mutable_vector(self._acceleration).SetFromVector(acceleration)

    def _calc_status(self, context, output):
        book = context.get_discrete_state(self._book).get_value()
        age = context.get_time() - book[_T_GOOD]
        output.SetFromVector([float(age > self._params.stale_after), book[_NON_FINITE], book[_SATURATED],
                              book[_ERROR], age, book[_DROPPED]])


def AddFtSampleReceiver(builder: DiagramBuilder, lcm: DrakeLcmInterface, channel: str,
                        params: FtReceiverParams | None = None) -> FtSampleReceiver:
    """Adds a new ``FtSampleReceiver`` on ``channel`` of ``lcm`` (pumped by the diagram's
    ``LcmInterfaceSystem``). It never blocks ``Initialize()`` and reports ``stale``
    until the first good sample arrives."""
    return builder.AddNamedSystem("ft_receiver", FtSampleReceiver(LcmMailbox(lcm, channel), params))
