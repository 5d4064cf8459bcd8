"""``heft load``'s side of the load commands (``load_commands``: the running controller's side):
``send_load_command`` sends one and waits for the answers. Apart from the controller's side, whose
checks need the compiled kernels, so that ``heft load`` starts without numba."""

from __future__ import annotations

import select
import time

import numpy as np

from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.lcm_mailbox import open_buses
from heft.hardware_interface.lcmtypes import heft_load_command, heft_load_status, heft_station_status

ACTIONS = {"rezero": heft_load_command.REZERO, "tracking_on": heft_load_command.TRACKING_ON,
           "tracking_off": heft_load_command.TRACKING_OFF, "new_estimate": heft_load_command.NEW_ESTIMATE,
           "grasp": heft_load_command.GRASP, "release": heft_load_command.RELEASE}
"""The actions by name (``heft load``'s)."""


def send_load_command(channels: LcmChannels, action: str, phi=None, offsets=None,
                      timeout: float = 2.0) -> list[heft_load_status]:
    """Sends one ``action`` (a key of ``ACTIONS``; "new_estimate" with ``phi`` (10) and
    ``offsets`` (6)) on ``channels.lcm_url`` and returns the controller's answers (heard on its
    command URL): the first, and for a started re-zero also its outcome, for a grasp the object
    learned. A re-zero, which the controller refuses while its station is not healthy, is sent
    once the controller's ``heft_station_status`` says it is and its forces have ramped in (gain 1:
    past the start's transients). Raises TimeoutError if that or the answers do not come within
    ``timeout`` s."""
    if action not in ACTIONS:
        raise ValueError(f"unknown action {action!r}; one of {', '.join(ACTIONS)}")
    bus, answer_bus = open_buses(channels)
    deadline = time.monotonic() + timeout
    if action == "rezero":
        _wait_until_healthy(channels, answer_bus, deadline, timeout)
    command = heft_load_command()
    command.utime, command.action = round(time.time() * 1e6), ACTIONS[action]
    if action == "new_estimate":
        command.phi = np.asarray(phi, dtype=float).tolist()
        command.offsets = np.asarray(offsets, dtype=float).tolist()
    answers = []

    def on_status(_channel, payload):
        try:
            status = heft_load_status.decode(payload)
        except Exception:  # not an answer: another process's datagram, malformed
            return
        if status.command_utime == command.utime:
            answers.append(status)

    answer_bus.subscribe(channels.load_status.name, on_status)
    bus.publish(channels.load_command.name, command.encode())
    # A started re-zero is answered again when it ends, a grasp when the object has been learned.
    expected = 2 if action in ("rezero", "grasp") else 1
    while True:
        if answers and (len(answers) >= expected or not answers[-1].accepted):
            return answers
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            raise TimeoutError(f"no answer from the controller on {channels.load_status.name} within {timeout} s: "
                               f"is `heft teleop --hardware` running on {channels.lcm_url}?" if not answers else
                               f"the {action.replace('_', ' ')} did not finish within {timeout} s")
        if select.select([answer_bus.fileno()], [], [], remaining)[0]:
            answer_bus.handle()


def _wait_until_healthy(channels: LcmChannels, answer_bus, deadline: float, timeout: float) -> None:
    """Returns once a ``heft_station_status`` on ``answer_bus`` says the controller's station is healthy
    with its gain at 1; raises TimeoutError at ``deadline`` (``time.monotonic``), saying whether any
    status came."""
    heard = []

    def on_status(_channel, payload):
        try:
            status = heft_station_status.decode(payload)
        except Exception:  # another process's datagram, malformed
            return
        heard.append(status.healthy and status.gain >= 1.0)

    subscription = answer_bus.subscribe(channels.station_status.name, on_status)
    try:
        while not any(heard):
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise TimeoutError(
                    f"the controller's station was not healthy with its forces on within {timeout} s (are the drivers "
                    "publishing? `heft teleop` prints why), so no re-zero was asked" if heard else
                    f"no status from the controller on {channels.station_status.name} within {timeout} s: is `heft "
                    f"teleop --hardware` running on {channels.lcm_url}?")
            if select.select([answer_bus.fileno()], [], [], remaining)[0]:
                answer_bus.handle()
    finally:
        answer_bus.unsubscribe(subscription)
