"""Fig. 4's load estimator in the loop, one call per tick, for the real-time controller.

The per-block Diagram (``diagrams.teleop.MakeTeleopController`` with
``controller.estimator.mode: online``) wires four blocks: ``AccelerometerToMotion``,
``EstimatorGate``, ``EstimatorPrefilter`` and ``LoadEstimatorSystem`` (RLS, φ alone).
``OnlineLoadEstimator.step`` does what they do in one tick, one compiled kernel
(``online_estimate_step``) calling the same cores (``estimator_gate.gate_open``/``clocks_now``/
``advance_clocks``, ``estimator_prefilter.prefilter_step``,
``recursive_estimation.least_squares_update``, which ``RecursiveLeastSquares.update`` calls), in the
order a Diagram's discrete update sees them: the gate decides from this tick's
samples and the clocks before them, the estimator learns from the prefilter's output
of the last tick, then the prefilter takes this tick's sample. All state is
preallocated, the regressor included.
"""

from __future__ import annotations

import math

import numpy as np

from heft.systems.compiled import compiled, float_array
from heft.systems.contact_threshold import ContactThresholdParams
from heft.systems.estimator_gate import CLOCKS_START, advance_clocks, clocks_now, gate_open, gate_settings
from heft.systems.load_estimation_params import LoadEstimationParams
from heft.systems.estimator_prefilter import STATE_SIZE, WIDTH, prefilter_coefficients, prefilter_step
from heft.systems.recursive_estimation import (
    RecursiveLeastSquares, least_squares_start_from, least_squares_update)

ENABLED, SKIPPED, NEW_LOAD = 1, 2, 4
"""The bits of ``online_estimate_step``'s result: the sample was taken; the gate was open but the sample
learned from held a NaN or inf (not learned); a new load started at this sample."""


@compiled("int64(float64[:], float64[:], float64, float64[:], float64[:], float64[:], float64[:], float64[:], "
          "boolean, float64, float64[:], float64[:], float64[:], boolean, float64[:], float64[:], float64[:, :], "
          "float64[::1], int64, float64[:, :], float64[:], float64[:, :], float64[:], float64, float64, float64, "
          "float64)")
def online_estimate_step(settings, clocks, requests, contact, noncontact, acceleration, omega, gravity, fault, dt,
                         sample, filtered, coefficients, prefiltered, phi, no_gravity, gate_V, state, p, weighted,
                         row, V, row_scale, forgetting, sqrt_forgetting, pull, sqrt_prior):
    """``OnlineLoadEstimator.step``'s tick (its docstring; ``fault`` includes stale readings): the gate
    (``settings``, ``clocks`` (3), the reset ``requests`` counter, ``no_gravity`` and ``gate_V`` its
    scratch; the excitation judged on the sample learned from, the contact on this tick's), then the RLS
    (``least_squares_update`` on ``state`` and the arrays after it) learning from the prefilter's output
    (``filtered``, ``STATE_SIZE``, with ``coefficients`` if ``prefiltered``, else this tick's ``sample``
    (``WIDTH``; both laid out as ``estimator_prefilter.SIGNALS``)), φ̂ copied into ``phi`` (10); then the
    prefilter takes the sample.
    Returns ``ENABLED`` | ``SKIPPED`` | ``NEW_LOAD`` bits."""
    since_reset, seen, since_spoiled = clocks_now(clocks, requests)
    for i in range(6):
        sample[i] = contact[i] + noncontact[i]
        sample[6 + i] = acceleration[i]
    for i in range(3):
        sample[12 + i] = omega[i]
        sample[15 + i] = gravity[i]
    learned = filtered if prefiltered else sample
    flags = 0
    if gate_open(settings, learned[6:12], learned[12:15], contact, fault, since_reset, since_spoiled, no_gravity,
                 gate_V):
        flags |= ENABLED
    if seen > clocks[1]:  # a new load: forget the data before this sample
        least_squares_start_from(state, p, sqrt_prior, phi)
        flags |= NEW_LOAD
    advance_clocks(clocks, settings, since_reset, seen, since_spoiled, contact, fault, dt)
    if flags & ENABLED:
        finite = True
        for i in range(WIDTH):
            finite = finite and math.isfinite(learned[i])
        if finite:
            least_squares_update(state, p, weighted, row, V, row_scale, learned[0:6], learned[6:9], learned[9:12],
                                 learned[12:15], learned[15:18], forgetting, sqrt_forgetting, pull)
            for i in range(10):
                phi[i] = state[p - 10 + i]
        else:
            flags |= SKIPPED
    if prefiltered:
        prefilter_step(coefficients, filtered, sample)
    return flags


