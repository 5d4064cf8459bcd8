"""A single-axis linear model of the bilateral loop, and what it predicts.

The axis is the contact axis: the slave tool point S along the sheet spring's motion
(W's z) and the stylus E along the master axis that the motion scaling maps onto it.
Coordinates are deviations from an operating point (m, m/s, N); up is positive on both.

Physics (continuous):

    master   m_m ẍ_m = f_h + f_a − b_m ẋ_m                (Phantom + hand mass along the axis)
    slave    m_s ẍ_s = K_s (x_f − x_s) + B_s (ẋ_f − ẋ_s) + f_env   (arm + load, joint PD servo)
    hand     f_h = k_h (x_ref − x_m) + b_h (ẋ_ref − ẋ_m)   (the operator's grip; termination 1)
    sheet    f_env = −K_e x_s − B_e ẋ_s                   (environment on the tool; termination 2)
    sensor   contact c = −f_env,  non-contact n = m_L ẍ_s  (the wrist sensor on the load m_L,
                                                         split perfectly: φ̂ exact)

Controller (discrete, period T, each block a Drake discrete system):

    x_c = k_t F(x_m) delayed by d_fwd + n ticks, F the master filter of
    `heft.systems.controller.master_position_filter` (its low-pass, then its notch; identity without them)
    → setpoint filter
    (critically damped, exact ZOH discretisation of `heft.systems.station.setpoint_filter`) → [x_f, ẋ_f]
    f_a = −k_f (γ N(c) + σ n) delayed by d_fb + n ticks, N the mount notch of
    `heft.systems.controller.force_scaling` (identity without one)

The plants step from kT with the controller outputs of the previous tick (both plants of
the simulated station are discrete at the controller period and read their inputs before
the controller updates). The PO/PC, the device's force clamp and friction are left out:
this is the loop the passivity controller has to guard.

Closed-loop poles come from an all-discrete Diagram (the physics with its terminations
linearised by Drake and discretised exactly with zero-order hold, closed with the
controller) differentiated with Drake's AutoDiffXd (`linearize`). Frequency responses of the sampled-data loop keep
the physics continuous and take the sampled controller's fundamental component:
u(jω) = (1 − e^{−jωT})/(jωT)·K(e^{jωT})·y(jω), K the controller's discrete transfer as read
at kT (its one-tick state outputs included) and held by the plants over [kT, kT + T);
aliases are neglected, so this holds below the Nyquist frequency.

Two-port convention (Hannaford, IEEE T-RA 5(4), 1989): [F_h; −V_e] = H [V_h; F_e] with
F_h the force the hand applies to the stylus, V_h = ẋ_m, F_e the force the slave applies
to the environment (= −f_env), V_e = ẋ_s. An ideal teleoperator with scales has
h11 = h22 = 0, h12 = k_f, h21 = −k_t; the operator then feels Z_in = k_f·k_t·Z_e.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

from heft.analysis.plotting import plt
import numpy as np
from heft.analysis.stability import llewellyn_absolutely_stable
from heft.systems.controller.force_scaling import notch_coefficients
from heft.systems.station.sensor_models import lowpass_coefficients
from heft.systems.station.setpoint_filter import critically_damped_step_matrices
from pydrake.autodiffutils import ExtractGradient, InitializeAutoDiff
from pydrake.systems.analysis import DiscreteTimeApproximation
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import (
    Linearize,
    LinearSystem,
    MatrixGain,
    Multiplexer,
    PassThrough,
)

# Layout of the physics output y.
X_M, V_M, X_S, V_S, CONTACT, NONCONTACT = range(6)
OUTPUT_NAMES = ("x_m", "v_m", "x_s", "v_s", "contact", "noncontact")
# The controller's inputs (rows of y it reads) and outputs (the first inputs of the physics).
MEASURED = (X_M, CONTACT, NONCONTACT)
COMMAND_SIZE = 3  # [f_a, x_f, ẋ_f]


@dataclasses.dataclass
class LinearTeleoperatorParams:
    """Parameters of the single-axis model (module docstring). SI units."""

    master_mass: float                  # m_m, kg: device and hand mass along the master axis
    master_damping: float               # b_m, N·s/m: the device's own damping along the axis
    hand_stiffness: float               # k_h, N/m
    hand_damping: float                 # b_h, N·s/m
    translation_scale: float            # k_t, slave m per master m
    force_scale: float                  # k_f, master N per slave N
    slave_mass: float                   # m_s, kg: arm and load along the slave axis
    slave_stiffness: float              # K_s, N/m: the joint servo along the axis
    slave_damping: float                # B_s, N·s/m
    load_mass: float                    # m_L, kg: what hangs below the sensor
    environment_stiffness: float        # K_e, N/m
    environment_damping: float          # B_e, N·s/m
    period: float                       # T, s: the controller's (and plants') period
    setpoint_bandwidth: float = 20.0    # Hz, the slave controller's setpoint filter
    sigma: float = 1.0                  # σ: share of the non-contact force fed back
    gamma: float = 1.0                  # γ: share of the contact force fed back
    forward_delay_ticks: int = 2        # master sample → setpoint filter input (ticks)
    feedback_delay_ticks: int = 2       # sensor sample → actuator force (ticks, ≥ 1)
    communication_delay_ticks: int = 0  # n, added to each direction (ticks)
    mount_notch: float = 0.0            # Hz, the notch the contact is fed back through (0: none)
    mount_notch_quality: float = 0.7    # its Q
    master_filter: float = 0.0          # Hz, the low-pass on the master's positions (0: none)
    master_notch: float = 0.0           # Hz, the notch on the master's positions, after the low-pass (0: none)
    master_notch_quality: float = 0.7   # its Q

    def validate(self) -> LinearTeleoperatorParams:
        """Raises ValueError naming the first field out of range; returns self."""
        positive = ("master_mass", "slave_mass", "slave_stiffness", "period", "setpoint_bandwidth",
                    "mount_notch_quality", "master_notch_quality")
        for name in positive:
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be finite and > 0; got {value}")
        for field in dataclasses.fields(self):
            value = getattr(self, field.name)
            if field.name not in positive and not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{field.name} must be finite and >= 0; got {value}")
        for name in ("forward_delay_ticks", "feedback_delay_ticks", "communication_delay_ticks"):
            if int(getattr(self, name)) != getattr(self, name):
                raise ValueError(f"{name} must be a whole number of ticks; got {getattr(self, name)}")
        for name in ("master_filter", "master_notch"):
            if getattr(self, name) >= 0.5 / self.period:
                raise ValueError(f"{name} must lie below the Nyquist frequency {0.5 / self.period:g} Hz; got "
                                 f"{getattr(self, name)}")
        if self.feedback_delay_ticks < 1:
            raise ValueError("feedback_delay_ticks must be >= 1: a sampled force reaches the actuator "
                             f"one tick after it was measured at the earliest; got {self.feedback_delay_ticks}")
        return self


# --- the Drake diagrams ---------------------------------------------------------------

def MakePhysics(params: LinearTeleoperatorParams, hand: bool = True, environment: bool = True):
    """The continuous physics as a Diagram with one input and one output port.

    Input ``u``: [f_a (N), x_f (m), ẋ_f (m/s), then [x_ref (m), ẋ_ref (m/s)] if ``hand`` else f_h (N), then
    f_env (N) unless ``environment``]. Output ``y``: [x_m, ẋ_m, x_s, ẋ_s, c, n] (m, m/s, N).
    Without a termination its force becomes an input: the two-port's open port.
    """
    p = params.validate()
    builder = DiagramBuilder()
    sizes = [1, 2, 2 if hand else 1] + ([] if environment else [1])
    u = builder.AddNamedSystem("u", PassThrough(sum(sizes)))
    builder.ExportInput(u.get_input_port(), "u")

    def pick(*indices):
        """A MatrixGain selecting entries ``indices`` of u."""
        gain = builder.AddSystem(MatrixGain(np.eye(sum(sizes))[list(indices)]))
        builder.Connect(u.get_output_port(), gain.get_input_port())
        return gain

    master = builder.AddNamedSystem("master", LinearSystem(
        A=[[0, 1], [0, -p.master_damping / p.master_mass]], B=[[0, 0], [1 / p.master_mass, 1 / p.master_mass]],
        C=np.eye(2), D=np.zeros((2, 2))))
    a, b = p.slave_stiffness / p.slave_mass, p.slave_damping / p.slave_mass
    slave = builder.AddNamedSystem("slave", LinearSystem(
        A=[[0, 1], [-a, -b]], B=[[0, 0, 0], [a, b, 1 / p.slave_mass]], C=np.eye(2), D=np.zeros((2, 3))))
    # Sensor: [c, n] from [x_s, ẋ_s, x_f, ẋ_f, f_env]; n = m_L·ẍ_s with the slave's own ẍ_s.
    ratio = p.load_mass / p.slave_mass
    sensor = builder.AddNamedSystem("sensor", MatrixGain(np.array([
        [0, 0, 0, 0, -1],
        [-ratio * p.slave_stiffness, -ratio * p.slave_damping, ratio * p.slave_stiffness,
         ratio * p.slave_damping, ratio]])))
    master_in = builder.AddSystem(Multiplexer([1, 1]))
    slave_in = builder.AddSystem(Multiplexer([2, 1]))
    sensor_in = builder.AddSystem(Multiplexer([2, 2, 1]))
    builder.Connect(master_in.get_output_port(), master.get_input_port())
    builder.Connect(slave_in.get_output_port(), slave.get_input_port())
    builder.Connect(sensor_in.get_output_port(), sensor.get_input_port())

    f_a, setpoint = pick(0), pick(1, 2)
    builder.Connect(f_a.get_output_port(), master_in.get_input_port(1))
    builder.Connect(setpoint.get_output_port(), slave_in.get_input_port(0))
    builder.Connect(setpoint.get_output_port(), sensor_in.get_input_port(1))
    builder.Connect(slave.get_output_port(), sensor_in.get_input_port(0))

    exogenous = pick(3, 4) if hand else pick(3)
    if hand:  # f_h = k_h (x_ref − x_m) + b_h (ẋ_ref − ẋ_m) from [x_m, ẋ_m, x_ref, ẋ_ref]
        hand_in = builder.AddSystem(Multiplexer([2, 2]))
        grip = builder.AddNamedSystem("hand", MatrixGain(np.array([[-p.hand_stiffness, -p.hand_damping,
                                                                    p.hand_stiffness, p.hand_damping]])))
        builder.Connect(master.get_output_port(), hand_in.get_input_port(0))
        builder.Connect(exogenous.get_output_port(), hand_in.get_input_port(1))
        builder.Connect(hand_in.get_output_port(), grip.get_input_port())
        builder.Connect(grip.get_output_port(), master_in.get_input_port(0))
    else:
        builder.Connect(exogenous.get_output_port(), master_in.get_input_port(0))
    if environment:
        sheet = builder.AddNamedSystem("environment", MatrixGain(np.array([[-p.environment_stiffness,
                                                                            -p.environment_damping]])))
        builder.Connect(slave.get_output_port(), sheet.get_input_port())
        f_env = sheet.get_output_port()
    else:
        f_env = pick(sum(sizes) - 1).get_output_port()
    builder.Connect(f_env, slave_in.get_input_port(1))
    builder.Connect(f_env, sensor_in.get_input_port(2))

    y = builder.AddNamedSystem("y", Multiplexer([2, 2, 2]))
    builder.Connect(master.get_output_port(), y.get_input_port(0))
    builder.Connect(slave.get_output_port(), y.get_input_port(1))
    builder.Connect(sensor.get_output_port(), y.get_input_port(2))
    builder.ExportOutput(y.get_output_port(), "y")
    diagram = builder.Build()
    diagram.set_name("linear_teleoperator_physics")
    return diagram


def _delay(builder, ticks: int, period: float):
    """A one-signal shift register, y(k) = u(k − ticks) as read at tick k (a pass-through for 0).
    (Drake's DiscreteTimeDelay keeps one more sample: it delays by ``ticks`` in continuous
    time, one tick more for a reader that samples before the update.)"""
    if ticks == 0:
        return builder.AddSystem(PassThrough(1))
    return builder.AddSystem(LinearSystem(A=np.eye(ticks, k=1), B=np.eye(ticks)[:, -1:], C=np.eye(ticks)[:1],
                                          D=np.zeros((1, 1)), time_period=period))


def _biquad_on(coefficients, channel: int, size: int, period: float):
    """A ``size``-vector with its entry ``channel`` through the biquad ``coefficients`` (b0, b1, b2, a1, a2), the
    others passed, as a discrete state-space system of its transposed direct form II (a pass-through for None)."""
    if coefficients is None:
        return PassThrough(size)
    b0, b1, b2, a1, a2 = coefficients[:5]
    A = np.array([[-a1, 1.0], [-a2, 0.0]])
    B = np.zeros((2, size))
    B[:, channel] = [b1 - a1 * b0, b2 - a2 * b0]
    C = np.zeros((size, 2))
    C[channel, 0] = 1.0
    D = np.eye(size)
    D[channel, channel] = b0
    return LinearSystem(A=A, B=B, C=C, D=D, time_period=period)


def MakeController(params: LinearTeleoperatorParams):
    """The discrete controller (period T) as a Diagram: input ``measured`` [x_m, c, n],
    output ``command`` [f_a, x_f, ẋ_f]. No direct feedthrough."""
    p = params.validate()
    n = int(p.communication_delay_ticks)
    builder = DiagramBuilder()
    measured = builder.AddNamedSystem("measured", PassThrough(3))
    builder.ExportInput(measured.get_input_port(), "measured")
    motion = builder.AddNamedSystem("motion_scaling", MatrixGain(np.array([[p.translation_scale, 0, 0]])))
    master_filter = builder.AddNamedSystem("master_filter", _biquad_on(
        lowpass_coefficients(p.master_filter, p.period), 0, 1, p.period))
    master_notch = builder.AddNamedSystem("master_notch", _biquad_on(
        notch_coefficients(p.master_notch, p.master_notch_quality, p.period, "master_notch"), 0, 1,
        p.period))
    forward = _delay(builder, int(p.forward_delay_ticks) + n, p.period)
    A, B = critically_damped_step_matrices(p.setpoint_bandwidth, p.period)
    setpoint_filter = builder.AddNamedSystem("setpoint_filter", LinearSystem(
        A=A, B=B[:, None], C=np.eye(2), D=np.zeros((2, 1)), time_period=p.period))
    notch = builder.AddNamedSystem("mount_notch", _biquad_on(
        notch_coefficients(p.mount_notch, p.mount_notch_quality, p.period), 1, 3, p.period))
    force = builder.AddNamedSystem("force_feedback", MatrixGain(np.array([
        [0, -p.force_scale * p.gamma, -p.force_scale * p.sigma]])))
    feedback = _delay(builder, int(p.feedback_delay_ticks) + n, p.period)
    command = builder.AddNamedSystem("command", Multiplexer([1, 2]))
    chain = ((measured, motion), (motion, master_filter), (master_filter, master_notch),
             (master_notch, forward), (forward, setpoint_filter),
             (measured, notch),
             (notch, force), (force, feedback))
    for source, sink in chain:
        builder.Connect(source.get_output_port(), sink.get_input_port())
    builder.Connect(feedback.get_output_port(), command.get_input_port(0))
    builder.Connect(setpoint_filter.get_output_port(), command.get_input_port(1))
    builder.ExportOutput(command.get_output_port(), "command")
    diagram = builder.Build()
    diagram.set_name("linear_teleoperator_controller")
    return diagram


def linearize(system, state=None, input_value=None) -> LinearSystem:
    """First-order Taylor expansion of ``system`` (one input, one output port; continuous or
    discrete with one period) at ``state`` and ``input_value`` (default zeros: the
    operating point in deviation coordinates), as a LinearSystem.

    Continuous systems go through Drake's ``Linearize``. Drake's ``Linearize`` takes a single
    discrete state group only; a discrete Diagram has one per subsystem, so its update and
    output are differentiated here the same way, with Drake's AutoDiffXd scalar: the
    Jacobians of ``EvalUniquePeriodicDiscreteUpdate`` and of the output port."""
    context = system.CreateDefaultContext()
    port = system.get_input_port(0)
    u0 = np.zeros(port.size()) if input_value is None else np.asarray(input_value, dtype=float)
    if context.num_discrete_state_groups() == 0:
        if state is not None:
            context.SetContinuousState(state)
        port.FixValue(context, u0)
        return Linearize(system, context)
    period = system.GetUniquePeriodicDiscreteUpdateAttribute()
    if context.num_continuous_states() or context.num_abstract_states() or period is None:
        raise ValueError(f"{system.get_name()} must be continuous, or discrete with one update period")
    ad = system.ToAutoDiffXd()
    context = ad.CreateDefaultContext()
    sizes = [context.get_discrete_state(i).size() for i in range(context.num_discrete_state_groups())]
    n = sum(sizes)
    x0 = np.zeros(n) if state is None else np.asarray(state, dtype=float)
    variables = InitializeAutoDiff(np.concatenate((x0, u0))).ravel()
    for i, (start, size) in enumerate(zip(np.cumsum([0] + sizes[:-1]), sizes)):
        context.get_mutable_discrete_state(i).SetFromVector(variables[start:start + size])
    ad.get_input_port(0).FixValue(context, variables[n:])
    update = ad.EvalUniquePeriodicDiscreteUpdate(context)
    x_next = np.concatenate([update.get_vector(i).CopyToVector() for i in range(len(sizes))])
    J_x, J_y = ExtractGradient(x_next), ExtractGradient(ad.get_output_port(0).Eval(context))
    return LinearSystem(A=J_x[:, :n], B=J_x[:, n:], C=J_y[:, :n], D=J_y[:, n:], time_period=period.period_sec())


def MakeClosedLoop(params: LinearTeleoperatorParams, hand: bool = True, environment: bool = True):
    """The sampled-data loop as an all-discrete Diagram (period T): the physics (`MakePhysics`)
    linearised and discretised with zero-order hold, closed with `MakeController`.

    Input: the physics' exogenous inputs ([x_ref, ẋ_ref] or f_h, then f_env if not ``environment``).
    Output ``y`` as in `MakePhysics`, sampled."""
    p = params.validate()
    physics = DiscreteTimeApproximation(linearize(MakePhysics(p, hand, environment)), p.period)
    builder = DiagramBuilder()
    plant = builder.AddNamedSystem("physics", physics)
    controller = builder.AddNamedSystem("controller", MakeController(p))
    n_exogenous = physics.get_input_port().size() - COMMAND_SIZE
    inputs = builder.AddSystem(Multiplexer([COMMAND_SIZE, n_exogenous]))
    select = builder.AddSystem(MatrixGain(np.eye(len(OUTPUT_NAMES))[list(MEASURED)]))
    builder.Connect(controller.get_output_port(), inputs.get_input_port(0))
    builder.ExportInput(inputs.get_input_port(1), "exogenous")
    builder.Connect(inputs.get_output_port(), plant.get_input_port())
    builder.Connect(plant.get_output_port(), select.get_input_port())
    builder.Connect(select.get_output_port(), controller.get_input_port())
    builder.ExportOutput(plant.get_output_port(), "y")
    diagram = builder.Build()
    diagram.set_name("linear_teleoperator_closed_loop")
    return diagram


# --- what the model predicts ---------------------------------------------------------------

def closed_loop_eigenvalues(params: LinearTeleoperatorParams, hand: bool = True) -> np.ndarray:
    """Poles z of the sampled closed loop (hand and environment attached unless ``hand`` is
    False), from Drake's linearisation of `MakeClosedLoop`. Stable iff all |z| < 1."""
    return np.linalg.eigvals(linearize(MakeClosedLoop(params, hand=hand)).A())


