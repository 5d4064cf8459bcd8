"""Ground truth at the wrist sensor of a simulated slave, read off a
MultibodyPlant's output ports by one system (``WristTruth``): the sensor frame's
motion, the load's non-contact wrench, the accelerometer's ideal reading, the
weld's reaction wrench, and the contact wrench from the plant's contact results.

All outputs in docs/design.md §4 conventions: at S's origin, expressed in S (but the
accelerometer's reading, taken at its own point); wrenches [f; τ] as the sensor
exerts them on the load.
"""

from __future__ import annotations

import numpy as np
from pydrake.common.cpp_param import List
from pydrake.common.value import AbstractValue, Value
from pydrake.math import RigidTransform
from pydrake.multibody.math import SpatialAcceleration, SpatialForce, SpatialVelocity
from pydrake.multibody.plant import ContactResults
from pydrake.systems.framework import LeafSystem

from heft.systems.accelerometer_reading import (AT_S, CONVENTION, AccelerometerConvention, convention_record,
                                               reading_into)
from heft.systems.compiled import compiled, record_views
from heft.systems.drake_conventions import swap_halves
from heft.systems.load_dynamics import regressor_into


@compiled("void(float64[:, :], float64[:], float64[:], float64[:], float64[:], float64[:], float64[:])")
def frame_motion_into(R_WB, w_WB_W, alpha_WB_W, a_WBo_W, p_BF, g_W, motion) -> None:
    """[a; α; ω; g] (12, each in F, m/s², rad/s², rad/s, m/s²) into ``motion``: the motion of a frame F
    fixed at ``p_BF`` (m) in body B with B's axes, from B's rotation R_WB, its angular velocity and
    acceleration and its origin's acceleration in W, and gravity g_W. a_F = a_Bo + α×r + ω×(ω×r),
    r = R_WB·p_BF (a rigid body's acceleration field, as Drake's ``SpatialAcceleration.Shift``)."""
    rx = R_WB[0, 0] * p_BF[0] + R_WB[0, 1] * p_BF[1] + R_WB[0, 2] * p_BF[2]
    ry = R_WB[1, 0] * p_BF[0] + R_WB[1, 1] * p_BF[1] + R_WB[1, 2] * p_BF[2]
    rz = R_WB[2, 0] * p_BF[0] + R_WB[2, 1] * p_BF[1] + R_WB[2, 2] * p_BF[2]
    wx, wy, wz = w_WB_W[0], w_WB_W[1], w_WB_W[2]
    ax, ay, az = alpha_WB_W[0], alpha_WB_W[1], alpha_WB_W[2]
    vx, vy, vz = wy * rz - wz * ry, wz * rx - wx * rz, wx * ry - wy * rx  # ω × r
    linear = (a_WBo_W[0] + ay * rz - az * ry + wy * vz - wz * vy,
              a_WBo_W[1] + az * rx - ax * rz + wz * vx - wx * vz,
              a_WBo_W[2] + ax * ry - ay * rx + wx * vy - wy * vx)
    for i in range(3):  # R_BW = R_WBᵀ
        motion[i] = R_WB[0, i] * linear[0] + R_WB[1, i] * linear[1] + R_WB[2, i] * linear[2]
        motion[3 + i] = R_WB[0, i] * ax + R_WB[1, i] * ay + R_WB[2, i] * az
        motion[6 + i] = R_WB[0, i] * wx + R_WB[1, i] * wy + R_WB[2, i] * wz
        motion[9 + i] = R_WB[0, i] * g_W[0] + R_WB[1, i] * g_W[1] + R_WB[2, i] * g_W[2]


TRUTH_PARTS = (("acceleration", 6), ("omega", 3), ("gravity", 3), ("wrench", 6), ("wrench_object", 6),
               ("accelerometer_reading", 6), ("wrench_sensor", 6), ("wrench_contact", 6))
"""The parts of ``WristTruth``'s output ``truth``, in its order: (name, size)."""


