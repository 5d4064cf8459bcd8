import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource

from heft.systems.station.setpoint_filter import SetpointFilter


def test_step_response_is_the_critically_damped_closed_form():
    """From rest at q0 = 0.2 toward u = 1.2: q(t) = u − (u − q0)·e^{−ωt}(1 + ωt), q̇ = (u − q0)·ω²t·e^{−ωt}."""
    bandwidth, period = 20.0, 0.0005
    builder = DiagramBuilder()
    source = builder.AddSystem(ConstantVectorSource([1.2, 1.2]))
    filt = builder.AddSystem(SetpointFilter([0.2, 0.2], bandwidth, period))
    builder.Connect(source.get_output_port(), filt.get_input_port())
    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    simulator.Initialize()  # the filter starts at rest at its first input, here u itself
    state = filt.get_output_port().Eval(filt.GetMyContextFromRoot(context))
    np.testing.assert_allclose(state, [1.2, 1.2, 0, 0])
    # Restart from q0 = 0.2 explicitly, then compare with the closed form at sample instants.
    filt.GetMyMutableContextFromRoot(context).SetDiscreteState(np.array([0.2, 0.2, 0.0, 0.0]))
    w = 2 * np.pi * bandwidth
    for k in range(1, 200):
        simulator.AdvanceTo((k + 0.5) * period)
        q, qd = filt.get_output_port().Eval(filt.GetMyContextFromRoot(context))[[0, 2]]
        t = (k + 1) * period  # updates at 0, T, …, kT
        assert q == pytest.approx(1.2 - 1.0 * np.exp(-w * t) * (1 + w * t), abs=1e-12)
        assert qd == pytest.approx(1.0 * w * w * t * np.exp(-w * t), abs=1e-9)
        assert q <= 1.2  # no overshoot
    assert not filt.HasDirectFeedthrough(0, 0)


def test_bad_parameters():
    with pytest.raises(ValueError, match="bandwidth_hz and period"):
        SetpointFilter([0.0], 0.0, 0.001)
