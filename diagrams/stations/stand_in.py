"""The lab stand-in: the haptic master's, arm, JR3 and gripper drivers on LCM, modelled cheaply
enough to keep real time on one core.

``StandIn`` publishes ``heft_haptic_state``, ``lcmt_iiwa_status`` (the scenario's arm's 6 or 7 joints),
``heft_ft_samples`` (a buffered JR3 driver: the samples since the last arm step in one message)
and, for a "gripper_object" load, ``heft_gripper_state`` at the channels' nominal rates
(2, 2, 8 and 0.1 kHz by default: FT samples in messages at the arm's rate) on a python-lcm bus
and obeys ``heft_haptic_command`` and ``lcmt_iiwa_command`` from another
(``LcmChannels``: the command URL).
``FaultInjection`` degrades what it publishes, so ``HardwareStation`` can be
exercised against a misbehaving lab. ``run_stand_in`` runs it in wall-clock
real time, as a separate process would.

Models (frames as docs/design.md §4: W world = R slave base, B master base, S wrist sensor):

* Slave (arm driver): the joints follow the last valid command, approached no
  faster than the arm's joint speed limits (its controller's own limit: a command
  that jumps, as after a late or stalled stand-in, is not a jump of the arm), through
  the robot controller's critically damped setpoint filter
  (``Scenario.slave_setpoint_bandwidth``) and the simulated station's joint servo on the
  arm's inertia in the start pose (``slave_servo``), stepped exactly at the status rate: the
  measured position is the joints' (encoder-quantised), the estimated velocity the arm
  controller's estimate from those encoder readings (``EncoderVelocityEstimator``, the
  simulated station's ``slave_velocity_filter``; the joints' own q̇ when that is 0).
* Sensor frame S: pose, ω, and the kinematic acceleration [a; α] of S in S from
  the joints' state (``SerialChain``, from the plant's URDF): A_WS = J·q̈ + J̇·q̇, with q̈ the joints'
  acceleration after each step. Gravity in S is R_SW·g_W. The accelerometer
  reports what a real one does (``accelerometer_reading``: specific force a − g
  unless the scenario's ``accelerometer.includes_gravity`` is False) at its
  ``accelerometer.position``, as in the simulated station.
* Load (``stand_in_wrist.Wrist``): on the scenario's compliant mount, sized to the
  load as the simulated station's (``mount_for``), its small-deflection dynamics
  driven by S's motion (``mount.MountUnderMovingSensor``, stepped with the slave),
  or welded at S with ``load.mount.rigid``. A "gripper_object" load's gripper closes
  on the object at ``GraspTimes.grasp_at`` (CLOSING for ``GRIPPER_CLOSING_S``, then
  HOLDING: the object's inertia joins the gripper's, the mount rings) and opens at
  ``release_at`` (OPEN: the object is let go); its driver publishes that state.
* JR3 driver: the wrench is what the mount transmits, the load's non-contact wrench
  (V(a, α, ω, g)·φ, Eq. 5, at the load's own motion), with φ of what it carries as
  the simulated station computes it, through ``sensor_models``' measurement model (the sensor's
  low-pass filter, offsets, drift, noise, saturation, quantisation as the
  scenario's sensor parameters enable them, sampled at the channel rate); the
  accelerometer likewise. The
  kinematics are held (zero-order) between the slave's steps: each FT sample
  uses those of the latest slave step at or before its sample time.
  Published with the sensor's sign (the wrench the load exerts on the sensor).
* Master (the scenario's ``master``: the Phantom Premium 1.5 6DoF's driver, or a Touch's: six measured
  joints, the three of its wrist without motors): the joints move by J_M(q₀)⁻¹ times the operator's
  reference offset of the stylus (``smooth_sine_offset`` with the scenario's
  ``OperatorSpec``; translation, then roll-pitch-yaw, in B), so the stylus
  follows the reference to first order and the published velocity is the exact
  derivative of the position (published encoder-quantised). The driver
  applies the last command's torque, clipped to the amplifiers' limits (the URDF's efforts), only if
  it is enabled, 6 joints, finite and zero on every joint without a motor (else refused as
  "unactuated"), and drops it to zero ``HAPTIC_WATCHDOG_S`` after the last valid command.
  Button bit 0 (the clutch) is held in [``clutch_at``, ``clutch_release_at``). Either driver refuses a
  command of another joint count, one that does not decode or is not finite, and counts it by its reason
  (``StandIn.refused``).

Left out against ``MakeSimStation``: contact and the environment (no sheet
spring: the wrench is the load's own only), the arm's link dynamics but its inertia
in the start pose (no Coriolis or centrifugal torques, no change of inertia with the
pose; the mount's load does not move the wrist), the mount's second-order terms
(``MountUnderMovingSensor``), the object's approach and lift (it weighs on the
gripper all at once when the fingers close), the operator's impedance and the
master's dynamics (the applied torque does not move the master; the stylus follows
the reference only to first order), friction.

With ``record_truth`` the lab keeps the truth of every FT sample (``TruthRecord``);
``run_stand_in`` writes it to ``truth_path``.

Times are the lab's own clock: seconds since it started; ``utime`` is that clock
in µs at the message's sample time, so a restarted lab stamps from zero again
(as ``message_order`` expects of a restarted driver).
"""

from __future__ import annotations

import collections
import contextlib
import dataclasses
import math
import select
import struct
import time

import lcm
import numpy as np
from drake import lcmt_iiwa_command, lcmt_iiwa_status

