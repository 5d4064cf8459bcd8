"""Force feedback to the master (Fig. 4: f′ → f̄_M, τ̄_M → m̄_M = J_Mᵀ·[f̄_M; τ̄_M]).

Sign: f′ = [f; τ] is what the sensor exerts ON THE LOAD (docs/design.md §4). The operator
must feel what the environment does to the tool, and the environment's (and
gravity's) wrench on the load is, in equilibrium, minus the sensor's. So

    f_E = −k_f·R_BR·R_RS·f,   τ_E = −k_τ·R_BR·R_RS·τ

(in B): a contact pushing the tool up pushes the stylus up, and the load's weight,
which the sensor holds up, pulls the stylus down. The moment about S is rendered
as the moment about E (the point the motion scaling maps onto the tool); S's
position does not enter. Then each of f_E and τ_E is clamped to the device's
magnitude limit, keeping its direction.
"""

import math

import numpy as np
from pydrake.math import RollPitchYaw, RotationMatrix

from heft.systems.compiled import compiled, float_array
from heft.systems.controller.feedback_mapping_params import FeedbackMappingParams
from heft.systems.pose_vectors import POSE_SIZE, rotation_into
from heft.systems.tick_system import TickSystem

WRENCH_SIZE = 6
JACOBIAN_SIZE = 36


@compiled("float64(float64, float64, float64, float64)")
def clamp_factor(x: float, y: float, z: float, limit: float) -> float:
    """The factor that scales (x, y, z) down to magnitude ``limit`` if longer (1.0 if not)."""
    norm = math.sqrt(x * x + y * y + z * z)
    return limit / norm if norm > limit else 1.0


def rendered_wrench(wrench_S, R_BS: np.ndarray, force_scale: float, torque_scale: float, max_force: float,
                    max_torque: float) -> np.ndarray:
    """[f_E; τ_E] (6, N and N·m, in B) rendered on the hand from the sensor-on-load wrench
    [f; τ] at S in S (module docstring; ``rendered_wrench_into``); R_BS (3×3) = R_BR·R_RS."""
    out = np.empty(WRENCH_SIZE)
    rendered_wrench_into(float_array(wrench_S), float_array(R_BS), force_scale, torque_scale, max_force, max_torque,
                         out)
    return out


@compiled("void(float64[:], float64[:, :], float64, float64, float64, float64, float64[:])")
def rendered_wrench_into(wrench_S, R_BS, force_scale, torque_scale, max_force, max_torque, out) -> None:
    """``rendered_wrench`` into ``out`` (6): f_E = −k_f·R_BS·f and τ_E = −k_τ·R_BS·τ, each clamped
    to its limit."""
    for part, scale, limit in ((0, force_scale, max_force), (3, torque_scale, max_torque)):
        for r in range(3):
            out[part + r] = -scale * (R_BS[r, 0] * wrench_S[part] + R_BS[r, 1] * wrench_S[part + 1]
                                      + R_BS[r, 2] * wrench_S[part + 2])
        factor = clamp_factor(out[part], out[part + 1], out[part + 2], limit)
        for r in range(3):
            out[part + r] *= factor


@compiled("void(float64[:, :], float64[:, :], float64[:, :])")
def rotation_product_into(R_AB, R_BC, R_AC) -> None:
    """R_AC = R_AB·R_BC (3×3 each) into ``R_AC``."""
    for r in range(3):
        for c in range(3):
            R_AC[r, c] = R_AB[r, 0] * R_BC[0, c] + R_AB[r, 1] * R_BC[1, c] + R_AB[r, 2] * R_BC[2, c]


@compiled("boolean(float64[:], float64[:], float64[:, :], float64, float64, float64, float64, float64[:, :], "
          "float64[:, :], float64[:])")
def wrench_on_hand_into(wrench_S, pose_RS, R_BR, force_scale, torque_scale, max_force, max_torque, R_RS, R_BS,
                        out) -> bool:
    """``rendered_wrench_into`` of ``wrench_S`` with R_BS = R_BR·R_RS, R_RS of ``pose_RS`` (``rotation_into``;
    R_RS, R_BS (3×3) scratch). False, ``out`` untouched, when the wrench is not 6 finite numbers or the
    pose is not a pose (``rotation_into``)."""
    total = 0.0
    for value in wrench_S:
        total += value
    if wrench_S.shape[0] != WRENCH_SIZE or not math.isfinite(total) or not rotation_into(pose_RS, R_RS):
        return False
    rotation_product_into(R_BR, R_RS, R_BS)
    rendered_wrench_into(wrench_S, R_BS, force_scale, torque_scale, max_force, max_torque, out)
    return True


