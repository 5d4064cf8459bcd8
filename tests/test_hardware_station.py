"""Hardware station over real LCM (memq://): the sim station's port names; nothing
moves before every channel is fresh; watchdog fault on a stale channel and a
jump-free ramp back; rate-limited, never non-finite commands; FT sign flip."""

import numpy as np
import pytest
from drake import lcmt_iiwa_command, lcmt_iiwa_status
from heft.diagrams.scenario import Scenario
from heft.diagrams.sim_station import MakeSimStation
from heft.diagrams.teleop import STATION_INPUTS_DRIVEN, STATION_OUTPUTS_READ
from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.hardware_station import (
    STATUS_FIELDS,
    HardwareStationParams,
    MakeHardwareStation,
)
from heft.hardware_interface.lcmtypes import (
    heft_ft_sample,
    heft_haptic_command,
    heft_haptic_state,
)
from heft.hardware_interface.watchdog import watchdog_step
from pydrake.lcm import DrakeLcm
from pydrake.systems.analysis import Simulator

PARAMS = HardwareStationParams(period=0.001)
RAMP_STEP = PARAMS.period / PARAMS.watchdog.ramp_time
MAX_STEP = np.asarray(PARAMS.slave_velocity_limits) * PARAMS.period
CHANNELS = LcmChannels()
STATUS = {name: i for i, name in enumerate(STATUS_FIELDS)}
Q_MASTER = np.array([0.1, -0.2, 0.3, 0.0, 0.5, -0.1])
Q_SLAVE = np.array([0.0, -0.5, 1.2, 0.0, 0.8, 0.3])
TORQUE = np.array([0.1, -0.2, 0.05, 0.01, -0.02, 0.03])
RAW = np.array([1.0, -2.0, 3.0, 0.1, -0.2, 0.3])
ACCEL = np.array([0.5, 0.0, -9.81, 0.01, 0.02, -0.03])
ALL = ("master", "slave", "ft")


class Rig:
    """The station on memq://, the test playing the three drivers; built once per module (drake #23930)."""

    def __init__(self):
        self.lcm = DrakeLcm("memq://")
        self.station = MakeHardwareStation(CHANNELS, self.lcm, PARAMS)
        self.simulator = Simulator(self.station)
        self.master_commands, self.slave_commands = [], []
        self.lcm.Subscribe(CHANNELS.master_command.name,
                           lambda data: self.master_commands.append(heft_haptic_command.decode(data)))
        self.lcm.Subscribe(CHANNELS.slave_command.name,
                           lambda data: self.slave_commands.append(lcmt_iiwa_command.decode(data)))

    def reset(self):
        """Fresh state. Subscribers re-deliver their last message, so each is first
        made a "no message" one (utime 0)."""
        for channel, msg in ((CHANNELS.master_state, heft_haptic_state()), (CHANNELS.slave_status, lcmt_iiwa_status()),
                             (CHANNELS.ft_sample, heft_ft_sample())):
            self.lcm.Publish(channel.name, msg.encode())
        self.lcm.HandleSubscriptions(0)
        context = self.simulator.get_mutable_context()
        context.SetTime(0.0)
        self.station.SetDefaultContext(context)
        self.command(TORQUE, Q_SLAVE + 0.5)
        self.simulator.Initialize()
        self.master_commands.clear()
        self.slave_commands.clear()
        self.tick = 0
        self.driver_start = 0  # tick at which the drivers' clocks read zero

    def restart_drivers(self):
        """The drivers restart: their stamps and counters begin again from zero."""
        self.driver_start = self.tick

    def command(self, torque, position):
        context = self.simulator.get_mutable_context()
        self.station.GetInputPort("master.torque_commanded").FixValue(context, np.asarray(torque, dtype=float))
        self.station.GetInputPort("slave.position_commanded").FixValue(context, np.asarray(position, dtype=float))

    def run(self, duration, publish=ALL, q_slave=Q_SLAVE):
        """Plays the drivers named in ``publish`` once per period for ``duration`` s."""
        for _ in range(round(duration / PARAMS.period)):
            self.tick += 1
            utime = 1000 * (self.tick - self.driver_start)
            if "master" in publish:
                msg = heft_haptic_state()
                msg.utime, msg.num_joints = utime, 6
                msg.position, msg.velocity, msg.torque_applied = list(Q_MASTER), [0.0] * 6, [0.0] * 6
                self.lcm.Publish(CHANNELS.master_state.name, msg.encode())
            if "slave" in publish:
                msg = lcmt_iiwa_status()
                msg.utime, msg.num_joints = utime, 6
                msg.joint_position_measured = list(q_slave)
                for field in ("joint_velocity_estimated", "joint_position_commanded", "joint_position_ipo",
                              "joint_torque_measured", "joint_torque_commanded", "joint_torque_external"):
                    setattr(msg, field, [0.0] * 6)
                self.lcm.Publish(CHANNELS.slave_status.name, msg.encode())
            if "ft" in publish:
                msg = heft_ft_sample()
                msg.utime, msg.sample_counter = utime, self.tick - self.driver_start
                msg.wrench, msg.acceleration = list(RAW), list(ACCEL)
                self.lcm.Publish(CHANNELS.ft_sample.name, msg.encode())
            self.simulator.AdvanceTo(self.tick * PARAMS.period)
        self.lcm.HandleSubscriptions(0)

    def output(self, name):
        return self.station.GetOutputPort(name).Eval(self.simulator.get_context())

    def status(self, field):
        return self.output("hardware.status")[STATUS[field]]

    def torques(self):
        return np.array([m.torque for m in self.master_commands])

    def positions(self):
        return np.array([m.joint_position for m in self.slave_commands])


