"""A grasped load learned while the arm holds still: its weight and the static moment the pose shows.

At rest (a = α = ω = 0) Eq. 5 leaves f = m·s and τ = m·c × s, s = a − g the specific force at S: the force
gives the mass, the torque the two components of m·c perpendicular to s (gravity in S); the component along
it and the inertia stay unseen until the arm moves. The RLS takes no sample at rest (``EstimatorGate``: too
little excitation), so without this block a grasp held still is felt whole until the arm moves.

``RestLearner`` watches the estimator's inputs (after the prefilter, whose 10 Hz low-pass also holds back a
compliant mount's rocking) during ``learning_window`` s after a grasp (or a new load asked for from
outside), in blocks of ``rest_window`` s. A block counts if every tick of it is finite and at rest (its
excitation below ``min_excitation``, as the gate judges it). At the end of a block it computes the residual
r = w̄ − V(ā, ᾱ, ω̄, ḡ)·φ̂ of the block's means: the wrench the estimate in use does not explain. When two
blocks in a row agree (the step at the grasp has settled: their residuals within ``rest_agreement`` of the
newer's magnitude plus one sample's noise, per force and torque) and the newer's residual is beyond one
sample's noise (a step to learn), the newer block's means are the load's static sample: output ``sample``
([counter, ticks averaged, w̄ (6), [ā; ᾱ] (6), ω̄ (3), ḡ (3)]), which ``RlsLoadEstimator`` takes as the
new load's weight and static moment (``rls_load_estimator.take_rest_sample``). A release or a new tool's
estimate (known loads) ends the watch.

Units: N, N·m, m/s², rad/s², rad/s, s; all in S.
"""

import math

import numpy as np

from heft.systems.compiled import compiled
from heft.systems.controller.estimator_gate import regressor_norm
from heft.systems.controller.load_estimation_params import LoadEstimationParams
from heft.systems.identification.regression_noise import NoiseLevels
from heft.systems.load_dynamics import regressor_into
from heft.systems.tick_system import TickSystem

SAMPLE_SIZE = 20
"""The static sample handed to the estimator: [counter, ticks averaged, w̄ (6), [ā; ᾱ] (6), ω̄ (3), ḡ (3)]."""
SUMS = 18
"""The sums of a block: wrench (6), acceleration (6), omega (3), gravity (3), as ``SAMPLE_SIZE``'s means."""
BLOCK_TICKS, WINDOW, MIN_EXCITATION, AGREEMENT, FORCE_NOISE, TORQUE_NOISE, PERIOD = range(7)
"""Where ``rest_settings`` holds each setting."""
GRASPS_SEEN, RESETS_SEEN, SINCE = range(3)
"""The block's clocks: the grasp and new-load counters seen, the time (s) since the grasp watched (inf: none)."""
COUNT, VALID, BLOCK_SUMS, PREVIOUS_VALID, PREVIOUS_RESIDUAL = 0, 1, slice(2, 2 + SUMS), 2 + SUMS, slice(
    3 + SUMS, 9 + SUMS)
BLOCKS_SIZE = 9 + SUMS
"""The blocks' state: the ticks in the block under way, whether all were at rest and finite (1/0), their
sums; whether the previous block counted (1/0), its residual (6)."""
WORK_SIZE = SUMS + 6 + 3
"""The kernel's scratch: a block's means, the newer and the older residual (3 + 3), zeros (3)."""


def rest_settings(params: LoadEstimationParams, period: float, noise: NoiseLevels) -> np.ndarray:
    """The settings as the kernel takes them (indexed as named above): ticks per block (``rest_window``
    over ``period`` s, at least 1), ``learning_window`` (s), ``min_excitation``, ``rest_agreement`` and one
    sample's noise (N, N·m: ``noise``, the estimator's weights)."""
    params.validate()
    ticks = max(1, round(params.rest_window / period))
    return np.array([ticks, params.learning_window, params.min_excitation, params.rest_agreement, noise.force,
                     noise.torque, period])


@compiled("boolean(float64[:], float64, float64)")
def _agree(residuals, agreement, noise) -> bool:
    """Whether the 3-vectors ``residuals[:3]`` (the newer) and ``residuals[3:6]`` (the older) lie within
    ``agreement``·|newer| + ``noise`` of each other."""
    newer = math.sqrt(residuals[0] ** 2 + residuals[1] ** 2 + residuals[2] ** 2)
    apart = math.sqrt((residuals[0] - residuals[3]) ** 2 + (residuals[1] - residuals[4]) ** 2
                      + (residuals[2] - residuals[5]) ** 2)
    return apart <= agreement * newer + noise


@compiled("void(float64[:], float64[:], float64[:], float64[:], float64[:], float64[:], float64[:], float64[:], "
          "float64[:], float64[:], float64[:], float64[:, :], float64[:])")
