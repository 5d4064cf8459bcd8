"""The bundled UR5e and KUKA LBR iiwa 14 URDFs, written from their published numbers.

Run ``python make_arm_models.py`` to rewrite ``ur5e.urdf`` and ``iiwa14.urdf`` in this folder;
``tests/test_models.py`` checks that the files are what this script writes. Pure numpy, no Drake.

Frames as in ``rx90.urdf`` (docs/design.md §4): the root link ``<arm>_base`` is R (mounting
face, z up), the last link ``flange`` is F (origin on the flange face, z out of it), joints
``joint1``… with one ``SimpleTransmission`` each, whose actuator Drake names ``jointN_motor``.
Each link's frame sits on its joint's axis, z along it. Every number and its source: SOURCES.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

HALF_PI = math.pi / 2


@dataclass(frozen=True)
class Link:
    """A link's mass (kg), centre of mass (m) and inertia about it (kg·m²), both in the link frame."""
    name: str
    mass: float
    com: tuple
    inertia: np.ndarray


@dataclass(frozen=True)
class Joint:
    """A revolute joint: its frame in the parent link's (``xyz`` m, ``rpy`` rad, URDF's fixed-axis
    roll-pitch-yaw), axis z; limits in rad, rad/s and N·m."""
    xyz: tuple
    rpy: tuple
    lower: float
    upper: float
    velocity: float
    effort: float


@dataclass(frozen=True)
class Arm:
    name: str
    header: str
    links: list       # base, link 1 … link n−1, flange
    joints: list      # joint 1 … n
    radius: float     # m, the links drawn as cylinders of this radius (visual only)
    colour: str       # "r g b a" of the drawn links


def _rx(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def cylinder_inertia(mass: float, radius: float, length: float) -> np.ndarray:
    """A uniform cylinder's inertia about its centre, axis z (kg·m²)."""
    transverse = mass * (3 * radius ** 2 + length ** 2) / 12
    return np.diag([transverse, transverse, mass * radius ** 2 / 2])


# ---------------------------------------------------------------- UR5e

UR5E_DH = [  # UR's standard DH rows (θ offset, a, d, α) in rad and m
    (0.0, 0.0, 0.1625, HALF_PI),
    (0.0, -0.425, 0.0, 0.0),
    (0.0, -0.3922, 0.0, 0.0),
    (0.0, 0.0, 0.1333, HALF_PI),
    (0.0, 0.0, 0.0997, -HALF_PI),
    (0.0, 0.0, 0.0996, 0.0),
]
UR5E_MASSES = [3.761, 8.058, 2.846, 1.37, 1.3, 0.365]  # kg, links 1–6
UR5E_COMS = [  # m, links 1–6, in UR's DH frame i
    (0.0, -0.02561, 0.00193), (0.2125, 0.0, 0.11336), (0.15, 0.0, 0.0265),
    (0.0, -0.0018, 0.01634), (0.0, 0.0018, 0.01634), (0.0, 0.0, -0.001159)]
UR5E_INERTIAS = [  # kg·m² about the COM, axes of UR's DH frame i: (xx, xy, xz, yy, yz, zz)
    (0.00700210, 0.00000073, -0.00001053, 0.00648091, 0.00049994, 0.00657286),
    (0.01505885, -0.00005400, 0.00000563, 0.33388086, -0.00000181, 0.33247207),
    (0.00399632, -0.00001365, 0.00137272, 0.07879254, -0.00000660, 0.07848510),
    (0.00165491, -0.00000282, -0.00000438, 0.00135962, 0.00010157, 0.00126279),
    (0.00135617, -0.00000274, 0.00000444, 0.00127827, -0.00005048, 0.00096614),
    (0.00018694, 0.00000006, -0.00000017, 0.00018908, -0.00000092, 0.00025756)]
UR5E_WEIGHT = 20.6                         # kg, the whole arm
UR5E_RANGE = math.radians(360.0)           # every joint ±360°
UR5E_SPEED = math.radians(180.0)           # every joint 180°/s
UR5E_EFFORTS = [150.0, 150.0, 150.0, 28.0, 28.0, 28.0]  # N·m
UR5E_BASE_SIZE = (0.0745, 0.09)            # m, radius and height of the base drawn as a cylinder


def _tensor(entries) -> np.ndarray:
    xx, xy, xz, yy, yz, zz = entries
    return np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])


