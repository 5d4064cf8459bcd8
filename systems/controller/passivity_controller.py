"""Time-domain passivity observer and controller (PO/PC) at the master port.

After Hannaford & Ryu, "Time-domain passivity control of haptic interfaces"
(IEEE T-RO 18(1), 2002), with one PO/PC pair for the translational and one for
the rotational channel as in Preusche, Hirzinger, Ryu & Hannaford, "Time
domain passivity control for 6 degrees of freedom haptic displays" (IROS 2003).

The port. The controller (teleoperator, slave and environment: the network)
exerts the wrench w = [f; τ] on the operator's hand at the stylus E, expressed
in the master base B; the stylus moves with the twist [v; ω] of E in B, ω about
and v of E's origin, so w·[v; ω] = f·v + τ·ω is the power (W) the network
delivers to the hand.

Sign convention: the observed energy counts energy flowing from the hand INTO
the network as positive, per channel and sample (period T):

    E_t(n) = E_t(n−1) − f(n)·v(n)·T,    E_r(n) = E_r(n−1) − τ(n)·ω(n)·T.

A passive network keeps E ≥ 0 for all n (it never returns more than it
received); E < 0 flags active behaviour. Each channel is observed apart, so
energy the network carries from one channel into the other (the load's moment
m·c × a, made by translation, turning the stylus) reads as a deficit in the
receiving channel; docs/design.md §3 has fig7's numbers. The PC is the series damper of the
impedance-type port (velocity in, force out): the applied wrench is
f − α_t·v, τ − α_r·ω, which adds α·|v|²·T to E. When E would go negative,
α = −E / (T·|v|²), clamped to [0, α_max], so the PC dissipates exactly the
observed deficit as far as the bound allows (a deficit beyond it is carried
forward).

The device's limits come last: the applied wrench is clamped to the master's
force and torque magnitudes (``clamp_factor``, keeping the direction), so the PC's
damping can never push the command past what the device may render, and the
observer counts the wrench actually applied.
"""

import math

import numpy as np

from heft.systems.compiled import compiled, float_array
from heft.systems.controller.feedback_mapping import clamp_factor
from heft.systems.controller.passivity_params import PassivityParams
from heft.systems.sample_period import DEFAULT_PERIOD, require_period
from heft.systems.tick_system import Reshaped, TickSystem

ALL_ACTUATED = (1.0,) * 6
"""Every joint of a six-joint master actuated (the Phantom Premium 1.5 6DoF): force and torque rendered."""


# --- pure numpy core ----------------------------------------------------------

@compiled("UniTuple(float64, 3)(float64, float64, float64, float64, float64)")
def passivity_channel(energy: float, power: float, speed_squared: float, period: float,
                      max_damping: float) -> tuple[float, float, float]:
    """One PO/PC step of one channel → (energy after the PC (J), α, energy the PC
    dissipated in this step (J)).

    ``energy`` is E(n−1); ``power`` (W) is w·v of the desired wrench, the power the
    network would deliver to the hand; ``speed_squared`` is |v|² (m²/s² or
    rad²/s²); ``max_damping`` 0 disables the PC. At rest (|v| = 0) a deficit
    cannot be dissipated: α is then reported as the bound and E stays negative."""
    energy -= power * period
    if energy >= 0.0:
        return energy, 0.0, 0.0
    capacity = max_damping * speed_squared * period
    if capacity <= -energy:
        return energy + capacity, max_damping, capacity
    return 0.0, -energy / (speed_squared * period), -energy


