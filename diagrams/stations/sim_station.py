"""The simulated station: slave arm with wrist sensor, load and sheet spring; the
Phantom master with a simulated operator; sensor and encoder models.

``MakeSimStation(scenario)`` returns a Diagram whose exported ports are the
station ports of docs/design.md §3, plus ``truth.*`` outputs for analysis.
"""

from __future__ import annotations


import numpy as np
from pydrake.common.eigen_geometry import AngleAxis
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.plant import AddMultibodyPlant, CoulombFriction, MultibodyPlant
from pydrake.multibody.tree import (FixedOffsetFrame, MultibodyForces, PdControllerGains,
                                    PrismaticJoint, PrismaticSpring, SpatialInertia)
from pydrake.geometry import AddContactMaterial, Box, MeshcatVisualizer, ProximityProperties
from pydrake.systems.controllers import InverseDynamics
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, Demultiplexer, MatrixGain, Saturation

from heft.diagrams.plants import (AddMaster, AddSlave, SlaveParts, arm_name, load_phi, payload_max, phi_about_S,
                                   slave_arm)
from heft.diagrams.tool_check import check_carried
from heft.diagrams.scenario import Scenario
from heft.diagrams.stations.slave_servo import slave_servo_gains
from heft.systems.station.encoders import AddEncoderVelocityEstimate, EncoderQuantizer
from heft.systems.load_dynamics import GRAVITY_W
from heft.systems.station.operator_hand import OperatorHand
from heft.systems.station.setpoint_filter import SetpointFilter
from heft.systems.station.sensor_models import AccelerometerModel, ForceTorqueSensorModel
from heft.systems.station_ports import CLUTCH
from heft.systems.station.station_truth import TRUTH_PARTS, WristTruth

# Point-contact stiffness of the ball tip on the plate (N/m): steel on steel is far stiffer than the
# sheet spring, which then sets the felt stiffness; stiffer would only shrink the stable time step.
CONTACT_STIFFNESS = 2e5
# Hunt–Crossley dissipation (s/m) of that contact: steel on steel, restitution ≈ 0.6 at 0.5 m/s.
CONTACT_DISSIPATION = 1.0
# Phantom Premium 1.5 nominal position resolution ≈ 0.03 mm at ≈ 0.2 m links → ≈ 1.5e-4 rad.
MASTER_ENCODER_COUNTS_PER_REV = 4.2e4
# Ball tip sliding on the steel sheet: steel on steel, lightly oiled (≈ 0.1–0.2; dry ≈ 0.5).
PLATE_FRICTION = 0.2


def AddSheetSpring(plant: MultibodyPlant, spec) -> PrismaticJoint:
    """A plate on a vertical prismatic joint with a linear spring-damper (Fig. 5),
    resting with its top at ``spec.plate_top_W`` (its own weight preloads the spring)."""
    instance = plant.AddModelInstance("sheet_spring")
    size = np.asarray(spec.plate_size, dtype=float)
    plate = plant.AddRigidBody("plate", instance, SpatialInertia.SolidBoxWithMass(spec.plate_mass, *size))
    rest = plant.AddFrame(FixedOffsetFrame(
        "plate_rest", plant.world_frame(), RigidTransform(np.asarray(spec.plate_top_W) - [0, 0, size[2] / 2])))
    joint = plant.AddJoint(PrismaticJoint("plate_slide", rest, plate.body_frame(), [0.0, 0.0, 1.0],
                                          damping=spec.damping))
    # The spring's free length sits m·g/k above the rest position, so the plate rests at 0.
    plant.AddForceElement(PrismaticSpring(joint, nominal_position=-spec.plate_mass * GRAVITY_W[2] / spec.stiffness,
                                          stiffness=spec.stiffness))
    properties = ProximityProperties()
    AddContactMaterial(dissipation=CONTACT_DISSIPATION, point_stiffness=CONTACT_STIFFNESS,
                       friction=CoulombFriction(PLATE_FRICTION, PLATE_FRICTION), properties=properties)
    plant.RegisterCollisionGeometry(plate, RigidTransform(), Box(*size), "plate", properties)
    plant.RegisterVisualGeometry(plate, RigidTransform(), Box(*size), "plate", [0.6, 0.6, 0.65, 1.0])
    return joint


