"""Mass properties of heft's own robot and load models, from primitive solids.

Run ``python make_tool_inertia.py`` to print every mass, centre of mass and
inertia that the URDF files in this folder carry; the files hold these numbers
(rounded to 9 significant digits), and ``tests/test_models.py`` checks that
they still agree. Pure numpy, no Drake, so it runs anywhere.

Conventions (see docs/design.md §4): SI units; a body's inertia is the 3×3
tensor about its centre of mass, expressed in the body frame, with products of
inertia as tensor entries (I_xy = −∫ x y dm), which is what URDF and Drake's
``RotationalInertia`` expect.

The JR3 sensor (``jr3_sensor`` with its frame S) is in ``jr3_sensor.urdf``, on
its own; the loads are in ``tool.urdf`` (``tool``) and ``gripper_object.urdf``
(``gripper``, ``object``). The station builder welds the flange F to
``jr3_sensor`` and S to the load, both with the identity. Load bodies have
their frame origin AT S, axes parallel to S, z pointing away from the robot.
Their geometry starts at the sensor's tool-side face, ``JR3_S_TO_TOOL_FACE`` =
17.5 mm from S along +z.

What is measured, what is cited and what is estimated is listed in SOURCES.md.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

STEEL = 7850.0      # kg/m³
ALUMINIUM = 2700.0  # kg/m³
GRAVITY = 9.81      # m/s², only for the effort-limit estimate

# ---------------------------------------------------------------- primitive solids


@dataclass(frozen=True)
class Solid:
    """A homogeneous box, cylinder or sphere, axis-aligned in the frame it is given in.

    ``size``: box (x, y, z) edge lengths; cylinder (radius, length); sphere (radius,).
    ``axis``: a cylinder's axis, "x", "y" or "z". Give either ``density`` or ``mass``.
    """
    name: str
    shape: str
    size: tuple
    center: tuple
    density: float | None = None
    mass_kg: float | None = None
    axis: str = "z"

    @property
    def volume(self) -> float:
        if self.shape == "box":
            return float(np.prod(self.size))
        if self.shape == "cylinder":
            r, length = self.size
            return float(np.pi * r * r * length)
        if self.shape == "sphere":
            return float(4.0 / 3.0 * np.pi * self.size[0] ** 3)
        raise ValueError(f"unknown shape {self.shape!r}")

    @property
    def mass(self) -> float:
        if self.mass_kg is not None:
            return float(self.mass_kg)
        return self.density * self.volume

    @property
    def com(self) -> np.ndarray:
        return np.asarray(self.center, dtype=float)

    def central_inertia(self) -> np.ndarray:
        """Inertia about the solid's own centre, in the axes it is given in."""
        m = self.mass
        if self.shape == "box":
            a, b, c = self.size
            return m / 12.0 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])
        if self.shape == "cylinder":
            r, length = self.size
            axial = 0.5 * m * r * r
            transverse = m * (3.0 * r * r + length * length) / 12.0
            k = "xyz".index(self.axis)
            diag = np.full(3, transverse)
            diag[k] = axial
            return np.diag(diag)
        if self.shape == "sphere":
            return np.eye(3) * 0.4 * m * self.size[0] ** 2
        raise ValueError(f"unknown shape {self.shape!r}")


