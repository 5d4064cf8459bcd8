"""The bilateral teleoperation controller of Fig. 4.

``MakeTeleopController`` knows nothing of the station: its inputs and outputs
carry the station port names of docs/design.md §3, so it connects unchanged to
``MakeSimStation`` (``teleop_simulation``) or to the hardware station; this
module imports no simulation. The hardware's real-time loop steps it as its ``TickProgram``
(``diagrams.teleop_controller``), the simulation as one ``TickProgramSystem``.
"""


from collections.abc import Callable, Sequence

import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import Adder, ConstantVectorSource, DiscreteTimeDelay

from heft.diagrams.load_estimate import LoadEstimate
from heft.diagrams.online_estimation import AddOnlineLoadEstimator
from heft.diagrams.master_params import DEFAULT_MASTER
from heft.diagrams.plants import AddArmWithSensor, MakeMasterPlant, Robot, master_actuated
from heft.diagrams.scenario import ControllerSpec
from heft.systems.accelerometer_reading import AccelerometerConvention
from heft.systems.controller.chain_inverse_kinematics import ChainIk, ChainInverseKinematics
from heft.systems.controller.feedback_mapping import FeedbackMapping
from heft.systems.controller.force_scaling import ForceScalingElimination
from heft.systems.controller.master_kinematics import MasterKinematics
from heft.systems.controller.master_position_filter import MasterPositionFilter
from heft.systems.controller.motion_scaling import MotionScaling
from heft.systems.controller.offset_tracking import OffsetTracker
from heft.systems.controller.passivity_controller import PassivityController
from heft.systems.controller.rx_inverse_kinematics import RxKinematics
from heft.systems.controller.slave_inverse_kinematics import SlaveInverseKinematics
from heft.systems.controller.slave_kinematics import SlaveKinematics
from heft.systems.station_ports import CLUTCH, INPUT_AGE, STATION_INPUTS_DRIVEN, STATION_OUTPUTS_READ
from heft.systems.tick_system import TickSystem
from heft.systems.controller.load_model import FixedLoad

FeedbackBlock = Callable[[float], TickSystem]
"""Makes a block of a lab's own for the feedback path from the controller's period (s)."""
# Controller outputs logged for analysis (name → size).
CONTROLLER_LOG = {"log.wrench_feedback": 6, "log.wrench_contact": 6, "log.wrench_noncontact": 6,
                  "log.master_wrench": 6, "log.applied_wrench": 6, "log.pose_RS_desired": 7, "log.passivity_energy": 2,
                  "log.passivity_damping": 2, "log.ik_status": 2, "log.force_fault": 1, "log.scales": 3,
                  "log.offsets": 6, "log.rezero_status": 1, "log.phi_hat": 10}


RX_KINEMATICS = {"rx90": RxKinematics.rx90, "rx60": RxKinematics.rx60}
"""The bundled arms whose inverse kinematics is a closed form (``rx_inverse_kinematics``), and its numbers;
every other arm's is damped least squares on its chain (``chain_inverse_kinematics``)."""


def _slave_model(robot: Robot, period: float, slave_initial_q) -> tuple[MultibodyPlant, str, TickSystem]:
    """The controller's slave model: (arm + sensor plant (no load needed), the name of its base R, the
    inverse kinematics block to S: the RX's closed form, else damped least squares on the chain whose null
    space, on 7 joints, is drawn to ``slave_initial_q``)."""
    slave = MultibodyPlant(time_step=0.0)
    chain, _, S = AddArmWithSensor(slave, robot)
    slave.Finalize()
    if isinstance(robot, str) and robot in RX_KINEMATICS:
        X_FS = S.CalcPose(slave.CreateDefaultContext(), chain.flange)
        ik = SlaveInverseKinematics(RX_KINEMATICS[robot](), X_FS, slave_initial_q, period)
    else:
        ik = ChainInverseKinematics(ChainIk(slave, chain.base, S, slave_initial_q), period)
    return slave, chain.base.name(), ik


