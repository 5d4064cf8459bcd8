"""The hardware station: the lab's LCM channels behind the station ports of DESIGN §3.

``MakeHardwareStation(channels, lcm)`` exports exactly the simulated station's
controller-facing ports (``master.*``, ``slave.*``, ``ft.*``) plus
``hardware.status``, so the teleop controller connects to it unchanged. A
``Watchdog`` over the three incoming channels gates what goes out: master
torque is scaled by its gain (zero while faulted, enable off); while unhealthy
the slave is commanded to hold its last measured position. Slave commands are
rate-limited to the joint speed limits and not published at all before the
first slave status (there is nothing safe to command); non-finite commands are
never published (zero torque, hold position).
"""

import dataclasses
import math

import numpy as np
from drake import lcmt_iiwa_command, lcmt_iiwa_status
from pydrake.lcm import DrakeLcm, DrakeLcmInterface
from pydrake.manipulation import IiwaStatusReceiver
from pydrake.systems.framework import BasicVector, DiagramBuilder, LeafSystem
from pydrake.systems.lcm import LcmInterfaceSystem, LcmSubscriberSystem
from pydrake.systems.primitives import Demultiplexer, Multiplexer

from .channels import LcmChannels
from .ft_receiver import STATUS_FIELDS as FT_STATUS_FIELDS
from .ft_receiver import AddFtSampleReceiver, FtReceiverParams
from .lcm_mailbox import LcmMailbox
from .message_order import stamp_accepted
from .lcmtypes import heft_haptic_command, heft_haptic_state
from .watchdog import Watchdog, WatchdogParams

NUM_JOINTS = 6
"""Joints of the master (Phantom Premium 1.5 6DoF) and of the slave (RX90/RX60)."""
WATCHED_CHANNELS = ("master_state", "slave_status", "ft_sample")
"""Channels the watchdog watches; channel i is bit i of the fault bitmask."""
STATUS_FIELDS = ("healthy", "gain", "fault") + tuple(f"age_{name}" for name in WATCHED_CHANNELS)
"""Entries of ``hardware.status``: watchdog outputs, then each channel's age (s; inf before the first)."""


@dataclasses.dataclass
class HardwareStationParams:
    """Rates and limits of the hardware station; loadable with ``yaml_load_typed``."""

    period: float = 1.0 / 2000.0
    """Receive, watchdog and publish period (s); the controller's rate."""
    watchdog: WatchdogParams = dataclasses.field(default_factory=WatchdogParams)
    slave_velocity_limits: list[float] = dataclasses.field(default_factory=lambda: [
        4.118977034706618, 3.490658503988659, 4.991641660703783,
        6.998770300497261, 5.585053606381854, 10.122909661567112])
    """Joint speed limits of the slave (rad/s); the defaults are the RX90's (``rx90.urdf``)."""


def rate_limit(previous: np.ndarray, target: np.ndarray, max_step: np.ndarray) -> np.ndarray:
    """``target`` approached from ``previous`` by at most ``max_step`` per joint (rad)."""
    return previous + np.clip(target - previous, -max_step, max_step)


class HapticStateReceiver(LeafSystem):
    """Samples the latest ``heft_haptic_state`` in ``mailbox`` every ``period`` s and holds it.

    A message is accepted when its ``utime`` advances (or its driver restarted:
    ``message_order``), it has ``num_joints``
    joints, finite values and no driver ``error``; otherwise the outputs hold
    the last accepted one and its age keeps growing. Outputs: joint position
    (rad), velocity (rad/s) and ``age`` (s of diagram time since the last
    accepted message; inf before the first).
    """

    def __init__(self, mailbox: LcmMailbox, num_joints: int, period: float):
        super().__init__()
        self._n = num_joints
        self._mailbox = mailbox
        self._position = self.DeclareDiscreteState(num_joints)
        self._velocity = self.DeclareDiscreteState(num_joints)
        # Last accepted utime, diagram time of its acceptance, mailbox arrivals taken.
        self._book = self.DeclareDiscreteState(BasicVector([0.0, -math.inf, 0.0]))
        self.DeclareStateOutputPort("position_measured", self._position)
        self.DeclareStateOutputPort("velocity_estimated", self._velocity)
        self.DeclareVectorOutputPort("age", 1, self._calc_age,
                                     prerequisites_of_calc={self.time_ticket(), self.xd_ticket()})
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)

    def _update(self, context, discrete_state):
        book = discrete_state.get_mutable_vector(self._book).get_mutable_value()
        payload = self._mailbox.newer_than(book[2])
        if payload is None:
            return
        book[2] = self._mailbox.count
        msg = heft_haptic_state.decode(payload)
        if not stamp_accepted(msg.utime * 1e-6, book[0] * 1e-6) or msg.num_joints != self._n or msg.error:
            return
        position, velocity = np.asarray(msg.position, dtype=float), np.asarray(msg.velocity, dtype=float)
        if not (np.all(np.isfinite(position)) and np.all(np.isfinite(velocity))):
            return
        book[:2] = msg.utime, context.get_time()
        discrete_state.get_mutable_vector(self._position).SetFromVector(position)
        discrete_state.get_mutable_vector(self._velocity).SetFromVector(velocity)

    def _calc_age(self, context, output):
        output.SetAtIndex(0, context.get_time() - context.get_discrete_state(self._book).GetAtIndex(1))