class OnlineLoadEstimator:
    """φ̂ (10; Eq. 6) learned from f − ô = c + V·φ̂ while ``EstimatorGate``'s rule allows (module
    docstring), starting from ``phi``, for a controller of nominal ``period`` (s; the prefilter's
    design). ``params`` is ``controller.estimator``; its method must be RLS (``LoadEstimationParams``).

    ``new_load()`` (the grasp, a release, a new tool) forgets the data at the next step but keeps
    the estimate as the prior, and reopens the gate's learning window; ``start_from(phi)`` does the
    same from another estimate. After ``step``: ``phi`` (updated in place), ``enabled`` (the sample
    was taken), ``num_skipped`` (ticks the gate opened whose sample learned from held a NaN
    or inf, as ``LoadEstimatorSystem`` counts them), ``num_stale`` (ticks since the last new load
    whose readings were older than ``max_input_age``: they spoil the sample as a fault does),
    ``since_reset`` (s)."""

    def __init__(self, params: LoadEstimationParams, thresholds: ContactThresholdParams, phi, period: float):
        self._settings = gate_settings(params, thresholds)
        if params.mode != "online":
            raise ValueError(f"OnlineLoadEstimator needs controller.estimator.mode 'online'; got {params.mode!r}")
        self._params = params
        self._rls = RecursiveLeastSquares(offsets=False, forgetting=params.forgetting,
                                          initial_covariance=params.prior_covariance)  # as LoadEstimatorSystem's
        self._rls.start_from(phi)
        self.phi = self._rls.phi
        self._prefiltered = params.prefilter > 0
        self._coefficients = prefilter_coefficients(params.prefilter, period) if self._prefiltered else np.zeros(5)
        self._filter = np.full(STATE_SIZE, np.nan)
        self._gate_scratch = (np.zeros(3), np.empty((6, 10)))
        self._rls_arrays, self._rls_settings = self._rls.kernel_arguments
        self._sample = np.empty(WIDTH)
        self._clocks = np.array(CLOCKS_START)
        self._requests = 0.0
        self.enabled = False
        self.num_skipped = self.num_stale = 0

    @property
    def since_reset(self) -> float:
        """s since the last new load (or the start), as of the last step; 0 while one is pending."""
        return 0.0 if self._requests > self._clocks[1] else float(self._clocks[0])

    @property
    def learning_window(self) -> float:
        """s after a new load during which contact does not close the gate (``LoadEstimationParams``)."""
        return self._params.learning_window

    @property
    def max_input_age(self) -> float:
        """The oldest (s) the readings of a tick learned from may be (``LoadEstimationParams``)."""
        return self._params.max_input_age

    @property
    def num_samples(self) -> int:
        """Samples the estimator has taken since the last new load."""
        return self._rls.num_samples

    def new_load(self) -> None:
        """A new load from the next step: the data forgotten, the estimate kept as the prior."""
        self._requests += 1.0

    def start_from(self, phi) -> None:
        """A new load whose estimate is ``phi`` (10): the next step starts from it, as ``new_load``."""
        self._rls.start_from(phi)
        np.copyto(self.phi, phi)
        self.new_load()

    def restart_prefilter(self) -> None:
        """The prefilter forgets its past (a controller restarting after a fault): its next sample
        starts it in its steady state, and the tick after learns from it."""
        self._filter[:] = np.nan

    def step(self, dt: float, contact, noncontact, acceleration, omega, gravity, fault: bool,
             input_age: float = 0.0) -> None:
        """One tick of ``dt`` s: force scaling's ``contact`` c and ``noncontact`` V·φ̂ (6 each: their sum
        is f − ô) and ``fault``, S's kinematic ``acceleration`` [a; α] (6; ``motion_from_reading``),
        ``omega`` and ``gravity`` (3 each), all in S; ``input_age`` (s) the oldest of the readings they
        come from (``LoadEstimationParams.max_input_age``)."""
        stale = input_age > self._params.max_input_age
        flags = online_estimate_step(
            self._settings, self._clocks, self._requests, float_array(contact), float_array(noncontact),
            float_array(acceleration), float_array(omega), float_array(gravity), fault or stale, dt, self._sample,
            self._filter, self._coefficients, self._prefiltered, self.phi, *self._gate_scratch, *self._rls_arrays,
            *self._rls_settings)
        self.enabled = bool(flags & ENABLED)
        if flags & NEW_LOAD:
            self.num_stale = 0
        self.num_stale += stale
        self.num_skipped += bool(flags & SKIPPED)
