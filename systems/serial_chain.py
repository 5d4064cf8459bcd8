"""Kinematics of a frame on a chain of revolute joints, in closed form: products of exponentials.

X_BE(q) = e^{[S₁]q₁} ⋯ e^{[Sₙ]qₙ}·M (Lynch & Park, *Modern Robotics*, 2017, §4.1.1), with each
joint's screw S_i a unit axis ω̂_i through a point c_i, both in B at q = 0, and M = X_BE(0). These
constants are read off a finalized MultibodyPlant (its URDF's numbers); a compiled kernel
(``compiled``) then gives the pose, the geometric Jacobian and the motion of E with no Drake call
and no allocation (README "Compiled kernels": 2.5 µs where four Drake calls take 12 µs).
"""

from __future__ import annotations

import math

import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import Frame

from heft.systems.compiled import compiled, float_array, record_views

CHAIN_JOINTS = (6, 7)
"""The slave arms' numbers of joints heft drives: the per-chain kernels are compiled for each, and an arm's
model must have one of them."""
MOTION_SIZE = 12
"""``SerialChain.motion``: [a (3, m/s²); α (3, rad/s²); ω (3, rad/s); g (3, m/s²)], all in E."""
ACCELERATION, OMEGA, GRAVITY = slice(0, 6), slice(6, 9), slice(9, 12)
"""[a; α], ω and g in ``SerialChain.motion``."""


@compiled("void(float64[:, :], float64[:, :], float64[:, :], float64[:], float64[:], float64[:], float64[:], "
          "float64[:], float64[:, :], float64[:], float64[:, :], float64[:], float64[:, :])")
