"""The per-block controller Diagram on the lab's hardware: ``heft teleop --hardware --controller diagram``.

``DiagramTeleopController`` steps ``MakeTeleopController`` (Fig. 4, one LeafSystem per block) as the
real-time loop steps the fused ``RealtimeTeleopController``, behind the part of its interface that
``HardwareTeleop`` uses: each tick the station's readings are fixed on the Diagram's inputs, its periodic
discrete update (every block's, at the one controller period) is applied, and the commands are read
off its outputs. It is the lab's reference path, the blocks the simulation runs; the fused step stays
the default. What it does not do, and says when asked:

- it takes no load commands (re-zero, offset tracking, a new estimate, a grasp or release: the fused
  controller's ``heft load`` actions and the gripper driver's events are refused with that reason);
- its load estimate is fixed (``controller.estimator.mode: online`` is refused);
- its blocks integrate over their declared period, not the tick's measured duration, and its slave
  command is the one the IK computed at the tick before (``tests/test_realtime_controller.py``).
"""

from __future__ import annotations

import numpy as np

from heft.diagrams.load_estimate import LoadEstimate
from heft.diagrams.teleop import STATION_OUTPUTS_READ, MakeTeleopController
from heft.systems.accelerometer_reading import AccelerometerConvention
from heft.systems.slave_kinematics import NUM_JOINTS

NO_LOAD_COMMANDS = ("refused: the per-block Diagram controller (--controller diagram) takes no load commands; "
                    "re-zero, offset tracking, new estimates and grasps need the fused controller (the default)")
"""What a load command or a gripper's event is answered with while the Diagram controls."""


_TICK_OUTPUTS: list[str] = []
"""Outputs that feed through from the readings: what the tick computed, read before its update."""


def _state_output(port: str, doc: str) -> property:
    """The Diagram's output ``port``, its state after the last ``start`` or ``step`` (read when asked)."""
    return property(lambda self: self._state(port), doc=doc)


def _tick_output(port: str, doc: str) -> property:
    """The Diagram's output ``port`` as the last tick computed it from its readings (before its update)."""
    _TICK_OUTPUTS.append(port)
    return property(lambda self: self._tick_values[port], doc=doc)


