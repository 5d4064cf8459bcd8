"""`heft bench step`: one tick of the controller Diagram, as its program and as Drake steps it.

Both get the same station readings, tick by tick, in one process: the stylus and the arm on smooth
sines, the clutch engaged, a steady load on the sensor with a contact in the middle third. The program
(``TeleopController``, what ``heft teleop --hardware`` ticks: every block's kernel in the Diagram's order, compiled
as one function) is timed per ``step``, and so are the same program calling each kernel from Python and Drake's own
stepping of the same Diagram (``DrakeStepping``: the readings fixed on its input ports, its periodic discrete update
applied through the framework, block by block). Each tick
is timed on the wall clock (the machine's load included) and the CPU clock; the two commands are compared.
"""

from __future__ import annotations

import time

import numpy as np

from heft.diagrams.commands.console import logger

say = logger(__name__)

TICK_BUDGET = 50e-6
"""The program's tick p99 this bench holds against (s): a quarter of the 2 kHz loop's 200 µs, which also
receives, checks and sends the LCM messages."""


class DrakeStepping:
    """The controller Diagram ``diagram`` stepped by Drake's framework with ``TeleopController``'s interface
    (``start``, ``step``, ``torque``): the reference the program is timed against."""

    def __init__(self, diagram):
        self._diagram, self._context = diagram, diagram.CreateDefaultContext()
        self._fixed = {name: diagram.GetInputPort(name).FixValue(
            self._context, np.zeros(diagram.GetInputPort(name).size())) for name in READ}
        self._torque = diagram.GetOutputPort("master.torque_commanded")

    def start(self, slave_position) -> None:
        self._diagram.SetDefaultContext(self._context)
        self._fixed["slave.position_measured"].GetMutableData().get_mutable_value().SetFromVector(slave_position)
        self._diagram.ExecuteInitializationEvents(self._context)

    def step(self, dt, *readings) -> None:
        for name, value in zip(READ, (*readings[:-1], (1.0 if readings[-1] else 0.0,))):
            self._fixed[name].GetMutableData().get_mutable_value().SetFromVector(value)
        self._context.SetDiscreteState(self._diagram.EvalUniquePeriodicDiscreteUpdate(self._context))

    @property
    def torque(self) -> np.ndarray:
        return self._torque.Eval(self._context)


READ = ("master.position_measured", "master.velocity_estimated", "slave.position_measured",
        "slave.velocity_estimated", "ft.wrench_measured", "ft.acceleration_measured", "clutch")
"""The Diagram inputs a tick sets, in ``step``'s order."""


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
    """Wall and CPU time of each ``controller.step`` on ``sequence`` (``TeleopController`` or
    ``DrakeStepping``: the same interface); each tick's master torque appended to ``torques`` if given."""
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
    """Prints the three side by side, the ratios, whether they agree and whether the program keeps its budget."""
    program, by_kernel, drake = results["program"], results["by_kernel"], results["drake"]
    compiled = "compiled" if results["compiled"] else "not compiled (kernels as Python)"
    say.info(f"controller tick at {1 / period:.0f} Hz, {results['ticks']} ticks, one process; the program {compiled}:")
    for clock in ("wall", "cpu"):
        p50, p99 = program[clock]["p50_us"], program[clock]["p99_us"]
        say.info(f"  {clock:4s} p50 / p99: program {p50:.0f} / {p99:.0f} µs; kernel by kernel "
                 f"{by_kernel[clock]['p50_us']:.0f} / {by_kernel[clock]['p99_us']:.0f} µs "
                 f"(× {by_kernel[clock]['p50_us'] / p50:.2f} / {by_kernel[clock]['p99_us'] / p99:.2f}); "
                 f"Drake's stepping {drake[clock]['p50_us']:.0f} / {drake[clock]['p99_us']:.0f} µs "
                 f"(× {drake[clock]['p50_us'] / p50:.1f} / {drake[clock]['p99_us'] / p99:.1f})")
    say.info(f"  largest difference of the master torques: {results['torque_difference']:.3g} N·m")
    fits = program["wall"]["p99_us"] < 1e6 * TICK_BUDGET
    say.info(f"the program {'keeps' if fits else 'exceeds'} its budget: tick p99 < {1e6 * TICK_BUDGET:.0f} µs "
             "(before LCM's receive and send)")