class StampAge(LeafSystem):
    """Age (s of diagram time) of the last message whose device ``stamp`` (s) advanced (or
    whose driver restarted: ``message_order``) with finite ``values``; inf before the first.
    Samples every ``period`` s."""

    def __init__(self, size: int, period: float):
        super().__init__()
        self._stamp = self.DeclareVectorInputPort("stamp", 1)
        self._values = self.DeclareVectorInputPort("values", size)
        # Last accepted stamp, diagram time of its acceptance.
        self._book = self.DeclareDiscreteState(BasicVector([0.0, -math.inf]))
        self.DeclareVectorOutputPort("age", 1, self._calc_age,
                                     prerequisites_of_calc={self.time_ticket(), self.xd_ticket()})
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)

    def _update(self, context, discrete_state):
        stamp = self._stamp.Eval(context)[0]
        book = discrete_state.get_mutable_vector(self._book).get_mutable_value()
        if stamp_accepted(stamp, book[0]) and np.all(np.isfinite(self._values.Eval(context))):
            book[:] = stamp, context.get_time()

    def _calc_age(self, context, output):
        output.SetAtIndex(0, context.get_time() - context.get_discrete_state(self._book).GetAtIndex(1))


class CommandGate(LeafSystem):
    """What may leave for the hardware, sampled every ``period`` s and held as state.

    Master: ``torque`` = gain · ``torque_commanded`` (N·m), zero and ``enable`` 0
    while unhealthy or non-finite. Slave: ``ready`` turns 1 with the first slave
    status (``slave_age`` finite); until the station is first healthy the command
    follows ``slave_position_measured``; afterwards, while unhealthy it
    holds the measured position latched at the fault's onset, and on recovery the
    command restarts from the measured position (a restarted arm driver may report
    another one); a non-finite ``position_commanded`` holds the previous command;
    every change is limited to ``velocity_limits`` · ``period`` (rad).
    """

    def __init__(self, num_joints: int, velocity_limits, period: float):
        super().__init__()
        self._max_step = np.asarray(velocity_limits, dtype=float) * period
        self._torque_in = self.DeclareVectorInputPort("torque_commanded", num_joints)
        self._position_in = self.DeclareVectorInputPort("position_commanded", num_joints)
        self._measured = self.DeclareVectorInputPort("slave_position_measured", num_joints)
        self._slave_age = self.DeclareVectorInputPort("slave_age", 1)
        self._healthy_in = self.DeclareVectorInputPort("healthy", 1)
        self._gain_in = self.DeclareVectorInputPort("gain", 1)
        self._torque = self.DeclareDiscreteState(num_joints)
        self._enable = self.DeclareDiscreteState(1)
        self._position = self.DeclareDiscreteState(num_joints)
        self._hold = self.DeclareDiscreteState(num_joints)
        self._ready = self.DeclareDiscreteState(1)
        # Ever healthy, healthy at the previous tick.
        self._book = self.DeclareDiscreteState(2)
        self.DeclareStateOutputPort("torque", self._torque)
        self.DeclareStateOutputPort("enable", self._enable)
        self.DeclareStateOutputPort("position", self._position)
        self.DeclareStateOutputPort("ready", self._ready)
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)

    def _update(self, context, discrete_state):
        healthy = self._healthy_in.Eval(context)[0] > 0.5
        torque = self._gain_in.Eval(context)[0] * self._torque_in.Eval(context)
        enable = healthy and bool(np.all(np.isfinite(torque)))
        discrete_state.get_mutable_vector(self._torque).SetFromVector(torque if enable else np.zeros_like(torque))
        discrete_state.get_mutable_vector(self._enable).SetAtIndex(0, float(enable))

        book = discrete_state.get_mutable_vector(self._book).get_mutable_value()
        measured = self._measured.Eval(context)
        position = discrete_state.get_mutable_vector(self._position).get_mutable_value()
        hold = discrete_state.get_mutable_vector(self._hold).get_mutable_value()
        measured_ok = bool(np.isfinite(self._slave_age.Eval(context)[0]) and np.all(np.isfinite(measured)))
        if not book[0]:
            if measured_ok:
                position[:] = hold[:] = measured
                discrete_state.get_mutable_vector(self._ready).SetAtIndex(0, 1.0)
        elif healthy:
            if not book[1] and measured_ok:
                position[:] = measured
            commanded = self._position_in.Eval(context)
            if np.all(np.isfinite(commanded)):
                position[:] = rate_limit(position, commanded, self._max_step)
        else:
            if book[1] and measured_ok:
                hold[:] = measured
            position[:] = rate_limit(position, hold, self._max_step)
        book[0] = book[0] or healthy
        book[1] = healthy


