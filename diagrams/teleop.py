"""The bilateral teleoperation controller of Fig. 4 and its simulation.

``MakeTeleopController`` knows nothing of the station: its inputs and outputs
carry the station port names of DESIGN §3, so it connects unchanged to
``MakeSimStation`` or to the hardware station. ``MakeTeleopSimulation`` wires it
to the simulated station and logs what analysis needs.
"""

import dataclasses

import numpy as np
from pydrake.math import RigidTransform
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import Adder, ConstantVectorSource, DiscreteTimeDelay, LogVectorOutput

from heft.diagrams.models import model_path
from heft.diagrams.scenario import ControllerSpec, Scenario
from heft.diagrams.sim_station import AddArmWithSensor, MakeSimStation
from heft.systems.feedback_mapping import FeedbackMapping
from heft.systems.force_scaling import ForceScalingElimination
from heft.systems.master_kinematics import MasterKinematics, master_plant
from heft.systems.motion_scaling import MotionScaling
from heft.systems.offset_tracking import OffsetTracker
from heft.systems.passivity_controller import PassivityController
from heft.systems.realtime_controller import RealtimeTeleopController
from heft.systems.rx_inverse_kinematics import RxKinematics
from heft.systems.slave_inverse_kinematics import SlaveInverseKinematics
from heft.systems.slave_kinematics import SlaveKinematics

STATION_OUTPUTS_READ = ("master.position_measured", "master.velocity_estimated", "slave.position_measured",
                        "slave.velocity_estimated", "ft.wrench_measured", "ft.acceleration_measured")
STATION_INPUTS_DRIVEN = ("master.torque_commanded", "slave.position_commanded")
# Controller outputs logged for analysis (name → size).
CONTROLLER_LOG = {"log.wrench_feedback": 6, "log.wrench_contact": 6, "log.wrench_noncontact": 6,
                  "log.master_wrench": 6, "log.pose_RS_desired": 7, "log.passivity_energy": 2,
                  "log.passivity_damping": 2, "log.ik_status": 2, "log.force_fault": 1, "log.scales": 3,
                  "log.offsets": 6, "log.rezero_status": 1}


@dataclasses.dataclass
class LoadEstimate:
    """The load model the controller uses: φ̂ (Eq. 6) and offsets [f_o; τ_o] (N, N·m)."""
    phi: np.ndarray
    offsets: np.ndarray


def _slave_model(robot: str) -> MultibodyPlant:
    """The controller's kinematic model of the slave: arm and wrist sensor (no load needed)."""
    plant = MultibodyPlant(time_step=0.0)
    AddArmWithSensor(plant, robot)
    plant.Finalize()
    return plant


def _master_model() -> MultibodyPlant:
    """The controller's model of the master: the Phantom Premium 1.5 6DoF."""
    return master_plant(model_path("phantom_premium_6dof.urdf"))


def _slave_ik_model(robot: str) -> tuple[MultibodyPlant, RxKinematics, RigidTransform]:
    """The controller's slave model: (arm + sensor plant, closed-form IK, X_FS the pose of S in the flange)."""
    slave = _slave_model(robot)
    kinematics = RxKinematics.rx90() if robot == "rx90" else RxKinematics.rx60()
    X_FS = slave.GetFrameByName("S").CalcPose(slave.CreateDefaultContext(), slave.GetFrameByName("flange"))
    return slave, kinematics, X_FS


def MakeRealtimeTeleopController(spec: ControllerSpec, load: LoadEstimate, robot: str, *,
                                 accelerometer_includes_gravity: bool) -> RealtimeTeleopController:
    """The controller of ``MakeTeleopController`` as one computation per tick, for the hardware's
    real-time loop (``systems.realtime_controller``): same models, same parameters."""
    slave, kinematics, X_FS = _slave_ik_model(robot)
    return RealtimeTeleopController(_master_model(), slave, f"{robot}_base", kinematics, X_FS, load.phi, load.offsets,
                                    spec.motion, spec.force, spec.feedback, spec.passivity, spec.offsets,
                                    accelerometer_includes_gravity)


