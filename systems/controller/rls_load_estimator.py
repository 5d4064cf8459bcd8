"""φ̂ learned in the loop: recursive least squares on φ alone, as a block of the controller Diagram.

``RlsLoadEstimator`` takes one sample per tick while its ``enable`` input says so (``EstimatorGate``), from
f − ô = c + V·φ (the offsets are the OffsetTracker's, so the weight cannot trade against them), through
``recursive_estimation``'s kernels (``least_squares_update``: stabilized forgetting towards the prior
P₀ = ``prior_covariance``·E). Two request counters restart it: ``reset`` (a new load, the grasp: the data
forgotten, the estimate kept as the prior) and ``restart`` (a new estimate: [counter, φ (10), …], from which it
starts as from a new load). A third input, ``rest``, brings a new load's static sample (``RestLearner``: the means
of a stretch at rest), which sets the mass and the moment it shows (``take_rest_sample``).
"""

from __future__ import annotations

import math

import numpy as np

from heft.systems.compiled import compiled, record_views
from heft.systems.controller.load_estimation_params import LoadEstimationParams
from heft.systems.controller.offset_tracking import ESTIMATE_SIZE
from heft.systems.controller.rest_learner import SAMPLE_SIZE
from heft.systems.identification.recursive_estimation import (RecursiveLeastSquares, information_start,
                                                              information_update, least_squares_start_from,
                                                              least_squares_update)
from heft.systems.load_dynamics import regressor_into
from heft.systems.tick_system import TickSystem

P = 10
"""The unknowns: φ alone."""
RLS = np.dtype([("weighted", float, (6, P + 1)), ("row", float, P + 1), ("V", float, (6, 10)), ("row_scale", float, 6),
                ("forgetting", float), ("sqrt_forgetting", float), ("pull", float), ("sqrt_prior", float),
                ("theta", float, P)])
"""``least_squares_update``'s and ``least_squares_start_from``'s arguments besides the state, and a scratch φ."""
SKIPPED, RESETS, RESTARTS, RESTS, AT_REST = range(5)
"""The block's counters: enabled ticks whose sample held a NaN or inf, the reset and restart requests seen, the
static samples seen, and the ticks at rest they averaged since the last reset or restart."""
_ROOT = information_start(P)
"""Where the square-root information [S z; 0 ρ] starts in the state."""


@compiled("boolean(float64[::1], float64[:], RLS[:])", RLS=RLS)
def take_rest_sample(state, rest, rls) -> bool:
    """A new load's static sample ``rest`` (``rest_learner.SAMPLE_SIZE``: [counter, n, w̄, [ā; ᾱ], ω̄, ḡ], the
    means of n ticks at rest) into the estimator's ``state``. At rest f = m·s and τ = m·c × s (s = ā − ḡ), so
    the residual r = w̄ − V·φ̂ sets the mass, Δm = r_f·s/|s|², and the moment perpendicular to s,
    Δ(m·c) = s × r_τ/|s|²; the rest of φ̂ is kept. φ̂ moves there with the information it has (z ← z + S·Δ,
    so that S·φ̂ = z still), then the sample's rows, consistent with the new φ̂ and weighted as n samples,
    join the information: what the arm's motion teaches next moves the mass and that moment only as n
    samples at rest allow. A sample that would leave no positive mass (the object pressed on a surface, not
    hanging) or without gravity to weigh by is not taken; returns whether it was."""
    r = rls[0]
    theta, V, weighted = state[:P], r["V"], r["weighted"]
    a, alpha, omega, g = rest[8:11], rest[11:14], rest[14:17], rest[17:20]
    regressor_into(a, alpha, omega, g, V)
    s0, s1, s2 = a[0] - g[0], a[1] - g[1], a[2] - g[2]
    norm2 = s0 * s0 + s1 * s1 + s2 * s2
    if not norm2 > 0.0:
        return False
    residual = r["row"][:6]
    for k in range(6):
        explained = 0.0
        for j in range(P):
            explained += V[k, j] * theta[j]
        residual[k] = rest[2 + k] - explained
    delta = r["theta"]
    delta[:] = 0.0
    delta[0] = (residual[0] * s0 + residual[1] * s1 + residual[2] * s2) / norm2
    if not theta[0] + delta[0] > 0.0:
        return False
    delta[1] = (s1 * residual[5] - s2 * residual[4]) / norm2
    delta[2] = (s2 * residual[3] - s0 * residual[5]) / norm2
    delta[3] = (s0 * residual[4] - s1 * residual[3]) / norm2
    root = state[_ROOT:].reshape((P + 1, P + 1))
    for i in range(P):
        shift = 0.0
        for j in range(i, P):
            shift += root[i, j] * delta[j]
        root[i, P] += shift
    for j in range(P):
        theta[j] += delta[j]
    weight = math.sqrt(rest[1])
    for k in range(6):
        scale = weight * r["row_scale"][k]
        total = 0.0
        for j in range(P):
            weighted[k, j] = V[k, j] * scale
            total += V[k, j] * theta[j]
        weighted[k, P] = total * scale
    information_update(root, theta, weighted, 1.0, 0.0, r["row"])
    state[P] += rest[1]
    return True


