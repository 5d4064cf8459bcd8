"""`heft identify --hardware`: the excitation on the real arm over LCM, then Sec. IV's estimators.

The diagram is DESIGN §3's estimation picture: ``MakeHardwareStation`` with an
``ExcitationCommander`` on ``slave.position_commanded`` (it waits for the
watchdog, moves slowly to the excitation's start, settles, excites, holds) and
zero master torque. Loggers keep the station's wrench, accelerometer and
encoder outputs at the controller rate; the samples of the excitation phase —
exactly its whole periods — go to the same estimators as in simulation. There
is no truth on hardware: the report gives each method's estimate, its standard
deviations, the residual RMS of the wrench model per axis, and the spread
between methods.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
import yaml
from pydrake.lcm import DrakeLcm, DrakeLcmInterface
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, Demultiplexer, LogVectorOutput

from heft.diagrams.identify import (
    Recording,
    design_excitation,
    estimate_all,
    estimate_record,
    kinematic_signals,
    noise_levels,
)
from heft.diagrams.lcm_recording import LcmTrafficRecorder
from heft.diagrams.realtime import HardwareRunFailed, format_timing, run_realtime, timing_summary
from heft.diagrams.scenario import Scenario
from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.hardware_station import (
    NUM_JOINTS,
    STATUS_FIELDS,
    HardwareStationParams,
    MakeHardwareStation,
)
from heft.hardware_interface.watchdog import WatchdogParams
from heft.systems.excitation import ExcitationSettings
from heft.systems.excitation_commander import ExcitationCommander, Phase
from heft.systems.load_dynamics import regressor_with_offsets

LOGGED = ("ft.wrench_measured", "ft.acceleration_measured", "slave.position_measured")


class IdentificationAborted(HardwareRunFailed):
    """The hardware run could not give a usable recording (no hardware, a fault, incomplete)."""


WAIT_LIMIT = 10.0
"""Seconds to wait for healthy hardware before giving up."""


def MakeHardwareIdentification(scenario: Scenario, trajectory, duration: float, lcm: DrakeLcmInterface,
                               channels: LcmChannels | None = None, watchdog: WatchdogParams | None = None):
    """(diagram, loggers {name: logger}) driving the slave through ``trajectory`` for
    ``duration`` s over ``lcm``; the ``phase`` logger holds the commander's ``Phase``."""
    period = scenario.controller_period
    params = HardwareStationParams(period=period, watchdog=watchdog or WatchdogParams())
    builder = DiagramBuilder()
    station = builder.AddNamedSystem("hardware_station", MakeHardwareStation(channels or LcmChannels(), lcm, params))
    commander = builder.AddNamedSystem("excitation", ExcitationCommander(
        trajectory, duration, params.slave_velocity_limits, period))
    status = builder.AddNamedSystem("status", Demultiplexer(len(STATUS_FIELDS)))
    builder.Connect(station.GetOutputPort("hardware.status"), status.get_input_port())
    builder.Connect(status.get_output_port(STATUS_FIELDS.index("healthy")), commander.GetInputPort("healthy"))
    builder.Connect(station.GetOutputPort("slave.position_measured"), commander.GetInputPort("position_measured"))
    builder.Connect(commander.GetOutputPort("position_commanded"), station.GetInputPort("slave.position_commanded"))
    builder.Connect(builder.AddNamedSystem("no_torque", ConstantVectorSource(np.zeros(NUM_JOINTS))).get_output_port(),
                    station.GetInputPort("master.torque_commanded"))
    loggers = {name: LogVectorOutput(station.GetOutputPort(name), builder, period) for name in LOGGED}
    loggers["phase"] = LogVectorOutput(commander.GetOutputPort("phase"), builder, period)
    loggers["hardware.status"] = LogVectorOutput(station.GetOutputPort("hardware.status"), builder, period)
    diagram = builder.Build()
    diagram.set_name("hardware_identification")
    return diagram, loggers


def excitation_recording(logs: dict, period: float, duration: float) -> Recording:
    """The excitation phase's samples (exactly ``duration`` s) from the loggers' arrays
    {name: (N, n)}; raises if the run faulted or the phase is incomplete."""
    phase = logs["phase"][:, 0]
    if np.any(phase == Phase.ABORTED):
        aborted = int(np.argmax(phase == Phase.ABORTED))
        ages = ", ".join(f"{name[4:]} {1e3 * age:.0f} ms"
                         for name, age in zip(STATUS_FIELDS[3:], logs["hardware.status"][aborted][3:]))
        raise IdentificationAborted(
            f"the hardware faulted during the excitation at t = {aborted * period:.3f} s (watchdog; channel ages "
            f"{ages}): no estimate. Check the drivers' timing (or the LCM log) and run again; a stand-in slower "
            "than real time may need a longer --watchdog-timeout")
    exciting = np.flatnonzero(phase == Phase.EXCITING)
    samples = int(round(duration / period))
    if exciting.size < samples:
        raise IdentificationAborted(f"the excitation did not complete: {exciting.size} of {samples} samples")
    window = slice(exciting[0], exciting[0] + samples)
    return Recording(t=np.arange(samples) * period, wrench=logs["ft.wrench_measured"][window],
                     accel_measured=logs["ft.acceleration_measured"][window],
                     q=logs["slave.position_measured"][window])