def spectral_radius(params: LinearTeleoperatorParams, hand: bool = True) -> float:
    """max |z| of the closed-loop poles (< 1: asymptotically stable)."""
    return float(np.abs(closed_loop_eigenvalues(params, hand)).max())


def _frequency_response(system, s):
    """C (sI − A)⁻¹ B + D of a LinearSystem at the complex points ``s`` (N,) → (N, p, m)."""
    A, B, C, D = system.A(), system.B(), system.C(), system.D()
    identity = np.eye(A.shape[0])
    return np.array([C @ np.linalg.solve(point * identity - A, B) + D for point in s])


@dataclasses.dataclass
class TwoPort:
    """Hybrid parameters over a frequency grid (Hannaford's convention, module docstring)."""
    frequency: np.ndarray   # Hz
    h11: np.ndarray         # F_h/V_h at F_e = 0 (N·s/m): the free-motion impedance felt
    h12: np.ndarray         # F_h/F_e at V_h = 0: force transmission
    h21: np.ndarray         # −V_e/V_h at F_e = 0: motion transmission
    h22: np.ndarray         # −V_e/F_e at V_h = 0 (m/(N·s)): the slave's admittance with the master held

    def input_impedance(self, stiffness: float, damping: float) -> np.ndarray:
        """Z_in = F_h/V_h (N·s/m) with the environment Z_e = B_e + K_e/(jω) on the slave."""
        z_e = environment_impedance(self.frequency, stiffness, damping)
        return self.h11 - self.h12 * self.h21 * z_e / (1 + self.h22 * z_e)