def ur5e() -> Arm:
    """The UR5e. UR's standard DH product Rz(θᵢ)Tz(dᵢ)·Tx(aᵢ)Rx(αᵢ) regrouped: link frame i is UR's
    DH frame i less its trailing Tx(aᵢ)Rx(αᵢ) (so it lies on joint i's axis), joint i+1 sits at
    Tx(aᵢ)Rx(αᵢ)·Tz(dᵢ₊₁) in it. UR's DH frame 0 is R and frame 6 is F (a₆ = α₆ = 0)."""
    links = [Link("ur5e_base", UR5E_WEIGHT - sum(UR5E_MASSES), (0.0, 0.0, UR5E_BASE_SIZE[1] / 2),
                  cylinder_inertia(UR5E_WEIGHT - sum(UR5E_MASSES), *UR5E_BASE_SIZE))]
    for i, (mass, com, inertia) in enumerate(zip(UR5E_MASSES, UR5E_COMS, UR5E_INERTIAS)):
        _, a, _, alpha = UR5E_DH[i]
        R = _rx(alpha)  # UR's DH frame i in link frame i, offset by a along x
        links.append(Link("flange" if i == 5 else f"ur5e_link{i + 1}", mass,
                          tuple(R @ np.array(com) + [a, 0.0, 0.0]), R @ _tensor(inertia) @ R.T))
    joints = []
    for i, (_, _, d, _) in enumerate(UR5E_DH):
        _, a, _, alpha = UR5E_DH[i - 1] if i else (0.0, 0.0, 0.0, 0.0)
        xyz = (a, -d * math.sin(alpha), d * math.cos(alpha))  # Tx(a)·Rx(α)·Tz(d)
        joints.append(Joint(xyz, (alpha, 0.0, 0.0), -UR5E_RANGE, UR5E_RANGE, UR5E_SPEED, UR5E_EFFORTS[i]))
    return Arm("ur5e", "Universal Robots UR5e (5 kg payload)", links, joints, 0.045, "0.62 0.75 0.85 1")


# ---------------------------------------------------------------- KUKA LBR iiwa 14 R820

IIWA14_ORIGINS = [  # joint i's frame in link i−1's (xyz m, rpy rad)
    ((0.0, 0.0, 0.1575), (0.0, 0.0, 0.0)),
    ((0.0, 0.0, 0.2025), (HALF_PI, 0.0, math.pi)),
    ((0.0, 0.2045, 0.0), (HALF_PI, 0.0, math.pi)),
    ((0.0, 0.0, 0.2155), (HALF_PI, 0.0, 0.0)),
    ((0.0, 0.1845, 0.0), (-HALF_PI, math.pi, 0.0)),
    ((0.0, 0.0, 0.2155), (HALF_PI, 0.0, 0.0)),
    ((0.0, 0.081, 0.0), (-HALF_PI, math.pi, 0.0)),
]
IIWA14_FLANGE = 0.045  # m, link 7's frame to the flange face, along its z
IIWA14_LINKS = [  # link 0 (base) … 7: mass kg, COM m, (Ixx, Iyy, Izz) kg·m² about it, in the link frame
    (5.0, (-0.1, 0.0, 0.07), (0.05, 0.06, 0.03)),
    (5.76, (0.0, -0.03, 0.12), (0.033, 0.0333, 0.0123)),
    (6.35, (0.0003, 0.059, 0.042), (0.0305, 0.0304, 0.011)),
    (3.5, (0.0, 0.03, 0.13), (0.025, 0.0238, 0.0076)),
    (3.5, (0.0, 0.067, 0.034), (0.017, 0.0164, 0.006)),
    (3.5, (0.0001, 0.021, 0.076), (0.01, 0.0087, 0.00449)),
    (1.8, (0.0, 0.0006, 0.0004), (0.0049, 0.0047, 0.0036)),
    (1.2, (0.0, 0.0, 0.02), (0.001, 0.001, 0.001)),
]
IIWA14_WEIGHT = 29.9                                               # kg, the whole arm
IIWA14_RANGES = [170.0, 120.0, 170.0, 120.0, 170.0, 120.0, 175.0]  # ±°
IIWA14_SPEEDS = [85.0, 85.0, 100.0, 75.0, 130.0, 135.0, 135.0]     # °/s
IIWA14_EFFORTS = [320.0, 320.0, 176.0, 176.0, 110.0, 40.0, 40.0]   # N·m


