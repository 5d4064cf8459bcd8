"""When the online load estimator may learn (Fig. 4's estimator in the loop).

A sample teaches the estimator about φ only if the motion excites the regressor
beyond statics, and corrupts it if the wrench holds contact. So a sample is
taken when

* excitation: ‖V(a, α, ω, 0)‖ (the regressor of Eq. 5 without its static part,
  a the kinematic acceleration) of the motion the estimator learns from (the
  prefilter's output, ``EstimatorPrefilter``) reaches ``min_excitation``: at rest or
  in slow motion only gravity's direction is seen, which the stabilized forgetting
  of ``recursive_estimation`` already holds. Judged on the unfiltered motion, the
  accelerometer's noise alone reaches it at rest (heft's model, α's noise 0.5 rad/s²
  RMS: ‖V‖ has a median of 1.7 and passes 2 in a third of the samples), and the
  samples so taken fit what rest leaves unseen (m·c along gravity) to that noise; and
* no contact: the eliminated wrench c (Eq. 13, from force scaling) is within
  ``controller.contact`` (``ContactThresholdParams``), except during ``learning_window`` s
  after a reset (a new load), when c holds the not yet learned load itself,
* force scaling is not faulted, nor (on hardware) the readings older than
  ``max_input_age`` (its ``input_age`` input: a stalled lab's catch-up jerks the
  arm and rings the load on its mount), and
* no contact or fault for 2/``prefilter`` s before: the estimator's prefilter
  (``EstimatorPrefilter``) still carries such a sample that long; and
* ``new_load_wait`` s have passed since the last reset (0 by default).

Units: m/s², rad/s², rad/s for the motion, N and N·m for the wrench; all in S.
"""

import math

import numpy as np

from heft.systems.controller.contact_threshold import ContactThresholdParams
from heft.systems.compiled import compiled, float_array
from heft.systems.load_dynamics import beyond, regressor_into
from heft.systems.controller.load_estimation_params import LoadEstimationParams
from heft.systems.tick_system import TickSystem

_ZERO = np.zeros(3)
_V = np.empty((6, 10))
"""The regressor's scratch: the gate is judged on one thread (the loop's, or the simulator's)."""


@compiled("float64(float64[:], float64[:], float64[:], float64[:, :])")
def regressor_norm(acceleration, omega, g, V) -> float:
    """‖V(a, α, ω, g)‖ (Frobenius) of [a; α] (6), ω and g (3), V (6, 10) the scratch."""
    regressor_into(acceleration[:3], acceleration[3:], omega, g, V)
    total = 0.0
    for i in range(6):
        for j in range(10):
            total += V[i, j] * V[i, j]
    return math.sqrt(total)


def excitation(acceleration, omega) -> float:
    """‖V(a, α, ω, 0)‖ of the kinematic [a; α] (6) and ω (3), in S."""
    return regressor_norm(float_array(acceleration), float_array(omega), _ZERO, _V)


LEARNING_WINDOW, HOLD, NEW_LOAD_WAIT, MIN_EXCITATION, CONTACT_FORCE, CONTACT_TORQUE = range(6)
"""Where ``gate_settings`` holds each setting."""


def gate_settings(params: LoadEstimationParams, thresholds: ContactThresholdParams) -> np.ndarray:
    """The gate's settings as its kernels take them (6, indexed as named above): ``learning_window``,
    the hold 2/``prefilter`` (s; 0 without a prefilter), ``new_load_wait`` (s), ``min_excitation`` of
    ``params``, and the contact thresholds (N, N·m)."""
    params.validate()
    thresholds.validate()
    hold = 2.0 / params.prefilter if params.prefilter > 0 else 0.0
    return np.array([params.learning_window, hold, params.new_load_wait, params.min_excitation,
                     thresholds.force, thresholds.torque])


@compiled("boolean(float64[:], float64[:], boolean, float64)")
def spoiled(settings, contact, fault, since_reset) -> bool:
    """Whether this sample holds a fault, or contact (judged only ``learning_window`` s after a
    reset; ``since_reset`` in s): the estimator must not learn from it or its filtered echo."""
    if fault:
        return True
    if since_reset < settings[LEARNING_WINDOW]:
        return False
    return beyond(contact, settings[CONTACT_FORCE], settings[CONTACT_TORQUE])


@compiled("boolean(float64[:], float64[:], float64[:], float64[:], boolean, float64, float64, float64[:], "
          "float64[:, :])")
def gate_open(settings, acceleration, omega, contact, fault, since_reset, since_spoiled, no_gravity, V) -> bool:
    """Whether this sample may update the estimator (module docstring): [a; α] (6) and ω (3) S's kinematic
    motion, ``contact`` c (6), ``since_reset`` and ``since_spoiled`` (the time since the last ``spoiled``
    sample) in s; ``no_gravity`` (3) zeros and V (6, 10) scratch for the excitation."""
    return (not spoiled(settings, contact, fault, since_reset) and since_spoiled >= settings[HOLD]
            and since_reset >= settings[NEW_LOAD_WAIT]
            and regressor_norm(acceleration, omega, no_gravity, V) >= settings[MIN_EXCITATION])


CLOCKS_START = (0.0, 0.0, math.inf)
"""The gate's clocks before the first sample: the time since the last reset (s; the start counts
as one), the reset requests seen, the time since the last spoiled sample (s; none yet)."""