def MakeTeleopController(spec: ControllerSpec, load: LoadEstimate, robot: Robot, period: float, slave_initial_q, *,
                         accelerometer: AccelerometerConvention, feedback_blocks: Sequence[FeedbackBlock] = (),
                         master: str = DEFAULT_MASTER):
    """The hardware-agnostic controller Diagram of Fig. 4 (docs/design.md §3), ticking every ``period`` s.
    ``accelerometer``: the convention of ``ft.acceleration_measured`` (``accelerometer_reading``;
    the scenario's ``accelerometer.convention()``).

    Inputs: the station outputs ``STATION_OUTPUTS_READ``; ``clutch`` (1, > 0.5 engaged);
    optional ``sigma``, ``gamma``, ``eta`` (1 each; unconnected → ``spec.force``'s values), the load
    commands ``rezero`` (1, a request counter: ``OffsetTracker``), ``tracking`` (1, > 0.5 on; unconnected
    ``spec.offsets.tracking``) and ``estimate`` (``ESTIMATE_SIZE``: [counter, φ, offsets], a new tool's), ``hold``
    (1, s: how long this tick's torque is held, for the passivity observer; unconnected the period) and, with
    ``spec.estimator.mode`` "online", ``holding`` (1, the gripper holds an object: the grasp's split,
    ``GraspSplit``), ``estimator_reset`` (1, a request counter: a new load) and ``input_age`` (1, s). φ̂ is
    ``load.phi`` (``FixedLoad``) or, online, the load estimator's (``AddOnlineLoadEstimator``).
    ``feedback_blocks``: blocks of a lab's own between force scaling's f′ and the feedback mapping, in order
    (each made by ``make(period)``: a TickSystem with an input and an output ``wrench``, 6, at S in S).
    ``robot``: the slave arm (``plants.Robot``), ``slave_initial_q`` its start posture (rad); ``master``: the
    bundled master (``BUNDLED_MASTERS``), whose unactuated joints get no torque (a three-axis device renders
    the force only: ``PassivityController``).
    Outputs: ``master.torque_commanded`` (6, N·m), ``slave.position_commanded`` (n, rad: the arm's joints),
    the ``CONTROLLER_LOG`` signals, ``slave.gravity_S`` (3, g in S at the measured joints), ``slave.pose_RS`` and
    ``master.pose_BE`` (7 each, X_RS and X_BE measured: [p (m); w, x, y, z]) and, online,
    ``estimator.num_samples`` (1, since the last new load). The slave's tool frame T of the motion mapping is S.
    """
    builder = DiagramBuilder()
    slave, base, slave_ik = _slave_model(robot, period, slave_initial_q)
    master_plant = MakeMasterPlant(master)
    master_kinematics = builder.AddNamedSystem("master_kinematics", MasterKinematics(master_plant))
    slave_kinematics = builder.AddNamedSystem(
        "slave_kinematics", SlaveKinematics(slave, base_frame=base, sensor_frame="S"))
    motion = builder.AddNamedSystem("motion_scaling", MotionScaling(spec.motion, period))
    ik = builder.AddNamedSystem("slave_ik", slave_ik)
    force = builder.AddNamedSystem("force_scaling", ForceScalingElimination(
        spec.force, period, accelerometer))
    feedback = builder.AddNamedSystem("feedback_mapping", FeedbackMapping(spec.feedback, spec.motion.R_RB))
    passivity = builder.AddNamedSystem("passivity", PassivityController(
        spec.passivity, spec.feedback.max_force, spec.feedback.max_torque, period, master_actuated(master_plant)))
    spec.estimator.validate()
    offsets = builder.AddNamedSystem("offsets_hat", OffsetTracker(load.offsets, spec.offsets, spec.contact, period,
                                                                    slave.num_positions()))

    def export_input(name, *ports):
        builder.ExportInput(ports[0], name)
        for port in ports[1:]:
            builder.ConnectInput(name, port)

    export_input("master.position_measured", master_kinematics.get_input_port())
    master_pose, master_filter = master_kinematics.GetOutputPort("pose_BE"), None
    if spec.motion.master_filter > 0 or spec.motion.master_notch > 0:
        # the motion mapping follows the filtered positions, the feedback the measured
        master_filter = builder.AddNamedSystem("master_filter", MasterPositionFilter(
            spec.motion.master_filter, period, spec.motion.master_notch, spec.motion.master_notch_quality))
        filtered_kinematics = builder.AddNamedSystem("master_filtered_kinematics",
                                                     MasterKinematics(master_plant))
        builder.ConnectInput("master.position_measured", master_filter.GetInputPort("position"))
        builder.Connect(master_filter.get_output_port(), filtered_kinematics.get_input_port())
        master_pose = filtered_kinematics.GetOutputPort("pose_BE")
    export_input("master.velocity_estimated", passivity.GetInputPort("velocity"))
    export_input("hold", passivity.GetInputPort("hold"), *([] if master_filter is None else
                                                           [master_filter.GetInputPort("hold")]))
    export_input("slave.position_measured", slave_kinematics.GetInputPort("position"),
                 ik.GetInputPort("position_measured"))
    export_input("slave.velocity_estimated", slave_kinematics.GetInputPort("velocity"),
                 offsets.GetInputPort("slave_velocity"))
    export_input("ft.wrench_measured", force.GetInputPort("wrench"))
    export_input("ft.acceleration_measured", force.GetInputPort("acceleration"))
    export_input("tracking", offsets.GetInputPort("tracking"))
    if spec.estimator.mode == "online":
        phi_hat = AddOnlineLoadEstimator(builder, spec.estimator, spec.contact, load.phi, period, accelerometer,
                                         force, slave_kinematics, offsets, spec.force.phi_gripper)
    else:
        phi_hat = builder.AddNamedSystem("phi_hat", FixedLoad(load.phi, period))
        export_input("estimate", phi_hat.GetInputPort("estimate"), offsets.GetInputPort("estimate"))
        phi_hat = phi_hat.GetOutputPort("phi")
    export_input("clutch", motion.GetInputPort("clutch"))
    for name in ("sigma", "gamma", "eta"):
        export_input(name, force.GetInputPort(name))
    export_input("rezero", offsets.GetInputPort("rezero"))

    connect = builder.Connect
    connect(master_pose, motion.GetInputPort("pose_BE"))
    connect(slave_kinematics.GetOutputPort("pose_RS"), motion.GetInputPort("pose_RT_measured"))
    connect(motion.GetOutputPort("pose_RT_desired"), ik.GetInputPort("pose_desired"))
    connect(slave_kinematics.GetOutputPort("omega_S"), force.GetInputPort("omega"))
    connect(slave_kinematics.GetOutputPort("gravity_S"), force.GetInputPort("gravity"))
    connect(phi_hat, force.GetInputPort("phi"))
    connect(offsets.GetOutputPort("offsets"), force.GetInputPort("offsets"))
    connect(force.GetOutputPort("wrench_contact"), offsets.GetInputPort("wrench_contact"))
    connect(force.GetOutputPort("fault"), offsets.GetInputPort("fault"))
    wrench_feedback = force.GetOutputPort("wrench_feedback")
    for i, make in enumerate(feedback_blocks):
        block = builder.AddNamedSystem(f"feedback_block_{i}", make(period))
        connect(wrench_feedback, block.GetInputPort("wrench"))
        wrench_feedback = block.GetOutputPort("wrench")
    connect(wrench_feedback, feedback.GetInputPort("wrench_S"))
    connect(slave_kinematics.GetOutputPort("pose_RS"), feedback.GetInputPort("pose_RS"))
    connect(master_kinematics.GetOutputPort("jacobian"), feedback.GetInputPort("jacobian"))
    connect(feedback.GetOutputPort("wrench_E"), passivity.GetInputPort("wrench"))
    connect(master_kinematics.GetOutputPort("jacobian"), passivity.GetInputPort("jacobian"))

    builder.ExportOutput(passivity.GetOutputPort("torque"), "master.torque_commanded")
    builder.ExportOutput(ik.GetOutputPort("position_commanded"), "slave.position_commanded")
    for name, port in (("log.wrench_feedback", force.GetOutputPort("wrench_feedback")),
                       ("log.wrench_contact", force.GetOutputPort("wrench_contact")),
                       ("log.wrench_noncontact", force.GetOutputPort("wrench_noncontact")),
                       ("log.master_wrench", feedback.GetOutputPort("wrench_E")),
                       ("log.pose_RS_desired", motion.GetOutputPort("pose_RT_desired")),
                       ("log.passivity_energy", passivity.GetOutputPort("energy_observed")),
                       ("log.passivity_damping", passivity.GetOutputPort("damping")),
                       ("log.applied_wrench", passivity.GetOutputPort("applied_wrench")),
                       ("log.ik_status", ik.GetOutputPort("status")),
                       ("log.force_fault", force.GetOutputPort("fault")),
                       ("log.scales", force.GetOutputPort("scales")),
                       ("log.offsets", offsets.GetOutputPort("offsets")),
                       ("log.rezero_status", offsets.GetOutputPort("rezero_status")),
                       ("log.phi_hat", phi_hat)):
        builder.ExportOutput(port, name)
    builder.ExportOutput(slave_kinematics.GetOutputPort("gravity_S"), "slave.gravity_S")
    builder.ExportOutput(slave_kinematics.GetOutputPort("pose_RS"), "slave.pose_RS")
    builder.ExportOutput(master_kinematics.GetOutputPort("pose_BE"), "master.pose_BE")
    if spec.estimator.mode == "online":
        builder.ExportOutput(builder.GetSubsystemByName("phi_hat").GetOutputPort("num_samples"),
                             "estimator.num_samples")
    diagram = builder.Build()
    diagram.set_name("teleop_controller")
    return diagram


