"""A simulated operator: a hand impedance that pulls the master's stylus along a
reference motion and so feels, and yields to, whatever the device renders."""

from __future__ import annotations

import math

import numpy as np
from pydrake.common.cpp_param import List
from pydrake.common.value import Value
from pydrake.math import RigidTransform
from pydrake.multibody.math import SpatialForce
from pydrake.multibody.plant import ExternallyAppliedSpatialForce, MultibodyPlant
from pydrake.multibody.tree import RigidBody
from pydrake.systems.framework import LeafSystem

from heft.systems.compiled import compiled, float_array, record_views
from heft.systems.pose_vectors import pose_into
from heft.systems.serial_chain import SerialChain, chain_dtype, chain_kinematics


@compiled("UniTuple(float64, 2)(float64, float64, float64, float64[:])")
def smooth_sine_factors(t, start_time, frequency, stroke_scales) -> tuple[float, float]:
    """(s_k·(1 − cos 2πf(t − t0))/2, s_k·πf·sin 2πf(t − t0)) for t ≥ t0, else (0, 0): the offset and
    the rate of ``smooth_sine_offset`` per unit of amplitude."""
    if t < start_time:
        return 0.0, 0.0
    cycles = frequency * (t - start_time)
    scale = stroke_scales[min(int(cycles), stroke_scales.shape[0] - 1)]
    phase = 2.0 * math.pi * cycles
    return scale * 0.5 * (1.0 - math.cos(phase)), scale * math.pi * frequency * math.sin(phase)


def smooth_sine_offset(t, start_time, frequency, amplitude, stroke_scales=(1.0,)):
    """Reference offset s_k·A·(1 − cos 2πf(t − t0))/2 for t ≥ t0, else 0: starts at rest.
    Stroke k is the k-th period, [t0 + k/f, t0 + (k + 1)/f) (s); it is scaled by
    ``stroke_scales[k]``, the last scale repeating. Each stroke starts and ends at rest
    at the start offset, so the reference stays continuous in position and rate.
    Returns (offset, rate) with amplitude's shape."""
    amplitude = np.asarray(amplitude, dtype=float)
    offset, rate = smooth_sine_factors(float(t), float(start_time), float(frequency), float_array(stroke_scales))
    return amplitude * offset, amplitude * rate


def stroke_windows(start_time, frequency, duration) -> list[tuple[float, float]]:
    """The strokes of ``smooth_sine_offset`` that begin before ``duration`` (s), as
    (start, end) in s: stroke k spans [t0 + k/f, t0 + (k + 1)/f)."""
    if frequency <= 0:
        return []
    count = math.ceil((duration - start_time) * frequency)
    return [(start_time + k / frequency, start_time + (k + 1) / frequency) for k in range(max(count, 0))]


@compiled("void(float64, float64, float64, float64[:], float64[:], float64[:], float64[:, :], float64[:], "
          "float64[:, :], float64[:], float64[:], float64[:])")
def reference_into(t, start_time, frequency, stroke_scales, amplitude, rotation_amplitude, R_WE0, p_WE0, R_ref, p_ref,
                   w_ref, v_ref) -> None:
    """The hand's reference at time ``t`` into R_ref (3×3), p_ref, w_ref, v_ref (3 each, in W): the start
    pose (R_WE0, p_WE0) moved by ``smooth_sine_offset`` of ``amplitude`` (m, in W) and of
    ``rotation_amplitude`` (rad, roll-pitch-yaw, R = R_z(y)·R_y(p)·R_x(r) as Drake's ``RollPitchYaw``,
    applied in W). For the small angles used, the roll-pitch-yaw rate is the angular velocity to first order."""
    offset, rate = smooth_sine_factors(t, start_time, frequency, stroke_scales)
    r, p, y = offset * rotation_amplitude[0], offset * rotation_amplitude[1], offset * rotation_amplitude[2]
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    rpy = ((cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr),
           (sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr),
           (-sp, cp * sr, cp * cr))
    for i in range(3):
        for j in range(3):
            R_ref[i, j] = rpy[i][0] * R_WE0[0, j] + rpy[i][1] * R_WE0[1, j] + rpy[i][2] * R_WE0[2, j]
        p_ref[i] = p_WE0[i] + offset * amplitude[i]
        w_ref[i], v_ref[i] = rate * rotation_amplitude[i], rate * amplitude[i]


@compiled("void(float64[:, :], float64[:], float64[:], float64[:], float64[:, :], float64[:], float64[:], "
          "float64[:], float64, float64, float64, float64, float64[:, :], float64[:], float64[:])")