def iiwa14() -> Arm:
    """The LBR iiwa 14 R820, its link frames those of its published description but for the last:
    joint 7 carries the flange F, on the flange face, 0.045 m along link 7's z (the same axis)."""
    base_mass = IIWA14_WEIGHT - sum(mass for mass, _, _ in IIWA14_LINKS[1:])
    scale = base_mass / IIWA14_LINKS[0][0]  # the base's inertia scaled with its mass
    links = [Link("iiwa14_base", base_mass, IIWA14_LINKS[0][1], scale * np.diag(IIWA14_LINKS[0][2]))]
    for i, (mass, com, moments) in enumerate(IIWA14_LINKS[1:], start=1):
        if i == 7:
            links.append(Link("flange", mass, (com[0], com[1], com[2] - IIWA14_FLANGE), np.diag(moments)))
        else:
            links.append(Link(f"iiwa14_link{i}", mass, com, np.diag(moments)))
    joints = []
    for i, (xyz, rpy) in enumerate(IIWA14_ORIGINS):
        if i == 6:  # the child frame moved along its own z (here the parent's y) to the flange face
            xyz = (xyz[0], xyz[1] + IIWA14_FLANGE, xyz[2])
        limit = math.radians(IIWA14_RANGES[i])
        joints.append(Joint(xyz, rpy, -limit, limit, math.radians(IIWA14_SPEEDS[i]), IIWA14_EFFORTS[i]))
    return Arm("iiwa14", "KUKA LBR iiwa 14 R820 (14 kg payload)", links, joints, 0.065, "1 0.42 0.04 1")


# ---------------------------------------------------------------- URDF text

def _num(x: float) -> str:
    x = float(x)
    return "0" if x == 0 else repr(x)


def _vec(v) -> str:
    return " ".join(_num(x) for x in v)


def _rpy_of_z_to(d: np.ndarray) -> tuple:
    """URDF roll-pitch-yaw (rad) of a rotation taking z to the unit vector ``d``."""
    axis, cosine = np.cross([0.0, 0.0, 1.0], d), float(np.clip(d[2], -1.0, 1.0))
    if np.linalg.norm(axis) < 1e-12:
        return (0.0, 0.0, 0.0) if cosine > 0 else (math.pi, 0.0, 0.0)
    k = axis / np.linalg.norm(axis)
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    angle = math.acos(cosine)
    R = np.eye(3) + math.sin(angle) * K + (1 - cosine) * K @ K
    return (math.atan2(R[2, 1], R[2, 2]), math.atan2(-R[2, 0], math.hypot(R[2, 1], R[2, 2])),
            math.atan2(R[1, 0], R[0, 0]))


def _cylinder(name: str, centre, rpy, radius: float, length: float, material: str) -> list[str]:
    return [f'    <visual name="{name}">', f'      <origin xyz="{_vec(centre)}" rpy="{_vec(rpy)}"/>',
            f'      <geometry><cylinder radius="{_num(radius)}" length="{_num(length)}"/></geometry>',
            f'      <material name="{material}"/>', "    </visual>"]


