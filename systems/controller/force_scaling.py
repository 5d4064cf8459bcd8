"""Scaling and elimination of non-contact wrenches (Kubus & Wahl, Sec. V, Fig. 2).

All vectors are expressed in the sensor frame S (docs/design.md §4): wrenches [f; τ]
(N, N·m) that the sensor exerts on the load, torque about S's origin;
accelerations [a; α] (m/s², rad/s²) of S; ω (rad/s) of S; g (m/s²) in S. The
block's ``acceleration`` input is the accelerometer's reading, converted by
``accelerometer_reading`` (specific force a − g unless the driver removes gravity).

With the load's estimated parameters φ̂ (Eq. 6) and the sensor offsets o, the
measurement f splits into the non-contact wrench n = V·φ̂ (Eq. 12) and the
contact wrench c = f − o − n (Eq. 13). The operator is sent

    f′ = γ·c + σ·n                               (Fig. 2; no gripper split)
    f′ = γ·c + σ·V·φ_gr + η·V·(φ̂ − φ_gr)         (gripper φ_gr known)

so σ scales the apparent mass of the load (σ = 0 eliminates it, σ = 1 keeps
it), γ scales the contact wrench, and with the split σ acts on the gripper and
η on the gripped object. For σ = 0, γ = 1 the split law equals Eq. 14:
f′ = f − o − V·φ_mod with φ_mod = φ_gr + (1 − η)·φ̂_obj.

A load on a compliant mount (a tool on an adapter plate) rocks at the mount's first
mode, tens of Hz, while the accelerometer in the sensor sees only S's motion: the
rocking is missing from V·φ̂ and lands in c. Fed back, it closes a loop through the
operator's hand and the arm that sustains the rocking. ``mount_notch`` then feeds
back c through a notch at that mode (f′ = γ·N(c) + …, N a second-order notch);
the ``wrench_contact`` output stays the c of Eq. 13.
"""

import math

import numpy as np
from scipy.signal import iirnotch, lfilter_zi

from heft.systems.accelerometer_reading import (
    AT_S, AccelerometerConvention, kernel_convention, motion_from_reading_into)
from heft.systems.compiled import compiled, float_array, record_views
from heft.systems.controller.force_scaling_params import ForceScalingParams
from heft.systems.load_dynamics import regressor_into
from heft.systems.sample_period import DEFAULT_PERIOD, require_period
from heft.systems.tick_system import TickSystem


# --- pure numpy core ------------------------------------------------------------

