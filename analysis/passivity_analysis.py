"""Energy at the master port and what the passivity controller did, from a run's log.

The port is the one of `heft.systems.controller.passivity_controller`: the network (teleoperator,
slave, environment) exerts the wrench w = [f; τ] (N, N·m) on the operator's hand at the
stylus E, expressed in the master base B; E moves with the twist [v; ω] (m/s, rad/s) of E
in B. w·[v; ω] is the power (W) the network delivers to the hand.

Sign convention (the passivity observer's): energy flowing from the hand INTO the network
is positive, per channel, translational (f·v) and rotational (τ·ω). A passive network keeps
it ≥ 0 at all times.

The log carries no twist: pass one, e.g. ``stylus_twist(jacobians, log["master_v"])``.
"""

from heft.analysis.plotting import plt
import numpy as np

CHANNELS = ("translational", "rotational")


def stylus_twist(jacobians, joint_velocity) -> np.ndarray:
    """Twists [v; ω] of E in B (N, 6; m/s, rad/s) from the master Jacobians (N, 6, 6) or
    row-major (N, 36), with [v; ω] = J·q̇, and the joint velocities q̇ (N, 6; rad/s)."""
    jacobians = np.asarray(jacobians, dtype=float).reshape(-1, 6, 6)
    return np.einsum("nij,nj->ni", jacobians, np.asarray(joint_velocity, dtype=float))


def sample_periods(t, period: float | np.ndarray | None = None) -> np.ndarray:
    """The interval (s) each sample's value holds for: ``period`` if given (one for all, or one
    per sample: a hardware controller's measured ticks), else t[k+1] − t[k] (the last sample
    repeats the one before)."""
    t = np.asarray(t, dtype=float)
    if period is not None:
        return np.broadcast_to(np.asarray(period, dtype=float), t.shape).copy()
    if t.size < 2:
        raise ValueError("need two samples or a period to know the sample interval")
    dt = np.diff(t)
    return np.append(dt, dt[-1])


def port_power(wrench, twist) -> np.ndarray:
    """Power (N, 2; W) the network delivers to the hand, per channel [f·v, τ·ω]."""
    wrench, twist = np.asarray(wrench, dtype=float), np.asarray(twist, dtype=float)
    product = wrench * twist
    return np.stack((product[:, :3].sum(axis=1), product[:, 3:].sum(axis=1)), axis=1)


def port_energy(t, wrench, twist, method: str = "rectangle", period: float | np.ndarray | None = None) -> np.ndarray:
    """Cumulative energy (N, 2; J) that flowed from the hand into the network through the
    master port, per channel [translational, rotational], positive into the network.

    ``wrench`` (N, 6) on the hand [f; τ] and ``twist`` (N, 6) [v; ω], both at E in B, at
    times ``t`` (N; s). "rectangle" is the sampled controller's sum, each product held over
    its sample interval (see `sample_periods`): E(k) = −Σ_{j≤k} w(j)·v(j)·T(j), the
    passivity observer's own estimate. "trapezoid" integrates the samples as continuous
    signals, E(0) = 0."""
    power = port_power(wrench, twist)
    if method == "rectangle":
        return -np.cumsum(power * sample_periods(t, period)[:, None], axis=0)
    if method == "trapezoid":
        steps = 0.5 * (power[1:] + power[:-1]) * np.diff(np.asarray(t, dtype=float))[:, None]
        return -np.concatenate((np.zeros((1, 2)), np.cumsum(steps, axis=0)))
    raise ValueError(f"method must be 'rectangle' or 'trapezoid'; got {method!r}")


def active_intervals(t, active, period: float | np.ndarray | None = None) -> list[tuple[float, float]]:
    """Maximal runs of samples where ``active`` holds, as (start, end) in s: start is the
    first active sample's time, end the last one's plus its sample interval."""
    t = np.asarray(t, dtype=float)
    flags = np.concatenate(([0], np.asarray(active, dtype=bool).astype(np.int8), [0]))
    starts = np.flatnonzero(np.diff(flags) == 1)
    stops = np.flatnonzero(np.diff(flags) == -1) - 1
    holds = sample_periods(t, period)
    return [(float(t[a]), float(t[b] + holds[b])) for a, b in zip(starts, stops)]


