"""The lab stand-in: the simulated station behind the lab drivers' LCM channels.

``MakeStandIn`` wraps ``MakeSimStation`` in what the Phantom, arm and JR3
drivers do on the bus: it publishes ``heft_haptic_state``, ``lcmt_iiwa_status``
(6 joints) and ``heft_ft_sample`` (the sensor's own sign: the wrench the load
exerts on the sensor) at the channel rates, and applies ``heft_haptic_command``
and ``lcmt_iiwa_command``. ``FaultInjection`` degrades what is published, so
``MakeHardwareStation`` can be exercised against a misbehaving lab.
``run_stand_in`` runs it as a process would.
"""

import dataclasses
import math

import numpy as np
from drake import lcmt_iiwa_command, lcmt_iiwa_status
from heft.diagrams.scenario import Scenario
from heft.diagrams.sim_station import MakeSimStation
from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.lcm_mailbox import LcmMailbox
from heft.hardware_interface.lcmtypes import (
    heft_ft_sample,
    heft_haptic_command,
    heft_haptic_state,
)
from pydrake.lcm import DrakeLcm, DrakeLcmInterface
from pydrake.manipulation import IiwaCommandReceiver, IiwaControlMode
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import BasicVector, DiagramBuilder, LeafSystem
from pydrake.systems.lcm import LcmInterfaceSystem, LcmSubscriberSystem
from pydrake.systems.primitives import DiscreteTimeDelay, Multiplexer

NUM_JOINTS = 6
"""Joints of the master and of the slave."""
_MASK64 = (1 << 64) - 1
_MASTER_STREAM, _SLAVE_STREAM, _FT_STREAM, _NAN_STREAM = range(4)
"""Random streams of ``_uniform``: losses per channel, then FT NaNs."""


@dataclasses.dataclass
class FaultInjection:
    """Faults applied to what the stand-in publishes; loadable with ``yaml_load_typed``.

    Random faults are a fixed function of (``seed``, channel, sample time), so a
    run is reproducible and independent of how often it is repeated.
    """

    drop_rate: float = 0.0
    """Probability (per message, every channel) that a loss starts."""
    burst_loss_s: float = 0.0
    """Length of each loss (s); 0 loses just the one message."""
    added_delay_s: float = 0.0
    """FT samples reach the bus this late (s); their ``utime`` stays the sample time."""
    nan_rate: float = 0.0
    """Probability (per FT sample) that its wrench is NaN."""
    saturate_at_s: float = math.inf
    """From this time on (s) every FT sample flags all wrench axes saturated."""
    die_at_s: float = math.inf
    """From this time on (s) nothing is published; ``run_stand_in`` returns here."""
    seed: int = 0


def _uniform(seed: int, stream: int, tick: int) -> float:
    """A uniform number in [0, 1), a fixed function of its arguments (splitmix64)."""
    x = (seed * 0x9E3779B97F4A7C15 + stream * 0xD1B54A32D192ED03 + tick) & _MASK64
    x = ((x ^ (x >> 30)) * 0xBF58476D1CE4E5B9) & _MASK64
    x = ((x ^ (x >> 27)) * 0x94D049BB133111EB) & _MASK64
    return ((x ^ (x >> 31)) >> 11) * 2.0 ** -53


class _DriverPublisher(LeafSystem):
    """Publishes one driver message on ``channel`` every ``period`` s, with losses.

    Publishing happens in the periodic discrete update, which also keeps the
    loss state (time, s, until which messages are lost). Messages whose sample
    time is not after 0 are not sent (``utime`` 0 means "no sample").
    Subclasses fill ``_message(context, tick, stamp)``; ``stamp`` is the
    sample time (s).
    """

    def __init__(self, stream: int, channel: str, lcm: DrakeLcmInterface, period: float,
                 faults: FaultInjection, delay: float = 0.0):
        super().__init__()
        self._stream, self._channel, self._lcm = stream, channel, lcm
        self._period, self._faults, self._delay = period, faults, delay
        self._lost_until = self.DeclareDiscreteState(BasicVector([-math.inf]))
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)

    def _update(self, context, discrete_state):
        t = context.get_time()
        stamp = t - self._delay
        faults = self._faults
        if stamp <= 0.0 or t >= faults.die_at_s:
            return
        tick = round(t / self._period)
        lost_until = discrete_state.get_mutable_vector(self._lost_until)
        if faults.drop_rate > 0.0 and _uniform(faults.seed, self._stream, tick) < faults.drop_rate:
            lost_until.SetAtIndex(0, max(lost_until.GetAtIndex(0), t + faults.burst_loss_s))
            return
        if t < lost_until.GetAtIndex(0):
            return
        self._lcm.Publish(self._channel, self._message(context, tick, stamp).encode(), t)