def _add_slave(builder: DiagramBuilder, scenario: Scenario):
    """The slave plant (discrete SAP, point contact), its joint servo and gravity feed-forward."""
    plant, scene_graph = AddMultibodyPlant(scenario.plant, builder)
    plant.set_name("slave_plant")
    parts = AddSlave(plant, scenario, mount_compliance=True)
    if scenario.environment.kind == "sheet_spring":
        AddSheetSpring(plant, scenario.environment)
    plant.mutable_gravity_field().set_gravity_vector(GRAVITY_W)

    # The robot controller's model of arm + payload, for gravity feed-forward.
    control_plant = MultibodyPlant(time_step=0.0)
    AddSlave(control_plant, scenario)
    control_plant.mutable_gravity_field().set_gravity_vector(GRAVITY_W)
    control_plant.Finalize()

    # Stiff joint servo standing in for the robot's own 10 kHz loop: implicit PD in SAP.
    kp, kd, _ = slave_servo_gains(scenario)
    for actuator, p, d in zip(parts.chain.actuators, kp, kd, strict=True):  # in joint order
        plant.get_mutable_joint_actuator(actuator.index()).set_controller_gains(PdControllerGains(p=p, d=d))
    plant.Finalize()
    plant.SetDefaultPositions(parts.arm, scenario.slave_initial_q)
    if parts.mount_joint is not None:
        context = plant.CreateDefaultContext()
        settle_mount(plant, context, parts.mount_joint)
        parts.mount_joint.SetDefaultPose(parts.mount_joint.GetPose(context))

    n = parts.chain.num_joints
    state = builder.AddSystem(Demultiplexer([n, n]))
    builder.Connect(plant.get_state_output_port(parts.arm), state.get_input_port())
    gravity = builder.AddSystem(InverseDynamics(control_plant,
                                                InverseDynamics.InverseDynamicsMode.kGravityCompensation))
    gravity.set_name("slave_gravity_feedforward")
    gravity.control_plant = control_plant  # the system refers to it, without keeping it alive
    builder.Connect(plant.get_state_output_port(parts.arm), gravity.get_input_port_estimated_state())
    builder.Connect(gravity.get_output_port_generalized_force(), plant.get_actuation_input_port(parts.arm))
    setpoints = builder.AddSystem(SetpointFilter(
        scenario.slave_initial_q, scenario.slave_setpoint_bandwidth, scenario.plant.time_step))
    setpoints.set_name("slave_setpoint_filter")
    builder.Connect(setpoints.get_output_port(), plant.get_desired_state_input_port(parts.arm))
    builder.ExportInput(setpoints.get_input_port(), "slave.position_commanded")

    encoders = builder.AddSystem(EncoderQuantizer(n, scenario.encoder_counts_per_rev))
    encoders.set_name("slave_encoders")
    builder.Connect(state.get_output_port(0), encoders.get_input_port())
    builder.ExportOutput(encoders.get_output_port(), "slave.position_measured")
    if scenario.slave_velocity_filter > 0:
        builder.ExportOutput(AddEncoderVelocityEstimate(builder, encoders.get_output_port(), scenario.plant.time_step,
                                                        scenario.slave_velocity_filter), "slave.velocity_estimated")
    else:
        builder.ExportOutput(state.get_output_port(1), "slave.velocity_estimated")
    builder.ExportOutput(state.get_output_port(0), "truth.slave_position")
    return plant, parts


def _add_wrist_sensor(builder: DiagramBuilder, scenario: Scenario, plant: MultibodyPlant, parts: SlaveParts):
    """JR3 force-torque + accelerometer models on the plant's truth, and the truth itself."""
    p_BS = parts.S.GetFixedPoseInBodyFrame().translation()
    L, undeflected = parts.load_bodies[0].body_frame(), _undeflected(plant, parts)  # L: at S on the mount at rest
    phi = phi_about_S(plant, L, parts.load_bodies, undeflected)
    phi_gripper = phi_about_S(plant, L, parts.gripper_bodies, undeflected) if parts.gripper_bodies else np.zeros(10)
    truth_phi = builder.AddNamedSystem("truth_phi", ConstantVectorSource(phi))  # set_holding changes it
    truth_phi_gripper = builder.AddSystem(ConstantVectorSource(phi_gripper))
    wrist = builder.AddSystem(WristTruth(parts.sensor_body.index(), p_BS, [b.index() for b in parts.load_bodies],
                                         parts.sensor_weld.index(), GRAVITY_W, scenario.accelerometer.convention()))
    for name in ("reaction_forces", "contact_results", "body_poses", "body_spatial_velocities",
                 "body_spatial_accelerations"):
        builder.Connect(plant.GetOutputPort(name), wrist.GetInputPort(name))
    builder.Connect(truth_phi.get_output_port(), wrist.GetInputPort("phi"))
    builder.Connect(truth_phi_gripper.get_output_port(), wrist.GetInputPort("phi_gripper"))
    wrist_parts = builder.AddSystem(Demultiplexer([size for _, size in TRUTH_PARTS]))
    builder.Connect(wrist.get_output_port(), wrist_parts.get_input_port())
    truth = {name: wrist_parts.get_output_port(i) for i, (name, _) in enumerate(TRUTH_PARTS)}

    ft = builder.AddSystem(ForceTorqueSensorModel(scenario.ft_sensor))
    builder.Connect(truth["wrench_sensor"], ft.GetInputPort("wrench_true"))
    accelerometer = builder.AddSystem(AccelerometerModel(scenario.accelerometer))
    builder.Connect(truth["accelerometer_reading"], accelerometer.GetInputPort("acceleration_true"))
    builder.ExportOutput(ft.GetOutputPort("wrench_measured"), "ft.wrench_measured")
    builder.ExportOutput(accelerometer.GetOutputPort("acceleration_measured"), "ft.acceleration_measured")

    for port, name in ((truth["wrench_sensor"], "truth.wrench_sensor"),
                       (truth["wrench_contact"], "truth.wrench_contact"),
                       (truth["wrench"], "truth.wrench_noncontact"),
                       (truth["wrench_object"], "truth.wrench_noncontact_object"),
                       (truth["acceleration"], "truth.acceleration"),
                       (truth["omega"], "truth.omega"),
                       (truth["gravity"], "truth.gravity_S"),
                       (ft.GetOutputPort("offsets_true"), "truth.ft_offsets"),
                       (ft.GetOutputPort("saturated"), "truth.ft_saturated"),
                       (accelerometer.GetOutputPort("saturated"), "truth.accelerometer_saturated"),
                       (truth_phi.get_output_port(), "truth.phi"),
                       (truth_phi_gripper.get_output_port(), "truth.phi_gripper")):
        builder.ExportOutput(port, name)