from heft.diagrams.scenario import Scenario
from heft.diagrams.plants import MakeArmPlant, MakeMasterPlant, master_actuated, slave_arm
from heft.diagrams.stations.sim_station import MASTER_ENCODER_COUNTS_PER_REV
from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.hardware_station import CLUTCH_BUTTON
from heft.hardware_interface.fixed_layout import FixedLayout, put_wire_double, put_wire_int
from heft.hardware_interface.ft_messages import FIELDS, OFFSETS, SAMPLE_BYTES, pack_samples
from heft.hardware_interface.lcm_mailbox import LcmMailbox, open_buses, pump
from heft.hardware_interface.message_checks import REASONS, Rejections
from heft.diagrams.stations.slave_servo import SERVO_ROWS, servo_step, servo_step_matrices, slave_servo_gains
from heft.diagrams.stations.stand_in_wrist import GraspTimes, SixAxisSampler, TruthRecord, Wrist
from heft.hardware_interface.lcmtypes import heft_gripper_state, heft_haptic_command, heft_haptic_state
from heft.systems.compiled import compiled, float_array
from heft.systems.station.encoders import EncoderVelocityEstimator
from heft.systems.controller.master_kinematics import BASE_FRAME, STYLUS_FRAME
from heft.systems.controller.master_kinematics import NUM_JOINTS as MASTER_JOINTS  # the haptic channels' joints
from heft.systems.station.operator_hand import smooth_sine_offset
from heft.systems.serial_chain import SerialChain, chain_dtype, chain_kinematics
from heft.systems.station.sensor_models import ACCELEROMETER_STREAM, FORCE_TORQUE_STREAM, NUM_AXES, quantize

HAPTIC_WATCHDOG_S = 0.02
"""The haptic driver zeroes its torque this long (s) after the last valid command."""
_PUBLISHED_KEEP = 8192
"""Master states (utime, joint positions) the haptic driver keeps, in a ring: 4 s at 2 kHz, more than
a stalled lab publishes between a command's state and the command's arrival."""
_NO_TORQUE = np.zeros(MASTER_JOINTS)
_NO_TORQUE.flags.writeable = False
"""The master's torque while its driver applies none."""
_WRENCH_SATURATED = 0x3F
"""The flag bits of the six wrench axes (``heft_ft_sample.saturated``)."""
_UTIME, _COUNTER, _WRENCH, _ACCELERATION, _SATURATED, _ERROR = range(1, 1 + len(FIELDS))
"""Columns of ``ft_messages.OFFSETS``: where each field of a sample starts."""
_TIME_BYTES, _COUNTER_BYTES, _VECTOR_BYTES, _FLAG_BYTES = (int(SAMPLE_BYTES[column - 1]) for column in (
    _UTIME, _COUNTER, _WRENCH, _SATURATED))
"""Bytes a sample's utime, counter, wrench (or acceleration) and flags take (``ft_messages.SAMPLE_BYTES``)."""
_NAMED_KEEP = 64
"""Master commands whose named state the lab keeps, to date the slave command of the same tick (32 ms at 2 kHz)."""
UNACTUATED = "unactuated"
"""Why the haptic driver refuses a command with torque on a joint without a motor (a Touch's wrist)."""
MASTER_COMMAND_REASONS = REASONS + (UNACTUATED,)
"""What the haptic driver counts a command it refuses by: the message checks' reasons and ``UNACTUATED``."""
_MASK64 = (1 << 64) - 1
_MASTER, _SLAVE, _FT, _GRIPPER = range(4)
"""Channel indices; channel i loses messages on random stream i and reorders them on 4 + i, but the
gripper's (i = 3, the NaN faults' stream) on ``_GRIPPER_STREAM`` and 4 + it."""
_NAN_STREAM, _REORDER_STREAM, _GRIPPER_STREAM = 3, 4, 7
_DUE_SLACK = 1e-9
"""A message is due when its nominal time is at most this (s) after ``now`` (round-off of k/rate)."""
_MAX_STEP = 0.05
"""The most lab time (s) one step covers: a stand-in starved of CPU catches up in steps this
long, so that it sees a stop request between two of them instead of after its whole backlog
(which, on a machine too busy for it to keep real time, grows without end)."""


