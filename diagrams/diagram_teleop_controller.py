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


_READ: list[str] = ["log.rezero_status"]
"""The Diagram's outputs read after each start and step: every ``_output``'s, and the re-zero status."""


def _output(port: str, doc: str) -> property:
    """The value of the Diagram's output ``port`` after the last ``start`` or ``step``."""
    _READ.append(port)
    return property(lambda self: self._values[port], doc=doc)


class DiagramTeleopController:
    """``MakeTeleopController(spec, load, robot, period, …)`` stepped tick by tick (module docstring).

    ``start(slave_position)`` begins (again) as the fused controller does: from the slave's measured
    position with the clutch disengaged, the blocks' state fresh but the offsets tracked so far.
    ``step(dt, …)`` takes one tick's readings; then the properties below are the Diagram's outputs
    after the tick's update."""

    estimator = None
    phi_gripper = None
    holding = False
    rezero_requests_seen = 0

    torque = _output("master.torque_commanded", "τ_M (6, N·m) to send")
    position = _output("slave.position_commanded", "q̄_S (6, rad) to send")
    master_wrench = _output("log.master_wrench", "the wrench mapped onto the hand, before the PC (6, at E in B)")
    applied_wrench = _output("log.applied_wrench", "the wrench the torque renders on the hand (6, at E in B)")
    energy = _output("log.passivity_energy", "the passivity observer's [E_t, E_r] (J)")
    damping = _output("log.passivity_damping", "the passivity controller's [α_t, α_r]")
    wrench_feedback = _output("log.wrench_feedback", "f′ (6, on the load at S in S)")
    wrench_contact = _output("log.wrench_contact", "the contact wrench (6, on the load at S in S)")
    wrench_noncontact = _output("log.wrench_noncontact", "the non-contact wrench (6, on the load at S in S)")
    scales = _output("log.scales", "σ, γ, η in effect")
    offsets = _output("log.offsets", "the sensor's offsets in use (6; N, N·m)")
    phi = _output("log.phi_hat", "φ̂ (10)")

    def __init__(self, spec, load: LoadEstimate, robot: str, period: float, *,
                 accelerometer: AccelerometerConvention):
        if spec.estimator.mode != "fixed":
            raise ValueError("the per-block Diagram controller (--controller diagram) keeps its load estimate "
                             f"fixed; controller.estimator.mode is {spec.estimator.mode!r}: set it to 'fixed', or "
                             "run the fused controller (the default) to learn the load online")
        self.period = period
        self.tracking = spec.offsets.tracking
        self._diagram = diagram = MakeTeleopController(spec, load, robot, period, np.zeros(NUM_JOINTS),
                                                       accelerometer=accelerometer)
        self._offsets_block = diagram.GetSubsystemByName("offsets_hat")
        # The readings fixed on the inputs: ``STATION_OUTPUTS_READ``, then the clutch.
        self._ports = [diagram.GetInputPort(name) for name in (*STATION_OUTPUTS_READ, "clutch")]
        self._outputs = [diagram.GetOutputPort(name) for name in _READ]
        self._context, self._fixed = None, []
        # Zero until the first start, as the fused controller's arrays are (the loop reports them every tick).
        self._values = {port.get_name(): np.zeros(port.size()) for port in self._outputs}

    @property
    def started(self) -> bool:
        return self._context is not None

    @property
    def rezero_status(self) -> int:
        """The offset tracker's re-zero status (``offset_tracking``): none is ever requested here."""
        return int(self._values["log.rezero_status"][0])

    def start(self, slave_position) -> None:
        """Begins from the slave measured at ``slave_position`` (6, rad), the clutch disengaged."""
        slave_position = np.asarray(slave_position, dtype=float)
        if slave_position.shape != (NUM_JOINTS,) or not np.isfinite(slave_position).all():
            raise ValueError(f"the slave's start position must be {NUM_JOINTS} finite joint angles; "
                             f"got {slave_position}")
        diagram, previous = self._diagram, self._context
        context = diagram.CreateDefaultContext()
        if previous is not None:  # the offsets tracked so far carry over a restart
            block = self._offsets_block
            block.GetMyMutableContextFromRoot(context).SetDiscreteState(
                block.GetMyContextFromRoot(previous).get_discrete_state())
        readings = [np.zeros(port.size()) for port in self._ports]
        readings[STATION_OUTPUTS_READ.index("slave.position_measured")] = slave_position
        self._fixed = [port.FixValue(context, reading) for port, reading in zip(self._ports, readings)]
        diagram.ExecuteInitializationEvents(context)
        self._context = context
        self._read()

    def step(self, dt: float, master_position, master_velocity, slave_position, slave_velocity, wrench, reading,
             clutch: bool, oldest_age: float = 0.0) -> None:
        """One tick on the station's readings (``dt`` and ``oldest_age`` as the fused step takes them, unused:
        the Diagram's blocks step by their period and its load estimate is fixed)."""
        if self._context is None:
            raise RuntimeError("start the controller (from the slave's measured position) before stepping it")
        # (Drake tells the blocks of a new value when its mutable data is asked for: once per tick.)
        for fixed, value in zip(self._fixed, (master_position, master_velocity, slave_position, slave_velocity,
                                              wrench, reading)):
            fixed.GetMutableData().get_mutable_value().SetFromVector(value)
        self._fixed[-1].GetMutableData().get_mutable_value().SetAtIndex(0, 1.0 if clutch else 0.0)
        context = self._context
        context.SetDiscreteState(self._diagram.EvalUniquePeriodicDiscreteUpdate(context))
        self._read()

    def _read(self) -> None:
        context, values = self._context, self._values
        for port in self._outputs:
            values[port.get_name()] = port.Eval(context)