def _visuals(arm: Arm, i: int) -> list[str]:
    """Link i drawn: the base a cylinder up to joint 1; a link a cylinder on its joint's axis and one
    from its origin to the next joint's; the flange a disc under its face."""
    r, name = arm.radius, arm.links[i].name
    if i == len(arm.links) - 1:
        return _cylinder(name, (0.0, 0.0, -0.005), (0.0, 0.0, 0.0), 0.7 * r, 0.01, arm.name)
    lines = [] if i == 0 else _cylinder(f"{name}_joint", (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), r, 2 * r, arm.name)
    to_next = np.array(arm.joints[i].xyz, dtype=float)
    length = float(np.linalg.norm(to_next))
    if length > 1e-9:
        lines += _cylinder(name, to_next / 2, _rpy_of_z_to(to_next / length), 0.8 * r, length, arm.name)
    return lines


def urdf(arm: Arm) -> str:
    """The URDF text of ``arm``."""
    lines = ['<?xml version="1.0"?>', "<!--", f"  {arm.header}, a slave arm bundled with heft.",
             "  Written by diagrams/models/make_arm_models.py from published numbers; sources in SOURCES.md.",
             f"  {arm.links[0].name} = R (mounting face, z up); flange = F (on the flange face, z out of it).",
             "  Each link frame sits on its joint's axis, z along it. Visual geometry only (drawn, not the",
             "  arm's shape): a cylinder on each joint's axis and one from it to the next joint.",
             "-->", f'<robot name="{arm.name}">',
             f'  <material name="{arm.name}"><color rgba="{arm.colour}"/></material>']
    for i, link in enumerate(arm.links):
        I = link.inertia
        lines += [f'  <link name="{link.name}">', "    <inertial>",
                  f'      <origin xyz="{_vec(link.com)}" rpy="0 0 0"/>', f'      <mass value="{_num(link.mass)}"/>',
                  f'      <inertia ixx="{_num(I[0, 0])}" ixy="{_num(I[0, 1])}" ixz="{_num(I[0, 2])}" '
                  f'iyy="{_num(I[1, 1])}" iyz="{_num(I[1, 2])}" izz="{_num(I[2, 2])}"/>',
                  "    </inertial>", *_visuals(arm, i), "  </link>"]
    for i, joint in enumerate(arm.joints):
        lines += [f'  <joint name="joint{i + 1}" type="revolute">', f'    <parent link="{arm.links[i].name}"/>',
                  f'    <child link="{arm.links[i + 1].name}"/>',
                  f'    <origin xyz="{_vec(joint.xyz)}" rpy="{_vec(joint.rpy)}"/>', '    <axis xyz="0 0 1"/>',
                  f'    <limit lower="{_num(joint.lower)}" upper="{_num(joint.upper)}" '
                  f'velocity="{_num(joint.velocity)}" effort="{_num(joint.effort)}"/>', "  </joint>"]
    for i in range(len(arm.joints)):
        lines += [f'  <transmission name="joint{i + 1}_transmission">',
                  "    <type>transmission_interface/SimpleTransmission</type>",
                  f'    <joint name="joint{i + 1}"><hardwareInterface>hardware_interface/EffortJointInterface'
                  "</hardwareInterface></joint>",
                  f'    <actuator name="joint{i + 1}_motor"><mechanicalReduction>1</mechanicalReduction></actuator>',
                  "  </transmission>"]
    return "\n".join(lines + ["</robot>", ""])


ARMS = {"ur5e.urdf": ur5e, "iiwa14.urdf": iiwa14}
"""The files this script writes, by name, and the arm each holds."""


def main() -> None:
    here = Path(__file__).resolve().parent
    for name, arm in ARMS.items():
        (here / name).write_text(urdf(arm()))
        print(f"wrote {here / name}")


if __name__ == "__main__":
    main()