def environment_impedance(frequency, stiffness: float, damping: float) -> np.ndarray:
    """Z_e(jω) = B_e + K_e/(jω) (N·s/m) at ``frequency`` (Hz)."""
    return damping + stiffness / (2j * np.pi * np.asarray(frequency, dtype=float))


def frequency_grid(params: LinearTeleoperatorParams, points: int = 400, lowest: float = 0.1) -> np.ndarray:
    """Log-spaced frequencies (Hz) from ``lowest`` to just below the Nyquist frequency 1/(2T)."""
    return np.logspace(math.log10(lowest), math.log10(0.999 / (2 * params.period)), points)


def two_port(params: LinearTeleoperatorParams, frequency=None) -> TwoPort:
    """H(jω) of the teleoperator with both terminations removed (module docstring)."""
    p = params.validate()
    frequency = frequency_grid(p) if frequency is None else np.asarray(frequency, dtype=float)
    physics = linearize(MakePhysics(p, hand=False, environment=False))
    controller = linearize(MakeController(p))
    w = 2 * np.pi * frequency
    z = np.exp(1j * w * p.period)
    P = _frequency_response(physics, 1j * w)                      # (N, 6, 5): u = [f_a, x_f, ẋ_f, f_h, f_env]
    K = _frequency_response(controller, z)                        # (N, 3, 3)
    hold = (1 - 1 / z) / (1j * w * p.period)                      # the plants hold what they read at kT
    measured = list(MEASURED)
    Y = np.empty((frequency.size, 2, 2), dtype=complex)           # [ẋ_m; ẋ_s] = Y [f_h; f_env]
    for i in range(frequency.size):
        P_u, P_w = P[i][:, :COMMAND_SIZE], P[i][:, COMMAND_SIZE:]
        G = hold[i] * K[i]
        u = np.linalg.solve(np.eye(COMMAND_SIZE) - G @ P_u[measured], G @ P_w[measured])
        Y[i] = (P_w + P_u @ u)[[V_M, V_S]]
    # F_h = f_h, F_e = −f_env: [V_h; V_e] = Yp [F_h; F_e] with Yp = Y·diag(1, −1); solve for H.
    y11, y12, y21, y22 = Y[:, 0, 0], -Y[:, 0, 1], Y[:, 1, 0], -Y[:, 1, 1]
    return TwoPort(frequency, 1 / y11, -y12 / y11, -y21 / y11, -(y22 - y21 * y12 / y11))


