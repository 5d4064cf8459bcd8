"""Stand-in and hardware station in one diagram on one memq:// DrakeLcm: the FT sign
flips cancel over the round trip, the slave follows a command sent through the
hardware station, a NaN-only sensor is flagged and held; faults are reproducible."""

import dataclasses

import numpy as np
import pytest
from heft.diagrams.scenario import Scenario
from heft.diagrams.stand_in import FaultInjection, MakeStandIn, _uniform, run_stand_in
from heft.hardware_interface.channels import LcmChannel, LcmChannels
from heft.hardware_interface.ft_receiver import STATUS_FIELDS as FT_STATUS_FIELDS
from heft.hardware_interface.hardware_station import (
    STATUS_FIELDS,
    HardwareStationParams,
    MakeHardwareStation,
)
from heft.hardware_interface.lcmtypes import heft_ft_sample
from pydrake.lcm import DrakeLcm
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

# FT at 2 kHz keeps the test fast; the lab's 8 kHz changes nothing here.
CHANNELS = LcmChannels(ft_sample=LcmChannel("HEFT_FT_SAMPLE", 2000.0))
PARAMS = HardwareStationParams(period=0.001)
STATUS = {name: i for i, name in enumerate(STATUS_FIELDS)}
DELTA = np.array([0.05, -0.05, 0.05, 0.1, -0.1, 0.1])


def quiet_scenario() -> Scenario:
    """No contact and ideal wrist sensors, so what they measure is the truth."""
    scenario = Scenario()
    scenario.environment.kind = "none"
    scenario.operator.amplitude = [0.0, 0.0, 0.0]
    for sensor in (scenario.ft_sensor, scenario.accelerometer):
        for name in ("noise", "offsets", "drift", "quantization"):
            setattr(sensor, name, False)
    return scenario


class Loop:
    """Stand-in + hardware station sharing one memq:// DrakeLcm, simulated at full speed."""

    def __init__(self, faults: FaultInjection):
        self.scenario = quiet_scenario()
        lcm = DrakeLcm("memq://")
        builder = DiagramBuilder()
        self.stand_in = builder.AddSystem(MakeStandIn(self.scenario, CHANNELS, lcm, faults))
        self.hardware = builder.AddSystem(MakeHardwareStation(CHANNELS, lcm, PARAMS))
        self.simulator = Simulator(builder.Build())
        context = self.simulator.get_mutable_context()
        self.hw_context = self.hardware.GetMyMutableContextFromRoot(context)
        self.stand_in_context = self.stand_in.GetMyContextFromRoot(context)
        self.hardware.GetInputPort("master.torque_commanded").FixValue(self.hw_context, np.zeros(6))
        self.q_command = np.asarray(self.scenario.slave_initial_q) + DELTA
        self.hardware.GetInputPort("slave.position_commanded").FixValue(self.hw_context, self.q_command)
        self.simulator.Initialize()

    def hw(self, name):
        return self.hardware.GetOutputPort(name).Eval(self.hw_context)

    def sim(self, name):
        return self.stand_in.GetOutputPort(f"sim.{name}").Eval(self.stand_in_context)


@pytest.fixture(scope="module")
def clean():
    loop = Loop(FaultInjection())
    loop.simulator.AdvanceTo(1.5)
    return loop


@pytest.fixture(scope="module")
def nan_sensor():
    loop = Loop(FaultInjection(nan_rate=1.0))
    loop.simulator.AdvanceTo(0.3)
    return loop


def test_ft_signs_cancel_over_the_round_trip(clean):
    truth = clean.sim("truth.wrench_sensor")
    assert np.linalg.norm(truth[:3]) > 20.0  # the 3.13 kg tool's weight
    np.testing.assert_allclose(clean.hw("ft.wrench_measured"), truth, atol=1e-3)
    np.testing.assert_allclose(clean.hw("ft.acceleration_measured"), clean.sim("ft.acceleration_measured"),
                               atol=1e-3)


def test_slave_follows_command_through_the_hardware_station(clean):
    status = clean.hw("hardware.status")
    assert status[STATUS["healthy"]] == 1.0 and status[STATUS["fault"]] == 0.0
    np.testing.assert_allclose(clean.sim("truth.slave_position"), clean.q_command, atol=2e-3)
    np.testing.assert_allclose(clean.hw("slave.position_measured"), clean.sim("slave.position_measured"), atol=2e-3)
    np.testing.assert_allclose(clean.hw("master.position_measured"), clean.scenario.master_initial_q, atol=1e-3)


def test_non_finite_sensor_is_flagged_and_held(nan_sensor):
    ft = nan_sensor.hardware.GetSubsystemByName("ft_receiver")
    ft_status = ft.GetOutputPort("status").Eval(ft.GetMyContextFromRoot(nan_sensor.simulator.get_context()))
    assert ft_status[FT_STATUS_FIELDS.index("non_finite")] == 1.0
    np.testing.assert_array_equal(nan_sensor.hw("ft.wrench_measured"), np.zeros(6))
    status = nan_sensor.hw("hardware.status")
    assert status[STATUS["healthy"]] == 0.0 and int(status[STATUS["fault"]]) == 1 << 2
    np.testing.assert_allclose(nan_sensor.sim("truth.slave_position"), nan_sensor.scenario.slave_initial_q,
                               atol=1e-3)


def test_faults_on_published_ft_samples():
    """Drops, delay and saturation as the bus sees them; the same seed, the same run."""
    faults = FaultInjection(drop_rate=0.05, burst_loss_s=0.002, added_delay_s=0.005, saturate_at_s=0.05,
                            die_at_s=0.1, seed=7)
    runs = []
    for _ in range(2):
        lcm, received = DrakeLcm("memq://"), []
        lcm.Subscribe(CHANNELS.ft_sample.name, lambda data, received=received: received.append(heft_ft_sample.decode(data)))
        simulator = Simulator(MakeStandIn(quiet_scenario(), CHANNELS, lcm, faults))
        simulator.AdvanceTo(0.15)
        lcm.HandleSubscriptions(0)
        runs.append([(m.sample_counter, m.utime, m.saturated) for m in received])
    assert runs[0] == runs[1]
    counters = np.array([r[0] for r in runs[0]])
    utimes = np.array([r[1] for r in runs[0]])
    first, end = round(0.005 * CHANNELS.ft_sample.rate) + 1, round(0.1 * CHANNELS.ft_sample.rate)
    assert counters[0] >= first and counters[-1] < end  # nothing before its sample time is > 0, nor after die_at_s
    assert 0.6 * (end - first) < len(counters) < 0.95 * (end - first)
    gaps = np.diff(counters) - 1
    assert gaps[gaps > 0].min() >= round(0.002 * CHANNELS.ft_sample.rate)  # whole bursts are lost
    np.testing.assert_array_equal(utimes, np.round((counters / CHANNELS.ft_sample.rate - 0.005) * 1e6))
    assert all((s & 0x3F) == 0x3F for _, u, s in runs[0] if u >= 50_000)


def test_uniform_is_uniform_and_fixed():
    u = np.array([_uniform(3, 1, k) for k in range(20000)])
    assert 0.0 <= u.min() and u.max() < 1.0 and abs(u.mean() - 0.5) < 0.01
    assert _uniform(3, 1, 5) == _uniform(3, 1, 5) != _uniform(4, 1, 5)


def test_run_stand_in_returns_at_death():
    faults = dataclasses.replace(FaultInjection(), die_at_s=0.02)
    assert run_stand_in(quiet_scenario(), CHANNELS, "memq://", 1.0, realtime_rate=0.0, faults=faults) == 0.02