def compose(solids) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass, centre of mass, inertia about that centre) of rigidly joined solids,
    by the parallel-axis theorem. All solids in one frame."""
    masses = np.array([s.mass for s in solids])
    total = masses.sum()
    com = sum(m * s.com for m, s in zip(masses, solids)) / total
    inertia = np.zeros((3, 3))
    for m, s in zip(masses, solids):
        d = s.com - com
        inertia += s.central_inertia() + m * (d @ d * np.eye(3) - np.outer(d, d))
    return float(total), com, inertia


def inertia_about_origin(mass: float, com, inertia_com) -> np.ndarray:
    """Shift a central inertia to the frame origin (parallel-axis theorem)."""
    c = np.asarray(com, dtype=float)
    return np.asarray(inertia_com) + mass * (c @ c * np.eye(3) - np.outer(c, c))


# ---------------------------------------------------------------- JR3 sensor

JR3_DIAMETER = 0.085        # m, JR3 85M35A3-I40-D 200N12 (model code: 85 mm dia., 35 mm thick)
JR3_THICKNESS = 0.035       # m
JR3_S_OFFSET = JR3_THICKNESS / 2.0   # S from the robot-side mounting face, along +z (assumed: sensor centre)
JR3_S_TO_TOOL_FACE = JR3_THICKNESS - JR3_S_OFFSET
# Estimated: 75 % of a solid aluminium puck of the sensor's size (the body is machined hollow).
JR3_FILL = 0.75


def jr3_solid() -> Solid:
    """The sensor as one uniform cylinder in the ``jr3_sensor`` body frame of
    jr3_sensor.urdf (origin at the robot-side mounting face, z away from the robot)."""
    r = JR3_DIAMETER / 2.0
    puck = Solid("jr3", "cylinder", (r, JR3_THICKNESS), (0.0, 0.0, JR3_THICKNESS / 2.0), density=ALUMINIUM)
    return Solid("jr3_sensor", "cylinder", (r, JR3_THICKNESS), puck.center, mass_kg=JR3_FILL * puck.mass)


# ---------------------------------------------------------------- the paper's tool (Fig. 5)

TOOL_TOTAL_MASS = 3.13  # kg, Kubus & Wahl 2009, Sec. VI-B: "overall mass ... including the sensor adapter"
# Chosen dimensions (the paper gives only the parts and the total mass):
ADAPTER_DIAMETER, ADAPTER_THICKNESS = 0.085, 0.015     # aluminium disc, sensor diameter
CUBOID_X, CUBOID_Y = 0.120, 0.080                       # steel cuboid footprint; thickness solved below
ROD_DIAMETER, ROD_LENGTH = 0.020, 0.250                 # aluminium rod
BALL_DIAMETER = 0.025                                   # steel ball tip (a bearing ball)


def _tool_parts(cuboid_thickness: float) -> list[Solid]:
    z = JR3_S_TO_TOOL_FACE
    adapter = Solid("adapter", "cylinder", (ADAPTER_DIAMETER / 2, ADAPTER_THICKNESS),
                    (0, 0, z + ADAPTER_THICKNESS / 2), density=ALUMINIUM)
    z += ADAPTER_THICKNESS
    cuboid = Solid("cuboid", "box", (CUBOID_X, CUBOID_Y, cuboid_thickness),
                   (0, 0, z + cuboid_thickness / 2), density=STEEL)
    z += cuboid_thickness
    rod = Solid("rod", "cylinder", (ROD_DIAMETER / 2, ROD_LENGTH), (0, 0, z + ROD_LENGTH / 2), density=ALUMINIUM)
    z += ROD_LENGTH
    ball = Solid("ball", "sphere", (BALL_DIAMETER / 2,), (0, 0, z + BALL_DIAMETER / 2), density=STEEL)
    return [adapter, cuboid, rod, ball]


def tool_cuboid_thickness() -> float:
    """Thickness of the steel cuboid that makes the whole tool weigh TOOL_TOTAL_MASS."""
    others = sum(p.mass for p in _tool_parts(0.0) if p.name != "cuboid")
    return (TOOL_TOTAL_MASS - others) / (STEEL * CUBOID_X * CUBOID_Y)


def tool_parts() -> list[Solid]:
    """Adapter, steel cuboid, aluminium rod and steel ball, in the ``tool`` frame of
    tool.urdf (= S when welded)."""
    return _tool_parts(tool_cuboid_thickness())


def tool_tip() -> np.ndarray:
    """Ball centre in the tool frame."""
    return tool_parts()[-1].com


# ---------------------------------------------------------------- gripper + gripped object

GRIPPER_HOUSING_MASS = 1.20  # kg, estimated for a Schunk PG 70-class parallel gripper (see SOURCES.md)
OBJECT_SIZE = (0.040, 0.040, 0.040)      # m, steel block held between the fingers
OBJECT_Y_OFFSET = 0.005                  # m, gripped 5 mm off the gripper's centre line


def _gripper_layout():
    z = JR3_S_TO_TOOL_FACE
    plate_t = 0.012
    plate = Solid("adapter_plate", "cylinder", (0.0425, plate_t), (0, 0, z + plate_t / 2), density=ALUMINIUM)
    z += plate_t
    hx, hy, hz = 0.120, 0.070, 0.090
    housing = Solid("housing", "box", (hx, hy, hz), (0, 0, z + hz / 2), mass_kg=GRIPPER_HOUSING_MASS)
    z += hz
    fx, fy, fz = 0.015, 0.025, 0.060
    inner = OBJECT_SIZE[0] / 2  # fingers touch the object's ±x faces
    fingers = [Solid(f"finger_{side}", "box", (fx, fy, fz), (sign * (inner + fx / 2), 0, z + fz / 2), density=STEEL)
               for side, sign in (("left", -1.0), ("right", 1.0))]
    grasp_center = np.array([0.0, OBJECT_Y_OFFSET, z + 0.005 + OBJECT_SIZE[2] / 2])
    return [plate, housing, *fingers], grasp_center


def gripper_parts() -> list[Solid]:
    """Adapter plate, housing and two steel fingers, in the ``gripper`` frame (= S)."""
    return _gripper_layout()[0]


def grasp_center() -> np.ndarray:
    """Where the object's centre sits, in the gripper frame (= S)."""
    return _gripper_layout()[1]


