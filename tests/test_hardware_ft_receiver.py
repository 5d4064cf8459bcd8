"""FT sample receiver over real LCM (memq://): sign flip, hold-and-flag of bad
samples, ordering; and the committed LCM Python types match lcm-gen's output."""

import math

import numpy as np
import pytest
from heft.hardware_interface.ft_receiver import (
    STATUS_FIELDS,
    AddFtSampleReceiver,
    FtReceiverParams,
)
from heft.hardware_interface.lcmtypes import heft_ft_sample
from heft.hardware_interface.lcmtypes import regenerate as lcmtypes_regenerate
from pydrake.lcm import DrakeLcm
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.lcm import LcmInterfaceSystem

CHANNEL = "TEST_FT_SAMPLE"
PARAMS = FtReceiverParams(period=0.001, stale_after=0.005)
STATUS = {name: i for i, name in enumerate(STATUS_FIELDS)}
RAW = np.array([1.0, -2.0, 3.0, 0.1, -0.2, 0.3])
ACCEL = np.array([0.5, 0.0, -9.81, 0.01, 0.02, -0.03])


class Rig:
    """LCM → subscriber → receiver, built once per module (drake #23930)."""

    def __init__(self):
        self.lcm = DrakeLcm("memq://")
        builder = DiagramBuilder()
        builder.AddSystem(LcmInterfaceSystem(self.lcm))
        self.receiver = AddFtSampleReceiver(builder, self.lcm, CHANNEL, PARAMS)
        self.diagram = builder.Build()
        self.simulator = Simulator(self.diagram)

    def reset(self):
        """Fresh state. A reset subscriber re-delivers the last message it
        received, so that is first made the "no sample" one (utime 0)."""
        self.lcm.Publish(CHANNEL, heft_ft_sample().encode())
        self.lcm.HandleSubscriptions(0)
        context = self.simulator.get_mutable_context()
        context.SetTime(0.0)
        self.diagram.SetDefaultContext(context)
        self.simulator.Initialize()

    def send(self, counter, utime, wrench=RAW, acceleration=ACCEL, saturated=0, error=False):
        """Publishes one sample and lets the receiver tick twice."""
        msg = heft_ft_sample()
        msg.sample_counter, msg.utime = counter, utime
        msg.wrench, msg.acceleration = list(wrench), list(acceleration)
        msg.saturated, msg.error = saturated, error
        self.lcm.Publish(CHANNEL, msg.encode())
        self.advance(2 * PARAMS.period)

    def advance(self, dt):
        self.simulator.AdvanceTo(self.simulator.get_context().get_time() + dt)

    def output(self, name):
        context = self.receiver.GetMyContextFromRoot(self.simulator.get_context())
        return self.receiver.GetOutputPort(name).Eval(context)

    def status(self, field):
        return self.output("status")[STATUS[field]]


@pytest.fixture(scope="module")
def module_rig():
    return Rig()


@pytest.fixture
def rig(module_rig):
    module_rig.reset()
    return module_rig


def test_stale_before_first_sample(rig):
    rig.advance(0.01)
    assert rig.status("stale") == 1.0
    assert math.isinf(rig.status("age"))
    np.testing.assert_array_equal(rig.output("wrench_measured"), np.zeros(6))


def test_sign_flipped_to_sensor_on_load(rig):
    rig.send(1, 1000)
    np.testing.assert_array_equal(rig.output("wrench_measured"), -RAW)
    np.testing.assert_array_equal(rig.output("acceleration_measured"), ACCEL)
    assert rig.output("status").tolist()[:4] == [0.0, 0.0, 0.0, 0.0]
    assert 0.0 <= rig.status("age") <= 2 * PARAMS.period
    rig.advance(2 * PARAMS.stale_after)
    assert rig.status("stale") == 1.0


@pytest.mark.parametrize(("flag", "bad"), [
    ("non_finite", {"wrench": [np.nan, 0, 0, 0, 0, 0]}),
    ("non_finite", {"acceleration": [0, 0, 0, 0, np.inf, 0]}),
    ("saturated", {"saturated": 1 << 2}),
    ("saturated", {"saturated": 1 << 9}),
    ("error", {"error": True}),
])
def test_bad_sample_held_and_flagged(rig, flag, bad):
    rig.send(1, 1000)
    rig.send(2, 1125, **{"wrench": 5 * RAW, "acceleration": 5 * ACCEL, **bad})
    np.testing.assert_array_equal(rig.output("wrench_measured"), -RAW)
    np.testing.assert_array_equal(rig.output("acceleration_measured"), ACCEL)
    assert rig.status(flag) == 1.0
    rig.send(3, 1250, wrench=2 * RAW)
    np.testing.assert_array_equal(rig.output("wrench_measured"), -2 * RAW)
    assert rig.status(flag) == 0.0


def test_duplicate_and_out_of_order_dropped(rig):
    rig.send(5, 5000)
    rig.send(5, 5000, wrench=7 * RAW)  # duplicate of the held sample
    rig.send(4, 6000, wrench=7 * RAW)  # counter went back
    rig.send(6, 4000, wrench=7 * RAW)  # utime went back
    np.testing.assert_array_equal(rig.output("wrench_measured"), -RAW)
    assert rig.status("dropped") == 2.0
    rig.send(7, 7000, wrench=3 * RAW)
    np.testing.assert_array_equal(rig.output("wrench_measured"), -3 * RAW)
    assert rig.status("dropped") == 2.0


def test_restarted_sensor_driver_accepted(rig):
    """Counter and clock from zero again, far behind the last sample: a restart, not a late packet."""
    rig.send(900, 2_000_000)
    rig.send(1, 1000, wrench=4 * RAW)
    np.testing.assert_array_equal(rig.output("wrench_measured"), -4 * RAW)
    rig.send(2, 2000, wrench=5 * RAW)
    np.testing.assert_array_equal(rig.output("wrench_measured"), -5 * RAW)
    assert rig.status("dropped") == 0.0


def test_committed_lcm_types_are_regenerated_byte_for_byte(tmp_path):
    names = lcmtypes_regenerate.regenerate(tmp_path)
    committed = {p.name for p in lcmtypes_regenerate.HERE.glob("*.py")} - {"regenerate.py"}
    assert set(names) == committed
    for name in names:
        assert (tmp_path / name).read_bytes() == (lcmtypes_regenerate.HERE / name).read_bytes(), name


def test_lcm_type_round_trip():
    msg = heft_ft_sample()
    msg.utime, msg.sample_counter, msg.saturated, msg.wrench = 12, 3, 1 << 11, list(RAW)
    decoded = heft_ft_sample.decode(msg.encode())
    assert (decoded.utime, decoded.sample_counter, decoded.saturated) == (12, 3, 1 << 11)
    assert list(decoded.wrench) == list(RAW)