class HapticStatePublisher(_DriverPublisher):
    """The Phantom driver: ``position`` (rad), ``velocity`` (rad/s) and ``torque_applied``
    (N·m) → ``heft_haptic_state``."""

    def __init__(self, channel: str, lcm: DrakeLcmInterface, period: float, faults: FaultInjection):
        super().__init__(_MASTER_STREAM, channel, lcm, period, faults)
        self._position = self.DeclareVectorInputPort("position", NUM_JOINTS)
        self._velocity = self.DeclareVectorInputPort("velocity", NUM_JOINTS)
        self._torque = self.DeclareVectorInputPort("torque_applied", NUM_JOINTS)

    def _message(self, context, tick, stamp):
        msg = heft_haptic_state()
        msg.utime = round(stamp * 1e6)
        msg.num_joints = NUM_JOINTS
        msg.position = self._position.Eval(context).tolist()
        msg.velocity = self._velocity.Eval(context).tolist()
        msg.torque_applied = self._torque.Eval(context).tolist()
        return msg


class IiwaStatusPublisher(_DriverPublisher):
    """The arm driver: ``position_measured`` (rad), ``velocity_estimated`` (rad/s) and
    ``position_commanded`` (rad) → ``lcmt_iiwa_status`` (torques reported as 0)."""

    def __init__(self, channel: str, lcm: DrakeLcmInterface, period: float, faults: FaultInjection):
        super().__init__(_SLAVE_STREAM, channel, lcm, period, faults)
        self._measured = self.DeclareVectorInputPort("position_measured", NUM_JOINTS)
        self._velocity = self.DeclareVectorInputPort("velocity_estimated", NUM_JOINTS)
        self._commanded = self.DeclareVectorInputPort("position_commanded", NUM_JOINTS)
        self._zeros = [0.0] * NUM_JOINTS

    def _message(self, context, tick, stamp):
        msg = lcmt_iiwa_status()
        msg.utime = round(stamp * 1e6)
        msg.num_joints = NUM_JOINTS
        msg.joint_position_measured = self._measured.Eval(context).tolist()
        msg.joint_velocity_estimated = self._velocity.Eval(context).tolist()
        msg.joint_position_commanded = msg.joint_position_ipo = self._commanded.Eval(context).tolist()
        msg.joint_torque_measured = msg.joint_torque_commanded = msg.joint_torque_external = self._zeros
        return msg


class FtSamplePublisher(_DriverPublisher):
    """The JR3 driver: ``sample`` = [wrench (DESIGN §4 sign: on the load, N, N·m);
    acceleration (m/s², rad/s²); 12 saturation flags (0/1, wrench then acceleration
    axes)] → ``heft_ft_sample`` with the sensor's sign (negated wrench), bit mask
    and a counter that counts lost samples too. ``delay`` (s): the input is that
    old, so ``utime`` is ``delay`` before the publishing time."""

    def __init__(self, channel: str, lcm: DrakeLcmInterface, period: float, faults: FaultInjection,
                 delay: float):
        super().__init__(_FT_STREAM, channel, lcm, period, faults, delay)
        self._sample = self.DeclareVectorInputPort("sample", 24)
        self._bits = 1 << np.arange(12)

    def _message(self, context, tick, stamp):
        sample = self._sample.Eval(context)
        faults = self._faults
        msg = heft_ft_sample()
        msg.utime = round(stamp * 1e6)
        msg.sample_counter = tick
        if faults.nan_rate > 0.0 and _uniform(faults.seed, _NAN_STREAM, tick) < faults.nan_rate:
            msg.wrench = [math.nan] * 6
        else:
            msg.wrench = (-sample[:6]).tolist()
        msg.acceleration = sample[6:12].tolist()
        saturated = int(self._bits @ (sample[12:] > 0.5))
        if stamp >= faults.saturate_at_s:
            saturated |= 0x3F
        msg.saturated = saturated
        return msg


class HapticCommandReceiver(LeafSystem):
    """The Phantom driver's side of ``heft_haptic_command``: samples the latest in
    ``mailbox`` every ``period`` s and holds the torque (N·m) it applies; zero before
    the first command, while not ``enable``, or when the message is malformed or
    non-finite (the driver rejects it)."""

    def __init__(self, mailbox: LcmMailbox, period: float):
        super().__init__()
        self._mailbox = mailbox
        self._torque = self.DeclareDiscreteState(NUM_JOINTS)
        self._taken = self.DeclareDiscreteState(1)  # mailbox arrivals taken
        self.DeclareStateOutputPort("torque", self._torque)
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)

    def _update(self, context, discrete_state):
        taken = discrete_state.get_mutable_vector(self._taken)
        payload = self._mailbox.newer_than(taken.GetAtIndex(0))
        if payload is None:
            return
        taken.SetAtIndex(0, self._mailbox.count)
        msg = heft_haptic_command.decode(payload)
        torque = np.asarray(msg.torque, dtype=float)
        ok = msg.enable and msg.num_joints == NUM_JOINTS and bool(np.all(np.isfinite(torque)))
        discrete_state.get_mutable_vector(self._torque).SetFromVector(torque if ok else np.zeros(NUM_JOINTS))