def scale_wrench(wrench, offsets, phi, acceleration, omega, gravity, sigma: float, gamma: float,
                 eta: float, phi_gripper=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(f′, contact c (Eq. 13), non-contact V·φ̂ (Eq. 12)), each (6,) in S, from one
    finite sample: wrench, offsets (6,), phi (10,), acceleration [a; α] (6,), omega,
    gravity (3,). The law is the module docstring's (``scale_wrench_into``)."""
    out = np.empty((3, 6))
    acceleration = float_array(acceleration)
    scale_wrench_into(float_array(wrench), float_array(offsets), float_array(phi), acceleration[:3],
                      acceleration[3:], float_array(omega), float_array(gravity), sigma, gamma, eta,
                      _NO_GRIPPER if phi_gripper is None else float_array(phi_gripper), phi_gripper is not None,
                      np.empty((6, 10)), out[0], out[1], out[2])
    return out[0], out[1], out[2]


@compiled("void(float64[:], float64[:], float64[:], float64[:], float64[:], float64[:], float64[:], float64, "
          "float64, float64, float64[:], boolean, float64[:, :], float64[:], float64[:], float64[:])")
def scale_wrench_into(wrench, offsets, phi, a, alpha, omega, gravity, sigma, gamma, eta, phi_gripper, split, V,
                      feedback, contact, noncontact) -> None:
    """The law of the module docstring for one sample of S's kinematic ``a``, ``alpha``: n = V·φ̂,
    c = f − o − n, f′ = γ·c + σ·n, or with the ``split`` (φ_gr = ``phi_gripper``)
    f′ = γ·c + σ·V·φ_gr + η·V·(φ̂ − φ_gr); ``V`` (6, 10) is scratch."""
    regressor_into(a, alpha, omega, gravity, V)
    for r in range(6):
        n = 0.0
        for k in range(10):
            n += V[r, k] * phi[k]
        c = wrench[r] - offsets[r] - n
        if split:
            n_gripper = 0.0
            for k in range(10):
                n_gripper += V[r, k] * phi_gripper[k]
            feedback[r] = gamma * c + sigma * n_gripper + eta * (n - n_gripper)
        else:
            feedback[r] = gamma * c + sigma * n
        contact[r], noncontact[r] = c, n


@compiled("UniTuple(float64, 3)(float64, float64, float64)")
def clamp_scales(sigma: float, gamma: float, eta: float) -> tuple[float, float, float]:
    """The request limited to its meaningful range: σ, γ ≥ 0 (a negative σ would
    render a negative mass, an active element), η ∈ [0, 1] (Eq. 14)."""
    return max(sigma, 0.0), max(gamma, 0.0), min(max(eta, 0.0), 1.0)


@compiled("float64(float64, float64, float64)")
def slew(current: float, target: float, max_step: float) -> float:
    """``current`` moved toward ``target`` by at most ``max_step`` (landing on it exactly)."""
    if abs(target - current) <= max_step:
        return target
    return current + math.copysign(max_step, target - current)


@compiled("float64(float64, float64)")
def decay_factor(dt: float, fault_decay_time: float) -> float:
    """The factor exp(−dt/τ) by which a faulted f′ decays over ``dt`` s (0 for τ = 0)."""
    return math.exp(-dt / fault_decay_time) if fault_decay_time > 0 else 0.0


def notch_coefficients(frequency: float, quality: float, period: float,
                       setting: str = "controller.force.mount_notch") -> np.ndarray | None:
    """(b0, b1, b2, a1, a2, z1, z2) of the second-order notch at ``frequency`` (Hz) of quality
    ``quality`` at sample ``period`` (s) (``scipy.signal.iirnotch``; a0 = 1), with its state
    (z1, z2) per unit input in the steady state; None for frequency 0. A frequency at or above Nyquist's
    raises ValueError naming ``setting``."""
    if frequency == 0:
        return None
    if not frequency < 0.5 / period:
        raise ValueError(f"{setting} ({frequency:g} Hz) must lie below the controller's "
                         f"Nyquist frequency {0.5 / period:g} Hz; lower it or set it to 0 (none)")
    b, a = iirnotch(frequency, quality, fs=1.0 / period)
    return np.concatenate((b, a[1:], lfilter_zi(b, a)))


# Layout of an evaluation: f′, contact (Eq. 13), non-contact, fault flag, and the contact as fed
# back (through the mount notch).
FEEDBACK, CONTACT, NONCONTACT, FAULT, CONTACT_FED_BACK = (slice(0, 6), slice(6, 12), slice(12, 18), 18,
                                                          slice(19, 25))
EVALUATION_SIZE = 25
# Layout of the memory: the f′ in effect during the last tick, the flag a non-finite request
# raised, the mount notch's state (2 × 6, transposed direct form II, rows z1 and z2; NaN: to start
# in the steady state of the next contact wrench).
LAST_FEEDBACK, REQUEST_FAULT, NOTCH_STATE = slice(0, 6), 6, slice(7, 19)
MEMORY_SIZE = 19
_Z1, _Z2 = 7, 13  # where the notch's z1 and z2 of axis 0 lie in the memory
_NO_GRIPPER, _NO_NOTCH = np.zeros(10), np.zeros(7)
_SCRATCH = np.empty((7, 10))  # V (6, 10) and S's kinematic [a; α] of one evaluation


def initial_memory() -> np.ndarray:
    """The memory of a block that has not ticked yet."""
    memory = np.zeros(MEMORY_SIZE)
    memory[NOTCH_STATE] = np.nan
    return memory


def evaluate(out: np.ndarray, wrench, reading, omega, gravity, phi, offsets, scales, memory,
             decay: float, phi_gripper=None, accelerometer: AccelerometerConvention = AT_S,
             notch: np.ndarray | None = None) -> None:
    """One evaluation of the block into ``out`` (``EVALUATION_SIZE``), as the
    ``ForceScalingElimination`` docstring describes: ``reading`` (6) is the accelerometer's
    (``accelerometer_reading``, ``accelerometer`` its convention), ``scales`` (3) are σ, γ,
    η in effect, ``memory`` (``MEMORY_SIZE``) the block's, ``decay`` the factor applied to the
    last f′ while faulted (``decay_factor``), ``notch`` the mount notch (``notch_coefficients``)."""
    includes_gravity, p_SA, R_SA, u, bias = kernel_convention(accelerometer)
    evaluate_into(out, float_array(wrench), float_array(reading), float_array(omega), float_array(gravity),
              float_array(phi), float_array(offsets), float_array(scales), float_array(memory), decay,
              _NO_GRIPPER if phi_gripper is None else phi_gripper, phi_gripper is not None, includes_gravity, p_SA,
              R_SA, u, bias, _NO_NOTCH if notch is None else notch, notch is not None, _SCRATCH)


@compiled("void(float64[:], float64[:], float64[:], float64[:], float64[:], float64[:], float64[:], float64[:], "
          "float64[:], float64, float64[:], boolean, boolean, float64[:], float64[:, :], float64, float64[:], "
          "float64[:], boolean, float64[:, :])")
def evaluate_into(out, wrench, reading, omega, gravity, phi, offsets, scales, memory, decay, phi_gripper, split,
                  includes_gravity, p_SA, R_SA, u, bias, notch, notched, scratch) -> None:
    """``evaluate`` with the optional parts as flags: ``split`` (φ_gr given), ``notched``; the
    accelerometer's convention as ``kernel_convention`` gives it; ``scratch`` (7, 10)."""
    total = 0.0
    for i in range(6):
        total += wrench[i] + reading[i] + offsets[i]
    for i in range(3):
        total += omega[i] + gravity[i]
    for i in range(10):
        total += phi[i]
    if memory[REQUEST_FAULT] == 0.0 and math.isfinite(total):
        motion = scratch[6, :6]
        motion_from_reading_into(motion, reading, gravity, omega, includes_gravity, p_SA, R_SA, u, bias)
        scale_wrench_into(wrench, offsets, phi, motion[:3], motion[3:], omega, gravity, scales[0], scales[1],
                          scales[2], phi_gripper, split, scratch[:6], out[0:6], out[6:12], out[12:18])
        gamma, finite = scales[1], 0.0
        for r in range(6):
            contact = out[6 + r]
            if notched:  # the notch's output for this contact, from its state (or its steady state)
                z1 = notch[5] * contact if math.isnan(memory[_Z1]) else memory[_Z1 + r]
                out[19 + r] = notch[0] * contact + z1
                out[r] += gamma * (out[19 + r] - contact)
            else:
                out[19 + r] = contact
            finite += out[r] + out[6 + r] + out[12 + r] + out[19 + r]
        out[FAULT] = 0.0
        if math.isfinite(finite):
            return
    for r in range(6):
        out[r] = decay * memory[r]
        out[6 + r] = out[12 + r] = out[19 + r] = 0.0
    out[FAULT] = 1.0


def next_memory_and_scales(memory: np.ndarray, scales: np.ndarray, evaluation: np.ndarray, requested,
                           max_step: float, notch: np.ndarray | None = None) -> None:
    """The update after an ``evaluation``, in place: ``memory`` ← [f′ in effect; 1 if the
    ``requested`` (σ, γ, η) is non-finite; the notch advanced by the evaluation's contact wrench,
    or restarted after a fault]; a finite request moves ``scales`` toward its clamped value by at
    most ``max_step`` each (``slew_rate``·dt)."""
    sigma, gamma, eta = requested
    next_memory_and_scales_into(memory, scales, float_array(evaluation), float(sigma), float(gamma), float(eta),
                                max_step, _NO_NOTCH if notch is None else notch, notch is not None)


@compiled("void(float64[:], float64[:], float64[:], float64, float64, float64, float64, float64[:], boolean)")
def next_memory_and_scales_into(memory, scales, evaluation, sigma, gamma, eta, max_step, notch, notched) -> None:
    """``next_memory_and_scales`` with the request as three numbers and the notch as a flag."""
    for r in range(6):
        memory[r] = evaluation[r]
    if notched:
        if evaluation[FAULT] > 0.5:
            for i in range(12):
                memory[_Z1 + i] = math.nan
        else:
            started = not math.isnan(memory[_Z1])
            for r in range(6):  # transposed direct form II
                x, y = evaluation[6 + r], evaluation[19 + r]
                z2 = memory[_Z2 + r] if started else notch[6] * x
                memory[_Z1 + r] = notch[1] * x - notch[3] * y + z2
                memory[_Z2 + r] = notch[2] * x - notch[4] * y
    request_ok = math.isfinite(sigma + gamma + eta)
    memory[REQUEST_FAULT] = 0.0 if request_ok else 1.0
    if request_ok:
        targets = clamp_scales(sigma, gamma, eta)
        for i in range(3):
            scales[i] = slew(scales[i], targets[i], max_step)


# --- Drake system -----------------------------------------------------------------

SETTINGS = np.dtype([("decay", float), ("max_step", float), ("includes_gravity", float), ("p_SA", float, 3),
                     ("R_SA", float, (3, 3)), ("u", float), ("bias", float, 6), ("notch", float, 7),
                     ("notched", float), ("scratch", float, (7, 10))])
"""``ForceScalingElimination``'s settings as its kernels take them: the fault's decay per tick, the scales'
largest step per tick, the accelerometer's convention (``kernel_convention``), the mount notch
(``notch_coefficients``, if ``notched``) and the evaluation's scratch."""


@compiled("void(float64[:], float64[:], float64[:], float64[:], float64[:], float64[:], float64[:], float64[:], "
          "float64[:], float64[:], float64[:], SETTINGS[:])", SETTINGS=SETTINGS)
def force_evaluation(out, wrench, reading, omega, gravity, phi, offsets, phi_gripper, scales, memory, split, settings):
    """``evaluate_into`` on the block's arrays: ``split`` (1) > 0.5 splits off ``phi_gripper``."""
    s = settings[0]
    evaluate_into(out, wrench, reading, omega, gravity, phi, offsets, scales, memory, s["decay"], phi_gripper,
                  split[0] > 0.5, s["includes_gravity"] > 0.5, s["p_SA"], s["R_SA"], s["u"], s["bias"], s["notch"],
                  s["notched"] > 0.5, s["scratch"])


@compiled("void(float64[:], float64[:], float64[:], float64[:], float64[:], float64[:], SETTINGS[:])",
          SETTINGS=SETTINGS)
def force_update(memory, scales, evaluation, sigma, gamma, eta, settings):
    """``next_memory_and_scales_into`` on the block's arrays (σ, γ, η requested, 1 each)."""
    s = settings[0]
    next_memory_and_scales_into(memory, scales, evaluation, sigma[0], gamma[0], eta[0], s["max_step"], s["notch"],
                                s["notched"] > 0.5)


class ForceScalingElimination(TickSystem):
    """Fig. 2 with the Eq. 14 split, as the module docstring describes.

    Inputs: ``wrench`` (6, the measured [f; τ] on the load), ``acceleration`` (6, the
    accelerometer's reading: [a − g; α] at the accelerometer, as its ``accelerometer``
    convention says), ``omega`` (3), ``gravity`` (3), ``phi`` (10, φ̂ of the whole load),
    ``offsets`` (6), ``sigma``, ``gamma``, ``eta`` (1 each, requested; when
    unconnected the parameter value is requested), ``phi_gripper`` (10, φ_gr) and ``split``
    (1, > 0.5: feed back the gripper's and the object's non-contact wrench apart; unconnected,
    ``params.phi_gripper`` says).
    Outputs: ``wrench_feedback`` f′ (6), ``wrench_contact`` (6, Eq. 13),
    ``wrench_noncontact`` (6, Eq. 12), ``scales`` (3, σ, γ, η in effect), ``fault``
    (1: 1.0 while f′ is not computed from the inputs).

    Updated every ``period`` s (the controller's rate; 2 kHz by default).

    Timing. f′, c, n and fault are a feedthrough calculation from the signal
    inputs and the discrete state. The controller reads ``ft.wrench_measured``, already
    a sampled state output, so no algebraic loop forms, and f′ reflects the
    newest sample without the extra tick of delay a state output would add.
    The scales in effect are discrete state: every ``period`` they move toward
    the clamped request (`clamp_scales`) by at most ``slew_rate·period`` each, so
    the requests reach f′ only through the state and do not feed through.

    Faults. While a signal input holds a NaN or inf (or the result overflows),
    or from the update that consumed a non-finite request (the scales are then
    held), f′ decays to zero by exp(−period/fault_decay_time) per tick from the
    last f′ in effect, c and n are zero and ``fault`` is 1. Decay rather than an
    immediate zero because a step of several newtons at the stylus is a jolt
    the operator's hand turns into motion; decay rather than hold because a stale
    force rendered indefinitely is a phantom force. On recovery f′ returns to the
    live value, the mount notch restarted in the steady state of the first live c.
    """

    def __init__(self, params: ForceScalingParams | None = None, period: float = DEFAULT_PERIOD,
                 accelerometer: AccelerometerConvention = AT_S):
        params = params or ForceScalingParams()
        params.validate()
        super().__init__(require_period(period))
        period = self.tick_period
        self.settings, settings = record_views(SETTINGS)
        self.settings["decay"] = decay_factor(period, params.fault_decay_time)
        self.settings["max_step"] = params.slew_rate * period
        includes_gravity, settings["p_SA"][:], settings["R_SA"][:], u, settings["bias"][:] = kernel_convention(
            accelerometer)
        self.settings["includes_gravity"], self.settings["u"] = float(includes_gravity), u
        notch = notch_coefficients(params.mount_notch, params.mount_notch_quality, period)
        if notch is not None:
            settings["notch"][:], self.settings["notched"] = notch, 1.0

        for name, size in (("wrench", 6), ("acceleration", 6), ("omega", 3), ("gravity", 3), ("phi", 10),
                           ("offsets", 6)):
            self.DeclareTickInput(name, size)
        for name in ("sigma", "gamma", "eta"):
            self.DeclareTickInput(name, 1, [getattr(params, name)])
        gripper = params.phi_gripper
        self.DeclareTickInput("phi_gripper", 10, _NO_GRIPPER if gripper is None else gripper)
        self.DeclareTickInput("split", 1, [0.0 if gripper is None else 1.0])
        self.DeclareTickState("scales", (params.sigma, params.gamma, params.eta))
        # The f′ in effect during the last tick (6; N, N·m), a flag (1) raised by a
        # non-finite request, the mount notch's state (12).
        self.DeclareTickState("memory", initial_memory())
        self.DeclareTickCalc("evaluation", EVALUATION_SIZE, force_evaluation, "calc:evaluation", "in:wrench",
                             "in:acceleration", "in:omega", "in:gravity", "in:phi", "in:offsets", "in:phi_gripper",
                             "x:scales", "x:memory", "in:split", self.settings)
        for name, part in (("wrench_feedback", FEEDBACK), ("wrench_contact", CONTACT),
                           ("wrench_noncontact", NONCONTACT)):
            self.DeclareTickOutput(name, "calc:evaluation", part.start, part.stop)
        self.DeclareTickOutput("scales", "x:scales")
        self.DeclareTickOutput("fault", "calc:evaluation", FAULT, FAULT + 1)
        self.DeclareTickUpdate(force_update, "next:memory", "next:scales", "calc:evaluation", "in:sigma", "in:gamma",
                               "in:eta", self.settings)
