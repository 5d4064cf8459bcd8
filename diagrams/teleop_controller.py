"""The controller Diagram as the lab's real-time loop steps it: ``TeleopController``.

``TeleopController`` builds ``MakeTeleopController`` (Fig. 4, one block per LeafSystem) and steps it as its
``TickProgram``: each tick the station's readings are written on the Diagram's inputs, every block's
kernel runs in the Diagram's order, and the commands are read off its outputs (``tests/test_tick_program.py``
holds this equal to Drake's stepping of the same Diagram). Load commands and the gripper's events reach the
Diagram through its inputs (``rezero``, ``tracking``, ``estimate``, ``holding``): this class checks a
command (a physical estimate, a grasp that the estimator can learn) and sets the input; the blocks do the
rest. The properties read the Diagram's outputs and the blocks' state in place.

A start (the first healthy tick, each recovery) restarts the blocks from the slave's measured position;
what the controller learned of the load (offsets, φ̂, the grasp) is kept. Without a station the clutch is
disengaged at a start; with one it is as the station reads it, and a clutch held at a start anchors the
stylus on the slave's measured pose (motion scaling's initialization), so the slave does not move.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence

import numpy as np
from pydrake.systems.framework import DiagramBuilder

from heft.diagrams.arm_params import BUNDLED_ARMS
from heft.diagrams.load_estimate import LoadEstimate
from heft.diagrams.master_params import DEFAULT_MASTER
from heft.diagrams.plants import Robot, arm_name
from heft.diagrams.scenario import ControllerSpec
from heft.diagrams.teleop import ConnectControllerToStation, FeedbackBlock, MakeTeleopController
from heft.hardware_interface.hardware_station import HardwareStation
from heft.hardware_interface.hardware_station_system import HardwareStationSystem
from heft.systems.accelerometer_reading import AccelerometerConvention, kernel_convention, motion_from_reading
from heft.systems.load_dynamics import checked_load, regressor
from heft.systems.controller.load_model import ESTIMATES_SEEN, GRASPS, HOLDING, PHI_GRIPPER, RESTARTS, SPLIT
from heft.systems.controller.offset_tracking import ESTIMATE_SIZE, OFFSETS, REQUESTS, STATUS, WINDOW_TIME
from heft.systems.station_ports import CLUTCH, INPUT_AGE, STATION_OUTPUTS_READ
from heft.systems.tick_program import TickProgram


@dataclasses.dataclass
class OnlineEstimation:
    """What the online estimator's blocks report, read in place (``TeleopController.estimator``)."""
    program: TickProgram
    params: object

    @property
    def learning_window(self) -> float:
        """s after a new load during which contact does not close the gate."""
        return self.params.learning_window

    @property
    def max_input_age(self) -> float:
        """The oldest (s) the readings of a tick learned from may be."""
        return self.params.max_input_age

    @property
    def since_reset(self) -> float:
        """s since the last new load (or the start), as of the last tick; 0 while one asked for is still on its
        way through the blocks (a grasp or a new estimate not yet taken up by the split, or by the gate)."""
        program = self.program
        clocks, split = program.block_state("estimator_gate", "clocks"), program.block_state("grasp", "state")
        asked = split[GRASPS] + split[RESTARTS] + program.input("estimator_reset")[0]
        if (program.input("holding")[0] > 0.5) != (split[HOLDING] > 0.5) or asked > clocks[1] or \
                program.input("estimate")[0] > split[ESTIMATES_SEEN]:
            return 0.0
        return float(clocks[0])

    @property
    def num_samples(self) -> int:
        """Samples taken since the last new load."""
        return int(self.program.output("estimator.num_samples")[0])

    @property
    def num_skipped(self) -> int:
        """Ticks the gate opened whose sample held a NaN or inf."""
        return int(self.program.block_state("phi_hat", "counters")[0])

    @property
    def num_stale(self) -> int:
        """Ticks since the last new load whose readings were older than ``max_input_age``."""
        return int(self.program.block_state("estimator_gate", "stale_ticks")[0])