def passivity_controller_summary(t, damping, energy_observed, twist=None,
                                 period: float | np.ndarray | None = None) -> dict:
    """When and how hard the passivity controller acted, per channel.

    ``damping`` (N, 2) is [α_t (N·s/m), α_r (N·m·s/rad)], ``energy_observed`` (N, 2) the
    PO's [E_t, E_r] (J). With ``twist`` (N, 6), paired row by row with the damping it met,
    the energy the PC dissipated, Σ α|v|²T (J), is added. Keys per channel c:
    ``c_active_s`` (total time with α > 0), ``c_active_fraction``, ``c_intervals`` (list of
    (start, end) s), ``c_first_active_s`` (None if never), ``c_peak_damping``,
    ``c_min_energy_J``, ``c_final_energy_J`` and ``c_dissipated_J``."""
    damping, energy = np.asarray(damping, dtype=float), np.asarray(energy_observed, dtype=float)
    holds = sample_periods(t, period)
    speed_squared = None
    if twist is not None:
        twist = np.asarray(twist, dtype=float)
        speed_squared = np.stack(((twist[:, :3] ** 2).sum(axis=1), (twist[:, 3:] ** 2).sum(axis=1)), axis=1)
    summary = {}
    for i, name in enumerate(CHANNELS):
        active = damping[:, i] > 0.0
        intervals = active_intervals(t, active, period)
        summary[f"{name}_active_s"] = float(holds[active].sum())
        summary[f"{name}_active_fraction"] = float(holds[active].sum() / holds.sum())
        summary[f"{name}_intervals"] = intervals
        summary[f"{name}_first_active_s"] = intervals[0][0] if intervals else None
        summary[f"{name}_peak_damping"] = float(damping[:, i].max(initial=0.0))
        summary[f"{name}_min_energy_J"] = float(energy[:, i].min())
        summary[f"{name}_final_energy_J"] = float(energy[-1, i])
        if speed_squared is not None:
            summary[f"{name}_dissipated_J"] = float((damping[:, i] * speed_squared[:, i] * holds).sum())
    return summary


def passivity_summary(log: dict, twist=None, period: float | np.ndarray | None = None) -> dict:
    """`passivity_controller_summary` of a run's log (keys t, passivity_damping,
    passivity_energy, master_force); with ``twist`` (N, 6) also the port energy of the
    desired wrench ``master_force`` (rectangle rule): ``c_port_energy_final_J`` and
    ``c_port_energy_min_J`` per channel c."""
    summary = passivity_controller_summary(log["t"], log["passivity_damping"], log["passivity_energy"],
                                           twist, period)
    if twist is not None:
        energy = port_energy(log["t"], log["master_force"], twist, period=period)
        for i, name in enumerate(CHANNELS):
            summary[f"{name}_port_energy_final_J"] = float(energy[-1, i])
            summary[f"{name}_port_energy_min_J"] = float(energy[:, i].min())
    return summary


def passivity_figure(log: dict, path, twist=None, period: float | np.ndarray | None = None, title: str = ""):
    """PNG at ``path``: per channel (columns), the PO's observed energy — and with
    ``twist`` the port energy of ``master_force`` — over t (top), and the PC's damping
    (bottom)."""
    t = np.asarray(log["t"], dtype=float)
    observed, damping = np.asarray(log["passivity_energy"]), np.asarray(log["passivity_damping"])
    port = port_energy(t, log["master_force"], twist, period=period) if twist is not None else None
    figure, panels = plt.subplots(2, 2, sharex=True, figsize=(9, 5))
    for i, (name, unit) in enumerate(zip(CHANNELS, ("N·s/m", "N·m·s/rad"))):
        panels[0, i].plot(t, observed[:, i], lw=1.0, label="observed (PO, after PC)")
        if port is not None:
            panels[0, i].plot(t, port[:, i], "--", lw=0.8, label="port energy of desired wrench")
        panels[0, i].axhline(0.0, color="k", lw=0.5)
        panels[0, i].set_ylabel("energy into network (J)")
        panels[0, i].set_title(name)
        panels[0, i].legend(loc="best", fontsize=8)
        panels[1, i].plot(t, damping[:, i], lw=1.0, color="C3")
        panels[1, i].set_ylabel(f"PC damping ({unit})")
        panels[1, i].set_xlabel("t (s)")
        for row in panels[:, i]:
            row.grid(alpha=0.3)
    if title:
        figure.suptitle(title)
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)