def ConnectControllerToStation(builder: DiagramBuilder, controller, station, delay_steps: int = 0,
                               period: float = 0.0, initial_values: dict | None = None):
    """Closes the loop by port name, the simulated station's or the lab's (``station_ports``): the readings and
    the clutch to the controller, its commands to the station, and the readings' age where the station knows it
    and the controller reads it.

    ``delay_steps`` > 0 adds a communication delay of that many ``period`` s to every channel, both ways
    (``AddDelay``; a channel starts at ``initial_values[name]``, else 0)."""
    def link(source, name, sink):
        if delay_steps:
            source = AddDelay(builder, source, delay_steps, period, (initial_values or {}).get(name))
        builder.Connect(source, sink)

    for name in STATION_OUTPUTS_READ:
        link(station.GetOutputPort(name), name, controller.GetInputPort(name))
    for name in STATION_INPUTS_DRIVEN:
        link(controller.GetOutputPort(name), name, station.GetInputPort(name))
    builder.Connect(station.GetOutputPort(CLUTCH), controller.GetInputPort(CLUTCH))
    if station.HasOutputPort(INPUT_AGE) and controller.HasInputPort(INPUT_AGE):
        builder.Connect(station.GetOutputPort(INPUT_AGE), controller.GetInputPort(INPUT_AGE))