def MakeStandIn(scenario: Scenario, channels: LcmChannels, lcm: DrakeLcmInterface,
                faults: FaultInjection | None = None):
    """The stand-in Diagram on ``lcm``: ``MakeSimStation(scenario)`` driven and read over LCM.

    Contains its own ``LcmInterfaceSystem``, so a Simulator pumps ``lcm``. No
    inputs; outputs are the sim station's, prefixed ``sim.`` (e.g.
    ``sim.truth.wrench_sensor``). The slave holds its measured position until
    the first ``lcmt_iiwa_command``; the master gets zero torque until the first
    enabled ``heft_haptic_command``. Subscribers never block ``Initialize()``.
    """
    faults = faults or FaultInjection()
    builder = DiagramBuilder()
    bus = builder.AddNamedSystem("lcm", LcmInterfaceSystem(lcm))
    station = builder.AddNamedSystem("sim_station", MakeSimStation(scenario))
    for i in range(station.num_output_ports()):
        port = station.get_output_port(i)
        builder.ExportOutput(port, f"sim.{port.get_name()}")

    master_command = builder.AddNamedSystem("master_command_receiver", HapticCommandReceiver(
        LcmMailbox(lcm, channels.master_command.name), 1.0 / channels.master_command.rate))
    builder.Connect(master_command.get_output_port(), station.GetInputPort("master.torque_commanded"))

    slave_sub = builder.AddNamedSystem("slave_command_subscriber", LcmSubscriberSystem.Make(
        channel=channels.slave_command.name, lcm_type=lcmt_iiwa_command, lcm=bus, use_cpp_serializer=True,
        wait_for_message_on_initialization_timeout=0.0))
    slave_command = builder.AddNamedSystem("slave_command_receiver", IiwaCommandReceiver(
        num_joints=NUM_JOINTS, control_mode=IiwaControlMode.kPositionOnly))
    builder.Connect(slave_sub.get_output_port(), slave_command.GetInputPort("lcmt_iiwa_command"))
    builder.Connect(station.GetOutputPort("slave.position_measured"), slave_command.GetInputPort("position_measured"))
    builder.Connect(slave_command.GetOutputPort("position"), station.GetInputPort("slave.position_commanded"))

    master_pub = builder.AddNamedSystem("master_state_publisher", HapticStatePublisher(
        channels.master_state.name, lcm, 1.0 / channels.master_state.rate, faults))
    builder.Connect(station.GetOutputPort("master.position_measured"), master_pub.GetInputPort("position"))
    builder.Connect(station.GetOutputPort("master.velocity_estimated"), master_pub.GetInputPort("velocity"))
    builder.Connect(master_command.get_output_port(), master_pub.GetInputPort("torque_applied"))

    slave_pub = builder.AddNamedSystem("slave_status_publisher", IiwaStatusPublisher(
        channels.slave_status.name, lcm, 1.0 / channels.slave_status.rate, faults))
    builder.Connect(station.GetOutputPort("slave.position_measured"), slave_pub.GetInputPort("position_measured"))
    builder.Connect(station.GetOutputPort("slave.velocity_estimated"), slave_pub.GetInputPort("velocity_estimated"))
    builder.Connect(slave_command.GetOutputPort("position"), slave_pub.GetInputPort("position_commanded"))

    ft_period = 1.0 / channels.ft_sample.rate
    steps = round(faults.added_delay_s / ft_period)
    sample = builder.AddNamedSystem("ft_sample", Multiplexer([6, 6, 6, 6]))
    for i, name in enumerate(("ft.wrench_measured", "ft.acceleration_measured", "truth.ft_saturated",
                              "truth.accelerometer_saturated")):
        builder.Connect(station.GetOutputPort(name), sample.get_input_port(i))
    ft_pub = builder.AddNamedSystem("ft_sample_publisher", FtSamplePublisher(
        channels.ft_sample.name, lcm, ft_period, faults, steps * ft_period))
    if steps:
        delay = builder.AddNamedSystem("ft_delay", DiscreteTimeDelay(ft_period, steps, 24))
        builder.Connect(sample.get_output_port(), delay.get_input_port())
        builder.Connect(delay.get_output_port(), ft_pub.get_input_port())
    else:
        builder.Connect(sample.get_output_port(), ft_pub.get_input_port())

    diagram = builder.Build()
    diagram.set_name("stand_in")
    return diagram


def run_stand_in(scenario: Scenario, channels: LcmChannels, lcm_url: str, duration: float,
                 realtime_rate: float = 1.0, faults: FaultInjection | None = None) -> float:
    """Runs ``MakeStandIn`` on a new ``DrakeLcm(lcm_url)`` for ``duration`` s at
    ``realtime_rate`` (0: as fast as possible); returns early at ``faults.die_at_s``.
    Returns the simulated time reached (s)."""
    faults = faults or FaultInjection()
    simulator = Simulator(MakeStandIn(scenario, channels, DrakeLcm(lcm_url), faults))
    simulator.set_target_realtime_rate(realtime_rate)
    simulator.Initialize()
    end = min(duration, faults.die_at_s)
    simulator.AdvanceTo(end)
    return end
