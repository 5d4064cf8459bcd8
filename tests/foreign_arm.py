"""A 7-joint arm's URDF in a layout heft did not choose, for the tests of ``robot: custom``: the Franka
Emika Panda's kinematics in the link and joint names of the ROS ``franka_description`` package
(``panda_link0`` … ``panda_link8``, ``panda_joint1`` … ``panda_joint7``, a fixed ``panda_joint8`` to the
flange, a hand turned −45° past it), with no ``<transmission>`` elements.

Kinematics and limits: Franka's published modified DH table (Craig's convention: d1 = 0.333,
d3 = 0.316, a3 = 0.0825, a4 = −0.0825, d5 = 0.384, a6 = 0.088, the flange 0.107 past joint 7) and
joint position, speed and torque limits, as Franka's "Robot and interface specifications" page gives
them (frankaemika.github.io/docs/control_parameters.html; the DH table as transcribed in DQ Robotics'
``FrankaEmikaPandaRobot.cpp``). Link masses: Gaz, Cognetti, Oliva, Robuffo Giordano & De Luca,
"Dynamic identification of the Franka Emika Panda robot with retrieval of feasible parameters using
penalty-based optimization", IEEE RA-L 2019, rounded (recalled, not checked against the paper).
Inertias: each link a uniform cylinder of radius 0.06 m from its joint to the next (a stand-in, not
the Panda's: these tests exercise how heft reads and drives an arm, not this arm's dynamics).
"""

from __future__ import annotations

import math

import numpy as np

H = math.pi / 2
# Craig's modified DH rows (α_{i−1}, a_{i−1}, d_i) of joints 1–7, and the flange past joint 7 (m, rad).
DH = [(0.0, 0.0, 0.333), (-H, 0.0, 0.0), (H, 0.0, 0.316), (H, 0.0825, 0.0), (-H, -0.0825, 0.384), (H, 0.0, 0.0),
      (H, 0.088, 0.0)]
FLANGE = 0.107
LOWER = [-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973]  # rad
UPPER = [2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973]       # rad
VELOCITY = [2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61]                # rad/s
EFFORT = [87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0]                      # N·m
MASSES = [4.97, 0.65, 3.23, 3.59, 1.23, 1.67, 0.74, 0.5]                 # kg, links 0 … 7 (link 0: placeholder)
LINK_RADIUS = 0.06                                                       # m

START = [0.0, 0.0133, 0.0, -2.0551, 0.0, 2.0684, 0.7854]
"""rad: with ``X_FS`` below, S 0.55 m in front of the base and 0.41 m above it, z down (where the bundled
arms' start postures put it), x along the base's x."""
X_FS = "{translation: [0, 0, 0.0175], rotation: !Rpy {deg: [0, 0, -45]}}"
"""The sensor on the flange as a lab would state it: S 17.5 mm out, turned as the hand is."""


def _origin(alpha: float, a: float, d: float) -> tuple[tuple, tuple]:
    """URDF (xyz, rpy) of Rx(α)·Tx(a)·Tz(d) = T(a, −d·sin α, d·cos α)·Rx(α)."""
    return (a, -d * math.sin(alpha), d * math.cos(alpha)), (alpha, 0.0, 0.0)


def _cylinder_inertial(mass: float, to_next: np.ndarray) -> str:
    """A uniform cylinder from the link frame's origin to ``to_next`` (m), about its centre, in link axes."""
    length = max(float(np.linalg.norm(to_next)), 0.05)
    axis = to_next / np.linalg.norm(to_next) if np.linalg.norm(to_next) > 1e-9 else np.array([0.0, 0.0, 1.0])
    transverse = mass * (3 * LINK_RADIUS ** 2 + length ** 2) / 12
    inertia = transverse * np.eye(3) + (mass * LINK_RADIUS ** 2 / 2 - transverse) * np.outer(axis, axis)
    c = to_next / 2
    return (f'<inertial><origin xyz="{c[0]:.6g} {c[1]:.6g} {c[2]:.6g}"/><mass value="{mass}"/>'
            f'<inertia ixx="{inertia[0, 0]:.9g}" ixy="{inertia[0, 1]:.9g}" ixz="{inertia[0, 2]:.9g}" '
            f'iyy="{inertia[1, 1]:.9g}" iyz="{inertia[1, 2]:.9g}" izz="{inertia[2, 2]:.9g}"/></inertial>')


def panda_urdf(drop: str = "") -> str:
    """The URDF text; ``drop`` leaves something out: "inertial" (link 4's), "limit" (joint 3's velocity)."""
    origins = [_origin(*row) for row in DH] + [((0.0, 0.0, FLANGE), (0.0, 0.0, 0.0))]
    links = []
    for i, mass in enumerate(MASSES):
        inertial = "" if drop == "inertial" and i == 4 else _cylinder_inertial(mass, np.array(origins[i][0]))
        links.append(f'<link name="panda_link{i}">{inertial}</link>')
    links.append('<link name="panda_link8"/>')
    links.append('<link name="panda_hand"/>')
    joints = []
    for i in range(7):
        (x, y, z), (r, p, w) = origins[i]
        velocity = "" if drop == "limit" and i == 2 else f' velocity="{VELOCITY[i]}"'
        joints.append(f'<joint name="panda_joint{i + 1}" type="revolute"><parent link="panda_link{i}"/>'
                      f'<child link="panda_link{i + 1}"/><origin xyz="{x:.6g} {y:.6g} {z:.6g}" rpy="{r} {p} {w}"/>'
                      f'<axis xyz="0 0 1"/><limit lower="{LOWER[i]}" upper="{UPPER[i]}"{velocity} '
                      f'effort="{EFFORT[i]}"/></joint>')
    joints.append(f'<joint name="panda_joint8" type="fixed"><parent link="panda_link7"/><child link="panda_link8"/>'
                  f'<origin xyz="0 0 {FLANGE}" rpy="0 0 0"/></joint>')
    joints.append('<joint name="panda_hand_joint" type="fixed"><parent link="panda_link8"/>'
                  f'<child link="panda_hand"/><origin xyz="0 0 0" rpy="0 0 {-math.pi / 4}"/></joint>')
    return '<?xml version="1.0"?>\n<robot name="panda">\n' + "\n".join(links + joints) + "\n</robot>\n"


def custom_scenario_text(urdf: str, extra: str = "") -> str:
    """A scenario's fields for this arm as ``robot: custom`` (its URDF at the path ``urdf``)."""
    return (f"robot: custom\narm:\n  urdf: {urdf}\n  base: panda_link0\n  flange: panda_link8\n  X_FS: {X_FS}\n"
            f"slave_initial_q: {START}\n{extra}")