@compiled("UniTuple(float64, 3)(float64[:], float64)")
def clocks_now(clocks, requests):
    """(since_reset, requests seen, since_spoiled) of ``clocks`` (``CLOCKS_START``'s layout) with
    this sample's reset request counter ``requests`` applied: an increase is a new load."""
    since_reset, seen, since_spoiled = clocks[0], clocks[1], clocks[2]
    if requests > seen:
        since_reset, seen = 0.0, requests
    return since_reset, seen, since_spoiled


@compiled("void(float64[:], float64[:], float64, float64, float64, float64[:], boolean, float64)")
def advance_clocks(out, settings, since_reset, seen, since_spoiled, contact, fault, dt) -> None:
    """The clocks after this sample into ``out`` (3): those of ``clocks_now`` advanced by ``dt`` s, the
    time since a spoiled sample restarted if this one is (``spoiled``)."""
    if spoiled(settings, contact, fault, since_reset):
        since_spoiled = 0.0
    out[0], out[1], out[2] = since_reset + dt, seen, since_spoiled + dt


@compiled("void(float64[:], float64[:], float64[:], float64[:], float64[:], float64[:], float64[:], float64[:], "
          "float64[:], float64[:], float64[:, :])")
def gate_enable(out, acceleration, omega, contact, fault, reset, input_age, clocks, settings, timing,
                scratch) -> None:
    """``gate_open`` on the block's arrays into ``out`` (1: 1.0 open): ``fault`` (1) > 0.5 or ``input_age``
    (1, s) beyond ``timing`` [period (s), max input age (s)] spoils the sample; ``reset`` (1) the request
    counter; ``clocks`` (3) the block's; ``scratch`` (7, 10): V, then zeros."""
    since_reset, _, since_spoiled = clocks_now(clocks, reset[0])
    stale = fault[0] > 0.5 or input_age[0] > timing[1]
    open_ = gate_open(settings, acceleration, omega, contact, stale, since_reset, since_spoiled, scratch[6, :3],
                      scratch[:6])
    out[0] = 1.0 if open_ else 0.0


@compiled("void(float64[:], float64[:], float64[:], float64[:], float64[:], float64[:], float64[:], float64[:])")
def gate_update(clocks, stale_ticks, contact, fault, reset, input_age, settings, timing) -> None:
    """``advance_clocks`` on the block's arrays (``gate_enable``'s); ``stale_ticks`` (1) counts the ticks
    since the last new load whose readings were older than the max input age."""
    since_reset, seen, since_spoiled = clocks_now(clocks, reset[0])
    if seen > clocks[1]:
        stale_ticks[0] = 0.0
    stale = input_age[0] > timing[1]
    if stale:
        stale_ticks[0] += 1.0
    advance_clocks(clocks, settings, since_reset, seen, since_spoiled, contact, fault[0] > 0.5 or stale, timing[0])


class EstimatorGate(TickSystem):
    """``enable`` (1: 1.0 to take the sample) for ``RlsLoadEstimator`` (module docstring).

    Inputs: ``acceleration`` (6, kinematic [a; α]) and ``omega`` (3) of the sample the estimator learns
    from (``EstimatorPrefilter``'s outputs, or ``AccelerometerToMotion``'s and the kinematics' without one),
    ``wrench_contact`` (6) and ``fault`` (1) from force scaling, ``reset`` (1, a request
    counter, as the estimator's; unconnected 0), ``input_age`` (1, s: how old the oldest reading of the tick
    is; unconnected 0). State: the time since the last reset (s), the counter seen and
    the time since the last spoiled sample (s), advanced every ``period`` s; the ticks since the last reset
    whose readings were older than ``params.max_input_age`` (output ``stale_ticks``). It keeps its state
    when the controller restarts (``kept_on_restart``).
    """

    kept_on_restart = True

    def __init__(self, params: LoadEstimationParams, thresholds: ContactThresholdParams, period: float):
        super().__init__(period)
        self.settings = gate_settings(params, thresholds)
        self.timing = np.array([period, params.max_input_age])
        self.DeclareTickInput("acceleration", 6)
        self.DeclareTickInput("omega", 3)
        self.DeclareTickInput("wrench_contact", 6)
        self.DeclareTickInput("fault", 1)
        self.DeclareTickInput("reset", 1, [0.0])
        self.DeclareTickInput("input_age", 1, [0.0])
        self.DeclareTickState("clocks", CLOCKS_START)
        self.DeclareTickState("stale_ticks", [0.0])
        self.DeclareTickCalc("enable", 1, gate_enable, "calc:enable", "in:acceleration", "in:omega",
                             "in:wrench_contact", "in:fault", "in:reset", "in:input_age", "x:clocks", self.settings,
                             self.timing, np.zeros((7, 10)))
        self.DeclareTickOutput("enable", "calc:enable")
        self.DeclareTickOutput("stale_ticks", "x:stale_ticks")
        self.DeclareTickOutput("clocks", "x:clocks")
        self.DeclareTickUpdate(gate_update, "next:clocks", "next:stale_ticks", "in:wrench_contact", "in:fault",
                               "in:reset", "in:input_age", self.settings, self.timing)
