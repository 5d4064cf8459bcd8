"""The controller's tick on LCM: ``heft_teleop_state`` on ``LcmChannels.teleop_state``.

``TeleopStatePublisher.publish`` sends, after a tick's commands and with their utime, what
the controller computed (the passivity observer's energy and damping, the wrench on the
hand before and after it, the contact and non-contact wrench) and the stamps of the driver
messages it read, so that a recording of the traffic holds everything the analyses of a
simulated run read (``heft.analysis.run_log``). Encoded by one kernel into a buffer of its ``FixedLayout``;
``heft teleop --hardware`` sends it each tick when it records, else at its ``STATE_RATE``.
"""

from __future__ import annotations

import lcm
import numpy as np

from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.fixed_layout import FixedLayout, put_wire_double, put_wire_int
from heft.hardware_interface.lcmtypes import heft_teleop_state
from heft.systems.compiled import compiled

ARRAY_FIELDS = ("master_wrench", "applied_wrench", "energy", "damping", "wrench_contact", "wrench_noncontact")
STATE_FIELDS = ("utime", "starts", "master_utime", "slave_utime", "ft_utime", "dt", "gain", *ARRAY_FIELDS)
"""The fields ``encode_teleop_state`` writes, in the order of its ``at``: ``stamps``' (µs, and the starts), then
``scalars``', then the arrays'."""
UTIME, STARTS, MASTER_UTIME, SLAVE_UTIME, FT_UTIME = range(5)
DT, GAIN = range(2)
_STAMP_SIZES = (8, 4, 8, 8, 8)  # bytes: int64_t, but the starts' int32_t


@compiled("void(uint8[:], int64[:], int64[:], float64[:], float64[:], float64[:], float64[:], float64[:], "
          "float64[:], float64[:])")
def encode_teleop_state(buffer, at, stamps, scalars, master_wrench, applied_wrench, energy, damping, contact,
                        noncontact) -> None:
    """Writes a ``heft_teleop_state``'s values into ``buffer`` (its ``STATE_FIELDS`` at ``at``): ``stamps``
    by ``UTIME`` … ``FT_UTIME``, ``scalars`` by ``DT``, ``GAIN``, and the arrays of ``ARRAY_FIELDS``."""
    for k in range(len(_STAMP_SIZES)):
        put_wire_int(buffer, at[k], _STAMP_SIZES[k], stamps[k])
    for k in range(2):
        put_wire_double(buffer, at[len(_STAMP_SIZES) + k], scalars[k])
    for k, values in enumerate((master_wrench, applied_wrench, energy, damping, contact, noncontact)):
        for j in range(values.shape[0]):
            put_wire_double(buffer, at[len(_STAMP_SIZES) + 2 + k] + 8 * j, values[j])


class TeleopStatePublisher:
    """Publishes ``heft_teleop_state`` on ``command_bus`` (the controller's URL)."""

    def __init__(self, command_bus: lcm.LCM, channels: LcmChannels):
        self._bus, self._channel = command_bus, channels.teleop_state.name
        self._buffer, self._at = FixedLayout(heft_teleop_state).buffer(STATE_FIELDS)
        self._stamps, self._scalars = np.zeros(5, dtype=np.int64), np.zeros(2)

    def publish(self, utime: int, dt: float, starts: int, stamps, controller, gain: float) -> None:
        """The tick at ``utime`` (µs, the commands'), stepped by ``dt`` (s) on the driver messages
        stamped ``stamps`` (master, slave, FT; µs), of ``controller`` (``TeleopController``
        after ``step``, started ``starts`` times so far), with the watchdog's
        ``gain``; ``dt`` is the hold the controller's blocks stepped by."""
        packed, scalars = self._stamps, self._scalars
        packed[UTIME], packed[STARTS] = utime, starts
        packed[MASTER_UTIME], packed[SLAVE_UTIME], packed[FT_UTIME] = stamps
        scalars[DT], scalars[GAIN] = dt, gain
        encode_teleop_state(self._buffer, self._at, packed, scalars, controller.master_wrench,
                            controller.applied_wrench, controller.energy, controller.damping,
                            controller.wrench_contact, controller.wrench_noncontact)
        self._bus.publish(self._channel, self._buffer.tobytes())
