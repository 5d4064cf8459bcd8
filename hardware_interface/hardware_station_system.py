"""The lab's hardware as a System with the simulated station's ports: LCM in, LCM out.

``HardwareStationSystem`` wraps a ``HardwareStation`` (the channels, every message's checks, the second
publishers, the watchdog) in a ``TickSystem`` whose ports carry the names of ``station_ports``, as Drake's
``MakeHardwareStation(hardware=True)`` stands in for its simulation: one function connects the controller
to either (``diagrams.teleop.ConnectControllerToStation``). At the start of each tick it receives (one LCM
pump, the messages the wait before it left unchecked checked, the newest of each channel, the watchdog judged)
into its state, which its outputs show; at the end it sends the controller's commands, gated by the station's
health: while the station is not healthy, zero torque and the slave held. The loop sets ``now`` (s, its monotonic clock)
before each tick.
"""

from __future__ import annotations

import numpy as np

from heft.hardware_interface.hardware_station import HardwareStation
from heft.systems.compiled import compiled
from heft.systems.controller.master_kinematics import NUM_JOINTS as MASTER_JOINTS
from heft.systems.station_ports import CLUTCH, INPUT_AGE, STATION_INPUTS_DRIVEN, STATION_OUTPUTS_READ
from heft.systems.tick_system import TickSystem

CLUTCH_AT, AGE_AT, HEALTHY_AT = -3, -2, -1
"""Where the station's state (``readings``) ends: after the six readings (in ``STATION_OUTPUTS_READ``'s order:
q_M, q̇_M of the master's 6 joints, q_S, q̇_S of the slave's n, the wrench and the accelerometer's reading, 6
each), the clutch (1), the oldest reading's age (1, s) and the health (1: 1.0 healthy)."""


@compiled("void(float64[:], float64[:], float64[:], float64[:], float64[:], float64[:], float64[:], boolean, "
          "float64[:], boolean)")
def readings_into(readings, master_position, master_velocity, slave_position, slave_velocity, wrench, acceleration,
                  clutch, ages, healthy) -> None:
    """The station's state ``readings`` (module constants) from its readings, ``clutch``, the largest of ``ages`` (s)
    and ``healthy``."""
    end = 0
    for reading in (master_position, master_velocity, slave_position, slave_velocity, wrench, acceleration):
        for i in range(reading.shape[0]):
            readings[end + i] = reading[i]
        end += reading.shape[0]
    oldest = ages[0]
    for i in range(1, ages.shape[0]):
        oldest = max(oldest, ages[i])
    readings[readings.shape[0] + CLUTCH_AT] = 1.0 if clutch else 0.0
    readings[readings.shape[0] + AGE_AT] = oldest
    readings[readings.shape[0] + HEALTHY_AT] = 1.0 if healthy else 0.0


class HardwareStationSystem(TickSystem):
    """``station`` (a ``HardwareStation``) as a System ticking every ``period`` s (module docstring).

    Inputs: ``master.torque_commanded`` (6, N·m), ``slave.position_commanded`` (n, rad: the station's
    ``num_joints``). Outputs (state):
    the ``STATION_OUTPUTS_READ``, ``clutch`` (1), ``input_age`` (1, s) and ``healthy`` (1). Its state is the
    lab's, kept when the controller restarts (``kept_on_restart``)."""

    kept_on_restart = True

    def __init__(self, station: HardwareStation, period: float):
        super().__init__(period)
        self.station = station
        self.now = 0.0
        """The tick's time (s, the loop's monotonic clock), set by the loop before each tick."""
        n = station.num_joints
        for name, size in zip(STATION_INPUTS_DRIVEN, (MASTER_JOINTS, n)):
            self.DeclareTickInput(name, size)
        # The station's arrays, updated in place by its receive, in the state's order.
        self._readings = (station.master_position, station.master_velocity, station.slave_position,
                          station.slave_velocity, station.wrench, station.acceleration)
        size = sum(reading.size for reading in self._readings) + 3
        self.DeclareTickState("readings", np.zeros(size))
        self.DeclareTickReceive(self.receive_into, "next:readings")
        end = 0
        for name, reading in zip(STATION_OUTPUTS_READ, self._readings):
            self.DeclareTickOutput(name, "x:readings", end, end + reading.size)
            end += reading.size
        for name, at in ((CLUTCH, CLUTCH_AT), (INPUT_AGE, AGE_AT), ("healthy", HEALTHY_AT)):
            self.DeclareTickOutput(name, "x:readings", size + at, size + at + 1)
        self.DeclareTickPublish(self.send, *(f"in:{name}" for name in STATION_INPUTS_DRIVEN))

    def receive_into(self, readings: np.ndarray) -> None:
        """One pump of the lab's channels at ``now`` into ``readings`` (the station's state)."""
        station = self.station
        station.receive(self.now)
        readings_into(readings, *self._readings, station.clutch, station.ages, station.healthy)

    def send(self, torque: np.ndarray, position: np.ndarray) -> None:
        """The controller's commands at ``now``, gated by the station (``HardwareStation.send``: while it is not
        healthy, zero torque and the slave held)."""
        self.station.send(self.now, torque, position)