def hand_wrench_into(R_WE, p_WE, w_WE, v_WE, R_ref, p_ref, w_ref, v_ref, k, d, k_rot, d_rot, error, quaternion,
                     out) -> None:
    """Spatial impedance F = K·(ref − actual) + D·(ref rate − rate) at the stylus origin, in W, into
    ``out`` = [τ; f] (6): translational k (N/m), d (N·s/m); rotational k_rot (N·m/rad) on the rotation
    vector of R_ref·Rᵀ (from its quaternion with w ≥ 0: an angle in [0, π]), d_rot (N·m·s/rad).
    ``error`` (3×3) and ``quaternion`` (7, a pose vector) are scratch."""
    for i in range(3):
        for j in range(3):
            error[i, j] = R_ref[i, 0] * R_WE[j, 0] + R_ref[i, 1] * R_WE[j, 1] + R_ref[i, 2] * R_WE[j, 2]
    pose_into(error, p_WE, quaternion)
    x, y, z = quaternion[4], quaternion[5], quaternion[6]
    norm = math.sqrt(x * x + y * y + z * z)
    per_unit = 2.0 * math.atan2(norm, quaternion[3]) / norm if norm > 0.0 else 0.0
    for i in range(3):
        out[i] = k_rot * per_unit * quaternion[4 + i] + d_rot * (w_ref[i] - w_WE[i])
        out[3 + i] = k * (p_ref[i] - p_WE[i]) + d * (v_ref[i] - v_WE[i])


HAND = np.dtype([("start_time", float), ("frequency", float), ("amplitude", float, 3),
                 ("rotation_amplitude", float, 3), ("R_WE0", float, (3, 3)), ("p_WE0", float, 3),
                 ("stiffness", float), ("damping", float), ("rotational_stiffness", float),
                 ("rotational_damping", float), ("R_ref", float, (3, 3)), ("error", float, (3, 3)),
                 ("p_ref", float, 3), ("w_ref", float, 3), ("v_ref", float, 3), ("quaternion", float, 7)])
"""The simulated hand as ``hand_force_into`` takes it: ``reference_into``'s timing, amplitudes and start pose,
``hand_wrench_into``'s gains, and their scratch (the reference, the error rotation, its quaternion)."""


def hand_record(spec, X_WE0: RigidTransform) -> np.ndarray:
    """A ``HAND`` record of the hand ``spec`` (the scenario's ``operator``) starting at the stylus pose X_WE0."""
    hand, arrays = record_views(HAND)
    for name in ("start_time", "frequency", "stiffness", "damping", "rotational_stiffness", "rotational_damping"):
        hand[name] = getattr(spec, name)
    arrays["amplitude"][:], arrays["rotation_amplitude"][:] = spec.amplitude, spec.rotation_amplitude
    arrays["R_WE0"][:], arrays["p_WE0"][:] = X_WE0.rotation().matrix(), X_WE0.translation()
    return hand


@compiled("void(float64, float64[:, :], float64[:], float64[:], HAND[:], float64[:])", HAND=HAND)
def hand_force_into(t, X_WE, V_WE, stroke_scales, hand, out) -> None:
    """``hand_wrench_into`` of the stylus at pose X_WE = [R_WE p_WE] (3×4) with twist V_WE = [ω; v] (6, in W)
    toward ``reference_into``'s reference at time ``t`` (s), strokes scaled by ``stroke_scales``, into ``out`` =
    [τ; f] (6); ``hand``: a ``HAND`` record."""
    h = hand[0]
    R_ref, p_ref, w_ref, v_ref = h["R_ref"], h["p_ref"], h["w_ref"], h["v_ref"]
    reference_into(t, h["start_time"], h["frequency"], stroke_scales, h["amplitude"], h["rotation_amplitude"],
                   h["R_WE0"], h["p_WE0"], R_ref, p_ref, w_ref, v_ref)
    hand_wrench_into(X_WE[:, :3], X_WE[:, 3], V_WE[:3], V_WE[3:], R_ref, p_ref, w_ref, v_ref, h["stiffness"],
                     h["damping"], h["rotational_stiffness"], h["rotational_damping"], h["error"], h["quaternion"], out)


STYLUS_JOINTS = 6
"""The joints between the world and a master's stylus (both bundled masters: ``MasterKinematics``' six)."""
STYLUS = np.dtype([("rows", np.int64, 2 * STYLUS_JOINTS), ("q", float, STYLUS_JOINTS), ("qd", float, STYLUS_JOINTS),
                   ("X_WE", float, (3, 4)), ("V_WE", float, 6)])