class TeleopController:
    """``MakeTeleopController(spec, load, robot, period, …, feedback_blocks)`` stepped tick by tick (module
    docstring); with a ``station`` (a function making the lab's ``HardwareStation``), the two in one Diagram
    (``HardwareStationSystem``, connected as the simulation connects its station) stepped by ``tick(now)``.

    ``robot``: the slave arm (``plants.Robot``), ``slave_initial_q`` its start posture (rad; default a bundled
    arm's own, ``BundledArm.start``), which the inverse kinematics of a 7-joint arm draws its null space to.
    ``master``: the bundled haptic master (``BUNDLED_MASTERS``) whose kinematics and actuated joints the controller
    computes with (``MakeTeleopController``'s).
    ``start(slave_position)`` begins (again); ``step(dt, …)`` takes one tick's readings. After a step:
    ``torque`` τ_M (6, N·m) and ``position`` q̄_S (n, rad: the arm's joints) to send, the state the update left
    (``applied_wrench``, ``energy``, ``damping``, ``scales``, ``offsets``, ``phi``, ``pose_RS_desired``) and
    what the tick computed from its readings (``wrench_feedback``, ``wrench_contact``, ``wrench_noncontact``,
    ``master_wrench``: at S in S, on the hand at E in B). ``compile`` as ``TickProgram``'s."""

    def __init__(self, spec: ControllerSpec, load: LoadEstimate, robot: Robot, period: float, *,
                 accelerometer: AccelerometerConvention, slave_initial_q=None,
                 feedback_blocks: Sequence[FeedbackBlock] = (), station: Callable[[], HardwareStation] | None = None,
                 compile: bool = True, master: str = DEFAULT_MASTER):
        phi, offsets = checked_load(load.phi, load.offsets)
        self.period = period
        if slave_initial_q is None:
            if not isinstance(robot, str):
                raise ValueError(f"the controller of the arm {arm_name(robot)} needs its start posture "
                                 "(slave_initial_q, one angle per joint, rad)")
            slave_initial_q = BUNDLED_ARMS[robot].start
        controller = MakeTeleopController(spec, LoadEstimate(phi, offsets), robot, period, slave_initial_q,
                                          accelerometer=accelerometer, feedback_blocks=feedback_blocks, master=master)
        self.num_joints = len(slave_initial_q)
        """The arm's joints."""
        # The station's subscriptions open after the controller's models are built (about a second), when the
        # loop is about to pump them.
        self.station = None if station is None else HardwareStationSystem(station(), period)
        self.diagram = controller if station is None else _with_station(controller, self.station)
        self.program = program = TickProgram(self.diagram, compile=compile)
        online = spec.estimator.mode == "online"
        self.estimator = OnlineEstimation(program, spec.estimator) if online else None
        if station is None:
            self._readings = [program.input(name) for name in STATION_OUTPUTS_READ]
            self._clutch = program.input(CLUTCH)
            self._input_age = program.input(INPUT_AGE) if online else None
        self._rezero = program.input("rezero")
        self._tracking, self._estimate = program.input("tracking"), program.input("estimate")
        self._holding = program.input("holding") if online else None
        self._offset_state = program.block_state("offsets_hat", "state")
        self._estimates_seen = program.block_state("offsets_hat", "estimates_seen")
        self._grasp = program.block_state("grasp", "state") if online else None
        self._accelerometer = accelerometer
        self._conventions = [program.block("force_scaling").settings]
        if online:
            self._conventions.append(program.block("accelerometer_to_motion").convention)
        for name in ("torque", "position", "applied_wrench", "energy", "damping", "scales", "offsets", "phi",
                     "pose_RS_desired", "wrench_feedback", "wrench_contact", "wrench_noncontact", "master_wrench",
                     "gravity_S", "ik_status", "force_fault", "pose_RS", "pose_BE"):
            setattr(self, f"_{name}", program.output(OUTPUTS[name]))
        self._hold = program.input("hold")
        self.started = self._was_healthy = False

    # --- ticking ------------------------------------------------------------------------

    def start(self, slave_position) -> None:
        """Begins (again) from the slave measured at ``slave_position`` (n, rad; with a station, its reading), the
        clutch disengaged (with a station, as it reads it): the blocks restart, what was learned of the load is kept
        (``TickProgram.restart``)."""
        slave_position = np.asarray(slave_position, dtype=float)
        if slave_position.shape != (self.num_joints,) or not np.isfinite(slave_position).all():
            raise ValueError(f"the slave's start position must be {self.num_joints} finite joint angles; "
                             f"got {slave_position}")
        program = self.program
        program.restart()
        if self.station is None:
            program.input("slave.position_measured")[:] = slave_position
            self._clutch[0] = 0.0
        program.initialize()
        self.started = True

    def step(self, dt: float, master_position, master_velocity, slave_position, slave_velocity, wrench,
             acceleration, clutch: bool, input_age: float = 0.0) -> None:
        """One tick on the station's readings: q_M, q̇_M (rad, rad/s), q_S, q̇_S (rad, rad/s), the wrench
        [f; τ] the sensor exerts on the load and the accelerometer's reading, the clutch engaged, the oldest
        reading ``input_age`` s old. The blocks step by the controller's period; ``dt`` (s, measured) is not
        theirs to take."""
        if not self.started:
            raise RuntimeError("TeleopController.step before start(): start it from the measured slave position "
                               "once the station is healthy")
        if self.station is not None:
            raise RuntimeError("a TeleopController with its station reads it: tick(now), not step(…)")
        for array, value in zip(self._readings, (master_position, master_velocity, slave_position, slave_velocity,
                                                 wrench, acceleration)):
            array[:] = value
        self._clutch[0] = 1.0 if clutch else 0.0
        if self._input_age is not None:
            self._input_age[0] = input_age
        self.program.tick()

    def tick(self, now: float, dt: float) -> bool:
        """One tick of the controller with its hardware station at ``now`` (s, the loop's monotonic clock), ``dt``
        s after the last (measured; 0 at the first): the station receives; while it is healthy the controller
        steps (started afresh, from the slave's measured position, at the first healthy tick and each recovery),
        the passivity observer holding this tick's torque for ``dt``; the station sends (zero torque and the slave
        held while it is not healthy). Returns whether the controller stepped."""
        station, program = self.station, self.program
        self._hold[0] = dt
        station.now = now
        program.receive()
        healthy = station.station.healthy
        if healthy:
            if not self._was_healthy:
                self.start(station.station.slave_position)
            program.step()
        self._was_healthy = healthy
        program.publish()
        return healthy

    # --- what a tick left --------------------------------------------------------------

    torque = property(lambda self: self._torque, doc="τ_M (6, N·m) to send")
    applied_wrench = property(lambda self: self._applied_wrench,
                              doc="the wrench the torque renders on the hand (6, at E in B)")
    energy = property(lambda self: self._energy, doc="the passivity observer's [E_t, E_r] (J)")
    damping = property(lambda self: self._damping, doc="the passivity controller's [α_t, α_r]")
    scales = property(lambda self: self._scales, doc="σ, γ, η in effect")
    offsets = property(lambda self: self._offsets, doc="the sensor's offsets in use (6; N, N·m)")
    phi = property(lambda self: self._phi, doc="φ̂ in use (10; Eq. 6)")
    pose_RS_desired = property(lambda self: self._pose_RS_desired, doc="X_RS* (7)")
    wrench_feedback = property(lambda self: self._wrench_feedback, doc="f′ (6, on the load at S in S)")
    wrench_contact = property(lambda self: self._wrench_contact, doc="c (6, Eq. 13)")
    wrench_noncontact = property(lambda self: self._wrench_noncontact, doc="V·φ̂ (6, Eq. 12)")
    master_wrench = property(lambda self: self._master_wrench,
                             doc="the wrench mapped onto the hand, the passivity controller's input (6, at E in B)")
    gravity_S = property(lambda self: self._gravity_S, doc="g in S (3, m/s²) at the slave's last reading")
    pose_RS = property(lambda self: self._pose_RS, doc="X_RS (7) at the slave's last reading")
    pose_BE = property(lambda self: self._pose_BE, doc="X_BE (7) at the master's last reading")
    ik_status = property(lambda self: self._ik_status, doc="[this tick's pose reachable (1/0), ticks rejected]")

    @property
    def position(self) -> np.ndarray | None:
        """q̄_S (n, rad) to send; None before ``start``."""
        return self._position if self.started else None

    @property
    def hold(self) -> float:
        """How long (s) the last tick's torque is held (the passivity observer's): the period, or with a station
        the tick's measured ``dt``."""
        return float(self._hold[0])

    @property
    def reachable(self) -> bool:
        return bool(self._ik_status[0] > 0.5)

    @property
    def force_fault(self) -> bool:
        return bool(self._force_fault[0] > 0.5)

    # --- the load model at run time ------------------------------------------------------

    @property
    def rezero_status(self) -> int:
        """The re-zero status code (``offset_tracking.STATUS_TEXT``)."""
        return int(self._offset_state[STATUS])

    @property
    def rezero_requests_seen(self) -> int:
        return int(self._offset_state[REQUESTS])

    @property
    def rezero_elapsed(self) -> float:
        """How long (s) the re-zero window under way has averaged."""
        return float(self._offset_state[WINDOW_TIME])

    @property
    def tracking(self) -> bool:
        """Offset tracking on, as last set (``set_tracking``; the next tick takes it)."""
        return bool(self._tracking[0] > 0.5)

    def request_rezero(self) -> None:
        """A re-zero from the next tick (refused there if the slave moves or touches)."""
        self._rezero[0] += 1.0

    def set_tracking(self, on: bool) -> None:
        self._tracking[0] = 1.0 if on else 0.0

    def set_load(self, phi, offsets) -> None:
        """A new tool from the next tick: φ̂ (10) and offsets (6) (``checked_load``; a ValueError changes
        nothing); online, the estimator starts from it as from a new load."""
        phi, offsets = checked_load(phi, offsets)
        estimate = self._estimate
        estimate[0] += 1.0
        estimate[1:11], estimate[11:ESTIMATE_SIZE] = phi, offsets

    @property
    def estimates_requested(self) -> int:
        """New estimates given to ``set_load`` so far."""
        return int(self._estimate[0])

    @property
    def estimates_taken(self) -> int:
        """New estimates a tick has taken up so far (in use from then on)."""
        return int(self._estimates_seen[0])

    @property
    def accelerometer(self) -> AccelerometerConvention:
        """The accelerometer's convention in use, its bias as last measured (``set_accelerometer_bias``)."""
        return self._accelerometer

    def set_accelerometer_bias(self, bias, reading, gravity_S) -> None:
        """The accelerometer's biases (6: the linear channels' in its own axes and unit, the angular channels'
        in rad/s²; ``bias_at_rest``) from the next tick on, in every block that reads the accelerometer. The
        offsets measured at rest with the old biases, over readings averaging ``reading`` (6) under ``gravity_S``
        (3, m/s² in S), hold the load's wrench of those biases: they give it back, o += (V_old − V_new)·φ̂."""
        new = dataclasses.replace(self._accelerometer, bias=tuple(float(x) for x in bias[:3]),
                                  angular_bias=tuple(float(x) for x in bias[3:]))
        gravity_S, at_rest = np.asarray(gravity_S, dtype=float), np.zeros(3)
        offsets = self._offset_state[OFFSETS]
        for convention, sign in ((self._accelerometer, 1.0), (new, -1.0)):
            motion = motion_from_reading(np.empty(6), reading, gravity_S, at_rest, convention)
            offsets += sign * (regressor(motion[:3], motion[3:], at_rest, gravity_S) @ self._phi)
        new_bias = kernel_convention(new)[4]
        for record in self._conventions:
            record["bias"] = new_bias
        self._accelerometer = new

    # --- the grasp (Eq. 14) --------------------------------------------------------------

    @property
    def holding(self) -> bool:
        """An object is held (since ``grasp``, until ``release``)."""
        return self._grasp is not None and bool(self._grasp[HOLDING] > 0.5)

    @property
    def grasps(self) -> int:
        """Grasps the split has taken up so far."""
        return 0 if self._grasp is None else int(self._grasp[GRASPS])

    @property
    def phi_gripper(self) -> np.ndarray | None:
        """φ_gr of the Eq. 14 split in use (10), or None (the load as one body)."""
        if self._grasp is None or not self._grasp[SPLIT] > 0.5:
            return None
        return self._grasp[PHI_GRIPPER]

    def grasp(self) -> None:
        """The gripper closed on an object, from the next tick: φ̂ in use is kept as the gripper's φ_gr and
        the estimator learns the whole load (``GraspSplit``). A ValueError changes nothing: with the estimate
        fixed, or while already holding."""
        if self._holding is None:
            raise ValueError("a grasp needs the load estimator online to learn the object; run the controller with "
                             "--set '{controller: {estimator: {mode: online}}}'")
        if self._holding[0] > 0.5:
            raise ValueError("the gripper already holds an object; release it first")
        self._holding[0] = 1.0

    def release(self) -> None:
        """The gripper opened, from the next tick: φ̂ returns to the gripper's φ_gr. A ValueError (nothing held)
        changes nothing."""
        if self._holding is None or not self._holding[0] > 0.5:
            raise ValueError("the gripper holds nothing to release")
        self._holding[0] = 0.0


