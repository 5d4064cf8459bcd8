"""The teleoperation controller on the lab's LCM channels, with timing statistics.

``run_hardware_teleop`` closes ``MakeTeleopController`` (clutch engaged) around
``MakeHardwareStation`` on a ``DrakeLcm(lcm_url)`` and runs it at real-time
rate 1, one controller period per ``AdvanceTo``, measuring every tick. It
returns (and the CLI prints) what the run saw: whether fresh data arrived,
when the watchdog was healthy and faulted, whether every master torque
published was finite, and the timing: achieved rate, deadline misses (ticks
that completed more than one period after their real-time deadline) and the
tick cost (wall and CPU time per ``AdvanceTo``).
"""

from __future__ import annotations

import math
import time

import numpy as np
from pydrake.lcm import DrakeLcm
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from heft.diagrams.scenario import Scenario
from heft.diagrams.teleop import ConnectControllerToStation, LoadEstimate, MakeTeleopController
from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.hardware_station import STATUS_FIELDS, HardwareStationParams, MakeHardwareStation

_STATUS = {name: i for i, name in enumerate(STATUS_FIELDS)}


def MakeHardwareTeleop(scenario: Scenario, load: LoadEstimate, lcm_url: str):
    """Controller (clutch constant 1) + hardware station on a new ``DrakeLcm(lcm_url)``.
    Returns the diagram and its hardware station subsystem."""
    period = scenario.controller_period
    channels = LcmChannels(lcm_url=lcm_url)
    builder = DiagramBuilder()
    station = builder.AddNamedSystem("hardware_station", MakeHardwareStation(
        channels, DrakeLcm(lcm_url), HardwareStationParams(period=period)))
    controller = builder.AddNamedSystem("controller", MakeTeleopController(
        scenario.controller, load, scenario.robot, period, scenario.slave_initial_q))
    ConnectControllerToStation(builder, controller, station)
    diagram = builder.Build()
    diagram.set_name("hardware_teleop")
    return diagram, station


def _percentile_us(values, q) -> float:
    return float(np.percentile(values, q) * 1e6) if len(values) else math.nan


def run_hardware_teleop(scenario: Scenario | str, estimate: LoadEstimate, lcm_url: str, duration: float) -> dict:
    """Runs the controller against the lab (or a stand-in) on ``lcm_url`` for ``duration`` s
    at real-time rate 1; returns the run's summary (JSON-serialisable; times in s).
    ``scenario``: a Scenario, or a bundled name / YAML path (its controller, robot and rate are used)."""
    if not isinstance(scenario, Scenario):
        from heft.diagrams.simulate import resolve_scenario
        scenario = resolve_scenario(scenario)
    period = scenario.controller_period
    diagram, station = MakeHardwareTeleop(scenario, estimate, lcm_url)
    simulator = Simulator(diagram)
    simulator.set_target_realtime_rate(1.0)
    context = simulator.get_mutable_context()
    station_context = station.GetMyContextFromRoot(context)
    status_port = station.GetOutputPort("hardware.status")
    gate = station.GetSubsystemByName("command_gate")
    gate_context = gate.GetMyContextFromRoot(context)
    torque_port, enable_port = gate.GetOutputPort("torque"), gate.GetOutputPort("enable")
    simulator.Initialize()

    ticks = max(1, round(duration / period))
    wall = np.empty(ticks)
    cpu = np.empty(ticks)
    lateness = np.empty(ticks)
    fresh_ticks = healthy_ticks = 0
    torque_finite = True
    torque_peak = 0.0
    first_fresh = first_healthy = fault_onset = None
    last_fresh = None  # time of the last tick at which every channel was fresh (age ≤ one period)
    was_healthy = False
    t0 = context.get_time()
    start = time.perf_counter()
    for k in range(ticks):
        target = t0 + (k + 1) * period
        c0, w0 = time.thread_time(), time.perf_counter()
        simulator.AdvanceTo(target)
        w1 = time.perf_counter()
        cpu[k], wall[k] = time.thread_time() - c0, w1 - w0
        lateness[k] = (w1 - start) - (target - t0)
        status = status_port.Eval(station_context)
        ages = status[_STATUS["age_master_state"]:]
        healthy = status[_STATUS["healthy"]] > 0.5
        if np.all(ages <= max(2 * period, 0.005)):
            fresh_ticks += 1
            last_fresh = target
            if first_fresh is None:
                first_fresh = target
        if healthy:
            healthy_ticks += 1
            if first_healthy is None:
                first_healthy = target
        elif was_healthy:
            fault_onset = target
        was_healthy = healthy
        torque = torque_port.Eval(gate_context)
        if not np.all(np.isfinite(torque)):
            torque_finite = False
        else:
            torque_peak = max(torque_peak, float(np.abs(torque).max()))
    elapsed = time.perf_counter() - start
    status = status_port.Eval(station_context)
    return {
        "duration": ticks * period,
        "period": period,
        "ticks": ticks,
        "fresh_ticks": fresh_ticks,
        "first_fresh": first_fresh,
        "last_fresh": last_fresh,
        "healthy_ticks": healthy_ticks,
        "first_healthy": first_healthy,
        "fault_onset": fault_onset,
        "final_healthy": bool(status[_STATUS["healthy"]] > 0.5),
        "final_fault": int(status[_STATUS["fault"]]),
        "final_ages": [float(a) if math.isfinite(a) else None for a in status[_STATUS["age_master_state"]:]],
        "final_master_enable": bool(enable_port.Eval(gate_context)[0] > 0.5),
        "master_torque_finite": torque_finite,
        "master_torque_peak": torque_peak,
        "timing": {
            "wall": elapsed,
            "achieved_rate_hz": ticks / elapsed,
            "realtime_factor": ticks * period / elapsed,
            "deadline_misses": int(np.count_nonzero(lateness > period)),
            "max_lateness": float(lateness.max()),
            "tick_wall_p50_us": _percentile_us(wall, 50),
            "tick_wall_p99_us": _percentile_us(wall, 99),
            "tick_cpu_p50_us": _percentile_us(cpu, 50),
            "tick_cpu_p99_us": _percentile_us(cpu, 99),
        },
    }


def format_summary(summary: dict) -> str:
    """The summary as a few human lines."""
    t = summary["timing"]
    fault = summary["fault_onset"]
    return "\n".join((
        f"ran {summary['duration']:g} s, {summary['ticks']} ticks of {1e6 * summary['period']:.0f} µs",
        f"fresh data on every channel in {summary['fresh_ticks']} ticks (first at {summary['first_fresh']}); "
        f"watchdog healthy in {summary['healthy_ticks']} ticks (first at {summary['first_healthy']}); "
        f"fault after healthy: {'none' if fault is None else f'at {fault:.4f} s'}; "
        f"final: healthy {summary['final_healthy']}, fault bits {summary['final_fault']}, "
        f"master enable {summary['final_master_enable']}",
        f"master torque finite: {summary['master_torque_finite']} (peak {summary['master_torque_peak']:.3g} N·m)",
        f"timing: achieved {t['achieved_rate_hz']:.0f} Hz ({t['realtime_factor']:.2f}× real time), "
        f"{t['deadline_misses']} deadline misses (max lateness {1e3 * t['max_lateness']:.1f} ms); "
        f"tick wall p50 {t['tick_wall_p50_us']:.0f} µs p99 {t['tick_wall_p99_us']:.0f} µs, "
        f"cpu p50 {t['tick_cpu_p50_us']:.0f} µs p99 {t['tick_cpu_p99_us']:.0f} µs",
    ))