def object_parts() -> list[Solid]:
    """The gripped steel block, in the ``object`` frame (= S when gripped)."""
    return [Solid("object", "box", OBJECT_SIZE, tuple(grasp_center()), density=STEEL)]


# ---------------------------------------------------------------- RX90 / RX60 arm links

H = np.pi / 2


@dataclass(frozen=True)
class ArmSpec:
    """A Stäubli RX arm in modified (Craig / Khalil–Kleinfinger) DH form.

    ``dh`` rows are (alpha_{i-1}, a_{i-1}, theta_offset_i, d_i); joint angle
    theta_i = q_i + theta_offset_i. Frame 0 is the base R (mounting face), the
    last frame is the flange F. ``shapes`` are given in R at q = 0 (the Stäubli
    calibration pose: arm straight up) as (link index, shape, size, center, axis)
    and are filled with one uniform density so that the moving links plus the
    base weigh ``total_mass``.
    """
    name: str
    dh: tuple
    total_mass: float
    shapes: tuple
    payload_max: float


RX90 = ArmSpec(
    name="rx90",
    dh=((0.0, 0.0, 0.0, 0.420),
        (-H, 0.0, -H, 0.0),
        (0.0, 0.450, -H, 0.0),
        (-H, 0.0, 0.0, 0.450),
        (H, 0.0, 0.0, 0.0),
        (-H, 0.0, np.pi, 0.085)),
    total_mass=111.0,
    shapes=((0, "cylinder", (0.120, 0.300), (0, 0, 0.150), "z"),
            (1, "cylinder", (0.130, 0.240), (0, 0, 0.420), "z"),
            (2, "box", (0.120, 0.160, 0.570), (0, 0, 0.645), "z"),
            (3, "box", (0.140, 0.160, 0.200), (0, 0, 0.910), "z"),
            (4, "cylinder", (0.060, 0.260), (0, 0, 1.140), "z"),
            (5, "box", (0.090, 0.120, 0.100), (0, 0, 1.320), "z"),
            (6, "cylinder", (0.040, 0.030), (0, 0, 1.390), "z")),
    payload_max=12.0,
)

RX60 = ArmSpec(
    name="rx60",
    dh=((0.0, 0.0, 0.0, 0.341),
        (-H, 0.0, -H, 0.0),
        (0.0, 0.290, -H, 0.049),
        (-H, 0.0, 0.0, 0.310),
        (H, 0.0, 0.0, 0.0),
        (-H, 0.0, np.pi, 0.065)),
    total_mass=41.0,
    shapes=((0, "cylinder", (0.090, 0.240), (0, 0, 0.120), "z"),
            (1, "cylinder", (0.095, 0.200), (0, 0, 0.341), "z"),
            (2, "box", (0.090, 0.110, 0.390), (0, 0.049, 0.486), "z"),
            (3, "box", (0.110, 0.120, 0.160), (0, 0.049, 0.661), "z"),
            (4, "cylinder", (0.045, 0.180), (0, 0.049, 0.820), "z"),
            (5, "box", (0.060, 0.080, 0.070), (0, 0.049, 0.941), "z"),
            (6, "cylinder", (0.025, 0.020), (0, 0.049, 0.996), "z")),
    payload_max=4.5,
)


def mdh_transform(alpha: float, a: float, theta: float, d: float) -> np.ndarray:
    """Modified DH: Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i) Tz(d_i)."""
    ca, sa, ct, st = np.cos(alpha), np.sin(alpha), np.cos(theta), np.sin(theta)
    return np.array([[ct, -st, 0.0, a],
                     [st * ca, ct * ca, -sa, -sa * d],
                     [st * sa, ct * sa, ca, ca * d],
                     [0.0, 0.0, 0.0, 1.0]])