OUTPUTS = {"torque": "master.torque_commanded", "position": "slave.position_commanded",
           "applied_wrench": "log.applied_wrench", "energy": "log.passivity_energy",
           "damping": "log.passivity_damping", "scales": "log.scales", "offsets": "log.offsets", "phi": "log.phi_hat",
           "pose_RS_desired": "log.pose_RS_desired", "wrench_feedback": "log.wrench_feedback",
           "wrench_contact": "log.wrench_contact", "wrench_noncontact": "log.wrench_noncontact",
           "master_wrench": "log.master_wrench", "gravity_S": "slave.gravity_S", "pose_RS": "slave.pose_RS",
           "pose_BE": "master.pose_BE", "ik_status": "log.ik_status", "force_fault": "log.force_fault"}
"""``TeleopController``'s views by name: the Diagram output each reads."""


def _with_station(controller, station: HardwareStationSystem):
    """The controller Diagram and the hardware ``station`` in one Diagram, connected as the simulation connects
    its station (``ConnectControllerToStation``); the controller's other inputs (load commands) and every output
    exported under their names, and the station's health."""
    builder = DiagramBuilder()
    builder.AddNamedSystem("station", station)
    builder.AddNamedSystem("controller", controller)
    ConnectControllerToStation(builder, controller, station)
    connected = {*STATION_OUTPUTS_READ, CLUTCH, INPUT_AGE}
    for i in range(controller.num_input_ports()):
        name = controller.get_input_port(i).get_name()
        if name not in connected:
            builder.ExportInput(controller.get_input_port(i), name)
    for i in range(controller.num_output_ports()):
        builder.ExportOutput(controller.get_output_port(i), controller.get_output_port(i).get_name())
    builder.ExportOutput(station.GetOutputPort("healthy"), "station.healthy")
    diagram = builder.Build()
    diagram.set_name("teleop_on_hardware")
    return diagram