def MakeTeleopController(spec: ControllerSpec, load: LoadEstimate, robot: str, period: float, slave_initial_q, *,
                         accelerometer_includes_gravity: bool):
    """The hardware-agnostic controller Diagram of Fig. 4 (DESIGN §3), ticking every ``period`` s.
    ``accelerometer_includes_gravity``: the convention of ``ft.acceleration_measured``
    (``accelerometer_reading``; the scenario's ``accelerometer.includes_gravity``).

    Inputs: the station outputs ``STATION_OUTPUTS_READ``; ``clutch`` (1, > 0.5 engaged);
    optional ``sigma``, ``gamma``, ``eta`` (1 each; unconnected → ``spec.force``'s values) and
    ``rezero`` (1, a request counter: ``OffsetTracker``).
    Outputs: ``master.torque_commanded`` (6, N·m), ``slave.position_commanded`` (6, rad),
    and the ``CONTROLLER_LOG`` signals. The slave's tool frame T of the motion mapping is S.
    """
    builder = DiagramBuilder()
    rate = {"period": period}
    slave, kinematics, X_FS = _slave_ik_model(robot)
    master_kinematics = builder.AddNamedSystem("master_kinematics", MasterKinematics(_master_model()))
    slave_kinematics = builder.AddNamedSystem(
        "slave_kinematics", SlaveKinematics(slave, base_frame=f"{robot}_base", sensor_frame="S"))
    motion = builder.AddNamedSystem("motion_scaling", MotionScaling(dataclasses.replace(spec.motion, **rate)))
    ik = builder.AddNamedSystem("slave_ik", SlaveInverseKinematics(kinematics, X_FS, slave_initial_q, period))
    force = builder.AddNamedSystem("force_scaling", ForceScalingElimination(
        dataclasses.replace(spec.force, **rate), accelerometer_includes_gravity))
    feedback = builder.AddNamedSystem("feedback_mapping", FeedbackMapping(spec.feedback))
    passivity = builder.AddNamedSystem("passivity", PassivityController(
        dataclasses.replace(spec.passivity, **rate), spec.feedback.max_force, spec.feedback.max_torque))
    phi = builder.AddNamedSystem("phi_hat", ConstantVectorSource(np.asarray(load.phi, dtype=float)))
    offsets = builder.AddNamedSystem("offsets_hat", OffsetTracker(load.offsets, spec.offsets, period))

    def export_input(name, *ports):
        builder.ExportInput(ports[0], name)
        for port in ports[1:]:
            builder.ConnectInput(name, port)

    export_input("master.position_measured", master_kinematics.get_input_port())
    export_input("master.velocity_estimated", passivity.GetInputPort("velocity"))
    export_input("slave.position_measured", slave_kinematics.GetInputPort("position"),
                 ik.GetInputPort("position_measured"))
    export_input("slave.velocity_estimated", slave_kinematics.GetInputPort("velocity"),
                 offsets.GetInputPort("slave_velocity"))
    export_input("ft.wrench_measured", force.GetInputPort("wrench"))
    export_input("ft.acceleration_measured", force.GetInputPort("acceleration"))
    export_input("clutch", motion.GetInputPort("clutch"))
    for name in ("sigma", "gamma", "eta"):
        export_input(name, force.GetInputPort(name))
    export_input("rezero", offsets.GetInputPort("rezero"))

    connect = builder.Connect
    connect(master_kinematics.GetOutputPort("pose_BE"), motion.GetInputPort("pose_BE"))
    connect(slave_kinematics.GetOutputPort("pose_RS"), motion.GetInputPort("pose_RT_measured"))
    connect(motion.GetOutputPort("pose_RT_desired"), ik.GetInputPort("pose_desired"))
    connect(slave_kinematics.GetOutputPort("omega_S"), force.GetInputPort("omega"))
    connect(slave_kinematics.GetOutputPort("gravity_S"), force.GetInputPort("gravity"))
    connect(phi.get_output_port(), force.GetInputPort("phi"))
    connect(offsets.GetOutputPort("offsets"), force.GetInputPort("offsets"))
    connect(force.GetOutputPort("wrench_contact"), offsets.GetInputPort("wrench_contact"))
    connect(force.GetOutputPort("fault"), offsets.GetInputPort("fault"))
    connect(force.GetOutputPort("wrench_feedback"), feedback.GetInputPort("wrench_S"))
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
                       ("log.ik_status", ik.GetOutputPort("status")),
                       ("log.force_fault", force.GetOutputPort("fault")),
                       ("log.scales", force.GetOutputPort("scales")),
                       ("log.offsets", offsets.GetOutputPort("offsets")),
                       ("log.rezero_status", offsets.GetOutputPort("rezero_status"))):
        builder.ExportOutput(port, name)
    diagram = builder.Build()
    diagram.set_name("teleop_controller")
    return diagram


