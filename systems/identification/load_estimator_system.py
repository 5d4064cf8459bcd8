"""The load estimator of docs/design.md §3 as a Drake LeafSystem around the recursive estimators."""

from __future__ import annotations

import math

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import EventStatus, LeafSystem, ValueProducer

from heft.systems.identification.recursive_estimation import (
    RecursiveInstrumentalVariables, RecursiveLeastSquares, RecursiveTotalLeastSquares)
from heft.systems.identification.regression_noise import NoiseLevels

ESTIMATORS = {
    "rls": RecursiveLeastSquares,
    "riv": RecursiveInstrumentalVariables,
    "rtls": RecursiveTotalLeastSquares,
}
# Entries of the ``quality`` output port.
QUALITY_NAMES = (
    "num_samples",           # samples the estimator has taken
    "num_skipped",           # enabled ticks skipped because an input was NaN or inf
    "reciprocal_condition",  # 1 / estimator.condition_number: 0 when some direction is unidentifiable
    "residual_rms_force",    # ‖forgetting-weighted RMS residual of fx, fy, fz‖ (N)
    "residual_rms_torque",   # ‖… of τx, τy, τz‖ (N·m)
)


class LoadEstimatorSystem(LeafSystem):
    """Estimates φ (Eq. 6) and the sensor offsets online, one sample every ``period`` s.

    Input ports (all in the sensor frame S, docs/design.md §4):
      wrench (6) [f; τ] the sensor exerts on the load (N, N·m); acceleration (6) [a; α]
      (m/s², rad/s²; kinematic: ``accelerometer_reading.AccelerometerToMotion`` converts the
      sensor's reading); omega (3) (rad/s); gravity (3) (m/s²); enable (1): > 0.5 takes the
      sample, otherwise the estimate is frozen; reset (1, optional): a request counter, each
      increase forgets the data before the sample (a new load): RLS keeps its estimate as the
      prior mean (``start_from``), the others start from zero. For method "riv" also
      instrument_acceleration (6) and instrument_omega (3): the same motion from signals
      whose noise is independent of the accelerometer's (e.g. encoder-derived); the
      instrument's gravity is the gravity input.
    Output ports, computed from the discrete state only (no direct feedthrough, so the
    estimator never closes an algebraic loop): phi (10); offsets (6) [f_o; τ_o], zeros when
    not estimated; quality (5), see ``QUALITY_NAMES``.

    ``method`` is "rls", "riv" or "rtls" (``recursive_estimation.Recursive*``); ``initial_theta`` (RLS
    only) the estimate it starts from, [offsets; φ] (or φ); ``forgetting``,
    ``noise`` (``regression_noise.NoiseLevels``, None for its defaults) and ``offsets`` go to the
    estimator, and so do ``estimator_options``
    (``initial_covariance`` for rls/riv, ``prior_weight`` for rtls, ``rcond``). The
    estimator's state is the discrete state vector [estimator.state_vector(), num_skipped,
    resets seen];
    the numpy estimator object that updates it is per-context scratch in a cache entry, so
    nothing mutable lives on the system. A tick whose inputs are not all finite is skipped
    and counted; it never reaches the state.
    """

    def __init__(self, method: str = "rtls", offsets: bool = True, period: float = 1 / 2000,
                 forgetting: float = 1.0, noise: NoiseLevels | None = None, initial_theta=None,
                 **estimator_options):
        super().__init__()
        if method not in ESTIMATORS:
            raise ValueError(f"method must be one of {tuple(ESTIMATORS)}; got {method!r}")
        if not (period > 0.0 and math.isfinite(period)):
            raise ValueError(f"period must be a positive time in s; got {period}")

        def make_estimator():
            return ESTIMATORS[method](offsets=offsets, forgetting=forgetting, noise=noise, **estimator_options)

        prototype = make_estimator()
        if initial_theta is not None:
            if not hasattr(prototype, "start_from"):
                raise ValueError(f"an initial estimate needs method 'rls' (a prior mean); got {method!r}")
            prototype.start_from(initial_theta)
        self._p = 16 if offsets else 10
        self._offsets = offsets
        self._instrumented = method == "riv"

        self._wrench = self.DeclareVectorInputPort("wrench", 6)
        self._acceleration = self.DeclareVectorInputPort("acceleration", 6)
        self._omega = self.DeclareVectorInputPort("omega", 3)
        self._gravity = self.DeclareVectorInputPort("gravity", 3)
        self._enable = self.DeclareVectorInputPort("enable", 1)
        self._reset = self.DeclareVectorInputPort("reset", 1)
        if self._instrumented:
            self._instrument_acceleration = self.DeclareVectorInputPort("instrument_acceleration", 6)
            self._instrument_omega = self.DeclareVectorInputPort("instrument_omega", 3)

        self._state_index = self.DeclareDiscreteState(np.append(prototype.state_vector(), [0.0, 0.0]))
        self._scratch = self.DeclareCacheEntry(
            description="estimator scratch (reloaded from the state before every use)",
            value_producer=ValueProducer(allocate=lambda: AbstractValue.Make(make_estimator()),
                                         calc=lambda context, value: None),
            prerequisites_of_calc={self.nothing_ticket()})
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)

        state_only = {self.xd_ticket()}
        self.DeclareVectorOutputPort("phi", 10, self._calc_phi, prerequisites_of_calc=state_only)
        self.DeclareVectorOutputPort("offsets", 6, self._calc_offsets, prerequisites_of_calc=state_only)
        self.DeclareVectorOutputPort("quality", len(QUALITY_NAMES), self._calc_quality,
                                     prerequisites_of_calc=state_only)

    def _estimator_at(self, context, state: np.ndarray):
        estimator = self._scratch.get_mutable_cache_entry_value(context).GetMutableValueOrThrow()
        estimator.load_state_vector(state[:-2])
        return estimator

    def _update(self, context, discrete_state) -> EventStatus:
        state = discrete_state.get_mutable_vector(self._state_index).get_mutable_value()
        requests = self._reset.Eval(context)[0] if self._reset.HasValue(context) else 0.0
        if requests > state[-1]:  # a new load: forget the data before this sample
            estimator = self._estimator_at(context, state)
            if hasattr(estimator, "start_from"):
                estimator.start_from(estimator.state_vector()[:self._p])  # keep the estimate as the prior
            else:
                estimator.reset()
            state[:-2], state[-1] = estimator.state_vector(), requests
        if not self._enable.Eval(context)[0] > 0.5:
            return EventStatus.Succeeded()
        signals = [self._wrench.Eval(context), self._acceleration.Eval(context),
                   self._omega.Eval(context), self._gravity.Eval(context)]
        if self._instrumented:
            signals += [self._instrument_acceleration.Eval(context), self._instrument_omega.Eval(context)]
        if not math.isfinite(sum(sum(signal.tolist()) for signal in signals)):
            state[-2] += 1.0
            return EventStatus.Succeeded()
        estimator = self._estimator_at(context, state)
        wrench, acceleration, omega, gravity = signals[:4]
        if self._instrumented:
            instrument = (signals[4][:3], signals[4][3:], signals[5], gravity)
            estimator.update(wrench, acceleration[:3], acceleration[3:], omega, gravity, instrument=instrument)
        else:
            estimator.update(wrench, acceleration[:3], acceleration[3:], omega, gravity)
        state[:-2] = estimator.state_vector()
        return EventStatus.Succeeded()

    def _state(self, context) -> np.ndarray:
        return context.get_discrete_state(self._state_index).get_value()

    def _calc_phi(self, context, output):
        output.SetFromVector(self._state(context)[self._p - 10:self._p])

    def _calc_offsets(self, context, output):
        output.SetFromVector(self._state(context)[:6] if self._offsets else np.zeros(6))

    def _calc_quality(self, context, output):
        state = self._state(context)
        estimator = self._estimator_at(context, state)
        condition = estimator.condition_number
        rms = estimator.residual_rms
        output.SetFromVector([estimator.num_samples, state[-2], 1.0 / condition,
                              np.linalg.norm(rms[:3]), np.linalg.norm(rms[3:])])
