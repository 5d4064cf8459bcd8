"""A simulated operator: a hand impedance that pulls the master's stylus along a
reference motion and so feels, and yields to, whatever the device renders."""

from __future__ import annotations

import math

import numpy as np
from pydrake.common.cpp_param import List
from pydrake.common.value import Value
from pydrake.math import RigidTransform, RotationMatrix, RollPitchYaw
from pydrake.multibody.math import SpatialForce, SpatialVelocity
from pydrake.multibody.plant import ExternallyAppliedSpatialForce
from pydrake.systems.framework import LeafSystem


def smooth_sine_offset(t, start_time, frequency, amplitude, stroke_scales=(1.0,)):
    """Reference offset s_k·A·(1 − cos 2πf(t − t0))/2 for t ≥ t0, else 0: starts at rest.
    Stroke k is the k-th period, [t0 + k/f, t0 + (k + 1)/f) (s); it is scaled by
    ``stroke_scales[k]``, the last scale repeating. Each stroke starts and ends at rest
    at the start offset, so the reference stays continuous in position and rate.
    Returns (offset, rate) with amplitude's shape."""
    amplitude = np.asarray(amplitude, dtype=float)
    if t < start_time:
        return np.zeros_like(amplitude), np.zeros_like(amplitude)
    cycles = frequency * (t - start_time)
    amplitude = amplitude * stroke_scales[min(int(cycles), len(stroke_scales) - 1)]
    phase = 2 * np.pi * cycles
    return amplitude * 0.5 * (1 - np.cos(phase)), amplitude * np.pi * frequency * np.sin(phase)


def stroke_windows(start_time, frequency, duration) -> list[tuple[float, float]]:
    """The strokes of ``smooth_sine_offset`` that begin before ``duration`` (s), as
    (start, end) in s: stroke k spans [t0 + k/f, t0 + (k + 1)/f)."""
    if frequency <= 0:
        return []
    count = math.ceil((duration - start_time) * frequency)
    return [(start_time + k / frequency, start_time + (k + 1) / frequency) for k in range(max(count, 0))]


def hand_wrench(X_WE, V_WE, X_WE_ref, V_WE_ref, k, d, k_rot, d_rot):
    """Spatial impedance F = K·(ref − actual) + D·(ref rate − rate) at the stylus
    origin, in W: translational k (N/m), d (N·s/m); rotational k_rot (N·m/rad)
    on the axis-angle of R_ref·Rᵀ, d_rot (N·m·s/rad). Returns (f_W, τ_W)."""
    f = k * (X_WE_ref.translation() - X_WE.translation()) + d * (V_WE_ref[3:] - V_WE[3:])
    error = (X_WE_ref.rotation() @ X_WE.rotation().inverse()).ToAngleAxis()
    tau = k_rot * error.angle() * error.axis() + d_rot * (V_WE_ref[:3] - V_WE[:3])
    return f, tau


class OperatorHand(LeafSystem):
    """Hand impedance on the stylus body of a master MultibodyPlant.

    Input ``body_poses`` / ``body_spatial_velocities``: the master plant's ports.
    Output ``spatial_force``: [ExternallyAppliedSpatialForce] on the stylus, for the
    plant's ``applied_spatial_force`` port. Reference: the start pose X_WE0 moved by
    smooth sines (``amplitude`` m in W, ``rotation_amplitude`` rad as roll-pitch-yaw),
    stroke k scaled by ``stroke_scales[k]`` (``smooth_sine_offset``).
    """

    def __init__(self, stylus_body_index, X_WE0: RigidTransform, spec):
        super().__init__()
        self._stylus = int(stylus_body_index)
        self._X_WE0 = X_WE0
        self._spec = spec
        self._poses = self.DeclareAbstractInputPort("body_poses", Value[List[RigidTransform]]())
        self._velocities = self.DeclareAbstractInputPort("body_spatial_velocities", Value[List[SpatialVelocity]]())
        self._stylus_index = stylus_body_index
        self.DeclareAbstractOutputPort("spatial_force", lambda: Value[List[ExternallyAppliedSpatialForce]](),
                                       self._calc_force)

    def reference(self, t):
        """(X_WE_ref, V_WE_ref as [ω; v] in W) at time t."""
        s = self._spec
        dp, dp_rate = smooth_sine_offset(t, s.start_time, s.frequency, s.amplitude, s.stroke_scales)
        drpy, drpy_rate = smooth_sine_offset(t, s.start_time, s.frequency, s.rotation_amplitude, s.stroke_scales)
        R = RotationMatrix(RollPitchYaw(drpy)) @ self._X_WE0.rotation()
        X_ref = RigidTransform(R, self._X_WE0.translation() + dp)
        # For the small angles used, the roll-pitch-yaw rate is the angular velocity to first order.
        return X_ref, np.concatenate((drpy_rate, dp_rate))

    def _calc_force(self, context, output):
        s = self._spec
        X_WE = self._poses.Eval(context)[self._stylus]
        V = self._velocities.Eval(context)[self._stylus]
        X_ref, V_ref = self.reference(context.get_time())
        f, tau = hand_wrench(X_WE, np.concatenate((V.rotational(), V.translational())), X_ref, V_ref,
                             s.stiffness, s.damping, s.rotational_stiffness, s.rotational_damping)
        force = ExternallyAppliedSpatialForce()
        force.body_index, force.p_BoBq_B = self._stylus_index, np.zeros(3)
        force.F_Bq_W = SpatialForce(tau=tau, f=f)
        output.set_value([force])
