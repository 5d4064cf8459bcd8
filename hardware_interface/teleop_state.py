"""The controller's tick on LCM: ``heft_teleop_state`` on ``LcmChannels.teleop_state``.

``TeleopStatePublisher.publish`` sends, after a tick's commands and with their utime, what
the controller computed (the passivity observer's energy and damping, the wrench on the
hand before and after it, the contact and non-contact wrench) and the stamps of the driver
messages it read, so that a recording of the traffic holds everything the analyses of a
simulated run read (``heft.analysis.run_log``). Packed by its ``FixedLayout`` in one call;
``heft teleop --hardware`` sends it each tick when it records, else at its ``STATE_RATE``.
"""

from __future__ import annotations

import lcm

from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.fixed_layout import FixedLayout
from heft.hardware_interface.lcmtypes import heft_teleop_state


class TeleopStatePublisher:
    """Publishes ``heft_teleop_state`` on ``command_bus`` (the controller's URL)."""

    def __init__(self, command_bus: lcm.LCM, channels: LcmChannels):
        self._bus, self._channel = command_bus, channels.teleop_state.name
        self._layout = FixedLayout(heft_teleop_state)

    def publish(self, utime: int, dt: float, starts: int, stamps, controller, gain: float) -> None:
        """The tick at ``utime`` (µs, the commands'), stepped by ``dt`` (s) on the driver messages
        stamped ``stamps`` (master, slave, FT; µs), of ``controller`` (``TeleopController``
        after ``step``, started ``starts`` times so far), with the watchdog's
        ``gain``; ``dt`` is the hold the controller's blocks stepped by."""
        master_utime, slave_utime, ft_utime = stamps
        self._bus.publish(self._channel, self._layout.pack(
            utime, dt, starts, master_utime, slave_utime, ft_utime, *controller.master_wrench.tolist(),
            *controller.applied_wrench.tolist(), gain, *controller.energy.tolist(), *controller.damping.tolist(),
            *controller.wrench_contact.tolist(), *controller.wrench_noncontact.tolist()))
