"""The lab's hardware as a System with the simulated station's ports: LCM in, LCM out.

``HardwareStationSystem`` wraps a ``HardwareStation`` (the channels, every message's checks, the second
publishers, the watchdog) in a ``TickSystem`` whose ports carry the names of ``station_ports``, as Drake's
``MakeHardwareStation(hardware=True)`` stands in for its simulation: one function connects the controller
to either (``diagrams.teleop.ConnectControllerToStation``). At the start of each tick it receives (one LCM
pump, every message checked, the newest of each channel, the watchdog judged) into its state, which its
outputs show; at the end it sends the controller's commands, gated by the station's health: while the
station is not healthy, zero torque and the slave held. The loop sets ``now`` (s, its monotonic clock)
before each tick.
"""

from __future__ import annotations

import numpy as np

from heft.hardware_interface.hardware_station import HardwareStation
from heft.systems.station_ports import CLUTCH, INPUT_AGE, STATION_INPUTS_DRIVEN, STATION_OUTPUTS_READ
from heft.systems.tick_system import TickSystem

NUM_READINGS = 6 * len(STATION_OUTPUTS_READ)
READINGS_SIZE = NUM_READINGS + 3
"""The station's state: the six readings (6 each, in ``STATION_OUTPUTS_READ``'s order), the clutch (1), the
oldest reading's age (1, s) and the health (1: 1.0 healthy)."""
CLUTCH_AT, AGE_AT, HEALTHY_AT = NUM_READINGS, NUM_READINGS + 1, NUM_READINGS + 2


class HardwareStationSystem(TickSystem):
    """``station`` (a ``HardwareStation``) as a System ticking every ``period`` s (module docstring).

    Inputs: ``master.torque_commanded`` (6, N·m), ``slave.position_commanded`` (6, rad). Outputs (state):
    the ``STATION_OUTPUTS_READ``, ``clutch`` (1), ``input_age`` (1, s) and ``healthy`` (1). Its state is the
    lab's, kept when the controller restarts (``kept_on_restart``)."""

    kept_on_restart = True

    def __init__(self, station: HardwareStation, period: float):
        super().__init__(period)
        self.station = station
        self.now = 0.0
        """The tick's time (s, the loop's monotonic clock), set by the loop before each tick."""
        for name in STATION_INPUTS_DRIVEN:
            self.DeclareTickInput(name, 6)
        self.DeclareTickState("readings", np.zeros(READINGS_SIZE))
        self.DeclareTickReceive(self.receive_into, "next:readings")
        for i, name in enumerate(STATION_OUTPUTS_READ):
            self.DeclareTickOutput(name, "x:readings", 6 * i, 6 * i + 6)
        for name, at in ((CLUTCH, CLUTCH_AT), (INPUT_AGE, AGE_AT), ("healthy", HEALTHY_AT)):
            self.DeclareTickOutput(name, "x:readings", at, at + 1)
        self.DeclareTickPublish(self.send, *(f"in:{name}" for name in STATION_INPUTS_DRIVEN))

    def receive_into(self, readings: np.ndarray) -> None:
        """One pump of the lab's channels at ``now`` into ``readings`` (``READINGS_SIZE``)."""
        station = self.station
        station.receive(self.now)
        for i, reading in enumerate((station.master_position, station.master_velocity, station.slave_position,
                                     station.slave_velocity, station.wrench, station.acceleration)):
            readings[6 * i:6 * i + 6] = reading
        readings[CLUTCH_AT] = 1.0 if station.clutch else 0.0
        readings[AGE_AT] = station.oldest_age
        readings[HEALTHY_AT] = 1.0 if station.healthy else 0.0

    def send(self, torque: np.ndarray, position: np.ndarray) -> None:
        """The controller's commands at ``now``, gated by the station (``HardwareStation.send``: while it is not
        healthy, zero torque and the slave held)."""
        self.station.send(self.now, torque, position)