class HapticCommandPublisher(LeafSystem):
    """Publishes ``torque`` (N·m) and ``enable`` (> 0.5 on) as ``heft_haptic_command`` on
    ``channel`` every ``period`` s; utime from diagram time."""

    def __init__(self, num_joints: int, channel: str, lcm: DrakeLcmInterface, period: float):
        super().__init__()
        self._channel, self._lcm = channel, lcm
        self._msg = heft_haptic_command()
        self._msg.num_joints = num_joints
        self._torque = self.DeclareVectorInputPort("torque", num_joints)
        self._enable = self.DeclareVectorInputPort("enable", 1)
        self.DeclarePeriodicPublishEvent(period, 0.0, self._publish)

    def _publish(self, context):
        msg = self._msg
        msg.utime = round(context.get_time() * 1e6)
        msg.torque = self._torque.Eval(context).tolist()
        msg.enable = bool(self._enable.Eval(context)[0] > 0.5)
        self._lcm.Publish(self._channel, msg.encode(), context.get_time())


class SlaveCommandPublisher(LeafSystem):
    """Publishes ``position`` (rad) as ``lcmt_iiwa_command`` on ``channel`` every ``period`` s,
    only while ``ready`` > 0.5; utime from diagram time."""

    def __init__(self, num_joints: int, channel: str, lcm: DrakeLcmInterface, period: float):
        super().__init__()
        self._n, self._channel, self._lcm = num_joints, channel, lcm
        self._position = self.DeclareVectorInputPort("position", num_joints)
        self._ready = self.DeclareVectorInputPort("ready", 1)
        self.DeclarePeriodicPublishEvent(period, 0.0, self._publish)

    def _publish(self, context):
        if self._ready.Eval(context)[0] <= 0.5:
            return
        msg = lcmt_iiwa_command()
        msg.utime = round(context.get_time() * 1e6)
        msg.num_joints = self._n
        msg.joint_position = self._position.Eval(context).tolist()
        self._lcm.Publish(self._channel, msg.encode(), context.get_time())