class WristTruth(LeafSystem):
    """The truth at the wrist sensor, read off the slave plant's ports: S's motion, the load's non-contact wrench,
    the accelerometer's ideal reading, the weld's reaction and the contact wrench. S is fixed at p_BS (m) in the
    sensor body B's frame, with B's axes. One system reads the plant's lists (each Eval builds a Python list of
    every body's or joint's value, which costs more than the arithmetic) once a step, and one port carries every
    part, so that a step calls into Python once for all of them (a ``Demultiplexer`` parts them).

    Inputs: the plant's ``reaction_forces``, ``contact_results``, ``body_poses``, ``body_spatial_velocities`` and
    ``body_spatial_accelerations``; ``phi`` (10, the load's true φ about L's origin in L) and ``phi_gripper`` (10,
    the gripper's share, Eq. 14). Output ``truth`` (42): the parts ``TRUTH_PARTS`` names end to end,

    - ``acceleration`` [a; α] of S in S (m/s², rad/s²), ``omega`` ω_WS in S (rad/s), ``gravity`` g in S (m/s²);
    - ``wrench``: V(a, α, ω, g)·φ (Eq. 12) of the true φ with the true motion of the load's own frame L (the body
      frame of the first of ``load_body_indices``: at S when the load is welded there; on a compliant mount it
      moves against S), moved from L to S, in S, so that it equals the sensor's reaction minus the contact wrench
      (Eq. 11) on either mount; ``wrench_object`` the same for the gripped object's share φ − φ_gripper (zero
      without a split);
    - ``accelerometer_reading``: what an ideal accelerometer in the sensor reports (``accelerometer_reading`` with
      the ``accelerometer`` convention: at p_SA, in its axes and unit);
    - ``wrench_sensor``: the reaction of the sensor's weld joint ``sensor_weld_index``, [f; τ] on the child body
      at the child's joint frame, in it;
    - ``wrench_contact``: the contact part of the sensor's wrench (Eq. 11), minus the sum of the environment's
      point contact forces on the ``load_body_indices``, moved to S, in S (the station's plant uses contact_model
      "point").
    """

    def __init__(self, sensor_body_index, p_BS, load_body_indices, sensor_weld_index, gravity_W,
                 accelerometer: AccelerometerConvention = AT_S):
        super().__init__()
        self._sensor, self._weld = int(sensor_body_index), int(sensor_weld_index)
        self._loads = {int(i) for i in load_body_indices}
        self._load = int(load_body_indices[0])
        self._truth, arrays = record_views(TRUTH)
        arrays["p_BS"][:], arrays["g_W"][:] = p_BS, gravity_W
        self._p_BS = arrays["p_BS"]
        self._accelerometer = convention_record(accelerometer)
        self._reactions = self.DeclareAbstractInputPort("reaction_forces", Value[List[SpatialForce]]())
        self._contacts = self.DeclareAbstractInputPort("contact_results", AbstractValue.Make(ContactResults()))
        self._poses = self.DeclareAbstractInputPort("body_poses", Value[List[RigidTransform]]())
        self._velocities = self.DeclareAbstractInputPort("body_spatial_velocities", Value[List[SpatialVelocity]]())
        self._accelerations = self.DeclareAbstractInputPort("body_spatial_accelerations",
                                                            Value[List[SpatialAcceleration]]())
        self._phi = self.DeclareVectorInputPort("phi", 10)
        self._phi_gripper = self.DeclareVectorInputPort("phi_gripper", 10)
        self.DeclareVectorOutputPort("truth", sum(size for _, size in TRUTH_PARTS), self._calc,
                                     prerequisites_of_calc={self.all_input_ports_ticket()})

    def _calc(self, context, output):
        out = output.get_mutable_value()
        poses, velocities = self._poses.Eval(context), self._velocities.Eval(context)
        accelerations, B, L = self._accelerations.Eval(context), self._sensor, self._load
        motion_and_wrenches_into(poses[B].GetAsMatrix34(), velocities[B].get_coeffs(), accelerations[B].get_coeffs(),
                                 poses[L].GetAsMatrix34(), velocities[L].get_coeffs(), accelerations[L].get_coeffs(),
                                 self._phi.Eval(context), self._phi_gripper.Eval(context), self._truth,
                                 self._accelerometer, out)
        out[30:36] = swap_halves(self._reactions.Eval(context)[self._weld].get_coeffs())  # [τ; f] → [f; τ]
        self._contact_wrench_into(self._contacts.Eval(context), poses[B], out[36:42])

    def _contact_wrench_into(self, results, X_WB, out) -> None:
        """``wrench_contact`` of the plant's contact ``results`` with B at ``X_WB``, into ``out`` (6)."""
        if results.num_hydroelastic_contacts():
            raise RuntimeError("WristTruth sums point contacts only; build the plant with contact_model='point'")
        count = results.num_point_pair_contacts()
        if not count:
            out[:] = 0.0
            return
        p_WS = X_WB @ self._p_BS
        f_W, tau_W = np.zeros(3), np.zeros(3)  # environment on load, about S
        for i in range(count):
            info = results.point_pair_contact_info(i)
            sign = (int(info.bodyB_index()) in self._loads) - (int(info.bodyA_index()) in self._loads)
            if sign:
                f = sign * info.contact_force()
                f_W += f
                tau_W += np.cross(info.contact_point() - p_WS, f)
        R_SW = X_WB.rotation().inverse().matrix()
        out[:3], out[3:] = -(R_SW @ f_W), -(R_SW @ tau_W)