"""Where the stylus's joints sit in the master plant's state [q; q̇] (``rows``: the positions', then the
velocities'), and ``hand_force_from_state_into``'s scratch: the joints' q, q̇ and the stylus's pose and twist."""


@compiled("void(float64, float64[:], CHAIN[:], STYLUS[:], float64[:], HAND[:], float64[:])",
          CHAIN=chain_dtype(STYLUS_JOINTS), STYLUS=STYLUS, HAND=HAND)
def hand_force_from_state_into(t, state, chain, stylus, stroke_scales, hand, out) -> None:
    """``hand_force_into`` of the stylus at the master plant's ``state`` [q; q̇]: its pose X_WE and twist
    [ω; v] in W from the joints' q and q̇ (``chain_kinematics`` from the world to the stylus body, ``chain``;
    the twist J·q̇), into ``out`` = [τ; f] (6). ``stylus``: a ``STYLUS`` record."""
    s, c = stylus[0], chain[0]
    q, qd, rows, X, V = s["q"], s["qd"], s["rows"], s["X_WE"], s["V_WE"]
    n = q.shape[0]
    for j in range(n):
        q[j], qd[j] = state[rows[j]], state[rows[n + j]]
    R, p, J = c["R"], c["p"], c["J"]
    chain_kinematics(c["axes"], c["points"], c["M_R"], c["M_p"], q, c["zeros"], c["zeros"], c["gravity_B"], R, p, J,
                     c["motion"], c["work"])
    for i in range(3):
        for k in range(3):
            X[i, k] = R[i, k]
        X[i, 3] = p[i]
    for r in range(6):  # J's rows [v; ω], the twist's [ω; v]
        rate = 0.0
        for j in range(n):
            rate += J[r, j] * qd[j]
        V[(r + 3) % 6] = rate
    hand_force_into(t, X, V, stroke_scales, hand, out)


class OperatorHand(LeafSystem):
    """Hand impedance on the stylus body of a master MultibodyPlant (finalized; the stylus reached from the world
    through six revolute joints and welds, as ``SerialChain`` takes them).

    Input ``state``: the master plant's [q; q̇] (its ``state`` port), from which the stylus's pose and twist
    follow (``hand_force_from_state_into``). Output ``spatial_force``: [ExternallyAppliedSpatialForce] on the
    stylus, for the plant's ``applied_spatial_force`` port. Reference: the stylus's pose in the plant's default
    context, X_WE0, moved by smooth sines (``amplitude`` m in W, ``rotation_amplitude`` rad as roll-pitch-yaw),
    stroke k scaled by ``stroke_scales[k]`` (``smooth_sine_offset``).
    """

    def __init__(self, plant: MultibodyPlant, stylus: RigidBody, spec):
        super().__init__()
        chain = SerialChain(plant, plant.world_frame(), stylus.body_frame())
        if chain.num_joints != STYLUS_JOINTS:
            raise ValueError(f"the operator's hand takes a stylus {STYLUS_JOINTS} joints from the world; "
                             f"{stylus.name()!r} is {chain.num_joints}")
        record, arrays = record_views(STYLUS)
        arrays["rows"][:] = [joint.position_start() for joint in chain.joints] + [
            plant.num_positions() + joint.velocity_start() for joint in chain.joints]
        X_WE0 = plant.EvalBodyPoseInWorld(plant.CreateDefaultContext(), stylus)
        # ``hand_force_from_state_into``'s arguments after the state, and its [τ; f].
        self._wrench = np.empty(6)
        self._settings = (chain.record, record, float_array(spec.stroke_scales), hand_record(spec, X_WE0),
                          self._wrench)
        self._state = self.DeclareVectorInputPort("state", plant.num_multibody_states())
        # The force's body and point, set once; each calculation sets its wrench (the output holds a copy).
        self._force = ExternallyAppliedSpatialForce()
        self._force.body_index, self._force.p_BoBq_B = stylus.index(), np.zeros(3)
        self.DeclareAbstractOutputPort("spatial_force", lambda: Value[List[ExternallyAppliedSpatialForce]](),
                                       self._calc_force)

    def _calc_force(self, context, output):
        hand_force_from_state_into(context.get_time(), self._state.Eval(context), *self._settings)
        self._force.F_Bq_W = SpatialForce(self._wrench)  # [τ; f]
        output.set_value([self._force])