def arm_link_poses(arm: ArmSpec, q) -> list[np.ndarray]:
    """X_R_Li for i = 0..6 (index 0 is R itself)."""
    poses = [np.eye(4)]
    for (alpha, a, offset, d), qi in zip(arm.dh, q):
        poses.append(poses[-1] @ mdh_transform(alpha, a, qi + offset, d))
    return poses


def arm_density(arm: ArmSpec) -> float:
    volume = sum(Solid("", s, size, c, density=1.0, axis=ax).volume for _, s, size, c, ax in arm.shapes)
    return arm.total_mass / volume


def arm_link_solids(arm: ArmSpec) -> list[list[tuple[Solid, np.ndarray]]]:
    """For each link 0..6: [(solid in R at q=0, X_L_shape 4×4 pose of the shape in the link frame)]."""
    rho = arm_density(arm)
    poses = arm_link_poses(arm, np.zeros(6))
    out = [[] for _ in range(7)]
    for link, shape, size, center, axis in arm.shapes:
        solid = Solid(f"{arm.name}_link{link}", shape, size, center, density=rho, axis=axis)
        X_R_shape = np.eye(4)
        X_R_shape[:3, 3] = center
        out[link].append((solid, np.linalg.inv(poses[link]) @ X_R_shape))
    return out


def arm_link_inertias(arm: ArmSpec) -> list[tuple[float, np.ndarray, np.ndarray]]:
    """(mass, com in link frame, inertia about com in link frame) for links 0..6."""
    result = []
    for solids in arm_link_solids(arm):
        mass, com_R, inertia_R = compose([s for s, _ in solids])
        R_L_R = solids[0][1][:3, :3]  # all shapes of a link share the link's rotation
        p_L_R = solids[0][1][:3, 3] - R_L_R @ solids[0][0].com
        com, inertia = p_L_R + R_L_R @ com_R, R_L_R @ inertia_R @ R_L_R.T
        result.append((mass, _clean(com), _clean(inertia)))
    return result


def _clean(x: np.ndarray) -> np.ndarray:
    """Zero the round-off (< 1e-12) left by the 90° rotations between R and the link frames."""
    return np.where(np.abs(x) < 1e-12, 0.0, x)


def arm_effort_estimate(arm: ArmSpec, margin: float = 3.0) -> np.ndarray:
    """Joint torque limits (N·m), estimated as ``margin`` × the worst static holding
    torque: arm stretched horizontally, ``payload_max`` 0.1 m beyond the flange.
    J1 (vertical axis, no gravity load) gets J2's value, J4 gets J5's; J6 holds
    the payload 0.05 m off its axis. Rounded up to 5 N·m."""
    links = arm_link_inertias(arm)
    poses = arm_link_poses(arm, np.zeros(6))
    origin = [poses[i][:3, 3] for i in range(7)]
    com_R = [poses[i][:3, :3] @ links[i][1] + origin[i] for i in range(7)]
    flange = origin[6]
    payload_at = flange + np.array([0.0, 0.0, 0.1])

    def holding(joint: int) -> float:
        # Arm straight up in R; laid horizontal, lever = height above the joint's axis.
        axis_z = origin[joint][2]
        torque = sum(links[k][0] * (com_R[k][2] - axis_z) for k in range(joint, 7))
        torque += arm.payload_max * (payload_at[2] - axis_z)
        return GRAVITY * torque

    static = np.array([holding(2), holding(2), holding(3), holding(5), holding(5),
                       arm.payload_max * GRAVITY * 0.05])
    return np.ceil(margin * static / 5.0) * 5.0


# ---------------------------------------------------------------- Phantom Premium 1.5 6DoF

PHANTOM_L1 = 0.215  # m, shoulder–elbow (Cavusoglu et al. 2001/2002, Premium 1.5)
PHANTOM_L2 = 0.170  # m, elbow–gimbal centre


