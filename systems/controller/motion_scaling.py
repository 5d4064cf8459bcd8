"""Motion scaling with a clutch (Fig. 4: ᴮT_E → ᴿT_E, "for orientation scaling
quaternions are employed").

At engagement the stylus pose X_BE0 and the slave tool pose X_RT0 are stored as
anchors. While engaged, the desired tool pose is

    p_RT* = p_RT0 + k_t·R_RB·(p_BE − p_BE0)
    R_RT* = R_RB·ΔR^k_r·R_RBᵀ·R_RT0,   ΔR = R_BE·R_BE0ᵀ  (the stylus rotation since engagement, in B)

where ΔR^k_r is the quaternion power (the slerp from the identity to ΔR at k_r): the
same axis, the angle θ ∈ [0, π] scaled by k_r. R_RB·AngleAxis(kθ, a)·R_RBᵀ =
AngleAxis(kθ, R_RB·a), so the scaled rotation turns about the mapped axis. As for any
quaternion power, a stylus rotation through π from the anchor flips the axis; with
k_r ≠ 1 the output then jumps: re-index (clutch) before that.

No jumps: the clutch released holds the last desired pose; at re-engagement the
anchors are the current stylus pose and the slave's measured pose, so the output
continues from where the slave is (it steps by the slave's tracking error only, zero
for a settled slave); a change of k_t or k_r while engaged re-anchors at the current
stylus pose and the desired pose just computed with the old scales.
"""

import math

import numpy as np
from pydrake.math import RollPitchYaw, RotationMatrix

from heft.systems.compiled import compiled, float_array
from heft.systems.controller.motion_scaling_params import MotionScalingParams
from heft.systems.pose_vectors import POSE_SIZE
from heft.systems.sample_period import DEFAULT_PERIOD, require_period
from heft.systems.tick_system import TickSystem

IDENTITY_POSE = np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0])
# Layout of the memory state: [engaged, k_t, k_r, pose_BE0 (7), pose_RT0 (7)].
_ENGAGED, _SCALES, _BE0, _RT0 = 0, slice(1, 3), slice(3, 10), slice(10, 17)
MEMORY_SIZE = 17


@compiled("boolean(float64[:])")
def valid_pose(pose) -> bool:
    """True if ``pose`` is 7 finite numbers with a non-zero quaternion."""
    if pose.shape[0] != POSE_SIZE:
        return False
    total = 0.0
    for i in range(POSE_SIZE):
        total += pose[i]
    norm2 = pose[3] * pose[3] + pose[4] * pose[4] + pose[5] * pose[5] + pose[6] * pose[6]
    return math.isfinite(total) and norm2 > 1e-18


@compiled("void(float64[:], float64[:])")
def unit_pose_into(pose, out) -> None:
    """``pose`` (valid) with its quaternion normalised and w ≥ 0, into ``out`` (may be ``pose``)."""
    w, x, y, z = pose[3], pose[4], pose[5], pose[6]
    scale = math.copysign(1.0 / math.sqrt(w * w + x * x + y * y + z * z), w)
    out[0], out[1], out[2] = pose[0], pose[1], pose[2]
    out[3], out[4], out[5], out[6] = w * scale, x * scale, y * scale, z * scale


@compiled("UniTuple(float64, 4)(float64, float64, float64, float64, float64, float64, float64, float64)")
def _product(aw, ax, ay, az, bw, bx, by, bz):
    """The Hamilton product a ⊗ b of quaternions (w, x, y, z): the rotation R_a·R_b."""
    return (aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw)


