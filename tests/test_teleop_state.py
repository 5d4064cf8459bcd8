"""``TeleopStatePublisher`` on a real bus: what a controller computed in a tick, read back by the
generated decoder."""

import lcm
import numpy as np

from heft.diagrams.running.simulation import true_load
from heft.diagrams.scenario import Scenario
from heft.diagrams.teleop_controller import TeleopController
from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.lcmtypes import heft_teleop_state
from heft.hardware_interface.teleop_state import TeleopStatePublisher


def test_a_tick_is_published_field_by_field():
    scenario = Scenario()
    load, _ = true_load(scenario)
    controller = TeleopController(scenario.controller, load, scenario.robot, scenario.controller_period,
                                  accelerometer=scenario.accelerometer.convention())
    controller.start(np.array(scenario.slave_initial_q))
    rng = np.random.default_rng(5)
    controller.step(5e-4, np.array(scenario.master_initial_q) + 0.01, rng.normal(0, 0.5, 6),
                    np.array(scenario.slave_initial_q), rng.normal(0, 0.1, 6),
                    np.array([1.0, -2.0, 30.0, 0.1, 0.2, -0.1]), np.array([0.1, 0.2, 9.9, 0.0, 0.1, 0.0]), True)
    bus, channels, received = lcm.LCM("memq://"), LcmChannels(), []
    bus.subscribe(channels.teleop_state.name, lambda _, data: received.append(heft_teleop_state.decode(data)))
    TeleopStatePublisher(bus, channels).publish(1234, 5e-4, 2, (11, 22, 33), controller, 0.75)
    bus.handle_timeout(100)
    (msg,) = received
    assert (msg.utime, msg.dt, msg.starts, msg.gain) == (1234, 5e-4, 2, 0.75)
    assert (msg.master_utime, msg.slave_utime, msg.ft_utime) == (11, 22, 33)
    for name in ("master_wrench", "applied_wrench", "energy", "damping", "wrench_contact", "wrench_noncontact"):
        np.testing.assert_array_equal(getattr(msg, name), getattr(controller, name), err_msg=name)
    assert np.abs(msg.wrench_contact).max() > 0 and np.abs(msg.master_wrench).max() > 0