@compiled("void(float64[:], float64[:], float64[:], float64[:, :], float64[:], float64[:, :])")
def hand_wrench_into(out, wrench_S, pose_RS, R_BR, settings, scratch) -> None:
    """[wrench on the hand (6, zero while an input is bad); 1 if the inputs were good] into ``out`` (7):
    ``wrench_on_hand_into`` with ``settings`` [k_f, k_τ, max force (N), max torque (N·m)], ``scratch`` (6, 3)."""
    if wrench_on_hand_into(wrench_S, pose_RS, R_BR, settings[0], settings[1], settings[2], settings[3],
                           scratch[:3], scratch[3:], out[:WRENCH_SIZE]):
        out[WRENCH_SIZE] = 1.0
        return
    for i in range(WRENCH_SIZE):
        out[i] = 0.0
    out[WRENCH_SIZE] = 0.0


@compiled("void(float64[:], float64[:], float64[:])")
def hand_torque_into(out, hand, jacobian) -> None:
    """[τ_M = J_Mᵀ·wrench (6, zero while an input is bad); 1 if one was] into ``out`` (7), from ``hand``
    (``hand_wrench_into``'s) and J_M (36, row-major)."""
    total = 0.0
    for i in range(JACOBIAN_SIZE):
        total += jacobian[i]
    good = hand[WRENCH_SIZE] > 0.5 and math.isfinite(total)
    for j in range(WRENCH_SIZE):
        torque = 0.0
        if good:
            for i in range(WRENCH_SIZE):
                torque += jacobian[i * WRENCH_SIZE + j] * hand[i]
        out[j] = torque
    out[WRENCH_SIZE] = 0.0 if good else 1.0


class FeedbackMapping(TickSystem):
    """Sensor wrench → wrench on the operator's hand and master joint torques.

    Inputs: ``wrench_S`` (6: f′, [f; τ] the sensor exerts on the load, at S, in S; N, N·m),
    ``pose_RS`` (7: S in R, [p; w, x, y, z]; only its rotation is used), ``jacobian``
    (36: J_M row-major, rows [v_E; ω_E] in B, as MasterKinematics gives).
    Outputs: ``wrench_E`` (6: [f; τ] on the hand at E, in B), ``torque`` (6: τ_M = J_Mᵀ·wrench_E,
    N·m), ``fault`` (1: 1.0 while an input is not finite or the pose's quaternion is zero).

    Safe on bad data: ``wrench_E`` is zero while ``wrench_S`` or ``pose_RS`` is bad, and
    ``torque`` zero while any input is bad. Outputs are computed with narrow prerequisites:
    ``wrench_E`` feeds through from ``wrench_S`` and ``pose_RS`` only; ``torque`` and
    ``fault`` from all three inputs. A loop closed through the master plant needs that
    plant's state (e.g. a discrete MultibodyPlant) to break it.
    """

    def __init__(self, params: FeedbackMappingParams | None = None, R_RB=(0.0, 0.0, 0.0)):
        """``R_RB``: the rotation from the master base B to the slave base R as roll-pitch-yaw (rad),
        the motion scaling's (``MotionScalingParams.R_RB``, its one home)."""
        super().__init__(None)
        params = params or FeedbackMappingParams()
        params.validate()
        self.R_BR = RotationMatrix(RollPitchYaw(list(R_RB))).inverse().matrix()
        self.settings = np.array((params.force_scale, params.torque_scale, params.max_force, params.max_torque))
        self.DeclareTickInput("wrench_S", WRENCH_SIZE)
        self.DeclareTickInput("pose_RS", POSE_SIZE)
        self.DeclareTickInput("jacobian", JACOBIAN_SIZE)
        self.DeclareTickCalc("hand", WRENCH_SIZE + 1, hand_wrench_into, "calc:hand", "in:wrench_S", "in:pose_RS",
                             self.R_BR, self.settings, np.empty((6, 3)))
        self.DeclareTickCalc("torque", WRENCH_SIZE + 1, hand_torque_into, "calc:torque", "calc:hand", "in:jacobian")
        self.DeclareTickOutput("wrench_E", "calc:hand", 0, WRENCH_SIZE)
        self.DeclareTickOutput("torque", "calc:torque", 0, WRENCH_SIZE)
        self.DeclareTickOutput("fault", "calc:torque", WRENCH_SIZE, WRENCH_SIZE + 1)
