"""A lab's own slave arm from its URDF (``ArmParams``): the serial chain from its base to its flange,
with the limits heft needs, or a refusal in one line.

heft needs, of every joint between ``base`` and ``flange``: a revolute or prismatic joint with a
``<limit>`` whose ``lower`` < ``upper`` are finite and whose ``velocity`` and ``effort`` are finite
and > 0, and whose link has a mass > 0 and a physically valid inertia; of the URDF: one unbranched
chain, no joint that moves anything off it, 6 or 7 joints. The limits are read from the URDF's own
``<limit>`` elements (Drake keeps an effort only with a ``<transmission>``, and stops on a lower limit
above the upper one), then the file is parsed by Drake. A joint without a ``<transmission>`` gets an
actuator of its URDF effort, so that every joint of the chain is driven, in the chain's order.
"""

from __future__ import annotations

import dataclasses
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
from pydrake.math import RigidTransform
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import JointActuatorIndex

from heft.diagrams.arm_params import ArmParams
from heft.systems.serial_chain import CHAIN_JOINTS


_UNITS = {"revolute": ("rad", "rad/s", "N·m"), "prismatic": ("m", "m/s", "N")}


class ArmRefused(ValueError):
    """A URDF that lacks what heft needs; its message is one line naming the file and what is missing."""


@dataclasses.dataclass
class ArmChain:
    """The arm as added to a plant: its model instance, the frames R (``base``) and F (``flange``), the
    joints from R to F and their actuators, and their limits (n,) in the joints' units (rad or m; per s;
    N·m or N)."""
    instance: object
    base: object
    flange: object
    joints: list
    actuators: list
    lower: np.ndarray
    upper: np.ndarray
    velocity: np.ndarray
    effort: np.ndarray

    @property
    def num_joints(self) -> int:
        return len(self.joints)


def AddArmFromUrdf(plant: MultibodyPlant, params: ArmParams, relative_to=None) -> ArmChain:
    """Adds the arm ``params`` gives (its URDF relative to the folder ``relative_to``) to the unfinalized
    ``plant``, its base frame welded at the world's origin; returns its chain. Raises ``ArmRefused``
    (one line) for a file that cannot be read or lacks what heft needs (module notes)."""
    path = params.urdf_path(relative_to)
    try:
        params.validate()
    except ValueError as error:
        raise ArmRefused(f"arm: {error}") from None

    def refuse(what: str):
        raise ArmRefused(f"arm URDF {path}: {what}")

    if not path.is_file():
        refuse("no such file")
    limits = _urdf_limits(path, refuse)
    parser = Parser(plant)
    parser.SetAutoRenaming(True)
    try:
        (instance,) = parser.AddModels(str(path))
    except (RuntimeError, ValueError) as error:
        refuse("Drake cannot parse it: " + _one_line(str(error)))
    links = [plant.get_body(index).name() for index in plant.GetBodyIndices(instance)]
    for role in ("base", "flange"):
        if not plant.HasBodyNamed(getattr(params, role), instance):
            refuse(f"no link '{getattr(params, role)}' for the {role} (links: {', '.join(links)})")
    base = plant.GetBodyByName(params.base, instance)
    flange = plant.GetBodyByName(params.flange, instance)
    inboard = {plant.get_joint(index).child_body().index(): plant.get_joint(index)
               for index in plant.GetJointIndices(instance)}
    chain, body = [], flange
    while body.index() != base.index():
        joint = inboard.get(body.index())
        if joint is None:
            refuse(f"link '{params.flange}' is not below link '{params.base}' in the URDF's tree")
        chain.append(joint)
        body = joint.parent_body()
    chain.reverse()
    on_chain = {joint.index() for joint in chain}
    for index in plant.GetJointIndices(instance):
        joint = plant.get_joint(index)
        if joint.num_positions() > 0 and index not in on_chain:
            refuse(f"joint '{joint.name()}' moves link '{joint.child_body().name()}', which is not between "
                   f"'{params.base}' and '{params.flange}': heft takes an unbranched arm")
    moving = [joint for joint in chain if joint.num_positions() > 0]
    for joint in moving:
        if joint.type_name() not in _UNITS:
            refuse(f"joint '{joint.name()}' is {joint.type_name()}: heft takes revolute and prismatic joints")
    if len(moving) not in CHAIN_JOINTS:
        refuse(f"the chain from '{params.base}' to '{params.flange}' has {len(moving)} joints "
               f"({', '.join(j.name() for j in moving) or 'none'}); heft takes "
               + " or ".join(str(n) for n in CHAIN_JOINTS))
    rows = [_checked_limits(joint.name(), joint.type_name(), limits.get(joint.name()), refuse) for joint in moving]
    for joint in moving:
        body = joint.child_body()
        if not (body.default_mass() > 0 and body.default_spatial_inertia().IsPhysicallyValid()):
            refuse(f"link '{body.name()}' (moved by joint '{joint.name()}') has no mass or no physical inertia: "
                   "heft needs its <inertial> (mass > 0, a valid inertia)")
    _weld_base(plant, base, inboard)
    lower, upper, velocity, effort = (np.array(column, dtype=float) for column in zip(*rows))
    actuators = _actuators(plant, instance, moving, effort, refuse)
    return ArmChain(instance, base.body_frame(), flange.body_frame(), moving, actuators, lower, upper, velocity,
                    effort)


