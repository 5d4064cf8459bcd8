"""The plants of heft's robots, built in one place: the slave arm with its JR3 and load,
and the master. The simulated station, the controller, identification, the stand-in,
replay and the analyses all take their models from here.

Sources of every number: the URDFs under ``diagrams/models`` (their own comments).
"""

from __future__ import annotations

import dataclasses

import numpy as np
from pydrake.math import RigidTransform
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import (FixedOffsetFrame, LinearBushingRollPitchYaw, QuaternionFloatingJoint,
                                    RotationalInertia, SpatialInertia)

from heft.diagrams import mount
from heft.diagrams.arm_params import BUNDLED_ARMS, ArmParams
from heft.diagrams.master_params import BUNDLED_MASTERS, DEFAULT_MASTER
from heft.diagrams.models import model_path
from heft.diagrams.scenario import LoadSpec, MountSpec, Scenario
from heft.diagrams.tool_check import check_inertia
from heft.diagrams.urdf_arm import AddArmFromUrdf, ArmChain
from heft.systems.load_dynamics import GRAVITY_W, InertialParameters, inertia_entries, inertia_matrix
from heft.systems.controller.master_kinematics import BASE_FRAME, STYLUS_FRAME


@dataclasses.dataclass
class SlaveParts:
    """Handles into a plant holding the slave arm, its wrist sensor and load."""
    arm: object                 # ModelInstanceIndex of the arm
    chain: ArmChain             # the arm's base R, flange F, joints and actuators base to flange, limits
    sensor_body: object         # the JR3 body; its frame is on the flange
    S: object                   # the sensor frame S
    load_bodies: list           # bodies below S (tool, or gripper and object, or custom)
    sensor_weld: object         # the weld joint at S whose reaction is the FT measurement
    gripper_bodies: list        # the gripper part of a gripper_object load (else empty)
    mount_joint: object = None  # a compliant mount's floating joint (mount plate → load), else None


def _custom_load_inertia(spec) -> SpatialInertia:
    load = InertialParameters(spec.mass, spec.com, inertia_matrix(spec.inertia_com)).require_physical("load")
    check_inertia(spec)
    I = load.inertia_com
    return SpatialInertia.MakeFromCentralInertia(
        load.mass, load.com, RotationalInertia(I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]))


Robot = str | ArmParams
"""A slave arm as the builders take it: a bundled arm's name (``BUNDLED_ARMS``), or a custom arm's
``ArmParams`` (its URDF's path absolute, or relative to the working directory)."""


def slave_arm(scenario: Scenario) -> Robot:
    """The scenario's slave arm: its ``robot``, or for ``robot: custom`` its ``arm`` section."""
    return scenario.arm if scenario.robot == "custom" else scenario.robot


def arm_params(robot: Robot) -> ArmParams:
    """The URDF and links of ``robot``: a bundled arm's model file, ``<name>_base`` and ``flange``."""
    if isinstance(robot, ArmParams):
        return robot
    if robot not in BUNDLED_ARMS:
        raise ValueError(f"no bundled arm {robot!r}; bundled: {', '.join(BUNDLED_ARMS)}")
    return ArmParams(urdf=model_path(f"{robot}.urdf"), base=f"{robot}_base", flange="flange")


def arm_name(robot: Robot) -> str:
    """The name reports give ``robot``: a bundled arm's, else the custom arm's URDF file name."""
    return robot if isinstance(robot, str) else arm_params(robot).urdf_path().name


def payload_max(robot: Robot) -> float:
    """The arm's rated payload (kg; inf where a custom arm states none)."""
    return BUNDLED_ARMS[robot].payload if isinstance(robot, str) else robot.payload


def AddArmWithSensor(plant: MultibodyPlant, robot: Robot):
    """Adds the arm ``robot`` (``AddArmFromUrdf``: base welded at W = R, every joint actuated) and the JR3 on
    its flange: a bundled arm's on the flange face, a custom arm's with S at its ``X_FS``; returns (the arm's
    chain, the sensor body, the sensor frame S). A custom arm's URDF that lacks what heft needs is refused
    (``ArmRefused``, one line)."""
    params = arm_params(robot)
    chain = AddArmFromUrdf(plant, params)
    parser = Parser(plant)
    parser.SetAutoRenaming(True)
    (sensor_instance,) = parser.AddModels(model_path("jr3_sensor.urdf"))
    sensor_body = plant.GetBodyByName("jr3_sensor", sensor_instance)
    S = plant.GetFrameByName("S", sensor_instance)
    X_FJ = RigidTransform() if isinstance(robot, str) else (
        params.X_FS.GetDeterministicValue() @ S.GetFixedPoseInBodyFrame().inverse())
    plant.WeldFrames(chain.flange, sensor_body.body_frame(), X_FJ)
    return chain, sensor_body, S