def _undeflected(plant: MultibodyPlant, parts: SlaveParts):
    """A default context of ``plant`` with the load's compliant mount (if any) at rest length."""
    context = plant.CreateDefaultContext()
    if parts.mount_joint is not None:
        parts.mount_joint.SetPose(context, RigidTransform())
    return context


def settle_mount(plant: MultibodyPlant, context, joint, iterations: int = 4) -> None:
    """Sets the floating ``joint`` of a compliant mount in ``context`` to the static equilibrium of
    its load under gravity and the mount's spring, the rest of the plant held where it is and at
    rest: Newton's method on the joint's generalized forces, the Jacobian by finite differences
    of small rotations and translations of the joint's pose (its velocity coordinates)."""
    plant.SetVelocities(context, np.zeros(plant.num_velocities()))
    velocities = slice(joint.velocity_start(), joint.velocity_start() + 6)
    forces = MultibodyForces(plant)

    def residual():
        plant.CalcForceElementsContribution(context, forces)  # gravity and springs
        return plant.CalcInverseDynamics(context, np.zeros(plant.num_velocities()), forces)[velocities]

    def moved(X, step):  # step = [rotation vector; translation] in the parent frame
        angle = np.linalg.norm(step[:3])
        R = RotationMatrix(AngleAxis(angle, step[:3] / angle)) if angle > 0 else RotationMatrix()
        return RigidTransform(R @ X.rotation(), X.translation() + step[3:])

    h = 1e-7
    for _ in range(iterations):
        X, r = joint.GetPose(context), residual()
        jacobian = np.empty((6, 6))
        for i in range(6):
            joint.SetPose(context, moved(X, h * np.eye(6)[i]))
            jacobian[:, i] = (residual() - r) / h
        joint.SetPose(context, moved(X, -np.linalg.solve(jacobian, r)))


