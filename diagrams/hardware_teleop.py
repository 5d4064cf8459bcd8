"""The teleoperation controller on the lab's LCM channels, with timing statistics.

``run_hardware_teleop`` closes ``MakeTeleopController`` (clutch engaged) around
``MakeHardwareStation`` on a ``DrakeLcm(lcm_url)`` and runs it at real-time
rate 1, one controller period per ``AdvanceTo``, measuring every tick. It
returns (and the CLI prints) what the run saw: whether fresh data arrived,
when the watchdog was healthy, each fault and its recovery (with the master
torque at the recovery tick: it must ramp in from zero, not jump), whether
every master torque published was finite, the largest slave command step,
and the timing: achieved rate, deadline misses (ticks
that completed more than one period after their real-time deadline) and the
tick cost (wall and CPU time per ``AdvanceTo``).
"""

from __future__ import annotations

import math

import numpy as np
from pydrake.lcm import DrakeLcm
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from heft.diagrams.lcm_recording import LcmTrafficRecorder
from heft.diagrams.realtime import format_timing, run_realtime, timing_summary
from heft.diagrams.scenario import Scenario
from heft.diagrams.teleop import ConnectControllerToStation, LoadEstimate, MakeTeleopController
from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.hardware_station import STATUS_FIELDS, HardwareStationParams, MakeHardwareStation
from heft.hardware_interface.watchdog import WatchdogParams

_STATUS = {name: i for i, name in enumerate(STATUS_FIELDS)}


def MakeHardwareTeleop(scenario: Scenario, load: LoadEstimate, lcm_url: str, watchdog: WatchdogParams | None = None):
    """Controller (clutch constant 1) + hardware station on a new ``DrakeLcm(lcm_url)``.
    Returns the diagram and its hardware station subsystem."""
    period = scenario.controller_period
    channels = LcmChannels(lcm_url=lcm_url)
    builder = DiagramBuilder()
    station = builder.AddNamedSystem("hardware_station", MakeHardwareStation(
        channels, DrakeLcm(lcm_url), HardwareStationParams(period=period, watchdog=watchdog or WatchdogParams())))
    controller = builder.AddNamedSystem("controller", MakeTeleopController(
        scenario.controller, load, scenario.robot, period, scenario.slave_initial_q))
    ConnectControllerToStation(builder, controller, station)
    diagram = builder.Build()
    diagram.set_name("hardware_teleop")
    return diagram, station