# Station outputs logged by the simulation (name → log key).
STATION_LOG = {"ft.wrench_measured": "wrench_measured", "ft.acceleration_measured": "accel_measured",
               "truth.wrench_contact": "wrench_contact_true", "truth.wrench_noncontact": "wrench_noncontact_true",
               "truth.acceleration": "accel_true", "truth.omega": "omega_true", "truth.gravity_S": "gravity_S",
               "truth.ft_offsets": "offsets_true", "truth.slave_position": "slave_q",
               "master.position_measured": "master_q", "master.velocity_estimated": "master_v",
               "truth.ft_saturated": "ft_saturated"}


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


def ConnectControllerToStation(builder: DiagramBuilder, controller, station, delay_steps: int = 0,
                               period: float = 0.0, initial_values: dict | None = None):
    """Closes the loop by port name (either station kind) and holds the clutch engaged.

    ``delay_steps`` > 0 adds a communication delay of that many ``period`` s to every
    channel, both ways (``AddDelay``; a channel starts at ``initial_values[name]``, else 0)."""
    def link(source, name, sink):
        if delay_steps:
            source = AddDelay(builder, source, delay_steps, period, (initial_values or {}).get(name))
        builder.Connect(source, sink)

    for name in STATION_OUTPUTS_READ:
        link(station.GetOutputPort(name), name, controller.GetInputPort(name))
    for name in STATION_INPUTS_DRIVEN:
        link(controller.GetOutputPort(name), name, station.GetInputPort(name))
    builder.Connect(builder.AddNamedSystem("clutch", ConstantVectorSource([1.0])).get_output_port(),
                    controller.GetInputPort("clutch"))


def MakeTeleopSimulation(scenario: Scenario, load: LoadEstimate, sigma: float | None = None, meshcat=None):
    """The controller closed around the simulated station, with loggers.

    Returns (diagram, loggers) where loggers maps a log key to its VectorLogSink
    (sampled every controller period). ``sigma`` overrides ``scenario.controller.force.sigma``;
    a ``meshcat`` shows the slave live (``MakeSimStation``).
    """
    spec = scenario.controller
    if sigma is not None:
        spec = dataclasses.replace(spec, force=dataclasses.replace(spec.force, sigma=sigma))
    builder = DiagramBuilder()
    station = builder.AddNamedSystem("station", MakeSimStation(scenario, meshcat))
    controller = builder.AddNamedSystem("controller", MakeTeleopController(
        spec, load, scenario.robot, scenario.controller_period, scenario.slave_initial_q,
        accelerometer_includes_gravity=scenario.accelerometer.includes_gravity))
    period = scenario.controller_period
    ConnectControllerToStation(builder, controller, station, round(spec.delay / period), period,
                               {"master.position_measured": scenario.master_initial_q,
                                "slave.position_measured": scenario.slave_initial_q,
                                "slave.position_commanded": scenario.slave_initial_q})
    loggers = {key: LogVectorOutput(station.GetOutputPort(name), builder, period)
               for name, key in STATION_LOG.items()}
    for name in CONTROLLER_LOG:
        loggers[name.removeprefix("log.")] = LogVectorOutput(controller.GetOutputPort(name), builder, period)
    diagram = builder.Build()
    diagram.set_name("teleop_simulation")
    return diagram, loggers