@pytest.fixture(scope="module")
def module_rig():
    return Rig()


@pytest.fixture
def rig(module_rig):
    module_rig.reset()
    return module_rig


def _names(system, kind):
    ports = system.num_input_ports() if kind == "input" else system.num_output_ports()
    get = system.get_input_port if kind == "input" else system.get_output_port
    return {get(i).get_name() for i in range(ports)}


def test_watchdog_core():
    assert watchdog_step([np.inf, 0.0, np.nan], 0.7, 0.02, 0.1) == (False, 0.0, 0b101)
    assert watchdog_step([0.0, 0.02, 0.01], 0.95, 0.02, 0.1) == (True, 1.0, 0)
    assert watchdog_step([0.0, 0.0, 0.0], 0.0, 0.02, 0.1) == (True, 0.1, 0)


def test_ports_match_sim_station(module_rig):
    sim = MakeSimStation(Scenario())
    sim_outputs = {n for n in _names(sim, "output") if not n.startswith("truth.")}
    assert _names(module_rig.station, "input") == _names(sim, "input") == set(STATION_INPUTS_DRIVEN)
    assert _names(module_rig.station, "output") == sim_outputs | {"hardware.status"}
    assert set(STATION_OUTPUTS_READ) <= sim_outputs


def test_nothing_moves_before_fresh_data(rig):
    rig.run(0.01, publish=())
    assert rig.status("fault") == 0b111 and rig.status("healthy") == 0.0
    assert rig.master_commands and not rig.slave_commands
    rig.run(0.05, publish=("master", "slave"))
    assert rig.status("fault") == 0b100 and rig.status("healthy") == 0.0
    assert all(not m.enable and m.num_joints == 6 for m in rig.master_commands)
    np.testing.assert_array_equal(rig.torques(), 0.0)
    np.testing.assert_array_equal(rig.positions(), np.tile(Q_SLAVE, (len(rig.slave_commands), 1)))
    np.testing.assert_array_equal(rig.output("master.position_measured"), Q_MASTER)


def test_torque_ramps_in_and_slave_rate_limited(rig):
    rig.run(0.3)
    scale = rig.torques() @ TORQUE / (TORQUE @ TORQUE)
    np.testing.assert_allclose(rig.torques(), np.outer(scale, TORQUE), atol=1e-12)
    steps = np.diff(scale)
    assert np.all(steps >= -1e-12) and np.all(steps <= RAMP_STEP + 1e-12)
    assert scale[0] == 0.0
    np.testing.assert_array_equal(rig.torques()[-1], TORQUE)
    assert rig.master_commands[-1].enable and rig.status("gain") == 1.0
    assert np.all(np.abs(np.diff(rig.positions(), axis=0)) <= MAX_STEP + 1e-12)
    np.testing.assert_allclose(rig.positions()[-1], Q_SLAVE + 0.5)