def run_hardware_teleop(scenario: Scenario | str, estimate: LoadEstimate, lcm_url: str, duration: float,
                        record=None, watchdog: WatchdogParams | None = None) -> dict:
    """Runs the controller against the lab (or a stand-in) on ``lcm_url`` for ``duration`` s
    at real-time rate 1; returns the run's summary (JSON-serialisable; times in s).
    ``scenario``: a Scenario, or a bundled name / YAML path (its controller, robot and rate are used).
    ``record``: a path to record the LCM traffic to (``lcm-logger`` format), or None;
    ``watchdog``: its timeout and ramp (default ``WatchdogParams()``)."""
    if not isinstance(scenario, Scenario):
        from heft.diagrams.simulate import resolve_scenario
        scenario = resolve_scenario(scenario)
    period = scenario.controller_period
    diagram, station = MakeHardwareTeleop(scenario, estimate, lcm_url, watchdog)
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    station_context = station.GetMyContextFromRoot(context)
    status_port = station.GetOutputPort("hardware.status")
    gate = station.GetSubsystemByName("command_gate")
    gate_context = gate.GetMyContextFromRoot(context)
    torque_port, enable_port = gate.GetOutputPort("torque"), gate.GetOutputPort("enable")
    position_port, ready_port = gate.GetOutputPort("position"), gate.GetOutputPort("ready")
    simulator.Initialize()

    ticks = max(1, round(duration / period))
    seen = {"fresh_ticks": 0, "healthy_ticks": 0, "torque_finite": True, "torque_peak": 0.0, "first_fresh": None,
            "first_healthy": None, "last_fresh": None, "faults": [], "was_healthy": False, "was_enabled": False,
            "position": None, "max_slave_step": 0.0}

    def on_tick(k, t):
        status = status_port.Eval(station_context)
        ages = status[_STATUS["age_master_state"]:]
        healthy = status[_STATUS["healthy"]] > 0.5
        if np.all(ages <= max(2 * period, 0.005)):  # every channel fresh within ~one period
            seen["fresh_ticks"] += 1
            seen["last_fresh"] = t
            if seen["first_fresh"] is None:
                seen["first_fresh"] = t
        if healthy:
            seen["healthy_ticks"] += 1
            if seen["first_healthy"] is None:
                seen["first_healthy"] = t
        elif seen["was_healthy"]:
            seen["faults"].append({"onset": t, "recovered": None, "torque_at_recovery": None})
        seen["was_healthy"] = healthy
        # The gate acts on the watchdog's state one tick later: its enable's rising edge is the recovery.
        torque = torque_port.Eval(gate_context)
        enabled = enable_port.Eval(gate_context)[0] > 0.5
        recovering = enabled and not seen["was_enabled"] and bool(seen["faults"])
        if recovering and seen["faults"][-1]["recovered"] is None:
            seen["faults"][-1].update(recovered=t, torque_at_recovery=float(np.abs(torque).max()))
        seen["was_enabled"] = enabled
        if not np.all(np.isfinite(torque)):
            seen["torque_finite"] = False
        else:
            seen["torque_peak"] = max(seen["torque_peak"], float(np.abs(torque).max()))
        # Commands are published once ready; a recovery restarts them at the measured position.
        position = position_port.Eval(gate_context).copy() if ready_port.Eval(gate_context)[0] > 0.5 else None
        if position is not None and seen["position"] is not None and not recovering:
            seen["max_slave_step"] = max(seen["max_slave_step"], float(np.abs(position - seen["position"]).max()))
        seen["position"] = position

    if record is None:
        times = run_realtime(simulator, period, ticks, on_tick)
    else:
        with LcmTrafficRecorder(lcm_url, record):
            times = run_realtime(simulator, period, ticks, on_tick)
    status = status_port.Eval(station_context)
    return {
        "duration": ticks * period,
        "period": period,
        "ticks": ticks,
        "fresh_ticks": seen["fresh_ticks"],
        "first_fresh": seen["first_fresh"],
        "last_fresh": seen["last_fresh"],
        "healthy_ticks": seen["healthy_ticks"],
        "first_healthy": seen["first_healthy"],
        "faults": seen["faults"],
        "fault_onset": seen["faults"][-1]["onset"] if seen["faults"] else None,
        "final_healthy": bool(status[_STATUS["healthy"]] > 0.5),
        "final_fault": int(status[_STATUS["fault"]]),
        "final_ages": [float(a) if math.isfinite(a) else None for a in status[_STATUS["age_master_state"]:]],
        "final_master_enable": bool(enable_port.Eval(gate_context)[0] > 0.5),
        "master_torque_finite": seen["torque_finite"],
        "master_torque_peak": seen["torque_peak"],
        "max_slave_command_step": seen["max_slave_step"],
        "lcm_log": None if record is None else str(record),
        "timing": timing_summary(times),
    }


def format_summary(summary: dict) -> str:
    """The summary as a few human lines."""
    faults = summary["faults"]
    fault_lines = "; ".join(
        f"at {f['onset']:.4f} s, " + ("not recovered" if f["recovered"] is None else
                                      f"recovered at {f['recovered']:.4f} s with {f['torque_at_recovery']:.2g} N·m")
        for f in faults[:5]) + (f" … ({len(faults)} in all)" if len(faults) > 5 else "")
    return "\n".join((
        f"ran {summary['duration']:g} s, {summary['ticks']} ticks of {1e6 * summary['period']:.0f} µs",
        f"fresh data on every channel in {summary['fresh_ticks']} ticks (first at {summary['first_fresh']}); "
        f"watchdog healthy in {summary['healthy_ticks']} ticks (first at {summary['first_healthy']}); "
        f"faults after healthy: {fault_lines or 'none'}; "
        f"final: healthy {summary['final_healthy']}, fault bits {summary['final_fault']}, "
        f"master enable {summary['final_master_enable']}",
        f"master torque finite: {summary['master_torque_finite']} (peak {summary['master_torque_peak']:.3g} N·m); "
        f"largest slave command step (recoveries aside) "
        f"{summary['max_slave_command_step']:.3g} rad",
        format_timing(summary["timing"]),
    ))