def AddDelay(builder: DiagramBuilder, port, steps: int, period: float, initial=None):
    """``port`` delayed by ``steps`` >= 1 samples of ``period`` s (a DiscreteTimeDelay): a system
    sampling it at t_k reads the value of t_{k−steps}; until then ``initial`` (default zeros)."""
    initial = np.zeros(port.size()) if initial is None else np.asarray(initial, dtype=float)
    # The delay line's output is state updated at the samples: that hold is the first period.
    delay = builder.AddSystem(DiscreteTimeDelay(period, steps - 1, port.size()))
    if not initial.any():
        builder.Connect(port, delay.get_input_port())
        return delay.get_output_port()
    # Delay the deviation from ``initial``, whose delay line starts at zero.
    deviation, restored = builder.AddSystem(Adder(2, port.size())), builder.AddSystem(Adder(2, port.size()))
    builder.Connect(port, deviation.get_input_port(0))
    builder.Connect(builder.AddSystem(ConstantVectorSource(-initial)).get_output_port(), deviation.get_input_port(1))
    builder.Connect(deviation.get_output_port(), delay.get_input_port())
    builder.Connect(delay.get_output_port(), restored.get_input_port(0))
    builder.Connect(builder.AddSystem(ConstantVectorSource(initial)).get_output_port(), restored.get_input_port(1))
    return restored.get_output_port()
