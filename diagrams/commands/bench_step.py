"""`heft bench step`: one controller tick, computed in one step and by the per-block Diagram.

Both get the same station readings, tick by tick, in one process: the stylus and the arm on smooth
sines, the clutch engaged, a steady load on the sensor with a contact in the middle third. The fused
step (``MakeRealtimeTeleopController``) is timed per ``step``, and so is the per-block Diagram as
``heft teleop --hardware --controller diagram`` ticks it (``DiagramTeleopController``: the readings fixed
on its input ports, its periodic discrete update applied, the commands read off its outputs). Each tick
is timed on the wall clock (the machine's load included) and the CPU clock.
"""

from __future__ import annotations

import time

import numpy as np

from heft.diagrams.commands.console import logger

say = logger(__name__)

FITS_DIAGRAM_P99 = 400e-6
"""The per-block Diagram is offered on hardware only if its tick's p99 stays below this (s) at 2 kHz."""


def readings(scenario, ticks: int, period: float) -> list[dict]:
    """The station's readings (``STATION_OUTPUTS_READ`` and the clutch) for ``ticks`` ticks."""
    rng = np.random.default_rng(3)
    q_M0, q_S0 = np.array(scenario.master_initial_q), np.array(scenario.slave_initial_q)
    w_M, w_S = rng.uniform(0.5, 2.0, 6), rng.uniform(0.5, 2.0, 6)  # rad/s of each joint's sine
    sequence = []
    for k in range(ticks):
        t = k * period
        contact = np.array([0.0, 0.0, 5.0, 0.2, 0.0, 0.0]) if ticks // 3 <= k < 2 * ticks // 3 else np.zeros(6)
        sequence.append({
            "master.position_measured": q_M0 + 0.1 * np.sin(w_M * t),
            "master.velocity_estimated": 0.1 * w_M * np.cos(w_M * t),
            "slave.position_measured": q_S0 + 0.05 * np.sin(w_S * t),
            "slave.velocity_estimated": 0.05 * w_S * np.cos(w_S * t),
            "ft.wrench_measured": np.array([0.3, -0.2, 30.7, 0.05, -0.1, 0.02]) + contact,
            "ft.acceleration_measured": np.array([0.1, 0.0, 9.81, 0.5, -0.2, 0.1]) * (1 + 0.1 * np.sin(5 * t)),
            "clutch": np.array([1.0]),
        })
    return sequence


def _percentiles(seconds: list[float]) -> dict:
    values = 1e6 * np.asarray(seconds)
    return {"p50_us": float(np.percentile(values, 50)), "p99_us": float(np.percentile(values, 99)),
            "mean_us": float(values.mean())}


def time_controller(controller, sequence, period: float, torques: list | None = None) -> dict:
    """Wall and CPU time of each ``controller.step`` on ``sequence`` (the fused ``RealtimeTeleopController``
    or the per-block ``DiagramTeleopController``: the same interface); each tick's master torque appended
    to ``torques`` if given."""
    controller.start(sequence[0]["slave.position_measured"])
    wall, cpu = [], []
    for inputs in sequence:
        arguments = (period, inputs["master.position_measured"], inputs["master.velocity_estimated"],
                     inputs["slave.position_measured"], inputs["slave.velocity_estimated"],
                     inputs["ft.wrench_measured"], inputs["ft.acceleration_measured"], inputs["clutch"][0] > 0.5)
        w, c = time.perf_counter(), time.process_time()
        controller.step(*arguments)
        cpu.append(time.process_time() - c)
        wall.append(time.perf_counter() - w)
        if torques is not None:
            torques.append(controller.torque.copy())
    return {"wall": _percentiles(wall), "cpu": _percentiles(cpu)}


def report(results: dict, period: float) -> None:
    """Prints the two side by side, their ratio and whether the Diagram fits."""
    fused, diagram = results["fused"], results["diagram"]
    say.info(f"controller tick at {1 / period:.0f} Hz, {results['ticks']} ticks, one process:")
    for clock in ("wall", "cpu"):
        say.info(f"  {clock:4s} p50 / p99: fused step {fused[clock]['p50_us']:.0f} / {fused[clock]['p99_us']:.0f} µs, "
                 f"per-block Diagram {diagram[clock]['p50_us']:.0f} / {diagram[clock]['p99_us']:.0f} µs "
                 f"(× {diagram[clock]['p50_us'] / fused[clock]['p50_us']:.1f} / "
                 f"{diagram[clock]['p99_us'] / fused[clock]['p99_us']:.1f})")
    fits = diagram["wall"]["p99_us"] < 1e6 * FITS_DIAGRAM_P99
    say.info(f"the per-block Diagram {'fits' if fits else 'does not fit'} a {1e3 * period:g} ms tick with p99 < "
             f"{1e6 * FITS_DIAGRAM_P99:.0f} µs (before LCM's receive and send)")
