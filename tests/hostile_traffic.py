"""A third process on the lab's LCM URL that publishes malformed and hostile traffic on every
channel the controller hears, for the two-process fuzz test.

Usage: python hostile_traffic.py LCM_URL DURATION_S SEED

For DURATION_S of wall time, about 1000 messages a second, each drawn from: random bytes;
the drivers' types cut short; wrong joint counts; master and slave states beyond the joint
limits, non-finite, or plausible but elsewhere (stamped on the real driver's clock, heard on
the bus, and on a clock of its own, the clutch button pressed at random); FT samples stamped
10 s ahead of the driver's or with their counter going back, each right behind one of the
driver's (so that it is the newest when the controller reads); non-physical load estimates.
Its master states carry bit ``MARK`` in ``buttons`` and its slave states ``MARK_TORQUE`` as
``joint_torque_external[0]``, fields the controller ignores, so that a test can tell them
from the drivers' in a recording. Prints "hostile: publishing" when it starts and, at the end,
"hostile: stopped at T" (wall-clock s since the Unix epoch) with what it sent.
"""

import math
import sys
import time

import lcm
import numpy as np
from drake import lcmt_iiwa_status

from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.ft_messages import decode_samples
from heft.hardware_interface.lcmtypes import heft_ft_sample, heft_haptic_state, heft_load_command

MARK = 1 << 7
MARK_TORQUE = 12345.0
RATE = 1000.0
LOAD_COMMAND_EVERY = 50
"""One non-physical load command per this many messages (20 a second)."""
KINDS = 14
"""The kinds of message ``main``'s ``kinds`` cycles through (the k-th is kind ``k % KINDS``)."""
FT_KINDS = (3, 11, 12)
"""The kinds that are FT messages: sent right behind the driver's."""


def haptic_state(utime, position, velocity=None, buttons=MARK, num_joints=6) -> bytes:
    msg = heft_haptic_state()
    msg.utime, msg.num_joints, msg.buttons = utime, num_joints, buttons | MARK
    msg.position = list(position)
    msg.velocity = list(velocity if velocity is not None else np.zeros(num_joints))
    msg.torque_applied = [0.0] * num_joints
    return msg.encode()


def iiwa_status(utime, position, velocity=None, num_joints=6) -> bytes:
    msg = lcmt_iiwa_status()
    msg.utime, msg.num_joints = utime, num_joints
    msg.joint_position_measured = list(position)
    msg.joint_velocity_estimated = list(velocity if velocity is not None else np.zeros(num_joints))
    for field in ("joint_position_commanded", "joint_position_ipo", "joint_torque_measured",
                  "joint_torque_commanded"):
        setattr(msg, field, [0.0] * num_joints)
    msg.joint_torque_external = [MARK_TORQUE] + [0.0] * (num_joints - 1)
    return msg.encode()


def ft_sample(utime, counter, wrench, acceleration=(0.0, 0.0, 9.81, 0.0, 0.0, 0.0)) -> bytes:
    msg = heft_ft_sample()
    msg.utime, msg.sample_counter = utime, counter
    msg.wrench, msg.acceleration = list(wrench), list(acceleration)
    return msg.encode()


def load_command(utime, phi, offsets) -> bytes:
    msg = heft_load_command()
    msg.utime, msg.action = utime, heft_load_command.NEW_ESTIMATE
    msg.phi, msg.offsets = list(phi), list(offsets)
    return msg.encode()


NON_PHYSICAL = (
    ([-5.0, 0, 0, 0.3, 0.05, 0, 0, 0.05, 0, 0.01], [0.0] * 6),           # negative mass
    ([1e12, 0, 0, 0, 0, 0, 0, 0, 0, 0], [0.0] * 6),                      # a mass no sensor carries
    ([3.13, 0, 0, 0.3, -0.05, 0, 0, -0.05, 0, -0.01], [0.0] * 6),        # negative inertia
    ([3.13, 0, 0, 0.3, 0.05, 0, 0, 0.05, 0, 0.01], [0, 0, 1e4, 0, 0, 0]),  # offsets beyond range
    ([math.nan] * 10, [0.0] * 6),                                        # not a number
)