def chain_kinematics(axes, points, M_R, M_p, q, qd, qdd, gravity_B, R, p, J, motion, work):
    """Writes E's pose ``R`` = R_BE (3, 3) and ``p`` = p_BE (3, m), ``J`` (6, n) with
    [v_E; ω_E] = J·q̇ (E's origin, measured and expressed in B; heft's row order) and
    ``motion`` (``MOTION_SIZE``, in E) at joint positions ``q`` (rad), velocities ``qd`` (rad/s) and
    accelerations ``qdd`` (rad/s²): a = J_v·q̈ + J̇_v·q̇, α likewise, ω = J_ω·q̇, g = R_EB·``gravity_B``.

    ``axes`` and ``points`` (n, 3): ω̂_i and c_i in B at q = 0; ``M_R``, ``M_p``: X_BE at q = 0;
    ``work`` (n, 6): scratch, left holding the joints' axes and points at q."""
    n = q.shape[0]
    # X_a = (R_a, p_a): the product of the exponentials so far, R_a's entries in scalars (no allocation).
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0
    pa0 = pa1 = pa2 = 0.0
    for i in range(n):
        # The axis and its point moved by the joints before i: w = R_a·ω̂_i, o = R_a·c_i + p_a.
        a0, a1, a2 = axes[i, 0], axes[i, 1], axes[i, 2]
        c0, c1, c2 = points[i, 0], points[i, 1], points[i, 2]
        work[i, 0] = r00 * a0 + r01 * a1 + r02 * a2
        work[i, 1] = r10 * a0 + r11 * a1 + r12 * a2
        work[i, 2] = r20 * a0 + r21 * a1 + r22 * a2
        work[i, 3] = r00 * c0 + r01 * c1 + r02 * c2 + pa0
        work[i, 4] = r10 * c0 + r11 * c1 + r12 * c2 + pa1
        work[i, 5] = r20 * c0 + r21 * c1 + r22 * c2 + pa2
        # e^{[S_i]q_i}: the rotation E = Rot(ω̂_i, q_i) (Rodrigues) about the line through c_i,
        # X_a ← X_a·(E, c_i − E·c_i).
        s, cq = math.sin(q[i]), math.cos(q[i])
        v = 1.0 - cq
        e00, e01, e02 = cq + a0 * a0 * v, a0 * a1 * v - a2 * s, a0 * a2 * v + a1 * s
        e10, e11, e12 = a1 * a0 * v + a2 * s, cq + a1 * a1 * v, a1 * a2 * v - a0 * s
        e20, e21, e22 = a2 * a0 * v - a1 * s, a2 * a1 * v + a0 * s, cq + a2 * a2 * v
        t0 = c0 - (e00 * c0 + e01 * c1 + e02 * c2)
        t1 = c1 - (e10 * c0 + e11 * c1 + e12 * c2)
        t2 = c2 - (e20 * c0 + e21 * c1 + e22 * c2)
        pa0 += r00 * t0 + r01 * t1 + r02 * t2
        pa1 += r10 * t0 + r11 * t1 + r12 * t2
        pa2 += r20 * t0 + r21 * t1 + r22 * t2
        r00, r01, r02 = r00 * e00 + r01 * e10 + r02 * e20, r00 * e01 + r01 * e11 + r02 * e21, \
            r00 * e02 + r01 * e12 + r02 * e22
        r10, r11, r12 = r10 * e00 + r11 * e10 + r12 * e20, r10 * e01 + r11 * e11 + r12 * e21, \
            r10 * e02 + r11 * e12 + r12 * e22
        r20, r21, r22 = r20 * e00 + r21 * e10 + r22 * e20, r20 * e01 + r21 * e11 + r22 * e21, \
            r20 * e02 + r21 * e12 + r22 * e22
    for c in range(3):  # X_BE = X_a·M
        m0, m1, m2 = M_R[0, c], M_R[1, c], M_R[2, c]
        R[0, c] = r00 * m0 + r01 * m1 + r02 * m2
        R[1, c] = r10 * m0 + r11 * m1 + r12 * m2
        R[2, c] = r20 * m0 + r21 * m1 + r22 * m2
    p[0] = r00 * M_p[0] + r01 * M_p[1] + r02 * M_p[2] + pa0
    p[1] = r10 * M_p[0] + r11 * M_p[1] + r12 * M_p[2] + pa1
    p[2] = r20 * M_p[0] + r21 * M_p[1] + r22 * M_p[2] + pa2

    # Columns: ω_i = w_i, v_i = w_i × (p_E − o_i). Velocities: ω, v_E = Σ columns·q̇.
    om0 = om1 = om2 = ve0 = ve1 = ve2 = 0.0
    for i in range(n):
        w0, w1, w2 = work[i, 0], work[i, 1], work[i, 2]
        d0, d1, d2 = p[0] - work[i, 3], p[1] - work[i, 4], p[2] - work[i, 5]
        J[0, i], J[1, i], J[2, i] = w1 * d2 - w2 * d1, w2 * d0 - w0 * d2, w0 * d1 - w1 * d0
        J[3, i], J[4, i], J[5, i] = w0, w1, w2
        ve0 += J[0, i] * qd[i]
        ve1 += J[1, i] * qd[i]
        ve2 += J[2, i] * qd[i]
        om0 += w0 * qd[i]
        om1 += w1 * qd[i]
        om2 += w2 * qd[i]

    # J̇·q̇, column by column: ẇ_i = Ω_{i−1} × w_i (the axis turns with the links before it), and
    # d/dt (p_E − o_i) = v_E − v(o_i), v(o_i) = Σ_{j<i} w_j × (o_i − o_j)·q̇_j (o_i is fixed on link i−1).
    al0 = al1 = al2 = ac0 = ac1 = ac2 = 0.0
    Om0 = Om1 = Om2 = 0.0  # Ω_{i−1}: the angular velocity of link i − 1
    for i in range(n):
        w0, w1, w2 = work[i, 0], work[i, 1], work[i, 2]
        o0, o1, o2 = work[i, 3], work[i, 4], work[i, 5]
        vo0 = vo1 = vo2 = 0.0
        for j in range(i):
            e0, e1, e2 = o0 - work[j, 3], o1 - work[j, 4], o2 - work[j, 5]
            vo0 += (work[j, 1] * e2 - work[j, 2] * e1) * qd[j]
            vo1 += (work[j, 2] * e0 - work[j, 0] * e2) * qd[j]
            vo2 += (work[j, 0] * e1 - work[j, 1] * e0) * qd[j]
        wd0, wd1, wd2 = Om1 * w2 - Om2 * w1, Om2 * w0 - Om0 * w2, Om0 * w1 - Om1 * w0
        d0, d1, d2 = p[0] - o0, p[1] - o1, p[2] - o2
        dd0, dd1, dd2 = ve0 - vo0, ve1 - vo1, ve2 - vo2
        ac0 += (wd1 * d2 - wd2 * d1 + w1 * dd2 - w2 * dd1) * qd[i] + J[0, i] * qdd[i]
        ac1 += (wd2 * d0 - wd0 * d2 + w2 * dd0 - w0 * dd2) * qd[i] + J[1, i] * qdd[i]
        ac2 += (wd0 * d1 - wd1 * d0 + w0 * dd1 - w1 * dd0) * qd[i] + J[2, i] * qdd[i]
        al0 += wd0 * qd[i] + w0 * qdd[i]
        al1 += wd1 * qd[i] + w1 * qdd[i]
        al2 += wd2 * qd[i] + w2 * qdd[i]
        Om0 += w0 * qd[i]
        Om1 += w1 * qd[i]
        Om2 += w2 * qd[i]

    # Expressed in E: x_E = R_BEᵀ·x_B.
    g0, g1, g2 = gravity_B[0], gravity_B[1], gravity_B[2]
    for c in range(3):
        motion[c] = R[0, c] * ac0 + R[1, c] * ac1 + R[2, c] * ac2
        motion[3 + c] = R[0, c] * al0 + R[1, c] * al1 + R[2, c] * al2
        motion[6 + c] = R[0, c] * om0 + R[1, c] * om1 + R[2, c] * om2
        motion[9 + c] = R[0, c] * g0 + R[1, c] * g1 + R[2, c] * g2