def passivity_step(wrench, twist, energy, period: float, max_damping) -> tuple[
        np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """One PO/PC step of both channels (``passivity_step_into``).

    ``wrench`` (6) desired [f; τ] on the hand, ``twist`` (6) [v; ω] of the stylus,
    ``energy`` (2) [E_t, E_r] after the last step, ``max_damping`` (2) [α_t max,
    α_r max]. Returns (applied wrench [f − α_t v; τ − α_r ω] (6), energy (2), α (2),
    energy dissipated in this step (2))."""
    applied, energy = np.empty(6), np.array(energy, dtype=float)
    damping, dissipated = np.empty(2), np.empty(2)
    passivity_step_into(float_array(wrench), float_array(twist), energy, period, float_array(max_damping), applied,
                        damping, dissipated)
    return applied, energy, damping, dissipated


@compiled("void(float64[:], float64[:], float64[:], float64, float64[:], float64[:], float64[:], float64[:])")
def passivity_step_into(wrench, twist, energy, period, max_damping, applied, damping, dissipated) -> None:
    """``passivity_step`` into ``applied`` (6), ``damping`` (2) and ``dissipated`` (2); ``energy`` (2)
    is advanced in place."""
    for channel in range(2):
        k = 3 * channel
        power = wrench[k] * twist[k] + wrench[k + 1] * twist[k + 1] + wrench[k + 2] * twist[k + 2]
        speed_squared = twist[k] * twist[k] + twist[k + 1] * twist[k + 1] + twist[k + 2] * twist[k + 2]
        energy[channel], damping[channel], dissipated[channel] = passivity_channel(
            energy[channel], power, speed_squared, period, max_damping[channel])
        for i in range(k, k + 3):
            applied[i] = wrench[i] - damping[channel] * twist[i]


def master_torque(wrench, velocity, jacobian, energy, period: float, max_damping, max_force: float,
                  max_torque: float, actuated=ALL_ACTUATED) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                                                     np.ndarray]:
    """One sample of the block (``master_torque_into``): (τ_M (6, N·m), the wrench applied on the hand
    (6, [f; τ] at E in B, N and N·m), energy (2, J), α (2), energy dissipated (2, J)), new arrays."""
    torque, applied, damping, dissipated = np.empty(6), np.empty(6), np.empty(2), np.empty(2)
    energy = np.array(energy, dtype=float)
    master_torque_into(float_array(wrench), float_array(velocity), float_array(np.reshape(jacobian, (6, 6))),
                       energy, period, float_array(max_damping), max_force, max_torque, float_array(actuated), torque,
                       applied, damping, dissipated, np.empty(12))
    return torque, applied, energy, damping, dissipated


@compiled("void(float64[:], float64[:], float64[:, :], float64[:], float64, float64[:], float64, float64, "
          "float64[:], float64[:], float64[:], float64[:], float64[:], float64[:])")
def master_torque_into(wrench, velocity, jacobian, energy, period, max_damping, max_force, max_torque, actuated,
                       torque, applied, damping, dissipated, scratch) -> None:
    """One sample of the block into ``torque`` (6, τ_M), ``applied`` (6), ``damping`` (2) and
    ``dissipated`` (2); ``energy`` (2) advanced in place; ``scratch`` (12).

    ``actuated`` (6): 1.0 for a joint an actuator drives, else 0.0. A device with an unactuated joint renders
    the force only: the desired torque τ is taken as zero (the observer's rotational channel sees no power),
    and an unactuated joint's torque is zero, so the actuated joints' torques are J_vᵀ·f.

    ``wrench`` (6) desired [f; τ] on the hand, ``velocity`` q̇_M (6, rad/s), ``jacobian``
    J_M (6×6, rows [v_E; ω_E]), ``energy`` [E_t, E_r] before, ``period`` the hold T (s),
    ``max_damping`` [α_t max, α_r max]. The PC's wrench is clamped to ``max_force`` (N)
    and ``max_torque`` (N·m) and the energy counts the clamped wrench. Any non-finite
    input gives zero torque, α = 0 and the energy unchanged."""
    total = 0.0
    for i in range(6):
        total += wrench[i] + velocity[i]
        for j in range(6):
            total += jacobian[i, j]
    if not math.isfinite(total):
        torque[:] = 0.0
        applied[:] = 0.0
        damping[:] = 0.0
        dissipated[:] = 0.0
        return
    twist, desired = scratch[:6], scratch[6:]
    force_only = False
    for j in range(6):
        force_only = force_only or actuated[j] < 0.5
    for i in range(6):
        desired[i] = 0.0 if force_only and i >= 3 else wrench[i]
    for i in range(6):
        twist[i] = 0.0
        for j in range(6):
            twist[i] += jacobian[i, j] * velocity[j]
    passivity_step_into(desired, twist, energy, period, max_damping, applied, damping, dissipated)
    for channel, limit in ((0, max_force), (1, max_torque)):
        k = 3 * channel
        factor = clamp_factor(applied[k], applied[k + 1], applied[k + 2], limit)
        if factor != 1.0:  # the power the clamp withheld from the hand goes back to the observer
            withheld = 0.0
            for i in range(k, k + 3):
                clamped = applied[i] * factor
                withheld += (applied[i] - clamped) * twist[i]
                applied[i] = clamped
            energy[channel] += withheld * period
    for j in range(6):
        torque[j] = 0.0
        if actuated[j] > 0.5:
            for i in range(6):
                torque[j] += jacobian[i, j] * applied[i]


# --- Drake system -------------------------------------------------------------