def llewellyn_eta(port: TwoPort) -> np.ndarray:
    """Llewellyn's η(ω) = (2 Re h11 Re h22 − Re h12h21) / |h12h21|: with Re h11, Re h22 ≥ 0,
    η ≥ 1 at every frequency is absolute stability (the verdict is
    `heft.analysis.stability.llewellyn_absolutely_stable`'s)."""
    product = port.h12 * port.h21
    return (2 * port.h11.real * port.h22.real - product.real) / np.abs(product)


def is_passive(port: TwoPort, stiffness: float, damping: float, added_damping: float = 0.0,
               tol: float = 1e-9) -> bool:
    """Re Z_in(jω) + ``added_damping`` ≥ −tol over the grid: the loop renders this environment
    passively (with ``added_damping`` N·s/m in parallel at the master, e.g. the grip's)."""
    return bool((port.input_impedance(stiffness, damping).real + added_damping >= -tol).all())


def _bisect_log(ok, low: float, high: float, rel_tol: float) -> float:
    """Largest x in [low, high] with ok(x), given ok(low) and not ok(high) (one crossing)."""
    while high / low > 1 + rel_tol:
        middle = math.sqrt(low * high)
        low, high = (middle, high) if ok(middle) else (low, middle)
    return low


def predicted_stiffness_limit(params: LinearTeleoperatorParams, lowest: float = 1.0, highest: float = 1e8,
                              rel_tol: float = 1e-3, hand: bool = True) -> float:
    """The environment stiffness K_e (N/m) at which the closed-loop poles leave the unit
    circle, bisected in log K_e between ``lowest`` and ``highest`` (other parameters as
    given; a single crossing assumed). 0 if already unstable at ``lowest``; inf if still
    stable at ``highest``."""
    def stable(stiffness):
        return spectral_radius(dataclasses.replace(params, environment_stiffness=stiffness), hand) < 1.0
    if not stable(lowest):
        return 0.0
    if stable(highest):
        return math.inf
    return _bisect_log(stable, lowest, highest, rel_tol)