def read_arm(params: ArmParams, relative_to=None) -> tuple[MultibodyPlant, ArmChain]:
    """(a finalized continuous plant of the arm alone, its chain): ``AddArmFromUrdf`` into a new plant."""
    plant = MultibodyPlant(time_step=0.0)
    chain = AddArmFromUrdf(plant, params, relative_to)
    plant.Finalize()
    return plant, chain


def _one_line(text: str) -> str:
    return " ".join(text.split())


def _urdf_limits(path: Path, refuse) -> dict:
    """{joint name: (URDF type, its <limit>'s attributes or None)} of every joint in the file; refuses
    a file that is not XML, and a lower limit above the upper one anywhere (which Drake would stop on)."""
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as error:
        refuse(f"not readable as XML: {error}")
    joints = {}
    for joint in root.findall("joint"):
        name, element = joint.get("name", ""), joint.find("limit")
        attributes = None if element is None else dict(element.attrib)
        joints[name] = (joint.get("type", ""), attributes)
        if attributes and "lower" in attributes and "upper" in attributes:
            lower, upper = _number(attributes["lower"]), _number(attributes["upper"])
            if not (lower is not None and upper is not None and math.isfinite(lower) and math.isfinite(upper)
                    and lower < upper):
                refuse(f"joint '{name}' has the position limits lower={attributes['lower']!r} "
                       f"upper={attributes['upper']!r}: they must be finite numbers, lower below upper")
    return joints


def _number(text: str) -> float | None:
    try:
        return float(text)
    except ValueError:
        return None


def _checked_limits(name: str, kind: str, entry, refuse) -> tuple[float, float, float, float]:
    """(lower, upper, velocity, effort) of the chain's joint ``name`` from its URDF entry, or a refusal
    naming what is missing or not physical."""
    position_unit, velocity_unit, effort_unit = _UNITS[kind]
    urdf_type, attributes = entry if entry is not None else ("", None)
    if urdf_type == "continuous":
        refuse(f"joint '{name}' is continuous: heft needs a revolute joint with position limits")
    if attributes is None:
        refuse(f"joint '{name}' has no <limit>: heft needs its lower, upper, velocity and effort")
    missing = [key for key in ("lower", "upper", "velocity", "effort") if key not in attributes]
    if missing:
        refuse(f"joint '{name}' has no {' and no '.join(missing)} in its <limit>")
    lower, upper = float(attributes["lower"]), float(attributes["upper"])  # checked by _urdf_limits
    values = {}
    for key, unit in (("velocity", velocity_unit), ("effort", effort_unit)):
        value = _number(attributes[key])
        if value is None or not math.isfinite(value) or value <= 0:
            refuse(f"joint '{name}' has {key}={attributes[key]!r}: it must be a finite number > 0 ({unit})")
        values[key] = value
    return lower, upper, values["velocity"], values["effort"]


def _actuators(plant: MultibodyPlant, instance, joints: list, effort: np.ndarray, refuse) -> list:
    """The actuators of ``joints`` in their order: the URDF's transmissions', and one of the joint's
    ``effort`` added for each joint without one; refuses transmissions that leave the actuators out of the
    chain's order (the plant takes its actuation in the actuators' order)."""
    def instance_actuators():  # by index (GetJointActuatorIndices is empty before Finalize)
        found = (plant.get_joint_actuator(JointActuatorIndex(i)) for i in range(plant.num_actuators()))
        return [actuator for actuator in found if actuator.model_instance() == instance]

    driven = {actuator.joint().index() for actuator in instance_actuators()}
    for joint, limit in zip(joints, effort):
        if joint.index() not in driven:
            plant.AddJointActuator(f"{joint.name()}_motor", joint, float(limit))
    actuators = instance_actuators()
    if [actuator.joint().name() for actuator in actuators] != [joint.name() for joint in joints]:
        refuse(f"its transmissions drive the joints in the order "
               f"{', '.join(actuator.joint().name() for actuator in actuators)}: give one for every joint of the "
               "chain, base to flange, or none")
    return actuators


def _weld_base(plant: MultibodyPlant, base, inboard: dict) -> None:
    """Welds the base's root link to the world so that the base frame is at the world's origin (the
    base's links above it are welds: any other joint was refused); nothing if the URDF welds it already."""
    X_RootBase, body = RigidTransform(), base
    while body.index() in inboard:
        joint = inboard[body.index()]
        X_PC = (joint.frame_on_parent().GetFixedPoseInBodyFrame() @ joint.X_FM()
                @ joint.frame_on_child().GetFixedPoseInBodyFrame().inverse())
        X_RootBase = X_PC @ X_RootBase
        body = joint.parent_body()
    if body.index() != plant.world_body().index():
        plant.WeldFrames(plant.world_frame(), body.body_frame(), X_RootBase.inverse())