@compiled("void(float64[:], float64[:], float64[:], float64[:, :], float64, float64, float64[:])")
def scaled_pose_into(pose_BE, pose_BE0, pose_RT0, R_RB, translation_scale, rotation_scale, pose) -> None:
    """X_RT* of the module docstring as a pose vector (w ≥ 0) into ``pose``: the stylus motion since
    the anchor ``pose_BE0``, scaled and mapped into R (``R_RB``, 3×3), applied to the tool's anchor
    ``pose_RT0``. Poses are unit pose vectors."""
    # ΔR = R_BE·R_BE0ᵀ as a quaternion, w ≥ 0 so that its angle θ = 2·atan2(|v|, w) is in [0, π].
    dw, dx, dy, dz = _product(pose_BE[3], pose_BE[4], pose_BE[5], pose_BE[6],
                              pose_BE0[3], -pose_BE0[4], -pose_BE0[5], -pose_BE0[6])
    if dw < 0.0:
        dw, dx, dy, dz = -dw, -dx, -dy, -dz
    sine = math.sqrt(dx * dx + dy * dy + dz * dz)
    sw, sx, sy, sz = 1.0, 0.0, 0.0, 0.0
    if sine > 0.0:
        half = rotation_scale * math.atan2(sine, dw)  # (k_r·θ)/2
        factor = math.sin(half) / sine
        sw = math.cos(half)  # the axis mapped into R: R_RB·(dx, dy, dz)/sine
        sx = factor * (R_RB[0, 0] * dx + R_RB[0, 1] * dy + R_RB[0, 2] * dz)
        sy = factor * (R_RB[1, 0] * dx + R_RB[1, 1] * dy + R_RB[1, 2] * dz)
        sz = factor * (R_RB[2, 0] * dx + R_RB[2, 1] * dy + R_RB[2, 2] * dz)
    for r in range(3):
        moved = 0.0
        for c in range(3):
            moved += R_RB[r, c] * (pose_BE[c] - pose_BE0[c])
        pose[r] = pose_RT0[r] + translation_scale * moved
    w, x, y, z = _product(sw, sx, sy, sz, pose_RT0[3], pose_RT0[4], pose_RT0[5], pose_RT0[6])
    sign = -1.0 if w < 0.0 else 1.0
    pose[3], pose[4], pose[5], pose[6] = sign * w, sign * x, sign * y, sign * z


def scaled_pose(pose_BE, pose_BE0, pose_RT0, R_RB: np.ndarray, translation_scale: float,
                rotation_scale: float) -> np.ndarray:
    """``scaled_pose_into`` as a new pose vector."""
    pose = np.empty(POSE_SIZE)
    scaled_pose_into(float_array(pose_BE), float_array(pose_BE0), float_array(pose_RT0), float_array(R_RB),
                     translation_scale, rotation_scale, pose)
    return pose