def rest_update(clocks, blocks, sample, wrench, acceleration, omega, gravity, phi, grasps, resets, settings, V,
                work) -> None:
    """One tick of ``RestLearner`` (module docstring) on its ``clocks`` (3), ``blocks`` (``BLOCKS_SIZE``) and
    ``sample`` (``SAMPLE_SIZE``) from the estimator's inputs and φ̂ (10); ``grasps`` (1) counts the grasps
    (and new loads asked for from outside), ``resets`` (1) every new load the estimator takes (a release's
    and a new tool's too); ``V`` (6, 10) and ``work`` (``WORK_SIZE``) are scratch."""
    if resets[0] > clocks[RESETS_SEEN]:
        clocks[RESETS_SEEN] = resets[0]
        clocks[SINCE] = math.inf
        if grasps[0] > clocks[GRASPS_SEEN]:
            clocks[GRASPS_SEEN], clocks[SINCE] = grasps[0], 0.0
            blocks[:] = 0.0
            blocks[VALID] = 1.0
    if not clocks[SINCE] < settings[WINDOW]:
        return
    clocks[SINCE] += settings[PERIOD]
    means, residuals, zeros = work[:SUMS], work[SUMS:SUMS + 6], work[SUMS + 6:]
    total = 0.0
    for i in range(6):
        total += wrench[i] + acceleration[i]
    for i in range(3):
        total += omega[i] + gravity[i]
    if not math.isfinite(total) or regressor_norm(acceleration, omega, zeros, V) >= \
            settings[MIN_EXCITATION]:
        blocks[VALID] = 0.0
    elif blocks[VALID] > 0.5:
        for i in range(6):
            blocks[BLOCK_SUMS.start + i] += wrench[i]
            blocks[BLOCK_SUMS.start + 6 + i] += acceleration[i]
        for i in range(3):
            blocks[BLOCK_SUMS.start + 12 + i] += omega[i]
            blocks[BLOCK_SUMS.start + 15 + i] += gravity[i]
    blocks[COUNT] += 1.0
    if blocks[COUNT] < settings[BLOCK_TICKS]:
        return
    counted = blocks[VALID] > 0.5
    if counted:
        for i in range(SUMS):
            means[i] = blocks[BLOCK_SUMS.start + i] / blocks[COUNT]
        regressor_into(means[6:9], means[9:12], means[12:15], means[15:18], V)
        steady, beyond = blocks[PREVIOUS_VALID] > 0.5, False
        for half in range(2):
            part, noise = 3 * half, settings[FORCE_NOISE + half]
            for r in range(3):
                explained = 0.0
                for j in range(10):
                    explained += V[part + r, j] * phi[j]
                residuals[r] = means[part + r] - explained
                residuals[3 + r] = blocks[PREVIOUS_RESIDUAL.start + part + r]
                blocks[PREVIOUS_RESIDUAL.start + part + r] = residuals[r]
            steady = steady and _agree(residuals, settings[AGREEMENT], noise)
            beyond = beyond or math.sqrt(residuals[0] ** 2 + residuals[1] ** 2 + residuals[2] ** 2) > noise
        if steady and beyond:
            sample[0] += 1.0
            sample[1] = blocks[COUNT]
            for i in range(SUMS):
                sample[2 + i] = means[i]
    blocks[:PREVIOUS_VALID] = 0.0
    blocks[VALID] = 1.0
    blocks[PREVIOUS_VALID] = 1.0 if counted else 0.0


class RestLearner(TickSystem):
    """The static sample of a grasped load held still (module docstring), every ``period`` s.

    Inputs (in S): ``wrench`` (6, f − ô), ``acceleration`` (6, kinematic [a; α]), ``omega`` (3), ``gravity`` (3),
    as the estimator takes them (``EstimatorPrefilter``'s outputs); ``phi`` (10, φ̂ in use); ``grasps`` (1, a
    counter of new loads to learn: ``GraspSplit``'s ``new_load``) and ``resets`` (1, a counter of every new load
    the estimator takes; both unconnected 0). Output: ``sample`` (``SAMPLE_SIZE``, state). It keeps its state when
    the controller restarts (``kept_on_restart``): a restart is no grasp."""

    kept_on_restart = True

    def __init__(self, params: LoadEstimationParams, period: float, noise: NoiseLevels):
        super().__init__(period)
        self.settings = rest_settings(params, period, noise)
        for name, size in (("wrench", 6), ("acceleration", 6), ("omega", 3), ("gravity", 3), ("phi", 10)):
            self.DeclareTickInput(name, size)
        self.DeclareTickInput("grasps", 1, [0.0])
        self.DeclareTickInput("resets", 1, [0.0])
        self.DeclareTickState("clocks", [0.0, 0.0, math.inf])
        self.DeclareTickState("blocks", np.zeros(BLOCKS_SIZE))
        self.DeclareTickState("sample", np.zeros(SAMPLE_SIZE))
        self.DeclareTickUpdate(rest_update, "next:clocks", "next:blocks", "next:sample", "in:wrench",
                               "in:acceleration", "in:omega", "in:gravity", "in:phi", "in:grasps", "in:resets",
                               self.settings, np.zeros((6, 10)), np.zeros(WORK_SIZE))
        self.DeclareTickOutput("sample", "x:sample")
