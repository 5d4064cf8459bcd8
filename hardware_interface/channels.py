"""LCM channel names and nominal rates of the lab hardware (docs/design.md §6, §7).

Message types: the master uses ``heft_haptic_state`` / ``heft_haptic_command``,
the wrist sensor ``heft_ft_sample`` and the gripper ``heft_gripper_state``; the
controller reports each tick in ``heft_teleop_state`` (``heft.hardware_interface.lcmtypes``).
The slave arm reuses Drake's ``lcmt_iiwa_status`` / ``lcmt_iiwa_command``:
their arrays are sized by ``num_joints`` (6 for the RX90/RX60), they carry
measured and commanded position, estimated velocity and torques, and Drake's
``IiwaStatusReceiver`` / ``IiwaCommandSender`` take ``num_joints``. Only the
name says "iiwa".
"""

import dataclasses
import re

DEFAULT_LCM_URL = "udpm://239.255.76.67:7667?ttl=0"
"""UDP multicast that cannot leave the machine (ttl=0)."""


def derived_command_url(lcm_url: str) -> str:
    """The command URL that goes with ``lcm_url`` when none is given: on ``udpm://`` the same
    group one port up (``udpm://G:P?opts`` → ``udpm://G:P+1?opts``, port 7667 when none is
    written), so that no process hears the traffic it sends; any other URL (``memq://``) itself."""
    match = re.fullmatch(r"udpm://([^:/?]*)(?::(\d+))?(\?.*)?", lcm_url)
    if match is None:
        return lcm_url
    group, port, options = match.groups()
    return f"udpm://{group}:{int(port or 7667) + 1}{options or ''}"


@dataclasses.dataclass
class LcmChannel:
    """One channel: its name and the rate its publisher nominally runs at (Hz; 0: sent on request)."""

    name: str
    rate: float


@dataclasses.dataclass
class LcmChannels:
    """Every channel between heft and the lab; loadable with ``yaml_load_typed``.

    Two LCM URLs, one per direction, so that no process receives what it publishes itself:
    ``lcm_url`` carries what the lab's drivers and ``heft load`` send to the controller,
    ``command_url`` what the controller sends back (``command_lcm_url``): commands, answers, status.
    """

    lcm_url: str = DEFAULT_LCM_URL
    """Heard by the controller: master state, slave status, FT samples, load commands."""
    command_url: str = ""
    """Published by the controller: master and slave commands, load status; empty: derived from
    ``lcm_url`` (``derived_command_url``: one port up)."""
    master_state: LcmChannel = dataclasses.field(
        default_factory=lambda: LcmChannel("HEFT_MASTER_STATE", 2000.0))
    """heft_haptic_state from the haptic master's driver (six measured joints; haptic loop above 2 kHz)."""
    master_command: LcmChannel = dataclasses.field(
        default_factory=lambda: LcmChannel("HEFT_MASTER_COMMAND", 2000.0))
    """heft_haptic_command from the controller (controller rate)."""
    slave_status: LcmChannel = dataclasses.field(
        default_factory=lambda: LcmChannel("HEFT_SLAVE_STATUS", 2000.0))
    """lcmt_iiwa_status from the arm driver."""
    slave_command: LcmChannel = dataclasses.field(
        default_factory=lambda: LcmChannel("HEFT_SLAVE_COMMAND", 2000.0))
    """lcmt_iiwa_command from the controller (controller rate)."""
    ft_sample: LcmChannel = dataclasses.field(
        default_factory=lambda: LcmChannel("HEFT_FT_SAMPLE", 8000.0))
    """heft_ft_sample from the JR3 driver (the paper samples up to 8 kHz)."""
    gripper_state: LcmChannel = dataclasses.field(
        default_factory=lambda: LcmChannel("HEFT_GRIPPER_STATE", 100.0))
    """heft_gripper_state from the gripper driver on the slave's flange."""
    load_command: LcmChannel = dataclasses.field(
        default_factory=lambda: LcmChannel("HEFT_LOAD_COMMAND", 0.0))
    """heft_load_command from the operator (``heft load``); sent on request (rate 0)."""
    load_status: LcmChannel = dataclasses.field(
        default_factory=lambda: LcmChannel("HEFT_LOAD_STATUS", 0.0))
    """heft_load_status from the controller, answering each command and each re-zero's end."""
    station_status: LcmChannel = dataclasses.field(
        default_factory=lambda: LcmChannel("HEFT_STATION_STATUS", 10.0))
    """heft_station_status from the controller: health and the messages it rejected, and at a run's end."""
    teleop_state: LcmChannel = dataclasses.field(
        default_factory=lambda: LcmChannel("HEFT_TELEOP_STATE", 2000.0))
    """heft_teleop_state from ``heft teleop --hardware``: what the controller computed, each tick it steps."""

    def command_lcm_url(self) -> str:
        """The URL of the controller's commands: ``command_url``, or derived from ``lcm_url``."""
        return self.command_url or derived_command_url(self.lcm_url)