def main(url: str, duration: float, seed: int) -> None:
    rng = np.random.default_rng(seed)
    channels = LcmChannels(lcm_url=url)
    bus = lcm.LCM(url)
    heard = {"master": 0, "slave": 0, "ft": 0, "ft_counter": 0}  # the drivers' newest stamps, its own left out
    own_ft = set()

    def on_master(_, payload):
        msg = heft_haptic_state.decode(payload)
        if not msg.buttons & MARK:
            heard["master"] = max(heard["master"], msg.utime)

    def on_slave(_, payload):
        msg = lcmt_iiwa_status.decode(payload)
        if msg.num_joints == 0 or msg.joint_torque_external[0] != MARK_TORQUE:
            heard["slave"] = max(heard["slave"], msg.utime)

    def on_ft(_, payload):
        if payload not in own_ft:
            sample = decode_samples(payload)[-1]  # the stand-in's newest
            heard["ft"], heard["ft_counter"] = sample.utime, sample.sample_counter

    for channel, handler in ((channels.master_state, on_master), (channels.slave_status, on_slave),
                             (channels.ft_sample, on_ft)):
        bus.subscribe(channel.name, lambda c, p, h=handler: _tolerant(h, c, p))

    master, slave, ft = channels.master_state.name, channels.slave_status.name, channels.ft_sample.name
    start = time.time()

    def kinds(k: int):
        """The k-th message: (channel, payload)."""
        own = round(1e6 * (time.time() - start)) + 1            # a clock of its own
        if k % LOAD_COMMAND_EVERY == 0:
            phi, offsets = NON_PHYSICAL[(k // LOAD_COMMAND_EVERY) % len(NON_PHYSICAL)]
            return channels.load_command.name, load_command(round(time.time() * 1e6), phi, offsets)
        choice = k % KINDS
        if choice == 0:
            channel = (master, slave, ft, channels.load_command.name)[rng.integers(4)]
            return channel, rng.bytes(int(rng.integers(0, 300)))
        if choice == 1:
            return master, haptic_state(heard["master"] + 1, rng.uniform(-1, 1, 6))[:int(rng.integers(1, 60))]
        if choice == 2:
            return slave, iiwa_status(heard["slave"] + 1, rng.uniform(-1, 1, 6))[:int(rng.integers(1, 200))]
        if choice == 3:
            return ft, ft_sample(heard["ft"] + 1, heard["ft_counter"] + 1, rng.normal(0, 50, 6))[:60]
        if choice == 4:
            return master, haptic_state(heard["master"] + 1, rng.uniform(-1, 1, 3), num_joints=3)
        if choice == 5:
            return slave, iiwa_status(heard["slave"] + 1, rng.uniform(-1, 1, 7), num_joints=7)
        if choice == 6:   # beyond every joint's limits, on the driver's clock, clutch pressed
            return master, haptic_state(heard["master"] + 1, rng.uniform(5, 50, 6) * rng.choice([-1, 1], 6),
                                        buttons=1)
        if choice == 7:   # not a number
            return slave, iiwa_status(heard["slave"] + 1, [math.nan, 0, 0, 0, 0, math.inf])
        if choice == 8:   # plausible, elsewhere, on the driver's clock, clutch pressed at random
            return master, haptic_state(heard["master"] + 1, rng.uniform(-0.6, 0.6, 6),
                                        buttons=int(rng.integers(2)))
        if choice == 9:   # plausible, elsewhere, on a clock of its own
            return slave, iiwa_status(own, rng.uniform(-1.5, 1.5, 6))
        if choice == 10:  # absurd speed
            return slave, iiwa_status(heard["slave"] + 1, rng.uniform(-0.5, 0.5, 6), velocity=[500.0] * 6)
        if choice == 11:  # 10 s in the future, an absurd wrench
            return ft, ft_sample(heard["ft"] + 10_000_000, heard["ft_counter"] + 80_000, rng.normal(0, 150, 6))
        if choice == 12:  # the counter going back on the driver's clock
            return ft, ft_sample(heard["ft"] + 1, max(1, heard["ft_counter"] - 1000), rng.normal(0, 50, 6))
        return master, haptic_state(own, rng.uniform(-0.6, 0.6, 6), buttons=1)

    print("hostile: publishing", flush=True)
    sent = 0
    period = 1.0 / RATE
    while time.time() - start < duration:
        while bus.handle_timeout(0) > 0:
            pass
        if sent % KINDS in FT_KINDS:
            _behind_the_driver(bus, heard)
        channel, payload = kinds(sent)
        if channel == ft:
            own_ft.add(payload)
        bus.publish(channel, payload)
        sent += 1
        pause = start + sent * period - time.time()
        if pause > 0:
            time.sleep(pause)
    print(f"hostile: stopped at {time.time():.6f} after {sent} messages", flush=True)


def _behind_the_driver(bus, heard, timeout: float = 0.002) -> None:
    """Handles the bus until the driver's next FT message is heard (at most ``timeout`` s), so that an FT
    message sent next lands right behind it: a controller that reads the newest FT sample first, and
    ticks as the lab publishes, then reads this one rather than the driver's."""
    before, deadline = heard["ft"], time.time() + timeout
    while heard["ft"] == before and time.time() < deadline:
        bus.handle_timeout(1)


def _tolerant(handler, channel, payload):
    """``handler`` on a payload that may be another publisher's garbage (this process's own)."""
    try:
        handler(channel, payload)
    except Exception:  # its own malformed messages come back on the bus
        pass


if __name__ == "__main__":
    main(sys.argv[1], float(sys.argv[2]), int(sys.argv[3]))