def passive_stiffness_limit(port: TwoPort, damping: float, added_damping: float = 0.0, lowest: float = 1.0,
                            highest: float = 1e8, rel_tol: float = 1e-3) -> float:
    """The largest K_e (N/m) with environment damping ``damping`` that the two-port renders
    passively (`is_passive` over its grid); 0 if not even ``lowest``, inf if ``highest``."""
    def passive(stiffness):
        return is_passive(port, stiffness, damping, added_damping)
    if not passive(lowest):
        return 0.0
    if passive(highest):
        return math.inf
    return _bisect_log(passive, lowest, highest, rel_tol)


@dataclasses.dataclass
class LinearAnalysis:
    """Everything `analyze` computes at one operating point."""
    params: LinearTeleoperatorParams
    eigenvalues: np.ndarray           # closed-loop poles z (hand and environment attached)
    port: TwoPort
    llewellyn_stable: bool
    llewellyn_ok: np.ndarray          # per frequency
    eta: np.ndarray
    transmitted_impedance: np.ndarray  # Z_t = Z_in with the scenario's environment (N·s/m)
    stiffness_limit: float            # K_e where the poles leave the unit circle (N/m)
    passive_limit: float              # largest K_e rendered passively by the device alone (N/m)
    passive_limit_with_grip: float    # the same with the hand's damping b_h at the master (N/m)

    def summary(self) -> dict:
        """A JSON-ready digest (SI units)."""
        p, port = self.params, self.port
        radius = float(np.abs(self.eigenvalues).max())
        ideal = p.force_scale * p.translation_scale * environment_impedance(
            port.frequency, p.environment_stiffness, p.environment_damping)
        ratio = np.abs(self.transmitted_impedance / ideal)
        failing = port.frequency[~self.llewellyn_ok]
        z_low = port.input_impedance(0.0, p.environment_damping)

        def finite(x):
            return x if math.isfinite(x) else None
        return {
            "params": dataclasses.asdict(p),
            "spectral_radius": radius,
            "stability_margin": 1.0 - radius,
            "stable": radius < 1.0,
            "llewellyn_absolutely_stable": self.llewellyn_stable,
            "llewellyn_first_failure_Hz": float(failing[0]) if failing.size else None,
            "llewellyn_eta_min": float(np.nanmin(self.eta)),
            "transparency_ratio_at_1Hz": float(np.interp(1.0, port.frequency, ratio)),
            "transparency_ratio_at_10Hz": float(np.interp(10.0, port.frequency, ratio)),
            "transmitted_stiffness_N_per_m": float(-(2 * np.pi * port.frequency[0])
                                                   * self.transmitted_impedance[0].imag),
            "rendered_stiffness_ideal_N_per_m": p.force_scale * p.translation_scale * p.environment_stiffness,
            "z_width": {"environment_damping_N_s_per_m": p.environment_damping,
                        "passive_stiffness_max_N_per_m": finite(self.passive_limit),
                        "passive_stiffness_max_with_grip_N_per_m": finite(self.passive_limit_with_grip),
                        "soft_environment_passive": is_passive(port, 0.0, p.environment_damping),
                        "min_Re_Z_in_soft_N_s_per_m": float(z_low.real.min()),
                        "Z_in_soft_range_N_s_per_m": [float(np.abs(z_low).min()), float(np.abs(z_low).max())]},
            "predicted_stiffness_limit_N_per_m": finite(self.stiffness_limit),
        }