@dataclasses.dataclass
class FaultInjection:
    """Faults applied to what the stand-in publishes; loadable with ``yaml_load_typed``.

    Random faults are a fixed function of (``seed``, channel, sample index), so a
    run is reproducible and independent of how often it is repeated.
    """

    drop_rate: float = 0.0
    """Probability (per message, every channel) that a loss starts."""
    burst_loss_s: float = 0.0
    """Length of each loss (s); 0 loses just the one message."""
    added_delay_s: float = 0.0
    """FT messages reach the bus this late (s); their samples' ``utime`` stays the sample time."""
    nan_rate: float = 0.0
    """Probability (per FT sample) that its wrench is NaN."""
    saturate_at_s: float = math.inf
    """From this time on (s) every FT sample flags all wrench axes saturated."""
    die_at_s: float = math.inf
    """From this time on (s) nothing is published; ``run_stand_in`` returns here."""
    seed: int = 0
    """Seed of every random fault."""
    reorder_rate: float = 0.0
    """Probability (per message, every channel) that it is held back and sent after the
    next message of its channel (out-of-order delivery)."""

    def validate(self) -> None:
        """Raises ValueError naming the first field out of range."""
        for name in ("drop_rate", "nan_rate", "reorder_rate"):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"fault {name} is a probability in [0, 1]; got {value}")
        for name in ("burst_loss_s", "added_delay_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"fault {name} must be a finite number of seconds >= 0; got {value}")
        for name in ("saturate_at_s", "die_at_s"):
            if math.isnan(getattr(self, name)):
                raise ValueError(f"fault {name} must be a time (s) or inf; got NaN")


def _uniform(seed: int, stream: int, tick: int) -> float:
    """A uniform number in [0, 1), a fixed function of its arguments (splitmix64)."""
    x = (seed * 0x9E3779B97F4A7C15 + stream * 0xD1B54A32D192ED03 + tick) & _MASK64
    x = ((x ^ (x >> 30)) * 0xBF58476D1CE4E5B9) & _MASK64
    x = ((x ^ (x >> 27)) * 0x94D049BB133111EB) & _MASK64
    return ((x ^ (x >> 31)) >> 11) * 2.0 ** -53


class _Outlet:
    """One driver's channel on the bus with the delivery faults: losses (decided per
    sample index) and reordering (at sending)."""

    def __init__(self, bus: lcm.LCM, name: str, channel: int, faults: FaultInjection):
        self.name, self.count = name, 0
        self._bus, self._channel, self._faults = bus, channel, faults
        self._lost_until = -math.inf
        self._held = None

    def lost(self, tick: int, t: float) -> bool:
        """Whether sample ``tick`` (sample time ``t``, s) is lost: a loss starts here with
        probability ``drop_rate`` and lasts ``burst_loss_s``."""
        faults = self._faults
        if faults.drop_rate > 0.0 and _uniform(faults.seed, self._channel, tick) < faults.drop_rate:
            self._lost_until = max(self._lost_until, t + faults.burst_loss_s)
            return True
        return t < self._lost_until

    def send(self, tick: int, payload: bytes) -> None:
        """Publishes ``payload``, then the one held back, if any; or holds this one back."""
        faults = self._faults
        if self._held is None and faults.reorder_rate > 0.0 and (
                _uniform(faults.seed, _REORDER_STREAM + self._channel, tick) < faults.reorder_rate):
            self._held = payload
            return
        self._bus.publish(self.name, payload)
        self.count += 1
        if self._held is not None:
            self._bus.publish(self.name, self._held)
            self.count += 1
            self._held = None


@compiled("float64(CHAIN[:], float64[:], float64[:], float64[:, :])", CHAIN=chain_dtype(MASTER_JOINTS))
def stylus_force_at(chain, position, torque, work) -> float:
    """|f| (N) of the wrench [f; τ_E] that joint ``torque`` (N·m) renders on the hand at joint ``position``
    (rad): the solution of J_Mᵀ·[f; τ_E] = τ, J_M the ``chain``'s Jacobian there (a ``SerialChain.record``,
    overwritten), by Gaussian elimination with partial pivoting on ``work`` (n, n + 1)."""
    c = chain[0]
    J, n = c["J"], position.shape[0]
    chain_kinematics(c["axes"], c["points"], c["M_R"], c["M_p"], position, c["zeros"], c["zeros"], c["gravity_B"],
                     c["R"], c["p"], J, c["motion"], c["work"])
    for r in range(n):  # [J_Mᵀ | τ]
        for k in range(n):
            work[r, k] = J[k, r]
        work[r, n] = torque[r]
    for k in range(n):
        pivot = k
        for r in range(k + 1, n):
            if abs(work[r, k]) > abs(work[pivot, k]):
                pivot = r
        for col in range(k, n + 1):
            work[k, col], work[pivot, col] = work[pivot, col], work[k, col]
        for r in range(k + 1, n):
            factor = work[r, k] / work[k, k]
            for col in range(k, n + 1):
                work[r, col] -= factor * work[k, col]
    for k in range(n - 1, -1, -1):  # back substitution: [f; τ_E] into the last column
        total = work[k, n]
        for col in range(k + 1, n):
            total -= work[k, col] * work[col, n]
        work[k, n] = total / work[k, k]
    return math.sqrt(work[0, n] * work[0, n] + work[1, n] * work[1, n] + work[2, n] * work[2, n])


@compiled("int64(int64[:], int64, int64, int64)")
def ring_slot(utimes, newest, filled, utime) -> int:
    """The slot of ``utime`` among the ``filled`` slots of the ring ``utimes`` that end at slot ``newest``,
    searched from the newest back; −1 if none holds it."""
    for back in range(filled):
        slot = newest - back
        if slot < 0:
            slot += utimes.shape[0]
        if utimes[slot] == utime:
            return slot
    return -1


class _Master:
    """The scenario's master's joints moved by the operator's reference motion through the master's
    Jacobian at its start pose: q = q₀ + J_M(q₀)⁻¹·[Δp; Δrpy](t), q̇ = its derivative.

    ``actuated`` (6): 1.0 for a joint with a motor, else 0.0 (``master_actuated``); ``effort_limits`` (6, N·m):
    each motor's limit (its URDF's effort), 0 on a joint without one."""

    def __init__(self, scenario: Scenario):
        plant = MakeMasterPlant(scenario.master)
        if plant.num_positions() != MASTER_JOINTS:
            raise ValueError(f"master: {scenario.master} has {plant.num_positions()} joints; the haptic channels "
                             f"carry {MASTER_JOINTS}: give the master six measured joints")
        self.actuated = master_actuated(plant)
        self.effort_limits = np.zeros(MASTER_JOINTS)
        for i in plant.GetJointActuatorIndices():
            actuator = plant.get_joint_actuator(i)
            self.effort_limits[actuator.joint().position_start()] = actuator.effort_limit()
        self._initial = np.array(scenario.master_initial_q, dtype=float)
        self._chain = SerialChain(plant, plant.GetFrameByName(BASE_FRAME), plant.GetFrameByName(STYLUS_FRAME))
        self._chain.update(self._initial)
        operator = self._operator = scenario.operator
        # The reference's offset is amplitude × one shape in time, so the joints' is J⁻¹·amplitude × it.
        self._amplitude = np.linalg.solve(self._chain.J, np.concatenate((operator.amplitude,
                                                                         operator.rotation_amplitude)))
        self.position, self.velocity = self._initial.copy(), np.zeros(MASTER_JOINTS)
        self._solve_work = np.empty((MASTER_JOINTS, MASTER_JOINTS + 1))

    def stylus_force(self, torque, position) -> float:
        """|f| (N) of the wrench that joint ``torque`` (N·m) renders on the hand at joint
        ``position`` (rad): τ = J_Mᵀ·[f; τ_E] (``stylus_force_at``)."""
        return stylus_force_at(self._chain.record, float_array(position), float_array(torque), self._solve_work)

    def update(self, t: float) -> None:
        """Moves the joints to the operator's reference at time ``t`` (s)."""
        operator = self._operator
        offset, self.velocity = smooth_sine_offset(t, operator.start_time, operator.frequency, self._amplitude,
                                                  operator.stroke_scales)
        self.position = self._initial + offset


@compiled("void(uint8[:], int64[:], int64, float64, float64, float64[:, :], float64[:, :], float64[:, :], "
          "float64[:, :])")
def ft_samples_into(message, starts, first, rate, saturate_at, wrench, acceleration, wrench_saturated,
                    acceleration_saturated) -> None:
    """Fills the ``heft_ft_samples`` ``message`` (fingerprint and count set; ``starts``, its row of
    ``ft_messages.OFFSETS``) with the JR3 driver's samples ``first`` … ``first`` + n − 1 (n, the rows of
    ``wrench``; sample j at j/``rate`` s): its utime (µs), counter, the measured ``wrench`` negated (the
    sensor's sign: the load on it), ``acceleration``, the flags (bit k: wrench axis k saturated, bit 6 + k:
    acceleration axis k; every wrench axis from ``saturate_at`` s on) and no error."""
    for k in range(wrench.shape[0]):
        tick = first + k
        put_wire_int(message, starts[_UTIME] + _TIME_BYTES * k, _TIME_BYTES, np.int64(np.rint(tick / rate * 1e6)))
        put_wire_int(message, starts[_COUNTER] + _COUNTER_BYTES * k, _COUNTER_BYTES, tick)
        flags = _WRENCH_SATURATED if tick / rate >= saturate_at else 0
        for axis in range(NUM_AXES):
            put_wire_double(message, starts[_WRENCH] + _VECTOR_BYTES * k + 8 * axis, -wrench[k, axis])
            put_wire_double(message, starts[_ACCELERATION] + _VECTOR_BYTES * k + 8 * axis, acceleration[k, axis])
            if wrench_saturated[k, axis] != 0.0:
                flags |= 1 << axis
            if acceleration_saturated[k, axis] != 0.0:
                flags |= 1 << (NUM_AXES + axis)
        put_wire_int(message, starts[_SATURATED] + _FLAG_BYTES * k, _FLAG_BYTES, flags)
        message[starts[_ERROR] + k] = 0


def _command_values(layout: FixedLayout, message_type, payload: bytes, num_joints: int, refused: Rejections,
                    *names: str):
    """The fields ``names`` of a command for ``num_joints`` joints (one value, or a tuple of them), or None
    if ``payload`` is not one (counted in ``refused``: undecodable, or another joint count): unpacked by
    ``layout``, or decoded when of another size."""
    values = layout.unpack(payload)
    if values is not None:
        fields = tuple(values[layout.field(name)] for name in names)
    else:
        try:
            msg = message_type.decode(payload)
        except (ValueError, struct.error):
            refused.add("undecodable")
            return None
        if msg.num_joints != num_joints:
            refused.add("joint_count")
            return None
        fields = tuple(getattr(msg, name) for name in names)
    return fields[0] if len(fields) == 1 else fields


class StandIn:
    """The lab's three drivers publishing on ``bus`` (python ``lcm.LCM``) and obeying the commands
    on ``command_bus`` (default ``bus``); models in the module docstring.

    Readable: ``num_joints`` (the arm's, 6 or 7: the scenario's arm), ``slave_position`` (n, rad, the arm's true
    joints), ``slave_command`` (n, rad, the last valid setpoint; ``slave_initial_q`` before the first),
    ``master_position`` (6, rad, true joints), ``master_torque`` (6, N·m, the torque the haptic driver applies
    now), ``stylus_force_peak`` (N, the largest force a command's torque rendered on the hand,
    ``_observe_stylus_force``), ``arm_steps_after_a_held_one`` (the arm's steps that took two
    or more new commands, as many steps before them having taken none: the setpoint stalled, then
    jumped),
    ``published`` / ``received`` (channel name → messages), ``refused`` (the commands' channel name → reason
    (``message_checks.REASONS``; for the master's also ``UNACTUATED``) → commands refused),
    ``phi_true`` (10, φ about S in S of what the sensor carries now, Eq. 6), ``offsets`` (6, N, N·m: the FT
    offsets in the latest sample, heft's sign), ``wrench_measured`` (6, N, N·m: the latest sample as measured,
    heft's sign, before the delivery faults), ``next_due`` (s, the nominal time of the next message),
    ``truth`` (the ``TruthRecord`` of every FT sample with ``record_truth``, else None).

    ``ft_outlet``, if given, takes the FT messages in place of the LCM channel (``name``, ``count``,
    ``lost(tick, t)``, ``send(tick, payload)``: ``stand_in_netft.NetFtResponder``).

    A "gripper_object" load has a gripper driver too: it closes on the object at ``grasp.grasp_at``
    and opens at ``grasp.release_at`` (``GraspTimes``; by default the scenario's ``load.grasp_at``).
    """

    def __init__(self, scenario: Scenario, bus: lcm.LCM, channels: LcmChannels = LcmChannels(),
                 faults: FaultInjection | None = None, clutch_at: float = 0.0,
                 clutch_release_at: float = math.inf, command_bus: lcm.LCM | None = None,
                 grasp: GraspTimes | None = None, record_truth: bool = False, ft_outlet=None):
        scenario.validate()
        self._faults = faults = faults or FaultInjection()
        faults.validate()
        gripper = scenario.load.kind == "gripper_object"
        if grasp is None:
            grasp = GraspTimes(scenario.load.grasp_at) if gripper else GraspTimes()
        grasp.validate()
        if not gripper and grasp != GraspTimes():
            raise ValueError(f"--grasp-at and --release-at need a 'gripper_object' load (e.g. --scenario grasp); "
                             f"this scenario's load is {scenario.load.kind!r}")
        self._grasp = grasp
        self._command_bus = command_bus = bus if command_bus is None else command_bus
        self._clutch = (clutch_at, clutch_release_at)
        drivers = [channels.master_state, channels.slave_status, channels.ft_sample] + (
            [channels.gripper_state] if gripper else [])
        self._rates = tuple(channel.rate for channel in drivers)
        self._ticks = [1] * len(drivers)
        self._due = [1.0 / rate for rate in self._rates] + [math.inf] * (_GRIPPER + 1 - len(drivers))
        self._outlets = [_Outlet(bus, channel.name, _GRIPPER_STREAM if i == _GRIPPER else i, faults)
                         for i, channel in enumerate(drivers)]
        if ft_outlet is not None:  # the FT samples go out another way (``stand_in_netft``: as a Net F/T)
            self._outlets[_FT] = ft_outlet
        self._delayed = collections.deque()  # (release time (s), newest sample's index, payload) of FT messages
        self._haptic_commands = LcmMailbox(command_bus, channels.master_command.name, keep=64)
        self._slave_commands = LcmMailbox(command_bus, channels.slave_command.name, keep=64)

        # The master's and the slave's commands refused, per reason.
        self._refused = (Rejections(MASTER_COMMAND_REASONS), Rejections())

        # Slave: the setpoint filter and the joint servo on the (4, n) state [q_f; q̇_f; q; q̇], and S's motion.
        slave_period = 1.0 / channels.slave_status.rate
        self._servo = servo_step_matrices(scenario.slave_setpoint_bandwidth, *slave_servo_gains(scenario),
                                          slave_period)
        arm, _ = MakeArmPlant(slave_arm(scenario))
        self.num_joints = n = arm.num_positions()
        self._no_arm_torques = (0.0,) * (3 * n)  # the status's torques (measured, commanded, external): not modelled
        self._slave = np.zeros((SERVO_ROWS, n))
        self._deviation = np.zeros(SERVO_ROWS * n)  # servo_step's working space
        self._slave[0] = self._slave[2] = scenario.slave_initial_q
        self._q, self._qd = self._slave[2], self._slave[3]  # views of the joints' rows
        self._qdd = np.zeros(n)  # the joints' q̈ at their state (rad/s²)
        self.stylus_force_peak = 0.0
        self.arm_steps_after_a_held_one, self._commands_since_step = 0, 0
        # The master state (s) each of the latest master commands names, by the command's utime (its tick's, which
        # that tick's slave command shares); the utime of the slave command in force and the state it was computed
        # from (s; None until its master command is heard).
        self._states_named = {}
        self._arm_command_utime = self._arm_command_state = None
        # The master states published lately: their utimes and (encoder-quantised) joint positions, a ring.
        self._published_utime = np.full(_PUBLISHED_KEEP, -1, dtype=np.int64)
        self._published_position = np.zeros((_PUBLISHED_KEEP, MASTER_JOINTS))
        self._published_count = 0
        self._now = 0.0  # the lab's time at the step under way (s)
        self.slave_command = np.array(scenario.slave_initial_q, dtype=float)
        self._setpoint = self.slave_command.copy()  # the command approached at the speed limits
        self._max_setpoint_step = arm.GetVelocityUpperLimits() * slave_period  # rad per status step
        self._slave_step = 2 * math.pi / scenario.encoder_counts_per_rev  # rad per encoder count
        self._velocity = (EncoderVelocityEstimator(quantize(self._q, self._slave_step), slave_period,
                                                   scenario.slave_velocity_filter)
                          if scenario.slave_velocity_filter > 0 else None)  # else the joints' own q̇
        self._wrist = Wrist(scenario, slave_period, grasp, self._q)
        self._wrist.update(0.0, self._q, self._qd, np.zeros(n))

        ft_period = 1.0 / channels.ft_sample.rate
        per_step = max(1, round(channels.ft_sample.rate / channels.slave_status.rate))  # FT samples per arm step
        self._ft = SixAxisSampler(scenario.ft_sensor, FORCE_TORQUE_STREAM, ft_period, per_step)
        self._accelerometer = SixAxisSampler(scenario.accelerometer, ACCELEROMETER_STREAM, ft_period, per_step)
        self.truth = TruthRecord(channels.ft_sample.rate, self._wrist.phis, channels.slave_status.rate) \
            if record_truth else None
        self.offsets, self.wrench_measured = np.zeros(6), np.zeros(6)
        self._ft_messages = {}  # samples → a heft_ft_samples of that many, rewritten for each message

        self._master = _Master(scenario)
        self._master_step = 2 * math.pi / MASTER_ENCODER_COUNTS_PER_REV
        self._torque_commanded = np.zeros(MASTER_JOINTS)
        self._torque_until = -math.inf  # the driver's watchdog: no torque from this time on (s)
        self.master_torque = np.zeros(MASTER_JOINTS)

        self._command_layouts = {_MASTER: FixedLayout(heft_haptic_command, num_joints=MASTER_JOINTS),
                                 _SLAVE: FixedLayout(lcmt_iiwa_command, num_joints=n, num_torques=0)}
        self._layouts = {_MASTER: FixedLayout(heft_haptic_state, num_joints=MASTER_JOINTS),
                         _SLAVE: FixedLayout(lcmt_iiwa_status, num_joints=n),
                         _GRIPPER: FixedLayout(heft_gripper_state)}

    @property
    def slave_position(self) -> np.ndarray:
        return self._q

    @property
    def master_position(self) -> np.ndarray:
        return self._master.position

    @property
    def phi_true(self) -> np.ndarray:
        return self._wrist.phi

    @property
    def ft_samples_due(self) -> int:
        """The FT samples whose time the lab's clock has reached (published, lost, in a message still
        filling, or after its death); an arm step's samples are taken at its first one's time."""
        return min(self._ticks[_FT] - 1, math.floor((self._now + _DUE_SLACK) * self._rates[_FT]))

    @property
    def published(self) -> dict[str, int]:
        return {outlet.name: outlet.count for outlet in self._outlets}

    @property
    def received(self) -> dict[str, int]:
        return {box.channel: box.count for box in (self._haptic_commands, self._slave_commands)}

    @property
    def refused(self) -> dict[str, dict[str, int]]:
        return {box.channel: rejections.nonzero()
                for box, rejections in zip((self._haptic_commands, self._slave_commands), self._refused)}

    @property
    def next_due(self) -> float:
        due = min(self._due)
        return min(due, self._delayed[0][0]) if self._delayed else due

    def view_row(self) -> dict:
        """What the lab is now, by ``analysis.run_log``'s names, for a live view (``diagrams.live_view``): the
        arm's true joints and its setpoint received (rad, rad/s), the master's joints and the torque its
        driver applies (N·m), the load's true non-contact wrench and the latest sample measured (at S in S,
        heft's sign; no contact here) and φ of what the sensor carries (Eq. 6)."""
        return {"slave_q": self._q, "slave_v": self._qd, "slave_q_commanded": self.slave_command,
                "master_q": self._master.position, "master_v": self._master.velocity,
                "master_torque": self.master_torque, "wrench_noncontact_true": self._wrist.wrench,
                "wrench_measured": self.wrench_measured, "phi_true": self._wrist.phi}

    def step(self, now: float) -> bool:
        """Advances the lab to ``now`` (s since it started; never decreasing): takes the
        pending commands, then steps the models and publishes every message whose nominal
        time is ≤ ``now``, oldest first (catching up when called late). Returns False once
        the lab has died (``faults.die_at_s``). Each channel's handler takes its due sample
        index and time and returns how many samples it took (an FT message holds several)."""
        die_at = self._faults.die_at_s
        self._now = now
        self._take_commands(now)
        due, handlers = self._due, (self._master_tick, self._slave_tick, self._ft_tick, self._gripper_tick)
        end = now + _DUE_SLACK
        delayed, outlet = self._delayed, self._outlets[_FT]
        while True:
            t = min(due)
            # FT messages go out in time order with the rest (a late lab catching up sends them
            # interleaved, not after everything else).
            if delayed and delayed[0][0] <= min(t, end) and delayed[0][0] < die_at:
                _, tick, payload = delayed.popleft()
                outlet.send(tick, payload)
                continue
            if t > end or t >= die_at:
                break
            # Ties go to the slave first (its step sets the kinematics the FT sample reads).
            channel = _SLAVE if due[_SLAVE] == t else due.index(t)
            tick = self._ticks[channel] + handlers[channel](self._ticks[channel], t)
            self._ticks[channel] = tick
            due[channel] = tick / self._rates[channel]
        self.master_torque = self._applied_torque(now)
        return end < die_at

    def _take_commands(self, now: float) -> None:
        """Applies the commands that arrived by ``now`` (s): one of the device's joint count unpacked by its
        layout, any other decoded (and a wrong joint count, garbage or a value not finite refused and counted)."""
        pump(self._command_bus)
        master_refused, slave_refused = self._refused
        for payload in self._slave_commands.take():
            values = _command_values(self._command_layouts[_SLAVE], lcmt_iiwa_command, payload, self.num_joints,
                                     slave_refused, "utime", "joint_position")
            if values is not None and not math.isfinite(sum(values[1])):
                slave_refused.add("non_finite")
            elif values is not None:
                self.slave_command[:] = values[1]
                self._commands_since_step += 1
                self._arm_command_utime, self._arm_command_state = values[0], None
        for payload in self._haptic_commands.take():
            values = _command_values(self._command_layouts[_MASTER], heft_haptic_command, payload, MASTER_JOINTS,
                                     master_refused, "torque", "enable", "master_utime", "utime")
            valid = values is not None
            if valid and not math.isfinite(sum(values[0])):
                master_refused.add("non_finite")
                valid = False
            elif valid and any(torque != 0.0 and not actuated
                               for torque, actuated in zip(values[0], self._master.actuated)):
                master_refused.add(UNACTUATED)
                valid = False
            if values is not None and values[2] > 0:  # 0: the controller had heard no master state
                named = self._states_named
                named[values[3]] = values[2] * 1e-6
                if len(named) > _NAMED_KEEP:
                    del named[next(iter(named))]
            if valid and values[1]:
                limits = self._master.effort_limits
                self._torque_commanded = np.minimum(np.maximum(values[0], -limits), limits)
                self._torque_until = now + HAPTIC_WATCHDOG_S
                self._observe_stylus_force(self._torque_commanded, values[2])
            else:
                self._torque_until = -math.inf

    def _observe_stylus_force(self, torque, master_utime: int) -> None:
        """Raises ``stylus_force_peak`` to the force ``torque`` renders at the master position this
        driver published at ``master_utime`` (the state the command says it was computed at), or at
        the present position if it published none then (another publisher's state, or none)."""
        if not torque.any():
            return
        count = self._published_count
        slot = ring_slot(self._published_utime, (count - 1) % _PUBLISHED_KEEP, min(count, _PUBLISHED_KEEP),
                         master_utime)
        position = self._published_position[slot] if slot >= 0 else self._master.position
        self.stylus_force_peak = max(self.stylus_force_peak, self._master.stylus_force(torque, position))

    def _applied_torque(self, t: float) -> np.ndarray:
        """The torque (N·m) the haptic driver applies at ``t`` (s)."""
        return self._torque_commanded if t < self._torque_until else _NO_TORQUE

    def _slave_tick(self, tick: int, t: float) -> int:
        if self._commands_since_step > 1:
            self.arm_steps_after_a_held_one += 1
        if self.truth is not None and self._arm_command_utime is not None:
            if self._arm_command_state is None:
                self._arm_command_state = self._states_named.get(self._arm_command_utime)
            if self._arm_command_state is not None:
                self.truth.arm_step(t, t - self._arm_command_state)
        self._commands_since_step = 0
        u, q, qd, qdd = self._setpoint, self._q, self._qd, self._qdd
        servo_step(*self._servo, self._max_setpoint_step, self.slave_command, u, self._slave, self._deviation, qdd)
        self._wrist.update(t, q, qd, qdd)
        measured = quantize(q, self._slave_step)
        velocity = qd if self._velocity is None else self._velocity.update(measured)
        outlet = self._outlets[_SLAVE]
        if not outlet.lost(tick, t):
            outlet.send(tick, self._layouts[_SLAVE].pack(round(t * 1e6), self.num_joints, *measured.tolist(),
                                                         *velocity.tolist(), *self.slave_command.tolist(), *u.tolist(),
                                                         *self._no_arm_torques))
        return 1

    def _master_tick(self, tick: int, t: float) -> int:
        master = self._master
        master.update(t)
        outlet = self._outlets[_MASTER]
        if outlet.lost(tick, t):
            return 1
        measured = quantize(master.position, self._master_step)
        utime = round(t * 1e6)
        ring = self._published_count % _PUBLISHED_KEEP
        self._published_utime[ring] = utime
        self._published_position[ring] = measured
        self._published_count += 1
        position = measured.tolist()
        buttons = CLUTCH_BUTTON if self._clutch[0] <= t < self._clutch[1] else 0
        outlet.send(tick, self._layouts[_MASTER].pack(utime, MASTER_JOINTS, *position,
                                                      *master.velocity.tolist(),
                                                      *self._applied_torque(t).tolist(), buttons, False))
        return 1

    def _ft_tick(self, first: int, t: float) -> int:
        """Samples the wrist sensor from sample ``first`` (at ``t``, s) until the next slave step, all
        on the kinematics held since the last one, and queues them as one message, published when
        its newest sample is due (``added_delay_s`` later with that fault); returns how many."""
        rate = self._rates[_FT]
        last = max(first, math.ceil(self._due[_SLAVE] * rate - 1e-6) - 1)
        wrist, count = self._wrist, last - first + 1
        wrench, offsets, wrench_saturated = self._ft.sample(first, count, wrist.wrench)
        acceleration, _, acceleration_saturated = self._accelerometer.sample(first, count, wrist.reading)
        if self.truth is not None:
            self.truth.add(first, count, wrist, offsets)
        self.offsets = offsets[-1]
        self.wrench_measured[:] = wrench[-1]
        faults, outlet, newest = self._faults, self._outlets[_FT], last / rate
        if outlet.lost(last, newest):
            return count
        message, starts = self._ft_message(count), OFFSETS[count]
        ft_samples_into(message, starts, first, rate, faults.saturate_at_s, wrench, acceleration, wrench_saturated,
                        acceleration_saturated)
        if faults.nan_rate > 0.0:
            for k, tick in enumerate(range(first, last + 1)):
                if _uniform(faults.seed, _NAN_STREAM, tick) < faults.nan_rate:
                    for axis in range(NUM_AXES):
                        put_wire_double(message, starts[_WRENCH] + _VECTOR_BYTES * k + 8 * axis, math.nan)
        self._delayed.append((newest + faults.added_delay_s, last, message.tobytes()))
        return count

    def _ft_message(self, count: int) -> np.ndarray:
        """The bytes (writable) of a ``heft_ft_samples`` of ``count`` samples, its fingerprint and count set."""
        message = self._ft_messages.get(count)
        if message is None:
            message = self._ft_messages[count] = np.frombuffer(bytearray(pack_samples(
                [0] * count, [0] * count, [0.0] * 6 * count, [0.0] * 6 * count, [0] * count, [False] * count)),
                dtype=np.uint8)
        return message

    def _gripper_tick(self, tick: int, t: float) -> int:
        outlet, grasp = self._outlets[_GRIPPER], self._grasp
        if not outlet.lost(tick, t):
            outlet.send(tick, self._layouts[_GRIPPER].pack(round(t * 1e6), grasp.state(t), grasp.width(t), False))
        return 1


def run_stand_in(scenario: Scenario, channels: LcmChannels, duration: float,
                 faults: FaultInjection | None = None, clutch_at: float = 0.0, clutch_release_at: float = math.inf,
                 clock=time.perf_counter, sleep=time.sleep, ready=None, stop=None, grasp: GraspTimes | None = None,
                 truth_path=None, ft_outlet=None, view=None) -> dict:
    """Runs ``StandIn`` on ``channels``' two URLs (``open_buses``) in real time on ``clock`` (s)
    for ``duration`` s or until it dies, waiting between due messages (a late lab catches up
    ``_MAX_STEP`` at a time): with the default
    ``sleep`` the wait is a ``select`` on the command bus that also ends when a command
    arrives; another ``sleep(seconds)`` (e.g. with a fake ``clock``) is called instead.

    Returns {"duration_s": wall time run (s; the lab's own time may lag it), "died", "slave_joints" (the arm's),
    "published" / "received" (channel name → messages), "refused" (``StandIn.refused``), "published_hz" /
    "received_hz"
    (channel name → messages per wall second),
    "max_lateness_ms": the latest a message was published after its nominal time,
    "lateness_ms_by_second": the same for the messages due in each second of the lab's clock, "cpu_s":
    this process's CPU time over the run, "stylus_force_peak", "arm_steps_after_a_held_one": ``StandIn``'s}.
    ``ready(epoch)``, if given, is called once the lab is built, as it starts publishing, with
    the wall-clock time (s since the Unix epoch) of its clock's zero, the time its ``utime``
    stamps count from; ``stop()``, if given, ends the run early once it returns True. With a
    ``truth_path``, the ``TruthRecord`` of the run is written there at the end (a .npz). ``ft_outlet``:
    ``StandIn``'s. ``view``: a ``diagrams.live_view.LiveView`` (not yet open; closed here) shown the lab
    (``StandIn.view_row``) after each step at its rate, timed from the clock's zero.
    """
    bus, command_bus = open_buses(channels)
    lab = StandIn(scenario, bus, channels, faults, clutch_at, clutch_release_at, command_bus, grasp,
                  record_truth=truth_path is not None, ft_outlet=ft_outlet)
    if sleep is time.sleep:
        fd = command_bus.fileno()

        def wait(seconds):
            select.select([fd], [], [], seconds)
    else:
        wait = sleep
    lateness, alive = 0.0, True
    by_second = [0.0] * (math.ceil(duration) if math.isfinite(duration) else 0)
    with contextlib.nullcontext() if view is None else view:
        if view is not None:
            widths = {key: np.size(value) for key, value in lab.view_row().items()}
            view.open(widths)
        cpu_start, start, epoch = time.process_time(), clock(), time.time()
        if view is not None:  # the same keys: only the messages' time origin moves, to the clock's zero
            view.open(widths, t0_ns=round(epoch * 1e9))
        if ready is not None:
            ready(epoch)
        now = wall = 0.0
        while True:
            late, second = wall - lab.next_due, int(lab.next_due)
            lateness = max(lateness, late)
            if second < len(by_second):
                by_second[second] = max(by_second[second], late)
            alive = lab.step(now)
            if view is not None and view.due(now):
                view.publish(now, lab.view_row())
            if not alive or now >= duration - _DUE_SLACK or (stop is not None and stop()):
                break
            pause = min(lab.next_due, duration) - (clock() - start)
            if pause > _DUE_SLACK:
                wait(pause)
            wall = clock() - start
            now = min(wall, now + _MAX_STEP)
        elapsed = max(clock() - start, 1e-9)
    published, received = lab.published, lab.received
    summary = {"duration_s": elapsed, "died": not alive, "slave_joints": lab.num_joints, "published": published,
               "received": received,
               "refused": lab.refused,
               "published_hz": {name: count / elapsed for name, count in published.items()},
               "received_hz": {name: count / elapsed for name, count in received.items()},
               "max_lateness_ms": 1e3 * lateness, "lateness_ms_by_second": [1e3 * late for late in by_second],
               "cpu_s": time.process_time() - cpu_start,
               "stylus_force_peak": lab.stylus_force_peak,
               "arm_steps_after_a_held_one": lab.arm_steps_after_a_held_one}
    if truth_path is not None:
        lab.truth.save(truth_path, lab.ft_samples_due)
    return summary