def _add_compliant_mount(plant: MultibodyPlant, S, load_body, spec: MountSpec):
    """The load on ``spec``'s spring-damper below S: a massless mount plate welded at S (its weld's
    reaction is then what the sensor measures), the load free on a floating joint from it, and
    the bushing between the two at ``spec.at`` (S when None), its frames there at rest. Returns
    (weld, floating joint)."""
    plate = plant.AddRigidBody("mount_plate", load_body.model_instance(), SpatialInertia.Zero())
    weld = plant.WeldFrames(S, plate.body_frame())
    joint = plant.AddJoint(QuaternionFloatingJoint("mount", plate.body_frame(), load_body.body_frame()))
    at = RigidTransform(np.asarray(spec.at if spec.at is not None else np.zeros(3), dtype=float))
    plant.AddForceElement(LinearBushingRollPitchYaw(
        plant.AddFrame(FixedOffsetFrame("mount_plate_at", plate.body_frame(), at)),
        plant.AddFrame(FixedOffsetFrame("mount_load_at", load_body.body_frame(), at)),
        spec.torque_stiffness, spec.torque_damping, spec.force_stiffness, spec.force_damping))
    return weld, joint


def _add_load(plant: MultibodyPlant, spec: LoadSpec) -> tuple[list, list]:
    """Adds the load ``spec`` describes (frames at S once welded there); returns (its bodies, the
    gripper's among them: none but for a "gripper_object")."""
    parser = Parser(plant)
    parser.SetAutoRenaming(True)
    if spec.kind == "tool":
        (instance,) = parser.AddModels(model_path("tool.urdf"))
        return [plant.GetBodyByName("tool", instance)], []
    if spec.kind == "gripper_object":
        (instance,) = parser.AddModels(model_path("gripper_object.urdf"))
        gripper, obj = plant.GetBodyByName("gripper", instance), plant.GetBodyByName("object", instance)
        plant.WeldFrames(gripper.body_frame(), obj.body_frame())
        return [gripper, obj], [gripper]
    instance = plant.AddModelInstance("custom_load")
    return [plant.AddRigidBody("load", instance, _custom_load_inertia(spec))], []


def AddSlave(plant: MultibodyPlant, scenario: Scenario, mount_compliance: bool = False,
             mount_constants: MountSpec | None = None) -> SlaveParts:
    """Adds the arm with its JR3 (``AddArmWithSensor``) and the scenario's load at S: welded, or on
    a compliant mount with ``mount_compliance`` (the simulated station's physics; models of the
    load for control and analysis stay rigid) of ``mount_constants``, by default the scenario's
    mount as the station builds it (``mount_for``)."""
    chain, sensor_body, S = AddArmWithSensor(plant, slave_arm(scenario))
    if len(scenario.slave_initial_q) != chain.num_joints:
        raise ValueError(f"scenario field 'slave_initial_q' needs {chain.num_joints} joint angles (rad) for the arm "
                         f"{arm_name(slave_arm(scenario))}; got {len(scenario.slave_initial_q)}")
    outside = [f"joint {j + 1} at {q:g} outside [{lo:g}, {hi:g}]" for j, (q, lo, hi) in
               enumerate(zip(scenario.slave_initial_q, chain.lower, chain.upper)) if not lo <= q <= hi]
    if outside:
        raise ValueError("scenario field 'slave_initial_q' must lie within the joint limits (rad): "
                         + "; ".join(outside))
    load_bodies, gripper_bodies = _add_load(plant, scenario.load)
    if mount_compliance and not scenario.load.mount.rigid:
        weld, joint = _add_compliant_mount(plant, S, load_bodies[0], mount_constants or mount_for(scenario))
    else:
        weld, joint = plant.WeldFrames(S, load_bodies[0].body_frame()), None
    return SlaveParts(chain.instance, chain, sensor_body, S, load_bodies, weld, gripper_bodies, joint)


def load_phi(spec: LoadSpec) -> np.ndarray:
    """φ (Eq. 6) of the load ``spec`` describes, about S in S."""
    plant = MultibodyPlant(time_step=0.0)
    bodies, _ = _add_load(plant, spec)
    plant.WeldFrames(plant.world_frame(), bodies[0].body_frame())
    plant.Finalize()
    return phi_about_S(plant, bodies[0].body_frame(), bodies)