def analyze(params: LinearTeleoperatorParams, frequency=None) -> LinearAnalysis:
    """Poles, two-port, Llewellyn, transparency, Z-width and stiffness limit at ``params``."""
    port = two_port(params, frequency)
    stable, ok = llewellyn_absolutely_stable(port.h11, port.h12, port.h21, port.h22)
    return LinearAnalysis(
        params, closed_loop_eigenvalues(params), port, stable, ok, llewellyn_eta(port),
        port.input_impedance(params.environment_stiffness, params.environment_damping),
        predicted_stiffness_limit(params), passive_stiffness_limit(port, params.environment_damping),
        passive_stiffness_limit(port, params.environment_damping, params.hand_damping))


# --- figures -----------------------------------------------------------------------------

def write_figures(result: LinearAnalysis, out_dir) -> list:
    """Bode plot of the h-parameters, Llewellyn's η(ω), the Z-width and the closed-loop poles
    as PNGs in ``out_dir``; returns their paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    p, port, f = result.params, result.port, result.port.frequency
    paths = []

    def save(fig, name):
        fig.tight_layout()
        fig.savefig(out / name, dpi=110)
        plt.close(fig)
        paths.append(out / name)

    fig, axes = plt.subplots(2, 4, figsize=(15, 6), sharex=True)
    ideal = {"h11": 0.0, "h12": p.force_scale, "h21": -p.translation_scale, "h22": 0.0}
    units = {"h11": "N·s/m", "h12": "N/N", "h21": "(m/s)/(m/s)", "h22": "m/(N·s)"}
    for column, name in enumerate(("h11", "h12", "h21", "h22")):
        h = getattr(port, name)
        axes[0, column].loglog(f, np.abs(h))
        if ideal[name]:
            axes[0, column].axhline(abs(ideal[name]), color="gray", ls="--", label="ideal")
            axes[0, column].legend()
        axes[0, column].set_title(f"{name} ({units[name]})")
        axes[1, column].semilogx(f, np.degrees(np.unwrap(np.angle(h))))
        axes[1, column].set_xlabel("frequency (Hz)")
    axes[0, 0].set_ylabel("magnitude")
    axes[1, 0].set_ylabel("phase (deg)")
    save(fig, "hybrid_parameters.png")

    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    top.semilogx(f, result.eta, label="η(ω)")
    top.axhline(1.0, color="gray", ls="--", label="η = 1")
    top.set_ylabel("Llewellyn η")
    top.set_title("Llewellyn: absolutely stable" if result.llewellyn_stable else "Llewellyn: not absolutely stable")
    top.legend()
    bottom.semilogx(f, port.h11.real, "C0")
    bottom.set_ylabel("Re h11 (N·s/m)", color="C0")
    bottom.axhline(0.0, color="gray", lw=0.8)
    bottom.set_xlabel("frequency (Hz)")
    right = bottom.twinx()
    right.semilogx(f, port.h22.real, "C1")
    right.set_ylabel("Re h22 (m/(N·s))", color="C1")
    bottom.set_title("both must stay ≥ 0")
    save(fig, "llewellyn.png")

    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 7))
    stiff = result.stiffness_limit if math.isfinite(result.stiffness_limit) else 1e7
    soft_z, stiff_z = port.input_impedance(0.0, p.environment_damping), port.input_impedance(
        stiff, p.environment_damping)
    top.fill_between(f, np.minimum(np.abs(soft_z), np.abs(stiff_z)), np.maximum(np.abs(soft_z), np.abs(stiff_z)),
                     color="C0", alpha=0.25, label=f"K_e from 0 to the stability limit {stiff:.3g} N/m")
    top.loglog(f, np.abs(result.transmitted_impedance), "C1", label=f"Z_t, K_e = {p.environment_stiffness:.3g} N/m")
    top.loglog(f, p.force_scale * p.translation_scale * np.abs(environment_impedance(
        f, p.environment_stiffness, p.environment_damping)), "k--", label="k_f·k_t·Z_e (ideal)")
    top.set_xlabel("frequency (Hz)")
    top.set_ylabel("|Z_in| (N·s/m)")
    top.set_title(f"Z-width at the master (B_e = {p.environment_damping:.3g} N·s/m)")
    top.legend(fontsize=8)
    stiffness = np.logspace(0, math.log10(max(10 * stiff, 10.0)), 60)
    least = np.array([port.input_impedance(k, p.environment_damping).real.min() for k in stiffness])
    bottom.semilogx(stiffness, least, label="device alone")
    bottom.semilogx(stiffness, least + p.hand_damping, label=f"with the grip's b_h = {p.hand_damping:.3g} N·s/m")
    bottom.axhline(0.0, color="gray", lw=0.8)
    if math.isfinite(result.stiffness_limit):
        bottom.axvline(result.stiffness_limit, color="C3", ls=":", label="poles leave |z| = 1")
    bottom.set_xlabel("environment stiffness K_e (N/m)")
    bottom.set_ylabel("min over ω of Re Z_in (N·s/m)")
    bottom.set_yscale("symlog", linthresh=1e-2)
    bottom.legend(fontsize=8)
    save(fig, "z_width.png")

    fig, axes = plt.subplots(1, 2, figsize=(12, 6))
    circle = np.linspace(0, 2 * np.pi, 2000)
    sets = [(f"K_e = {p.environment_stiffness:.3g} N/m (scenario)", result.eigenvalues, "k+")]
    if math.isfinite(result.stiffness_limit):
        for factor, marker in ((0.1, "C0."), (1.0, "C1o"), (2.0, "C3x")):
            stiffness = factor * result.stiffness_limit
            sets.append((f"K_e = {stiffness:.3g} N/m ({factor:g} × limit)", closed_loop_eigenvalues(
                dataclasses.replace(p, environment_stiffness=stiffness)), marker))
    slowest = result.eigenvalues[np.argsort(-np.abs(result.eigenvalues))[:6]]
    half = max(0.02, 1.5 * np.abs(slowest.imag).max(), 1.2 * (1 - slowest.real.min()))
    for ax, zoom in zip(axes, (False, True)):
        ax.plot(np.cos(circle), np.sin(circle), color="gray", lw=0.8)
        for label, poles, marker in sets:
            ax.plot(poles.real, poles.imag, marker, ls="none", mfc="none", label=label)
        ax.set_aspect("equal")
        ax.set_xlabel("Re z")
        ax.set_ylabel("Im z")
        if zoom:
            ax.set_xlim(1 - 1.6 * half, 1 + 0.4 * half)
            ax.set_ylim(-half, half)
            ax.set_title("near z = 1 (the slow, lightly damped poles)")
    axes[0].set_title(f"closed-loop poles, T = {p.period * 1e3:g} ms, max |z| = "
                      f"{np.abs(result.eigenvalues).max():.4f}")
    axes[0].legend(fontsize=8, loc="lower left")
    save(fig, "eigenvalues.png")
    return paths
