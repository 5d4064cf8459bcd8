"""The two LCM URLs over real UDP multicast (in a private network namespace): the controller
publishes its commands where it does not listen, and one URL for both still works."""

import subprocess
import sys

SEND_AND_LISTEN = """
import sys, time
import numpy as np
from heft.diagrams.device_limits import device_limits
from heft.diagrams.scenario import resolve_scenario
from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.hardware_station import HardwareStation
from heft.hardware_interface.lcm_mailbox import LcmMailbox, open_buses, pump

url = "udpm://239.255.76.67:7667?ttl=0"
channels = LcmChannels(lcm_url=url, command_url=sys.argv[1])
bus, command_bus = open_buses(channels)                # the controller's
station = HardwareStation(bus, channels, device_limits(resolve_scenario("fig6")), command_bus=command_bus)
echo = LcmMailbox(bus, channels.master_command.name)   # what the controller's own receive socket gets
_, driver_commands = open_buses(channels)              # the drivers'
received = LcmMailbox(driver_commands, channels.master_command.name, keep=100)
for i in range(10):
    station.send(1e-3 * i, np.zeros(6), None)
time.sleep(0.1)
pump(bus)
pump(driver_commands)
print(received.count, echo.count)
"""


def _counts(netns, command_url: str) -> tuple[int, int]:
    result = subprocess.run(["ip", "netns", "exec", netns, sys.executable, "-c", SEND_AND_LISTEN, command_url],
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, result.stderr
    received, echoed = map(int, result.stdout.split())
    return received, echoed


def test_the_controller_does_not_hear_its_own_commands(netns):
    """Default (command URL derived: one port up): the drivers get every command, the controller's
    receive socket none."""
    assert _counts(netns, "") == (10, 0)


def test_one_url_for_both_directions_still_works(netns):
    """Given the same URL for both, the drivers still get every command (and the controller hears
    them back, as LCM delivers them to every socket on the URL, and ignores them)."""
    assert _counts(netns, "udpm://239.255.76.67:7667?ttl=0") == (10, 10)