def _add_master(builder: DiagramBuilder, scenario: Scenario):
    """The scenario's master (its own discrete plant, without gravity: the Premium and the Touch are
    counterbalanced) with the operator's hand mass on the stylus and its impedance. Its amplifiers take the
    six joint torques commanded and drive the actuated joints' motors, each within its effort."""
    master = builder.AddSystem(MultibodyPlant(time_step=scenario.plant.time_step))
    master.set_name("master_plant")
    master.SetUseSampledOutputPorts(scenario.plant.use_sampled_output_ports)
    phantom, _, E = AddMaster(master, master=scenario.master)
    stylus = E.body()
    hand = master.AddRigidBody("operator_hand", phantom,
                               SpatialInertia.SolidSphereWithMass(max(scenario.operator.hand_mass, 1e-6), 0.04))
    master.WeldFrames(stylus.body_frame(), hand.body_frame())
    master.mutable_gravity_field().set_gravity_vector(np.zeros(3))
    master.Finalize()
    master.SetDefaultPositions(phantom, scenario.master_initial_q)

    limits = np.array([master.get_joint_actuator(i).effort_limit() for i in master.GetJointActuatorIndices(phantom)])
    amplifiers = builder.AddSystem(Saturation(-limits, limits))
    amplifiers.set_name("master_amplifiers")
    builder.Connect(amplifiers.get_output_port(), master.get_actuation_input_port(phantom))
    if len(limits) == master.num_positions(phantom):
        builder.ExportInput(amplifiers.get_input_port(), "master.torque_commanded")
    else:  # the actuated joints' torques of the six commanded
        motors = np.zeros((len(limits), master.num_positions(phantom)))
        for row, index in enumerate(master.GetJointActuatorIndices(phantom)):
            motors[row, master.get_joint_actuator(index).joint().position_start()] = 1.0
        select = builder.AddNamedSystem("master_motors", MatrixGain(motors))
        builder.Connect(select.get_output_port(), amplifiers.get_input_port())
        builder.ExportInput(select.get_input_port(), "master.torque_commanded")

    operator = builder.AddNamedSystem("operator", OperatorHand(master, stylus, scenario.operator))
    builder.Connect(master.get_state_output_port(), operator.GetInputPort("state"))
    builder.Connect(operator.get_output_port(), master.get_applied_spatial_force_input_port())

    state = builder.AddSystem(Demultiplexer([6, 6]))
    builder.Connect(master.get_state_output_port(phantom), state.get_input_port())
    encoders = builder.AddSystem(EncoderQuantizer(6, MASTER_ENCODER_COUNTS_PER_REV))
    encoders.set_name("master_encoders")
    builder.Connect(state.get_output_port(0), encoders.get_input_port())
    builder.ExportOutput(encoders.get_output_port(), "master.position_measured")
    builder.ExportOutput(state.get_output_port(1), "master.velocity_estimated")
    builder.ExportOutput(master.get_body_poses_output_port(), "truth.master_body_poses")
    return master


def set_holding(station, root_context, holding: bool, at_start: bool = False) -> None:
    """For a "gripper_object" load: whether the gripper holds the object in ``root_context`` (of
    the station or of a Diagram around it): the object's inertia, or none; the truth φ follows.
    Before the grasp of ``load.grasp_at`` it holds nothing; a runner calls this ``at_start`` of a
    run (a compliant mount then settles again to the load's sag, so the run does not begin by
    ringing) and at the grasp (where the mount rings, as a real one does). The arm controller's
    gravity feed-forward keeps the holding payload (a robot configured for the heavier load);
    before the grasp its servo takes up the rest."""
    plant = station.GetSubsystemByName("slave_plant")
    plant_context = plant.GetMyMutableContextFromRoot(root_context)
    obj = plant.GetBodyByName("object")
    obj.SetSpatialInertiaInBodyFrame(plant_context, obj.default_spatial_inertia() if holding else SpatialInertia.Zero())
    if at_start and plant.HasJointNamed("mount"):
        settle_mount(plant, plant_context, plant.GetJointByName("mount"))
    gripper = plant.GetBodyByName("gripper")
    source = station.GetSubsystemByName("truth_phi")
    source.get_mutable_source_value(source.GetMyMutableContextFromRoot(root_context)).set_value(
        phi_about_S(plant, gripper.body_frame(), [obj, gripper], plant_context))


def MakeSimStation(scenario: Scenario, meshcat=None):
    """The simulated station Diagram for ``scenario`` (validated here); with a ``meshcat``,
    the slave, its load and environment are drawn there live.

    Inputs: ``master.torque_commanded`` (6, N·m), ``slave.position_commanded`` (n, rad: one per joint
    of the slave).
    Outputs: ``master.position_measured``, ``master.velocity_estimated`` (6 each, rad, rad/s),
    ``slave.position_measured``, ``slave.velocity_estimated`` (n each, rad, rad/s),
    ``ft.wrench_measured`` ([f; τ] on the load at S in S), ``ft.acceleration_measured``
    (the accelerometer's reading, ``accelerometer_reading``: [a − g; α] of its point A, in S's
    axes), ``clutch`` (1, held engaged), and
    ``truth.*`` (see ``_add_wrist_sensor``; ``truth.acceleration`` is the kinematic [a; α]).
    """
    scenario.validate()
    robot = slave_arm(scenario)
    check_carried(scenario, load_phi(scenario.load), payload_max(robot), arm_name(robot))
    builder = DiagramBuilder()
    plant, parts = _add_slave(builder, scenario)
    _add_wrist_sensor(builder, scenario, plant, parts)
    _add_master(builder, scenario)
    # The operator holds the clutch engaged throughout.
    builder.ExportOutput(builder.AddNamedSystem("clutch", ConstantVectorSource([1.0])).get_output_port(), CLUTCH)
    if meshcat is not None:
        MeshcatVisualizer.AddToBuilder(builder, builder.GetMutableSubsystemByName("scene_graph"), meshcat)
    diagram = builder.Build()
    diagram.set_name("sim_station")
    return diagram
