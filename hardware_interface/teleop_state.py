"""The controller's tick on LCM: ``heft_teleop_state`` on ``LcmChannels.teleop_state``.

``TeleopStatePublisher.publish`` sends, after a tick's commands and with their utime, what
the controller computed (the passivity observer's energy and damping, the wrench on the
hand before and after it, the contact and non-contact wrench) and the stamps of the driver
messages it read, so that a recording of the traffic holds everything the analyses of a
simulated run read (``heft.analysis.run_log``). One message object, refilled each tick;
about 45 µs a tick (17 µs of it encoding), which ``heft teleop --hardware`` spends only when
it records.
"""

from __future__ import annotations

import lcm

from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.lcmtypes import heft_teleop_state


class TeleopStatePublisher:
    """Publishes ``heft_teleop_state`` on ``command_bus`` (the controller's URL)."""

    def __init__(self, command_bus: lcm.LCM, channels: LcmChannels):
        self._bus, self._channel = command_bus, channels.teleop_state.name
        self._msg = heft_teleop_state()

    def publish(self, utime: int, dt: float, starts: int, stamps, controller, gain: float) -> None:
        """The tick at ``utime`` (µs, the commands'), stepped by ``dt`` (s) on the driver messages
        stamped ``stamps`` (master, slave, FT; µs), of ``controller`` (``RealtimeTeleopController``
        after ``step``, started ``starts`` times so far), with the watchdog's ``gain``."""
        msg = self._msg
        msg.utime, msg.dt, msg.starts, msg.gain = utime, dt, starts, gain
        msg.master_utime, msg.slave_utime, msg.ft_utime = stamps
        msg.master_wrench, msg.applied_wrench = controller.master_wrench.tolist(), controller.applied_wrench.tolist()
        msg.energy, msg.damping = controller.energy.tolist(), controller.damping.tolist()
        msg.wrench_contact = controller.wrench_contact.tolist()
        msg.wrench_noncontact = controller.wrench_noncontact.tolist()
        self._bus.publish(self._channel, msg.encode())