class DiagramTeleopController:
    """``MakeTeleopController(spec, load, robot, period, …)`` stepped tick by tick (module docstring).

    ``start(slave_position)`` begins (again) as the fused controller does: from the slave's measured
    position with the clutch disengaged, the blocks' state fresh but the offsets tracked so far.
    ``step(dt, …)`` takes one tick's readings; the properties below are then the tick's, as the fused
    controller's are: the state its update left (the commands, the passivity controller's, the offsets,
    φ̂) and the wrenches it computed from the readings on the way."""

    estimator = None
    holding = False
    rezero_requests_seen = 0

    torque = _state_output("master.torque_commanded", "τ_M (6, N·m) to send")
    position = _state_output("slave.position_commanded", "q̄_S (6, rad) to send")
    applied_wrench = _state_output("log.applied_wrench", "the wrench the torque renders on the hand (6, at E in B)")
    energy = _state_output("log.passivity_energy", "the passivity observer's [E_t, E_r] (J)")
    damping = _state_output("log.passivity_damping", "the passivity controller's [α_t, α_r]")
    scales = _state_output("log.scales", "σ, γ, η in effect")
    offsets = _state_output("log.offsets", "the sensor's offsets in use (6; N, N·m)")
    phi = _state_output("log.phi_hat", "φ̂ (10)")
    master_wrench = _tick_output("log.master_wrench", "the wrench mapped onto the hand, the PC's input (6, at E in B)")
    wrench_feedback = _tick_output("log.wrench_feedback", "f′ (6, on the load at S in S)")
    wrench_contact = _tick_output("log.wrench_contact", "the contact wrench (6, on the load at S in S)")
    wrench_noncontact = _tick_output("log.wrench_noncontact", "the non-contact wrench (6, on the load at S in S)")

    def __init__(self, spec, load: LoadEstimate, robot: str, period: float, *,
                 accelerometer: AccelerometerConvention):
        if spec.estimator.mode != "fixed":
            raise ValueError("the per-block Diagram controller (--controller diagram) keeps its load estimate "
                             f"fixed; controller.estimator.mode is {spec.estimator.mode!r}: set it to 'fixed', or "
                             "run the fused controller (the default) to learn the load online")
        self.tracking = spec.offsets.tracking
        self.phi_gripper = None if spec.force.phi_gripper is None else np.array(spec.force.phi_gripper, dtype=float)
        self._diagram = diagram = MakeTeleopController(spec, load, robot, period, np.zeros(NUM_JOINTS),
                                                       accelerometer=accelerometer)
        self._offsets_block = diagram.GetSubsystemByName("offsets_hat")
        # One context, its inputs fixed once (``STATION_OUTPUTS_READ``, then the clutch) and set each tick.
        self._context = context = diagram.CreateDefaultContext()
        self._fixed = [diagram.GetInputPort(name).FixValue(context, np.zeros(diagram.GetInputPort(name).size()))
                       for name in (*STATION_OUTPUTS_READ, "clutch")]
        self._tick_ports = [diagram.GetOutputPort(name) for name in _TICK_OUTPUTS]
        self._tick_values = {port.get_name(): np.zeros(port.size()) for port in self._tick_ports}
        self.started = False

    @property
    def rezero_status(self) -> int:
        """The offset tracker's re-zero status (``offset_tracking``): none is ever requested here."""
        return int(self._state("log.rezero_status")[0])

    def _state(self, port: str) -> np.ndarray:
        return self._diagram.GetOutputPort(port).Eval(self._context)

    def start(self, slave_position) -> None:
        """Begins from the slave measured at ``slave_position`` (6, rad), the clutch disengaged."""
        slave_position = np.asarray(slave_position, dtype=float)
        if slave_position.shape != (NUM_JOINTS,) or not np.isfinite(slave_position).all():
            raise ValueError(f"the slave's start position must be {NUM_JOINTS} finite joint angles; "
                             f"got {slave_position}")
        diagram, context, block = self._diagram, self._context, self._offsets_block
        offsets = block.GetMyContextFromRoot(context).get_discrete_state().Clone()  # carried over a restart
        diagram.SetDefaultContext(context)
        if self.started:
            block.GetMyMutableContextFromRoot(context).SetDiscreteState(offsets)
        for fixed in self._fixed:
            fixed.GetMutableData().get_mutable_value().SetZero()
        self._set(STATION_OUTPUTS_READ.index("slave.position_measured"), slave_position)
        diagram.ExecuteInitializationEvents(context)
        self.started = True

    def step(self, dt: float, master_position, master_velocity, slave_position, slave_velocity, wrench, reading,
             clutch: bool, oldest_age: float = 0.0) -> None:
        """One tick on the station's readings (``dt`` and ``oldest_age`` as the fused step takes them, unused:
        the Diagram's blocks step by their period and its load estimate is fixed)."""
        if not self.started:
            raise RuntimeError("start the controller (from the slave's measured position) before stepping it")
        for i, value in enumerate((master_position, master_velocity, slave_position, slave_velocity, wrench,
                                   reading, (1.0 if clutch else 0.0,))):
            self._set(i, value)
        context = self._context
        update = self._diagram.EvalUniquePeriodicDiscreteUpdate(context)  # computes the tick's wrenches too
        for port in self._tick_ports:
            self._tick_values[port.get_name()][:] = port.Eval(context)
        context.SetDiscreteState(update)

    def _set(self, i: int, value) -> None:
        # Drake tells the blocks of a new value when its mutable data is asked for: once per change.
        self._fixed[i].GetMutableData().get_mutable_value().SetFromVector(value)
