"""Fig. 4's load estimator in the loop, one call per tick, for the real-time controller.

The per-block Diagram (``diagrams.teleop.MakeTeleopController`` with
``controller.estimator.mode: online``) wires four blocks: ``AccelerometerToMotion``,
``EstimatorGate``, ``EstimatorPrefilter`` and ``LoadEstimatorSystem`` (RLS, φ alone).
``OnlineLoadEstimator.step`` does what they do in one tick, calling the same cores
(``estimator_gate.gate_open``/``clocks_now``/``advance_clocks``,
``estimator_prefilter.prefilter_step``, ``recursive_estimation.RecursiveLeastSquares``), in the
order a Diagram's discrete update sees them: the gate decides from this tick's
samples and the clocks before them, the estimator learns from the prefilter's output
of the last tick, then the prefilter takes this tick's sample. All state is
preallocated, the regressor included; the gate, the prefilter and the RLS update are compiled
kernels (``compiled``).
"""

from __future__ import annotations

import math

import numpy as np

from heft.systems.contact_threshold import ContactThresholdParams
from heft.systems.estimator_gate import CLOCKS_START, advance_clocks, clocks_now, gate_open
from heft.systems.load_estimation_params import LoadEstimationParams
from heft.systems.estimator_prefilter import STATE_SIZE, WIDTH, prefilter_coefficients, prefilter_step
from heft.systems.recursive_estimation import RecursiveLeastSquares

# Where the prefilter's sample and output hold each signal (``estimator_prefilter.SIGNALS``).
_WRENCH, _A, _ALPHA, _OMEGA, _GRAVITY = slice(0, 6), slice(6, 9), slice(9, 12), slice(12, 15), slice(15, 18)


class OnlineLoadEstimator:
    """φ̂ (10; Eq. 6) learned from f − ô = c + V·φ̂ while ``EstimatorGate``'s rule allows (module
    docstring), starting from ``phi``, for a controller of nominal ``period`` (s; the prefilter's
    design). ``params`` is ``controller.estimator``; its method must be RLS (``LoadEstimationParams``).

    ``new_load()`` (the grasp, a release, a new tool) forgets the data at the next step but keeps
    the estimate as the prior, and reopens the gate's learning window; ``start_from(phi)`` does the
    same from another estimate. After ``step``: ``phi`` (updated in place), ``enabled`` (the sample
    was taken), ``num_skipped`` (enabled ticks whose filtered inputs were not finite: the
    prefilter's first tick, or a restart after a fault), ``num_stale`` (ticks since the last new load
    whose readings were older than ``max_input_age``: they spoil the sample as a fault does),
    ``since_reset`` (s)."""

    def __init__(self, params: LoadEstimationParams, thresholds: ContactThresholdParams, phi, period: float):
        params.validate()
        thresholds.validate()
        self._thresholds = thresholds
        if params.mode != "online":
            raise ValueError(f"OnlineLoadEstimator needs controller.estimator.mode 'online'; got {params.mode!r}")
        self._params = params
        self._rls = RecursiveLeastSquares(offsets=False, forgetting=params.forgetting)  # as LoadEstimatorSystem's
        self._rls.start_from(phi)
        self.phi = self._rls.phi
        self._coefficients = prefilter_coefficients(params.prefilter, period) if params.prefilter > 0 else None
        self._filter = np.full(STATE_SIZE, np.nan)
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
        params, sample = self._params, self._sample
        stale = input_age > params.max_input_age
        fault = fault or stale
        now = clocks_now(self._clocks, self._requests)
        self.enabled = gate_open(params, self._thresholds, acceleration, omega, contact, fault, now[0], now[2])
        rls = self._rls
        if now[1] > self._clocks[1]:  # a new load: forget the data before this sample
            rls.start_from(self.phi)
            self.num_stale = 0
        if stale:
            self.num_stale += 1
        advance_clocks(self._clocks, params, self._thresholds, now, contact, fault, dt)
        np.add(contact, noncontact, out=sample[_WRENCH])
        sample[6:12] = acceleration
        sample[_OMEGA] = omega
        sample[_GRAVITY] = gravity
        learned = self._filter if self._coefficients is not None else sample
        if self.enabled:
            if math.isfinite(sum(learned[:WIDTH].tolist())):
                rls.update(learned[_WRENCH], learned[_A], learned[_ALPHA], learned[_OMEGA], learned[_GRAVITY])
                self.phi[:] = rls.phi
            else:
                self.num_skipped += 1
        if self._coefficients is not None:
            prefilter_step(self._coefficients, self._filter, sample)
