"""Ground truth at the wrist sensor of a simulated slave, read off a
MultibodyPlant's output ports: the weld's reaction wrench, the sensor frame's
motion, and the contact wrench from the plant's contact results.

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
from pydrake.systems.framework import LeafSystem, ValueProducer

from heft.systems.accelerometer_reading import AT_S, AccelerometerConvention, reading_from_motion
from heft.systems.drake_conventions import wrench_from_spatial_force
from heft.systems.load_dynamics import regressor


class ReactionWrench(LeafSystem):
    """The reaction of one weld joint: input ``reaction_forces`` (the plant's port),
    output ``wrench`` (6) = [f; τ] on the child body at the child's joint frame, in it."""

    def __init__(self, joint_index):
        super().__init__()
        self._joint = int(joint_index)
        self._reactions = self.DeclareAbstractInputPort("reaction_forces", Value[List[SpatialForce]]())
        self.DeclareVectorOutputPort("wrench", 6, self._calc)

    def _calc(self, context, output):
        output.SetFromVector(wrench_from_spatial_force(self._reactions.Eval(context)[self._joint]))


def declare_body_motion_inputs(system: LeafSystem):
    """Declares on ``system`` the inputs ``body_poses``, ``body_spatial_velocities`` and
    ``body_spatial_accelerations`` (a MultibodyPlant's outputs of those names) and returns them."""
    return (system.DeclareAbstractInputPort("body_poses", Value[List[RigidTransform]]()),
            system.DeclareAbstractInputPort("body_spatial_velocities", Value[List[SpatialVelocity]]()),
            system.DeclareAbstractInputPort("body_spatial_accelerations", Value[List[SpatialAcceleration]]()))


def frame_motion(X_WB: RigidTransform, V_WB: SpatialVelocity, A_WB: SpatialAcceleration, p_BF, g_W):
    """(a, α, ω, g), each (3,), in F: the motion of a frame F fixed at ``p_BF`` (m) in body B with
    B's axes, from B's pose, spatial velocity and acceleration in W, and gravity g_W (m/s²)."""
    R_WB = X_WB.rotation()
    w_WB_W = V_WB.rotational()
    A_WF_W = A_WB.Shift(R_WB @ p_BF, w_WB_W)
    R_BW = R_WB.inverse().matrix()
    return R_BW @ A_WF_W.translational(), R_BW @ A_WF_W.rotational(), R_BW @ w_WB_W, R_BW @ g_W


class SensorFrameKinematics(LeafSystem):
    """Motion of the sensor frame S, fixed at p_BS (m) in body B's frame.

    Inputs: the plant's ``body_poses``, ``body_spatial_velocities``,
    ``body_spatial_accelerations``. Outputs: ``acceleration`` [a; α] of S in S
    (m/s², rad/s²), ``omega`` ω_WS in S (rad/s), ``gravity`` g in S (m/s²), and
    ``accelerometer_reading``, what an ideal accelerometer in the sensor reports
    (``accelerometer_reading`` with the ``accelerometer`` convention: at p_SA, in S's axes).
    """

    def __init__(self, body_index, p_BS, gravity_W, accelerometer: AccelerometerConvention = AT_S):
        super().__init__()
        self._accelerometer = accelerometer
        self._body = int(body_index)
        self._p_BS = np.asarray(p_BS, dtype=float)
        self._g_W = np.asarray(gravity_W, dtype=float)
        self._poses, self._velocities, self._accelerations = declare_body_motion_inputs(self)
        self._motion = self.DeclareCacheEntry(
            "motion", ValueProducer(allocate=lambda: AbstractValue.Make(np.zeros(12)), calc=self._calc_motion),
            prerequisites_of_calc={self._poses.ticket(), self._velocities.ticket(), self._accelerations.ticket()})
        for name, part in (("acceleration", slice(0, 6)), ("omega", slice(6, 9)), ("gravity", slice(9, 12))):
            self.DeclareVectorOutputPort(name, part.stop - part.start,
                                         lambda context, output, part=part: output.SetFromVector(
                                             self._motion.Eval(context)[part]),
                                         prerequisites_of_calc={self._motion.ticket()})
        self.DeclareVectorOutputPort("accelerometer_reading", 6, self._calc_reading,
                                     prerequisites_of_calc={self._motion.ticket()})

    def _calc_motion(self, context, value):
        body = self._body
        a, alpha, omega, g = frame_motion(self._poses.Eval(context)[body], self._velocities.Eval(context)[body],
                                          self._accelerations.Eval(context)[body], self._p_BS, self._g_W)
        value.get_mutable_value()[:] = np.concatenate((a, alpha, omega, g))

    def _calc_reading(self, context, output):
        motion = self._motion.Eval(context)
        output.SetFromVector(reading_from_motion(motion[:6], motion[9:], motion[6:9], self._accelerometer))


class ContactWrenchAtSensor(LeafSystem):
    """The contact part of the sensor's wrench (Eq. 11): minus the sum of the
    environment's contact forces on the load bodies, moved to S and expressed in S.

    Inputs: the plant's ``contact_results`` and ``body_poses``. Output ``wrench`` (6).
    Point contact only (the station's plant uses contact_model "point").
    """

    def __init__(self, load_body_indices, sensor_body_index, p_BS):
        super().__init__()
        self._load = {int(i) for i in load_body_indices}
        self._sensor = int(sensor_body_index)
        self._p_BS = np.asarray(p_BS, dtype=float)
        self._contacts = self.DeclareAbstractInputPort("contact_results", AbstractValue.Make(ContactResults()))
        self._poses = self.DeclareAbstractInputPort("body_poses", Value[List[RigidTransform]]())
        self.DeclareVectorOutputPort("wrench", 6, self._calc)

    def _calc(self, context, output):
        results = self._contacts.Eval(context)
        if results.num_hydroelastic_contacts():
            raise RuntimeError("ContactWrenchAtSensor sums point contacts only; "
                               "build the plant with contact_model='point'")
        X_WB = self._poses.Eval(context)[self._sensor]
        p_WS = X_WB @ self._p_BS
        f_W, tau_W = np.zeros(3), np.zeros(3)  # environment on load, about S
        for i in range(results.num_point_pair_contacts()):
            info = results.point_pair_contact_info(i)
            sign = (int(info.bodyB_index()) in self._load) - (int(info.bodyA_index()) in self._load)
            if sign:
                f = sign * info.contact_force()
                f_W += f
                tau_W += np.cross(info.contact_point() - p_WS, f)
        R_SW = X_WB.rotation().inverse().matrix()
        output.SetFromVector(-np.concatenate((R_SW @ f_W, R_SW @ tau_W)))


class TrueNonContactWrench(LeafSystem):
    """The load's non-contact wrench at S, in S: V(a, α, ω, g)·φ (Eq. 12) of the true φ with the
    true motion of the load's own frame L (at S when the load is welded there; on a compliant
    mount it moves against S), moved from L to S. So it equals the sensor's reaction minus the
    contact wrench (Eq. 11) on either mount.

    Inputs: the plant's ``body_poses``, ``body_spatial_velocities``,
    ``body_spatial_accelerations``; ``phi`` (10, the load's true φ about L's origin in L) and
    ``phi_gripper`` (10, the gripper's share, Eq. 14). Outputs ``wrench`` (6, for φ) and
    ``wrench_object`` (6, for the gripped object's share φ − φ_gripper; zero without a split).
    """

    def __init__(self, load_body_index, sensor_body_index, p_BS, gravity_W):
        super().__init__()
        self._load, self._sensor = int(load_body_index), int(sensor_body_index)
        self._p_BS = np.asarray(p_BS, dtype=float)
        self._g_W = np.asarray(gravity_W, dtype=float)
        self._poses, self._velocities, self._accelerations = declare_body_motion_inputs(self)
        self._phi = self.DeclareVectorInputPort("phi", 10)
        self._phi_gripper = self.DeclareVectorInputPort("phi_gripper", 10)
        self._X_BS = RigidTransform(self._p_BS)
        # Both wrenches at once (12): one evaluation of the load frame's motion per context change.
        self._wrenches = self.DeclareCacheEntry(
            "wrenches", ValueProducer(allocate=lambda: AbstractValue.Make(np.zeros(12)), calc=self._calc),
            prerequisites_of_calc={self.all_input_ports_ticket()})
        for name, part in (("wrench", slice(0, 6)), ("wrench_object", slice(6, 12))):
            self.DeclareVectorOutputPort(name, 6, lambda context, output, part=part: output.SetFromVector(
                self._wrenches.Eval(context)[part]), prerequisites_of_calc={self._wrenches.ticket()})

    def _calc(self, context, value):
        poses, load = self._poses.Eval(context), self._load
        phi, phi_gripper = self._phi.Eval(context), self._phi_gripper.Eval(context)
        phi_object = phi - phi_gripper if np.any(phi_gripper) else np.zeros(10)
        a, alpha, omega, g = frame_motion(poses[load], self._velocities.Eval(context)[load],
                                          self._accelerations.Eval(context)[load], np.zeros(3), self._g_W)
        V = regressor(a, alpha, omega, g)
        X_SL = (poses[self._sensor] @ self._X_BS).InvertAndCompose(poses[load])
        R_SL, p_SL = X_SL.rotation().matrix(), X_SL.translation()
        out = value.get_mutable_value()
        for part, share in ((slice(0, 6), phi), (slice(6, 12), phi_object)):
            wrench_L = V @ share
            f_S = R_SL @ wrench_L[:3]
            out[part] = np.concatenate((f_S, R_SL @ wrench_L[3:] + np.cross(p_SL, f_S)))