@compiled("void(float64[::1], float64[:], float64[:], float64[:], float64[:], float64[:], float64[:], float64[:], "
          "float64[:], float64[:], RLS[:])", RLS=RLS)
def rls_update(state, counters, wrench, acceleration, omega, gravity, enable, reset, restart, rest, rls) -> None:
    """One tick on the estimator's ``state`` and ``counters`` (5): a restart ([counter, φ]) or a reset
    (counter) request first, then a new static sample (``rest``, ``take_rest_sample``), then the sample if
    ``enable`` (1) > 0.5 and it is finite."""
    r = rls[0]
    theta = r["theta"]
    if restart[0] > counters[RESTARTS]:
        counters[RESTARTS], counters[AT_REST] = restart[0], 0.0
        for i in range(P):
            theta[i] = restart[1 + i]
        least_squares_start_from(state, P, r["sqrt_prior"], theta)
    if reset[0] > counters[RESETS]:
        counters[RESETS], counters[AT_REST] = reset[0], 0.0
        for i in range(P):
            theta[i] = state[i]
        least_squares_start_from(state, P, r["sqrt_prior"], theta)
    if rest[0] > counters[RESTS]:
        counters[RESTS] = rest[0]
        if take_rest_sample(state, rest, rls):
            counters[AT_REST] += rest[1]
    if not enable[0] > 0.5:
        return
    total = 0.0
    for i in range(6):
        total += wrench[i] + acceleration[i]
    for i in range(3):
        total += omega[i] + gravity[i]
    if not math.isfinite(total):
        counters[SKIPPED] += 1.0
        return
    least_squares_update(state, P, r["weighted"], r["row"], r["V"], r["row_scale"], wrench, acceleration[:3],
                         acceleration[3:], omega, gravity, r["forgetting"], r["sqrt_forgetting"], r["pull"])


class RlsLoadEstimator(TickSystem):
    """φ̂ (10; Eq. 6) learned online from ``phi`` (module docstring), one sample every ``period`` s.

    Inputs (in S): ``wrench`` (6, f − ô; N, N·m), ``acceleration`` (6, kinematic [a; α]), ``omega`` (3),
    ``gravity`` (3), ``enable`` (1), ``reset`` (1, a counter; unconnected 0), ``restart`` (``ESTIMATE_SIZE``: a
    counter and φ to start from, then offsets it ignores; unconnected none), ``rest`` (``SAMPLE_SIZE``: a new
    load's static sample, ``RestLearner``'s; unconnected none). It keeps its state when the controller restarts
    (``kept_on_restart``). Outputs (state): ``phi`` (10), ``num_samples`` (1, since the last reset or restart, a
    static sample counting as the ticks it averaged), ``num_skipped`` (1, enabled ticks whose sample held a NaN
    or inf)."""

    kept_on_restart = True

    def __init__(self, params: LoadEstimationParams, phi, period: float):
        super().__init__(period)
        prototype = RecursiveLeastSquares(offsets=False, forgetting=params.forgetting,
                                          initial_covariance=params.prior_covariance)
        prototype.start_from(phi)
        (state, _, weighted, row, V, row_scale), (forgetting, sqrt_forgetting, pull, sqrt_prior) = \
            prototype.kernel_arguments
        self.rls, arrays = record_views(RLS)
        arrays["weighted"][:], arrays["row"][:], arrays["V"][:], arrays["row_scale"][:] = weighted, row, V, row_scale
        for name, value in (("forgetting", forgetting), ("sqrt_forgetting", sqrt_forgetting), ("pull", pull),
                            ("sqrt_prior", sqrt_prior)):
            self.rls[name] = value
        for name, size in (("wrench", 6), ("acceleration", 6), ("omega", 3), ("gravity", 3), ("enable", 1)):
            self.DeclareTickInput(name, size)
        self.DeclareTickInput("reset", 1, [0.0])
        self.DeclareTickInput("restart", ESTIMATE_SIZE, np.zeros(ESTIMATE_SIZE))
        self.DeclareTickState("state", state)
        self.DeclareTickInput("rest", SAMPLE_SIZE, np.zeros(SAMPLE_SIZE))
        self.DeclareTickState("counters", np.zeros(5))
        self.DeclareTickUpdate(rls_update, "next:state", "next:counters", "in:wrench", "in:acceleration", "in:omega",
                               "in:gravity", "in:enable", "in:reset", "in:restart", "in:rest", self.rls)
        self.DeclareTickOutput("phi", "x:state", 0, P)
        self.DeclareTickOutput("num_samples", "x:state", P, P + 1)
        self.DeclareTickOutput("num_skipped", "x:counters", SKIPPED, SKIPPED + 1)
