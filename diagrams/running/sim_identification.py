"""Identification in simulation: the excitation run on the simulated station (free space,
the gripper alone for a load with a grasp), recorded sample-aligned for ``identify``."""

import math
from pathlib import Path

import numpy as np
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, LogVectorOutput, TrajectorySource

from heft.diagrams.identify import FitRefused, Recording, identify
from heft.diagrams.load_estimate import LoadEstimate, read_load_estimate
from heft.diagrams.progress import ProgressBar
from heft.diagrams.scenario import Scenario, layered, overrides_text
from heft.diagrams.stations.sim_station import MakeSimStation, set_holding
from heft.systems.identification.excitation import ExcitationSettings


def record_excitation(scenario: Scenario, trajectory, duration: float) -> Recording:
    """Drives the simulated slave through ``trajectory`` for ``duration`` s (free space)."""
    scenario = layered(scenario, overrides_text({"environment.kind": "none"}))
    period = scenario.controller_period
    builder = DiagramBuilder()
    station = builder.AddNamedSystem("station", MakeSimStation(scenario))
    samples = int(round(duration / period))
    command = builder.AddNamedSystem("excitation", TrajectorySource(trajectory.to_drake(duration, samples + 1)))
    builder.Connect(command.get_output_port(), station.GetInputPort("slave.position_commanded"))
    builder.Connect(builder.AddSystem(ConstantVectorSource(np.zeros(6))).get_output_port(),
                    station.GetInputPort("master.torque_commanded"))
    names = ("ft.wrench_measured", "ft.acceleration_measured", "slave.position_measured", "truth.ft_offsets",
             "truth.acceleration")
    loggers = {name: LogVectorOutput(station.GetOutputPort(name), builder, period) for name in names}
    diagram = builder.Build()
    simulator = Simulator(diagram)
    ApplySimulatorConfig(scenario.simulator, simulator)
    if math.isfinite(scenario.load.grasp_at):  # the gripper alone is identified, before any grasp
        set_holding(station, simulator.get_mutable_context(), False, at_start=True)
    simulator.Initialize()
    progress = ProgressBar(duration + period, "excitation")
    for t in np.arange(1, int(np.ceil((duration + period) / 0.1)) + 1) * 0.1:
        simulator.AdvanceTo(min(t, duration + period))
        progress.update(simulator.get_context().get_time())
    progress.close()
    context = simulator.get_context()
    logs = {name: logger.FindLog(context).data().T for name, logger in loggers.items()}
    phi = station.GetOutputPort("truth.phi").Eval(station.GetMyContextFromRoot(context))
    # A logger publishes before the discrete updates of its instant: the held sensor samples
    # it sees at t_k were taken at t_{k−1}, while plant-derived signals are those of t_k.
    held = slice(1, samples + 1)
    now = slice(0, samples)
    return Recording(t=np.arange(samples) * period, wrench=logs["ft.wrench_measured"][held],
                     accel_measured=logs["ft.acceleration_measured"][held],
                     q=logs["slave.position_measured"][now], phi_true=np.asarray(phi).copy(),
                     offsets_true=logs["truth.ft_offsets"][held], accel_true=logs["truth.acceleration"][now])


def simulated_recorder(scenario: Scenario):
    """The ``record`` of ``identify`` on the simulated station."""
    return lambda trajectory, duration: (record_excitation(scenario, trajectory, duration), {})


def identify_in_simulation(scenario: Scenario, out_dir, settings: ExcitationSettings | None = None) -> LoadEstimate:
    """Identifies the scenario's load in simulation (default method) and returns the estimate;
    a fit ``identify`` refuses is a ``FitRefused`` that says how to go on with it anyway."""
    try:
        identify(scenario, out_dir, simulated_recorder(scenario), settings=settings)
    except FitRefused as refused:
        raise FitRefused(f"{refused} (`heft identify --scenario FILE --out {out_dir}`), then give its estimate "
                         f"with --estimate {Path(out_dir) / 'estimate.yaml'}") from None
    return read_load_estimate(Path(out_dir) / "estimate.yaml")