def motion_scaling_update(memory, desired, pose_BE, engaged: bool, pose_RT_measured, translation_scale: float,
                          rotation_scale: float, R_RB: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One tick of the clutch logic (``motion_scaling_step``): (memory, desired pose) → the new (memory,
    desired pose), new arrays."""
    memory, desired = np.array(memory, dtype=float), np.array(desired, dtype=float)
    motion_scaling_step(memory, desired, float_array(pose_BE), engaged, float_array(pose_RT_measured),
                        translation_scale, rotation_scale, float_array(R_RB), np.empty(POSE_SIZE))
    return memory, desired


@compiled("void(float64[:], float64[:], float64[:], boolean, float64[:], float64, float64, float64[:, :], "
          "float64[:])")
def motion_scaling_step(memory, desired, pose_BE, engaged, pose_RT_measured, translation_scale, rotation_scale,
                        R_RB, scratch) -> None:
    """One tick of the clutch logic, in place on ``memory`` and ``desired`` (``scratch``: 7 floats).

    ``memory`` is [engaged, k_t, k_r, pose_BE0, pose_RT0] (17), ``desired`` the pose of
    the last tick (7), ``R_RB`` the 3×3 rotation from B to R. Disengaged, or an invalid
    stylus pose or scale: hold ``desired`` and drop the engagement (so the next valid
    engaged tick re-anchors). Rising edge: anchor at ``pose_BE`` and ``pose_RT_measured``
    (held if the latter is invalid). Engaged: the scaled pose with the stored scales; if
    the scales changed, re-anchor at ``pose_BE`` and that pose, and store the new scales.
    """
    usable = (engaged and valid_pose(pose_BE) and math.isfinite(translation_scale) and translation_scale >= 0
              and math.isfinite(rotation_scale) and rotation_scale >= 0)
    anchored = memory[_ENGAGED] >= 0.5
    if not usable or (not anchored and not valid_pose(pose_RT_measured)):
        memory[_ENGAGED] = 0.0
        return
    BE0, RT0 = memory[3:10], memory[10:17]
    unit_pose_into(pose_BE, scratch)
    if anchored:
        scaled_pose_into(scratch, BE0, RT0, R_RB, memory[1], memory[2], desired)
        if memory[1] == translation_scale and memory[2] == rotation_scale:
            return
    else:
        unit_pose_into(pose_RT_measured, desired)
    memory[_ENGAGED], memory[1], memory[2] = 1.0, translation_scale, rotation_scale
    BE0[:] = scratch
    RT0[:] = desired


@compiled("void(float64[:], float64[:], float64[:], float64[:], float64[:], float64[:], float64[:], float64[:, :], "
          "float64[:])")
def motion_tick(memory, desired, pose_BE, clutch, measured, translation_scale, rotation_scale, R_RB, scratch):
    """``motion_scaling_step`` on the block's arrays: ``clutch`` (1) > 0.5 engaged, the scales (1 each)."""
    motion_scaling_step(memory, desired, pose_BE, clutch[0] > 0.5, measured, translation_scale[0], rotation_scale[0],
                        R_RB, scratch)


@compiled("void(float64[:], float64[:], float64[:], float64[:], float64[:], float64[:], float64[:], float64[:, :], "
          "float64[:])")
def motion_initialize(memory, desired, pose_BE, clutch, measured, translation_scale, rotation_scale, R_RB, scratch):
    """The initialization: disengaged, the desired pose the ``measured`` one (if a pose), then a tick."""
    memory[_ENGAGED] = 0.0
    if valid_pose(measured):
        unit_pose_into(measured, desired)
    motion_tick(memory, desired, pose_BE, clutch, measured, translation_scale, rotation_scale, R_RB, scratch)


class MotionScaling(TickSystem):
    """Stylus pose → desired slave tool pose, scaled, with a clutch (module docstring).

    Inputs: ``pose_BE`` (7, stylus E in master base B), ``clutch`` (1, > 0.5 = engaged),
    ``pose_RT_measured`` (7, the slave tool frame T in slave base R, read at engagement
    and initialization), ``translation_scale`` and ``rotation_scale`` (1 each, optional:
    unconnected, the parameters' values are used). Output: ``pose_RT_desired`` (7).
    Poses are [p (m); quaternion w, x, y, z].

    Updated at initialization and every ``period`` (offset 0). Initialization clears the
    engagement and sets the desired pose to the measured one (so a start with the clutch
    released holds the slave where it is), then runs the tick (a start engaged anchors).
    The output is discrete state: no direct feedthrough, so the closed bilateral loop has
    no algebraic loop through here.
    """

    def __init__(self, params: MotionScalingParams | None = None, period: float = DEFAULT_PERIOD):
        params = params or MotionScalingParams()
        params.validate()
        super().__init__(require_period(period))
        self.R_RB = RotationMatrix(RollPitchYaw(params.R_RB)).matrix()
        self.DeclareTickInput("pose_BE", POSE_SIZE)
        self.DeclareTickInput("clutch", 1)
        self.DeclareTickInput("pose_RT_measured", POSE_SIZE)
        self.DeclareTickInput("translation_scale", 1, [params.translation_scale])
        self.DeclareTickInput("rotation_scale", 1, [params.rotation_scale])
        self.DeclareTickState("memory", np.concatenate(([0.0, params.translation_scale, params.rotation_scale],
                                                        IDENTITY_POSE, IDENTITY_POSE)))
        self.DeclareTickState("desired", IDENTITY_POSE)
        args = ("next:memory", "next:desired", "in:pose_BE", "in:clutch", "in:pose_RT_measured",
                "in:translation_scale", "in:rotation_scale", self.R_RB, np.empty(POSE_SIZE))
        self.DeclareTickInitialization(motion_initialize, *args)
        self.DeclareTickUpdate(motion_tick, *args)
        self.DeclareTickOutput("pose_RT_desired", "x:desired")