def test_stale_ft_faults_then_ramps_back_without_jump(rig):
    rig.run(0.3)
    rig.master_commands.clear()
    rig.slave_commands.clear()
    rig.run(0.019, publish=("master", "slave"))
    assert rig.status("healthy") == 1.0
    rig.run(0.005, publish=("master", "slave"))
    assert rig.status("fault") == 0b100 and rig.status("healthy") == 0.0 and rig.status("gain") == 0.0
    rig.run(0.01, publish=("master", "slave"))
    assert not rig.master_commands[-1].enable
    np.testing.assert_array_equal(rig.master_commands[-1].torque, np.zeros(6))
    # The slave heads back to the position measured when the fault began, at most at its speed limits.
    assert np.all(np.abs(np.diff(rig.positions(), axis=0)) <= MAX_STEP + 1e-12)
    rig.run(0.3, publish=("master", "slave"))
    np.testing.assert_allclose(rig.positions()[-1], Q_SLAVE)

    rig.master_commands.clear()
    rig.run(0.1)
    scale = rig.torques() @ TORQUE / (TORQUE @ TORQUE)
    assert scale[0] == 0.0 and rig.status("fault") == 0.0
    assert np.all(np.diff(scale) >= -1e-12) and np.all(np.diff(scale) <= RAMP_STEP + 1e-12)
    assert 0.0 < scale[-1] < 1.0


def test_restarted_drivers_recover_without_a_jump(rig):
    """Every driver dies for 50 ms and comes back with its clock and counter from zero
    (a late packet would be dropped; these are newer sessions) and the arm reporting
    another position: the station recovers, the slave command restarts from the new
    measured position (not where the old session held it) and moves on at most at
    the speed limits, and master torque ramps in from 0."""
    rig.run(1.0)
    rig.run(0.05, publish=())
    assert rig.status("healthy") == 0.0
    rig.restart_drivers()
    q_moved = Q_SLAVE + 0.2
    rig.master_commands.clear()
    rig.slave_commands.clear()
    rig.run(0.3, q_slave=q_moved)
    assert rig.status("healthy") == 1.0 and rig.status("fault") == 0.0
    positions = rig.positions()
    # The recovery tick restarts from the measured position and takes one limited step.
    at_measured = np.flatnonzero(np.all(np.abs(positions - q_moved) <= MAX_STEP + 1e-12, axis=1))
    assert at_measured.size, "the command never restarted from the measured position"
    assert np.any(np.abs(positions[at_measured[0] - 1] - q_moved) > 0.1), "it was already there"
    resumed = positions[at_measured[0]:]
    assert np.all(np.abs(np.diff(resumed, axis=0)) <= MAX_STEP + 1e-12)
    np.testing.assert_allclose(resumed[-1], Q_SLAVE + 0.5)
    scale = rig.torques() @ TORQUE / (TORQUE @ TORQUE)
    assert scale[0] == 0.0 and np.all(np.diff(scale) <= RAMP_STEP + 1e-12)
    np.testing.assert_allclose(scale[-1], 1.0)
    np.testing.assert_allclose(rig.output("ft.wrench_measured"), -RAW)


def test_non_finite_commands_never_published(rig):
    rig.run(0.3)
    held = rig.positions()[-1]
    rig.command(np.full(6, np.nan), np.full(6, np.inf))
    rig.master_commands.clear()
    rig.slave_commands.clear()
    rig.run(0.01)
    assert np.all(np.isfinite(rig.torques())) and np.all(np.isfinite(rig.positions()))
    np.testing.assert_array_equal(rig.torques()[-1], np.zeros(6))
    assert not rig.master_commands[-1].enable
    np.testing.assert_array_equal(rig.positions()[-1], held)


def test_ft_sign_flipped(rig):
    rig.run(0.005)
    np.testing.assert_array_equal(rig.output("ft.wrench_measured"), -RAW)
    np.testing.assert_array_equal(rig.output("ft.acceleration_measured"), ACCEL)
