"""The teleoperation controller closed around the simulated station: the loop of Fig. 4
in simulation, with an optional communication delay, and the signals analysis logs."""

import math
from collections.abc import Sequence

import numpy as np
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import (LogVectorOutput, Multiplexer,
                                        TrajectorySource)
from pydrake.trajectories import PiecewisePolynomial

from heft.diagrams.plants import slave_arm
from heft.diagrams.scenario import Scenario
from heft.diagrams.stations.sim_station import MakeSimStation
from heft.diagrams.load_estimate import LoadEstimate
from heft.diagrams.teleop import CONTROLLER_LOG, ConnectControllerToStation, FeedbackBlock, MakeTeleopController
from heft.systems.tick_program_system import TickProgramSystem


# Station outputs logged by the simulation (name → log key).
STATION_LOG = {"ft.wrench_measured": "wrench_measured", "ft.acceleration_measured": "accel_measured",
               "truth.wrench_contact": "wrench_contact_true", "truth.wrench_noncontact": "wrench_noncontact_true",
               "truth.acceleration": "accel_true", "truth.omega": "omega_true", "truth.gravity_S": "gravity_S",
               "truth.ft_offsets": "offsets_true", "truth.slave_position": "slave_q",
               "master.position_measured": "master_q", "master.velocity_estimated": "master_v",
               "truth.ft_saturated": "ft_saturated", "truth.phi": "phi_true",
               "truth.wrench_noncontact_object": "wrench_noncontact_object_true"}


class SimulationLog:
    """The signals a simulation logs, in one VectorLogSink behind a Multiplexer (one publish a tick
    instead of one per signal): ``arrays(context)`` gives them by log key, (N, size) each, with the
    sample times under ``"t"`` (s)."""

    def __init__(self, logger, columns: dict[str, slice]):
        self.logger, self.columns = logger, columns

    def arrays(self, context) -> dict[str, np.ndarray]:
        log = self.logger.FindLog(context)
        data = log.data().T
        return {"t": log.sample_times().copy(), **{key: data[:, part].copy() for key, part in self.columns.items()}}


def MakeTeleopSimulation(scenario: Scenario, load: LoadEstimate, meshcat=None,
                         feedback_blocks: Sequence[FeedbackBlock] = ()):
    """The controller closed around the simulated station, with its log.

    Returns (diagram, log): ``log`` a ``SimulationLog`` of ``STATION_LOG``'s and ``CONTROLLER_LOG``'s
    signals, sampled every controller period; a ``meshcat`` shows the slave live (``MakeSimStation``);
    ``feedback_blocks`` a lab's own blocks on the feedback path (``MakeTeleopController``).
    """
    spec = scenario.controller
    builder = DiagramBuilder()
    station = builder.AddNamedSystem("station", MakeSimStation(scenario, meshcat))
    logged = {**{name.removeprefix("log."): name for name in CONTROLLER_LOG},
              "master_torque": "master.torque_commanded"}  # log key → the controller's output
    controller = builder.AddNamedSystem("controller", TickProgramSystem(MakeTeleopController(
        spec, load, slave_arm(scenario), scenario.controller_period, scenario.slave_initial_q,
        accelerometer=scenario.accelerometer.convention(), feedback_blocks=feedback_blocks, master=scenario.master),
        gathered={"log": list(logged.values())}))
    period = scenario.controller_period
    ConnectControllerToStation(builder, controller, station, round(spec.delay / period), period,
                               {"master.position_measured": scenario.master_initial_q,
                                "slave.position_measured": scenario.slave_initial_q,
                                "slave.position_commanded": scenario.slave_initial_q})
    grasp_at = scenario.load.grasp_at
    if spec.estimator.mode == "online" and math.isfinite(grasp_at):  # the grasp is a new load
        step = PiecewisePolynomial.ZeroOrderHold([0.0, grasp_at, grasp_at + 1.0], [[0.0, 1.0, 1.0]])
        builder.Connect(builder.AddNamedSystem("grasp_event", TrajectorySource(step)).get_output_port(),
                        controller.GetInputPort("estimator_reset"))
    ports = [station.GetOutputPort(name) for name in STATION_LOG] + [controller.GetOutputPort("log")]
    keys = list(STATION_LOG.values()) + list(logged)  # the controller's in one port
    sizes = [station.GetOutputPort(name).size() for name in STATION_LOG] + [
        controller.GetOutputPort(name).size() for name in logged.values()]
    signals = builder.AddSystem(Multiplexer([port.size() for port in ports]))
    for i, port in enumerate(ports):
        builder.Connect(port, signals.get_input_port(i))
    columns, start = {}, 0
    for key, size in zip(keys, sizes, strict=True):
        columns[key], start = slice(start, start + size), start + size
    log = SimulationLog(LogVectorOutput(signals.get_output_port(), builder, period), columns)
    diagram = builder.Build()
    diagram.set_name("teleop_simulation")
    return diagram, log