def phantom_links() -> dict[str, tuple[float, np.ndarray, np.ndarray]]:
    """(mass, com, inertia about com) per link of the serial-equivalent Phantom, in the
    link frames of phantom_premium_6dof.urdf (x forward, z up at q = 0; link2 along +x,
    link3 along −z, gimbal links centred on the gimbal point, stylus along +z of E).

    Arm values adapt Cavusoglu et al.'s tabulated link masses and inertias (lumping
    the parallelogram's parts onto the serial links and evening out transverse
    moments so the triangle inequality holds); gimbal values are estimates.
    """
    # Cavusoglu et al. (as transcribed in mahilab/Phantom PhantomModel.cpp):
    m_a, I_a = 0.0202, (0.4864e-4, 0.001843e-4, 0.4864e-4)    # distal link (long axis: their y)
    m_c, I_c = 0.0249, (0.959e-4, 0.959e-4, 0.0051e-4)        # parallelogram rear link
    m_be, I_be = 0.2359, (11.09e-4, 10.06e-4, 0.591e-4)       # upper arm + drive (long axis: their z)
    m_df = 0.1906                                             # second drive link (moves with absolute q3)
    I_base_vertical = 11.87e-4                                # turret about the vertical axis
    links = {}
    # link1: turret, with the df drive link lumped on the vertical axis.
    links["phantom_link1"] = (m_df, np.zeros(3), np.diag([6.0e-4, 6.0e-4, I_base_vertical]))
    # link2: upper arm (be + c), along +x, com at mid-length.
    transverse = 0.5 * (I_be[0] + I_be[1]) + I_c[0]
    links["phantom_link2"] = (m_be + m_c, np.array([PHANTOM_L1 / 2, 0.0, 0.0]),
                              np.diag([I_be[2] + I_c[2], transverse, transverse]))
    # link3: distal link a, along −z.
    links["phantom_link3"] = (m_a, np.array([0.0, 0.0, -PHANTOM_L2 / 2]),
                              np.diag([I_a[0], I_a[2], I_a[1]]))
    # Gimbal (estimated: small aluminium yokes with the 6DoF's wrist motors).
    for name, solid in (("phantom_link4", Solid("yaw", "box", (0.02, 0.03, 0.05), (0, 0, 0.02), mass_kg=0.06)),
                        ("phantom_link5", Solid("pitch", "box", (0.05, 0.03, 0.02), (0, 0, 0), mass_kg=0.05)),
                        ("stylus", Solid("stylus", "cylinder", (0.006, 0.13), (0, 0, 0.035), mass_kg=0.04))):
        links[name] = (solid.mass, solid.com, solid.central_inertia())
    return links


# ---------------------------------------------------------------- printing


def _fmt(x) -> str:
    return " ".join(f"{v:.9g}" for v in np.ravel(x))


def _print_body(name: str, mass: float, com, inertia) -> None:
    inertia = np.asarray(inertia)
    print(f"{name}: mass {mass:.9g} kg")
    print(f"  com xyz            {_fmt(com)}")
    about_com = [inertia[0, 0], inertia[1, 1], inertia[2, 2], inertia[0, 1], inertia[0, 2], inertia[1, 2]]
    print(f"  I about com  ixx iyy izz ixy ixz iyz  {_fmt(about_com)}")


def main() -> None:
    s = jr3_solid()
    print(f"# jr3_sensor.urdf: JR3 sensor (S at z = {JR3_S_OFFSET} m above the robot-side face)")
    _print_body("jr3_sensor", s.mass, s.com, s.central_inertia())
    print(f"\n# tool.urdf: tool (frame = S); steel cuboid thickness {tool_cuboid_thickness():.9g} m")
    for p in tool_parts():
        print(f"  part {p.name:8s} {p.mass:.9g} kg at {_fmt(p.com)}")
    _print_body("tool", *compose(tool_parts()))
    print(f"  tool_tip (ball centre) {_fmt(tool_tip())}")
    print("\n# gripper_object.urdf: gripper + object (frames = S)")
    for p in gripper_parts() + object_parts():
        print(f"  part {p.name:14s} {p.mass:.9g} kg at {_fmt(p.com)}")
    _print_body("gripper", *compose(gripper_parts()))
    _print_body("object", *compose(object_parts()))
    _print_body("gripper+object", *compose(gripper_parts() + object_parts()))
    print(f"  grasp_center {_fmt(grasp_center())}")
    for arm in (RX90, RX60):
        print(f"\n# {arm.name}: density {arm_density(arm):.6g} kg/m³, total {arm.total_mass} kg")
        for i, (m, c, inertia) in enumerate(arm_link_inertias(arm)):
            _print_body(f"{arm.name} link{i}", m, c, inertia)
        print(f"  effort limits (N·m) {_fmt(arm_effort_estimate(arm))}")
    print("\n# phantom")
    for name, (m, c, inertia) in phantom_links().items():
        _print_body(name, m, c, inertia)


if __name__ == "__main__":
    main()