def mount_modes(scenario: Scenario, constants: MountSpec) -> mount.Modes:
    """The modes of the scenario's load on a mount of ``constants`` with the arm beside it free, in
    its start pose: the plant's mass matrix, the bushing's stiffness and damping at the mount's
    coordinates (``diagrams/mount.py``: the modes the plant's step must integrate)."""
    plant = MultibodyPlant(time_step=0.0)
    parts = AddSlave(plant, scenario, mount_compliance=True, mount_constants=constants)
    plant.Finalize()
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, parts.arm, scenario.slave_initial_q)
    M = plant.CalcMassMatrix(context)
    K, C = np.zeros_like(M), np.zeros_like(M)
    at = slice(parts.mount_joint.velocity_start(), parts.mount_joint.velocity_start() + 6)
    K[at, at], C[at, at] = mount.stiffness(constants), mount.damping(constants)
    return mount.modes(M, K, C)


def mount_for(scenario: Scenario) -> MountSpec:
    """The scenario's compliant mount as the station builds it (``mount.fitted_to_step``): each
    constant the scenario states, the rest ``DEFAULT_MOUNT``'s sized for the load; an unstated mount
    placed or softened until the plant's step integrates its every mode with the arm beside it
    (``mount_modes``); a stated one the step cannot integrate refused (ValueError) with what to change."""
    return mount.fitted_to_step(scenario.load.mount, load_phi(scenario.load), load_phi(LoadSpec(kind="tool")),
                                scenario.plant.time_step, lambda constants: mount_modes(scenario, constants))


def phi_about_S(plant: MultibodyPlant, S, bodies, context=None) -> np.ndarray:
    """φ (Eq. 6) of ``bodies`` about S's origin in S, from the plant's own composite inertia (in
    ``context``, else the default one)."""
    context = context or plant.CreateDefaultContext()
    M = plant.CalcSpatialInertia(context, S, [b.index() for b in bodies])
    return np.concatenate(([M.get_mass()], M.get_mass() * M.get_com(),
                           inertia_entries(M.CalcRotationalInertia().CopyToFullMatrix3())))


def AddMaster(plant: MultibodyPlant, X_WB: RigidTransform | None = None, master: str = DEFAULT_MASTER):
    """Adds the bundled master ``master`` (``BUNDLED_MASTERS``; default the Phantom Premium 1.5 6DoF) with its
    base B welded at ``X_WB`` (default: B = W); returns (its model instance, B, the stylus frame E)."""
    if master not in BUNDLED_MASTERS:
        raise ValueError(f"no bundled master {master!r}; bundled: {', '.join(BUNDLED_MASTERS)}")
    (instance,) = Parser(plant).AddModels(model_path(f"{master}.urdf"))
    B = plant.GetFrameByName(BASE_FRAME, instance)
    plant.WeldFrames(plant.world_frame(), B, X_WB or RigidTransform())
    return instance, B, plant.GetFrameByName(STYLUS_FRAME, instance)


def MakeMasterPlant(master: str = DEFAULT_MASTER) -> MultibodyPlant:
    """The master ``master`` (``AddMaster``) alone, as a finalized continuous plant: the kinematic model of
    the controller and the analyses."""
    plant = MultibodyPlant(time_step=0.0)
    AddMaster(plant, master=master)
    plant.Finalize()
    return plant


def master_actuated(plant: MultibodyPlant) -> np.ndarray:
    """1.0 for each of the master's joints (in ``plant``'s position order: a master plant alone,
    ``MakeMasterPlant``) that an actuator drives (its URDF's ``<transmission>``), else 0.0."""
    actuated = np.zeros(plant.num_positions())
    for index in plant.GetJointActuatorIndices():
        actuated[plant.get_joint_actuator(index).joint().position_start()] = 1.0
    return actuated


def MakeArmPlant(robot: Robot) -> tuple[MultibodyPlant, object]:
    """(finalized continuous plant of the arm ``robot`` with its JR3, its sensor frame S): the
    kinematic model a controller or an analysis needs (no load)."""
    plant = MultibodyPlant(time_step=0.0)
    _, _, S = AddArmWithSensor(plant, robot)
    plant.Finalize()
    return plant, S


def MakeSlavePlant(scenario: Scenario) -> tuple[MultibodyPlant, SlaveParts]:
    """(finalized continuous plant of the scenario's arm, JR3 and load under gravity, its parts)."""
    plant = MultibodyPlant(time_step=0.0)
    parts = AddSlave(plant, scenario)
    plant.mutable_gravity_field().set_gravity_vector(GRAVITY_W)
    plant.Finalize()
    return plant, parts