def MakeHardwareStation(channels: LcmChannels, lcm: DrakeLcmInterface | None = None,
                        params: HardwareStationParams | None = None):
    """The hardware station Diagram on ``lcm`` (None: a new one on ``channels.lcm_url``).

    The diagram contains its own ``LcmInterfaceSystem``, so a Simulator pumps
    ``lcm``. Inputs: ``master.torque_commanded`` (6, N·m), ``slave.position_commanded``
    (6, rad). Outputs: ``master.position_measured``, ``master.velocity_estimated``,
    ``slave.position_measured``, ``slave.velocity_estimated`` (6 each, rad, rad/s),
    ``ft.wrench_measured`` ([f; τ] on the load at S in S, N, N·m),
    ``ft.acceleration_measured`` ([a; α] of S in S), ``hardware.status``
    (``STATUS_FIELDS``). Subscribers never block ``Initialize()``.
    """
    params = params or HardwareStationParams()
    period = params.period
    builder = DiagramBuilder()
    lcm = DrakeLcm(channels.lcm_url) if lcm is None else lcm
    bus = builder.AddNamedSystem("lcm", LcmInterfaceSystem(lcm))

    master = builder.AddNamedSystem("master_receiver", HapticStateReceiver(
        LcmMailbox(lcm, channels.master_state.name), NUM_JOINTS, period))
    builder.ExportOutput(master.GetOutputPort("position_measured"), "master.position_measured")
    builder.ExportOutput(master.GetOutputPort("velocity_estimated"), "master.velocity_estimated")

    slave_sub = builder.AddNamedSystem("slave_subscriber", LcmSubscriberSystem.Make(
        channel=channels.slave_status.name, lcm_type=lcmt_iiwa_status, lcm=bus, use_cpp_serializer=True,
        wait_for_message_on_initialization_timeout=0.0))
    slave = builder.AddNamedSystem("slave_receiver", IiwaStatusReceiver(num_joints=NUM_JOINTS))
    builder.Connect(slave_sub.get_output_port(), slave.get_input_port())
    slave_age = builder.AddNamedSystem("slave_status_age", StampAge(NUM_JOINTS, period))
    builder.Connect(slave.GetOutputPort("time_measured"), slave_age.GetInputPort("stamp"))
    builder.Connect(slave.GetOutputPort("position_measured"), slave_age.GetInputPort("values"))
    builder.ExportOutput(slave.GetOutputPort("position_measured"), "slave.position_measured")
    builder.ExportOutput(slave.GetOutputPort("velocity_estimated"), "slave.velocity_estimated")

    ft = AddFtSampleReceiver(builder, lcm, channels.ft_sample.name, FtReceiverParams(period=period))
    builder.ExportOutput(ft.GetOutputPort("wrench_measured"), "ft.wrench_measured")
    builder.ExportOutput(ft.GetOutputPort("acceleration_measured"), "ft.acceleration_measured")
    ft_status = builder.AddNamedSystem("ft_status", Demultiplexer(len(FT_STATUS_FIELDS)))
    builder.Connect(ft.GetOutputPort("status"), ft_status.get_input_port())

    ages = builder.AddNamedSystem("ages", Multiplexer(len(WATCHED_CHANNELS)))
    builder.Connect(master.GetOutputPort("age"), ages.get_input_port(0))
    builder.Connect(slave_age.GetOutputPort("age"), ages.get_input_port(1))
    builder.Connect(ft_status.get_output_port(FT_STATUS_FIELDS.index("age")), ages.get_input_port(2))
    watchdog = builder.AddNamedSystem("watchdog", Watchdog(len(WATCHED_CHANNELS), period, params.watchdog))
    builder.Connect(ages.get_output_port(), watchdog.get_input_port())
    status = builder.AddNamedSystem("status", Multiplexer([1, 1, 1, len(WATCHED_CHANNELS)]))
    for i, name in enumerate(("healthy", "gain", "fault")):
        builder.Connect(watchdog.GetOutputPort(name), status.get_input_port(i))
    builder.Connect(ages.get_output_port(), status.get_input_port(3))
    builder.ExportOutput(status.get_output_port(), "hardware.status")

    gate = builder.AddNamedSystem("command_gate", CommandGate(NUM_JOINTS, params.slave_velocity_limits, period))
    builder.ExportInput(gate.GetInputPort("torque_commanded"), "master.torque_commanded")
    builder.ExportInput(gate.GetInputPort("position_commanded"), "slave.position_commanded")
    builder.Connect(slave.GetOutputPort("position_measured"), gate.GetInputPort("slave_position_measured"))
    builder.Connect(slave_age.GetOutputPort("age"), gate.GetInputPort("slave_age"))
    builder.Connect(watchdog.GetOutputPort("healthy"), gate.GetInputPort("healthy"))
    builder.Connect(watchdog.GetOutputPort("gain"), gate.GetInputPort("gain"))

    master_pub = builder.AddNamedSystem("master_publisher", HapticCommandPublisher(
        NUM_JOINTS, channels.master_command.name, lcm, period))
    builder.Connect(gate.GetOutputPort("torque"), master_pub.GetInputPort("torque"))
    builder.Connect(gate.GetOutputPort("enable"), master_pub.GetInputPort("enable"))

    slave_pub = builder.AddNamedSystem("slave_publisher", SlaveCommandPublisher(
        NUM_JOINTS, channels.slave_command.name, lcm, period))
    builder.Connect(gate.GetOutputPort("position"), slave_pub.GetInputPort("position"))
    builder.Connect(gate.GetOutputPort("ready"), slave_pub.GetInputPort("ready"))

    diagram = builder.Build()
    diagram.set_name("hardware_station")
    return diagram