@compiled("void(float64[:], float64[:], float64[:, :], float64[:], float64[:], float64[:], float64[:], float64[:], "
          "float64[:], float64[:], float64[:], float64[:])")
def passivity_update(wrench, velocity, jacobian, hold, limits, actuated, energy, torque, applied, damping, dissipated,
                     scratch):
    """``master_torque_into`` on the block's arrays: ``hold`` (1, s) the sample's, ``limits`` [α_t max, α_r max,
    max force (N), max torque (N·m)], ``actuated`` (6); ``dissipated`` (2) adds up; ``scratch`` (14)."""
    master_torque_into(wrench, velocity, jacobian, energy, hold[0], limits[0:2], limits[2], limits[3], actuated,
                       torque, applied, damping, scratch[:2], scratch[2:])
    dissipated[0] += scratch[0]
    dissipated[1] += scratch[1]


class PassivityController(TickSystem):
    """The PO/PC of the module docstring in front of the master's actuators.

    Inputs: ``wrench`` (6, desired [f; τ] on the hand at E, in B; N, N·m),
    ``velocity`` (6, q̇_M, rad/s), ``jacobian`` (36, row-major 6×6 J_M with
    [v_E; ω_E] = J_M·q̇_M, translational rows first), ``hold`` (1, s: how long the torque of this
    sample is held; unconnected the period; on hardware the tick's measured duration).
    Outputs (discrete state, held between samples): ``torque`` (6, τ_M =
    J_Mᵀ·applied wrench, N·m, the wrench within ``max_force`` (N) and ``max_torque``
    (N·m), the device's limits), ``energy_observed`` (2, [E_t, E_r] after the PC, J),
    ``damping`` (2, [α_t (N·s/m), α_r (N·m·s/rad)] applied), ``energy_dissipated``
    (2, cumulative energy the PC removed, J), ``applied_wrench`` (6, the wrench the torque renders
    on the hand: [f; τ] at E in B, N, N·m).

    Timing: every ``period`` the update samples the inputs and computes the
    torque, which is held until the next sample, as a device driver does (read
    encoders, compute, write the amplifiers). The outputs are state, so the
    system has no direct feedthrough and closes any loop. The PO pairs each
    desired wrench with the velocity it was computed from (Hannaford & Ryu's
    E(n) = T·Σ f(k)·v(k)); that the hold then acts over the following interval is
    the usual sampled-data approximation of the port energy.

    A sample with a NaN or inf in any input commands zero torque and leaves
    the energies unchanged (the step is not observed).
    """

    def __init__(self, params: PassivityParams | None = None, max_force: float = math.inf,
                 max_torque: float = math.inf, period: float = DEFAULT_PERIOD, actuated=ALL_ACTUATED):
        """``actuated`` (6): 1.0 for each master joint an actuator drives (``plants.master_actuated``), else 0.0;
        one unactuated joint makes the device force only (``master_torque_into``)."""
        params = params or PassivityParams()
        params.validate()
        super().__init__(require_period(period))
        if not (max_force > 0 and max_torque > 0):
            raise ValueError(f"max_force and max_torque must be > 0; got {max_force}, {max_torque}")
        max_damping = ((params.max_translational_damping, params.max_rotational_damping) if params.enabled
                       else (0.0, 0.0))
        self.limits = np.array((*max_damping, max_force, max_torque))
        self.actuated = np.array(actuated, dtype=float)
        if self.actuated.shape != (6,) or not np.isin(self.actuated, (0.0, 1.0)).all():
            raise ValueError(f"actuated must be six values of 1 (actuated) or 0; got {actuated}")
        self.DeclareTickInput("wrench", 6)
        self.DeclareTickInput("velocity", 6)
        self.DeclareTickInput("jacobian", 36)
        self.DeclareTickInput("hold", 1, [self.tick_period])
        for name, size in (("torque", 6), ("energy", 2), ("damping", 2), ("dissipated", 2), ("applied", 6)):
            self.DeclareTickState(name, np.zeros(size))
        self.DeclareTickUpdate(passivity_update, "in:wrench", "in:velocity", Reshaped("in:jacobian", (6, 6)),
                               "in:hold", self.limits, self.actuated, "next:energy", "next:torque", "next:applied",
                               "next:damping", "next:dissipated", np.empty(14))
        for port, state in (("torque", "torque"), ("energy_observed", "energy"), ("damping", "damping"),
                            ("energy_dissipated", "dissipated"), ("applied_wrench", "applied")):
            self.DeclareTickOutput(port, f"x:{state}")