class SerialChain:
    """The revolute joints of ``plant`` between frame ``B`` (fixed to the chain's root) and frame ``E``,
    base to tip, and E's kinematics from them (``chain_kinematics``).

    After ``update``: ``R`` (3, 3) R_BE, ``p`` (3, m) p_BE, ``J`` (6, n) rows [v_E; ω_E] in B,
    ``motion`` (``MOTION_SIZE``) E's acceleration, angular velocity and ``gravity_B`` in E. The arrays
    are overwritten by each update; copy what must outlive it. They and the chain's constants live in
    ``record`` (``chain_dtype``), which a kernel that calls ``chain_kinematics`` takes. ``joints`` are
    the chain's joints in the order ``update`` takes their positions.
    """

    def __init__(self, plant: MultibodyPlant, B: Frame, E: Frame, gravity_B=(0.0, 0.0, 0.0)):
        if not plant.is_finalized():
            raise ValueError("SerialChain needs a finalized plant")
        joints = []
        inboard = {plant.get_joint(index).child_body().index(): plant.get_joint(index)
                   for index in plant.GetJointIndices()}
        body = E.body()
        while body.index() != B.body().index():
            joint = inboard.get(body.index())
            if joint is None:
                raise ValueError(f"frame {E.name()!r} is not on a chain of joints below frame {B.name()!r}")
            if joint.num_positions() == 1:
                if joint.type_name() != "revolute":
                    raise ValueError(f"joint {joint.name()!r} is {joint.type_name()}; a SerialChain takes "
                                     "revolute and weld joints only")
                joints.append(joint)
            elif joint.num_positions() != 0:
                raise ValueError(f"joint {joint.name()!r} has {joint.num_positions()} positions; a SerialChain "
                                 "takes revolute and weld joints only")
            body = joint.parent_body()
        self.joints = joints[::-1]
        context = plant.CreateDefaultContext()
        for joint in self.joints:
            joint.set_angle(context, 0.0)
        n = len(self.joints)
        self.record, arrays = record_views(chain_dtype(n))
        for i, joint in enumerate(self.joints):
            X_BF = plant.CalcRelativeTransform(context, B, joint.frame_on_parent())
            arrays["axes"][i] = X_BF.rotation().matrix() @ joint.revolute_axis()
            arrays["points"][i] = X_BF.translation()
        X_BE = plant.CalcRelativeTransform(context, B, E)
        arrays["M_R"][:], arrays["M_p"][:] = X_BE.rotation().matrix(), X_BE.translation()
        arrays["gravity_B"][:] = np.array(gravity_B, dtype=float).reshape(3)
        arrays["R"][:] = np.eye(3)
        self._arrays = arrays
        self.R, self.p, self.J, self.motion = arrays["R"], arrays["p"], arrays["J"], arrays["motion"]

    @property
    def num_joints(self) -> int:
        return len(self.joints)

    def update(self, q, qd=None, qdd=None) -> None:
        """Evaluates the chain at joint positions ``q`` (rad), velocities ``qd`` (rad/s; default 0) and
        accelerations ``qdd`` (rad/s²; default 0), each (n,)."""
        a = self._arrays
        chain_kinematics(a["axes"], a["points"], a["M_R"], a["M_p"], float_array(q),
                         a["zeros"] if qd is None else float_array(qd), a["zeros"] if qdd is None else float_array(qdd),
                         a["gravity_B"], self.R, self.p, self.J, self.motion, a["work"])


def chain_dtype(n: int) -> np.dtype:
    """The record of a chain of ``n`` joints (``SerialChain.record``): ``chain_kinematics``' arrays by name
    (``axes``, ``points``, ``M_R``, ``M_p``, ``gravity_B``, ``R``, ``p``, ``J``, ``motion``, ``work``) and
    ``zeros`` (n: q̇ and q̈ when not given)."""
    return np.dtype([("axes", float, (n, 3)), ("points", float, (n, 3)), ("M_R", float, (3, 3)), ("M_p", float, 3),
                     ("gravity_B", float, 3), ("R", float, (3, 3)), ("p", float, 3), ("J", float, (6, n)),
                     ("motion", float, MOTION_SIZE), ("work", float, (n, 6)), ("zeros", float, n)])