TRUTH = np.dtype([("p_BS", float, 3), ("g_W", float, 3), ("origin", float, 3), ("load_motion", float, 12),
                  ("V", float, (6, 10)), ("X_SL", float, (3, 4))])
"""``motion_and_wrenches_into``'s settings (S at ``p_BS`` (m) in the sensor body B, gravity ``g_W`` (m/s²) in W)
and its scratch: ``origin`` (zeros), ``load_motion`` (12), ``V`` (6, 10) and ``X_SL`` = [R_SL p_SL] (3×4)."""


@compiled("void(float64[:], float64[:], float64[:], float64[:, :], float64[:], float64[:, :], float64[:])")
def wrenches_at_S_into(motion, phi, phi_gripper, R_SL, p_SL, V, out) -> None:
    """[V·φ; V·(φ − φ_gripper)] (12) into ``out``, each moved from L to S and expressed in S:
    f_S = R_SL·f_L, τ_S = R_SL·τ_L + p_SL × f_S. V is the regressor of L's ``motion`` [a; α; ω; g]
    (12, in L; ``V`` (6, 10) scratch); the object's share is zero when ``phi_gripper`` is."""
    regressor_into(motion[0:3], motion[3:6], motion[6:9], motion[9:12], V)
    split = False
    for k in range(10):
        split = split or phi_gripper[k] != 0.0
    out[:] = 0.0
    for start in range(0, 12 if split else 6, 6):
        for row in range(6):  # row r of V·share, rotated into S: column r mod 3 of R_SL
            w = 0.0
            for k in range(10):
                w += V[row, k] * (phi[k] - phi_gripper[k] if start == 6 else phi[k])
            base = start + (3 if row >= 3 else 0)
            for i in range(3):
                out[base + i] += R_SL[i, row % 3] * w
        fx, fy, fz = out[start], out[start + 1], out[start + 2]
        out[start + 3] += p_SL[1] * fz - p_SL[2] * fy
        out[start + 4] += p_SL[2] * fx - p_SL[0] * fz
        out[start + 5] += p_SL[0] * fy - p_SL[1] * fx


@compiled("void(float64[:, :], float64[:], float64[:], float64[:, :], float64[:], float64[:], float64[:], float64[:], "
          "TRUTH[:], CONVENTION[:], float64[:])", TRUTH=TRUTH, CONVENTION=CONVENTION)
def motion_and_wrenches_into(X_WB, V_WB, A_WB, X_WL, V_WL, A_WL, phi, phi_gripper, truth, accelerometer, out) -> None:
    """``WristTruth``'s arithmetic into ``out`` (30: its ``TRUTH_PARTS`` up to the reading), from Drake's values in
    W of the sensor body B and of the load body: poses [R p] (3×4), spatial velocities [ω; v] and accelerations
    [α; a] (6). S's [a; α; ω; g] (``frame_motion_into`` of S at p_BS in B) into out[:12]; the load's wrenches
    (``wrenches_at_S_into`` of the motion of L, the load body's frame) into out[12:24], with X_SL = X_SW·X_WL (S
    has B's axes: R_SL = R_WBᵀ·R_WL, p_SL = R_WBᵀ·(p_WL − p_WB) − p_BS); the accelerometer's reading of S's motion
    (``reading_into``, its ``CONVENTION`` record) into out[24:30]. ``truth``: a ``TRUTH`` record."""
    t = truth[0]
    p_BS, X_SL = t["p_BS"], t["X_SL"]
    for i in range(3):
        for k in range(3):
            X_SL[i, k] = X_WB[0, i] * X_WL[0, k] + X_WB[1, i] * X_WL[1, k] + X_WB[2, i] * X_WL[2, k]
        X_SL[i, 3] = (X_WB[0, i] * (X_WL[0, 3] - X_WB[0, 3]) + X_WB[1, i] * (X_WL[1, 3] - X_WB[1, 3])
                      + X_WB[2, i] * (X_WL[2, 3] - X_WB[2, 3]) - p_BS[i])
    frame_motion_into(X_WB[:, :3], V_WB[:3], A_WB[:3], A_WB[3:], p_BS, t["g_W"], out[:12])
    frame_motion_into(X_WL[:, :3], V_WL[:3], A_WL[:3], A_WL[3:], t["origin"], t["g_W"], t["load_motion"])
    wrenches_at_S_into(t["load_motion"], phi, phi_gripper, X_SL[:, :3], X_SL[:, 3], t["V"], out[12:24])
    reading_into(out[24:30], out[:6], out[9:12], out[6:9], accelerometer)