def record_on_hardware(scenario: Scenario, trajectory, duration: float, lcm_url: str, record=None,
                       watchdog: WatchdogParams | None = None):
    """Runs ``MakeHardwareIdentification`` on ``DrakeLcm(lcm_url)`` at real time until the
    excitation is done (or aborted); returns (Recording, timing summary)."""
    period = scenario.controller_period
    diagram, loggers = MakeHardwareIdentification(scenario, trajectory, duration, DrakeLcm(lcm_url),
                                                  watchdog=watchdog)
    simulator = Simulator(diagram)
    context = simulator.get_context()
    phase_port = diagram.GetSubsystemByName("excitation").GetOutputPort("phase")
    commander_context = diagram.GetSubsystemByName("excitation").GetMyContextFromRoot(context)
    simulator.Initialize()
    budget = WAIT_LIMIT + 60.0 + duration  # waiting, the slow approach and settling, the excitation

    def finished(k, t):
        phase = phase_port.Eval(commander_context)[0]
        if phase == Phase.WAITING and t > WAIT_LIMIT:
            raise IdentificationAborted(f"no healthy hardware on {lcm_url} within {WAIT_LIMIT:g} s: are the drivers "
                               "(or `heft stand-in`) running on this URL?")
        return phase in (Phase.DONE, Phase.ABORTED)

    ticks = int(round(budget / period))
    if record is None:
        times = run_realtime(simulator, period, ticks, finished)
    else:
        with LcmTrafficRecorder(lcm_url, record):
            times = run_realtime(simulator, period, ticks, finished)
    logs = {name: logger.FindLog(context).data().T.copy() for name, logger in loggers.items()}
    return excitation_recording(logs, period, duration), timing_summary(times)


def residual_rms(result, signals, wrench) -> list[float]:
    """RMS over samples of wrench − [E₆ V]·[offsets; φ] per axis ([f; τ]; N, N·m)."""
    theta = np.concatenate((np.asarray(result.offsets, dtype=float), np.asarray(result.phi, dtype=float)))
    predicted = regressor_with_offsets(*signals) @ theta
    return np.sqrt(np.mean((wrench - predicted) ** 2, axis=0)).tolist()


def identify_on_hardware(scenario: Scenario, out_dir, lcm_url: str, method: str = "tls",
                         signals: str = "accelerometer", settings: ExcitationSettings | None = None,
                         periods: int = 1, record=None, recording: Recording | None = None,
                         watchdog: WatchdogParams | None = None) -> dict:
    """Designs the excitation, runs it on the hardware at ``lcm_url`` (or takes ``recording``),
    estimates with every method, writes estimate.yaml (``method``'s) and metrics.json. Returns metrics."""
    settings = settings or ExcitationSettings()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    excitation = design_excitation(scenario, settings)
    duration = periods / settings.base_frequency
    timing = None
    if recording is None:
        print(f"identify: excitation of {duration:g} s on {lcm_url}; the arm first moves slowly to its start",
              flush=True)
        recording, timing = record_on_hardware(scenario, excitation.trajectory, duration, lcm_url, record, watchdog)
        print(format_timing(timing), flush=True)
    signal_set, instruments = kinematic_signals(scenario, recording, settings.base_frequency, settings.harmonics,
                                                signals)
    results, _ = estimate_all(recording.wrench, signal_set, instruments, noise_levels(scenario))
    records = {m: estimate_record(r, m, signals, len(recording.t)) for m, r in results.items()}
    masses = [r["phi"][0] for r in records.values()]
    metrics = {"signals": signals, "samples": len(recording.t), "duration_s": duration, "lcm_url": lcm_url,
               "excitation_condition_number": excitation.metrics.condition_number,
               "estimates": records,
               "residual_rms": {m: residual_rms(r, signal_set, recording.wrench) for m, r in results.items()},
               "mass_spread_kg": float(np.ptp(masses)), "timing": timing, "lcm_log": None if record is None
               else str(record), "wall_time_s": time.perf_counter() - started}
    (out / "estimate.yaml").write_text(yaml.safe_dump(records[method], sort_keys=False))
    (out / "metrics.json").write_text(json.dumps(metrics, indent=2) + "\n")
    print(f"{'method':8s}{'mass (kg)':>11s}{'σ (g)':>8s}{'COM (mm)':>26s}{'residual f (N)':>16s}{'τ (N·m)':>9s}")
    for m, r in records.items():
        com = 1e3 * np.asarray(r.get("com", [np.nan] * 3))
        rms = metrics["residual_rms"][m]
        print(f"{m:8s}{r['phi'][0]:11.4f}{1e3 * r['std_phi'][0]:8.2f}   "
              f"[{com[0]:7.2f} {com[1]:7.2f} {com[2]:7.2f}]{max(rms[:3]):16.3f}{max(rms[3:]):9.4f}")
    return metrics


def hardware_recording_in_process(scenario: Scenario, stand_in, trajectory, duration: float, lcm):
    """For tests and the stand-in: ``MakeHardwareIdentification`` beside ``stand_in`` (a
    stand-in Diagram on the same ``lcm``) in one Simulator, as fast as it runs; the Recording."""
    period = scenario.controller_period
    builder = DiagramBuilder()
    builder.AddNamedSystem("stand_in", stand_in)
    identification, loggers = MakeHardwareIdentification(scenario, trajectory, duration, lcm)
    builder.AddNamedSystem("identification", identification)
    diagram = builder.Build()
    simulator = Simulator(diagram)
    simulator.Initialize()
    context = simulator.get_context()
    commander = identification.GetSubsystemByName("excitation")
    phase_port = commander.GetOutputPort("phase")
    while phase_port.Eval(commander.GetMyContextFromRoot(context))[0] not in (Phase.DONE, Phase.ABORTED):
        if context.get_time() > WAIT_LIMIT + 60.0 + duration:
            raise IdentificationAborted("the excitation did not finish")
        simulator.AdvanceTo(context.get_time() + 0.1)
    logs = {name: logger.FindLog(context).data().T.copy() for name, logger in loggers.items()}
    return excitation_recording(logs, period, duration)

