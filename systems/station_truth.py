"""Ground truth at the wrist sensor of a simulated slave, read off a
MultibodyPlant's output ports: the weld's reaction wrench, the sensor frame's
motion, and the contact wrench from the plant's contact results.

All outputs in DESIGN §4 conventions: at S's origin, expressed in S; wrenches
[f; τ] as the sensor exerts them on the load.
"""

from __future__ import annotations

import numpy as np
from pydrake.common.cpp_param import List
from pydrake.common.value import AbstractValue, Value
from pydrake.math import RigidTransform
from pydrake.multibody.math import SpatialAcceleration, SpatialForce, SpatialVelocity
from pydrake.multibody.plant import ContactResults
from pydrake.systems.framework import LeafSystem

from heft.systems.accelerometer_reading import reading_from_motion
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


class SensorFrameKinematics(LeafSystem):
    """Motion of the sensor frame S, fixed at p_BS (m) in body B's frame.

    Inputs: the plant's ``body_poses``, ``body_spatial_velocities``,
    ``body_spatial_accelerations``. Outputs: ``acceleration`` [a; α] of S in S
    (m/s², rad/s²), ``omega`` ω_WS in S (rad/s), ``gravity`` g in S (m/s²), and
    ``accelerometer_reading``, what an ideal accelerometer at S reports
    (``accelerometer_reading`` with ``accelerometer_includes_gravity``).
    """

    def __init__(self, body_index, p_BS, gravity_W, accelerometer_includes_gravity: bool = True):
        super().__init__()
        self._includes_gravity = accelerometer_includes_gravity
        self._body = int(body_index)
        self._p_BS = np.asarray(p_BS, dtype=float)
        self._g_W = np.asarray(gravity_W, dtype=float)
        self._poses = self.DeclareAbstractInputPort("body_poses", Value[List[RigidTransform]]())
        self._velocities = self.DeclareAbstractInputPort("body_spatial_velocities", Value[List[SpatialVelocity]]())
        self._accelerations = self.DeclareAbstractInputPort("body_spatial_accelerations",
                                                            Value[List[SpatialAcceleration]]())
        self.DeclareVectorOutputPort("acceleration", 6, self._calc_acceleration)
        self.DeclareVectorOutputPort("omega", 3, self._calc_omega)
        self.DeclareVectorOutputPort("gravity", 3, self._calc_gravity)
        self.DeclareVectorOutputPort("accelerometer_reading", 6, self._calc_reading)

    def _R_SW(self, context):
        return self._poses.Eval(context)[self._body].rotation().inverse()

    def _calc_reading(self, context, output):
        output.SetFromVector(reading_from_motion(self.GetOutputPort("acceleration").Eval(context),
                                                 self.GetOutputPort("gravity").Eval(context), self._includes_gravity))

    def _calc_acceleration(self, context, output):
        R_WB = self._poses.Eval(context)[self._body].rotation()
        w_WB_W = self._velocities.Eval(context)[self._body].rotational()
        A_WS_W = self._accelerations.Eval(context)[self._body].Shift(R_WB @ self._p_BS, w_WB_W)
        R_SW = R_WB.inverse().matrix()
        output.SetFromVector(np.concatenate((R_SW @ A_WS_W.translational(), R_SW @ A_WS_W.rotational())))

    def _calc_omega(self, context, output):
        output.SetFromVector(self._R_SW(context) @ self._velocities.Eval(context)[self._body].rotational())

    def _calc_gravity(self, context, output):
        output.SetFromVector(self._R_SW(context) @ self._g_W)


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
    """V(a, α, ω, g)·φ (Eq. 12) for the true parameters.

    Inputs ``acceleration`` ([a; α], 6), ``omega`` (3), ``gravity`` (3), all in S, ``phi``
    (10, the load's true φ); output ``wrench`` (6)."""

    def __init__(self):
        super().__init__()
        self._phi = self.DeclareVectorInputPort("phi", 10)
        self._acceleration = self.DeclareVectorInputPort("acceleration", 6)
        self._omega = self.DeclareVectorInputPort("omega", 3)
        self._gravity = self.DeclareVectorInputPort("gravity", 3)
        self.DeclareVectorOutputPort("wrench", 6, self._calc)

    def _calc(self, context, output):
        accel = self._acceleration.Eval(context)
        V = regressor(accel[:3], accel[3:], self._omega.Eval(context), self._gravity.Eval(context))
        output.SetFromVector(V @ self._phi.Eval(context))
