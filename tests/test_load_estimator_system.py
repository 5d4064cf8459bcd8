"""LoadEstimatorSystem in a Drake diagram fed with exact signals of a known load.

One diagram for the whole module (Python LeafSystems with periodic events leak, drake
#23930): sources → [rls, riv, rtls] estimators, with the wrench passing an Adder whose second
input (exported, fixed per test) injects a NaN, and the enable input exported."""

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import Adder, Demultiplexer, TrajectorySource
from pydrake.trajectories import PiecewisePolynomial

from heft.systems.identification.recursive_estimation import RecursiveLeastSquares
from heft.systems.load_dynamics import InertialParameters, regressor
from heft.systems.identification.load_estimator_system import ESTIMATORS, QUALITY_NAMES, LoadEstimatorSystem

PERIOD = 1 / 2000
SAMPLES = 1200
QUALITY = {name: i for i, name in enumerate(QUALITY_NAMES)}


@pytest.fixture(scope="module")
def rig():
    rng = np.random.default_rng(30)
    load = InertialParameters.random(rng)
    offsets = rng.normal(size=6) * np.repeat([2.0, 0.1], 3)
    times = np.arange(SAMPLES) * PERIOD
    a, alpha, omega = (rng.normal(scale=scale, size=(SAMPLES, 3)) for scale in (3.0, 5.0, 2.0))
    g = rng.normal(size=(SAMPLES, 3))
    g *= 9.81 / np.linalg.norm(g, axis=1)[:, None]
    wrench = regressor(a, alpha, omega, g) @ load.to_phi() + offsets
    signals = np.hstack((wrench, a, alpha, omega, g))       # exact values at the sample times

    builder = DiagramBuilder()
    source = builder.AddSystem(TrajectorySource(PiecewisePolynomial.FirstOrderHold(times, signals.T)))
    split = builder.AddSystem(Demultiplexer([6, 6, 3, 3]))
    builder.Connect(source.get_output_port(), split.get_input_port())
    disturbed = builder.AddSystem(Adder(2, 6))
    builder.Connect(split.get_output_port(0), disturbed.get_input_port(0))
    builder.ExportInput(disturbed.get_input_port(1), "wrench_disturbance")
    estimators = {}
    for method in ESTIMATORS:
        estimator = builder.AddNamedSystem(method, LoadEstimatorSystem(method=method, period=PERIOD))
        builder.Connect(disturbed.get_output_port(), estimator.GetInputPort("wrench"))
        builder.Connect(split.get_output_port(1), estimator.GetInputPort("acceleration"))
        builder.Connect(split.get_output_port(2), estimator.GetInputPort("omega"))
        builder.Connect(split.get_output_port(3), estimator.GetInputPort("gravity"))
        for name in ("enable", "reset"):
            if estimators:
                builder.ConnectInput(name, estimator.GetInputPort(name))
            else:
                builder.ExportInput(estimator.GetInputPort(name), name)
        if method == "riv":  # exact data: the instrument is the same motion
            builder.Connect(split.get_output_port(1), estimator.GetInputPort("instrument_acceleration"))
            builder.Connect(split.get_output_port(2), estimator.GetInputPort("instrument_omega"))
        for name in ("phi", "offsets", "quality"):
            builder.ExportOutput(estimator.GetOutputPort(name), f"{method}.{name}")
        estimators[method] = estimator
    diagram = builder.Build()
    return diagram, source, estimators, load.to_phi(), offsets


def start(diagram, enable=1.0):
    """A fresh context and simulator; disturbance 0."""
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    diagram.GetInputPort("enable").FixValue(context, [enable])
    diagram.GetInputPort("wrench_disturbance").FixValue(context, np.zeros(6))
    simulator.Initialize()
    return simulator, context


def outputs(diagram, context, method):
    return [diagram.GetOutputPort(f"{method}.{name}").Eval(context) for name in ("phi", "offsets", "quality")]


def test_phi_and_offsets_converge_to_the_true_load(rig):
    diagram, _, _, phi, offsets = rig
    simulator, context = start(diagram)
    for method in ESTIMATORS:
        estimated_phi, estimated_offsets, quality = outputs(diagram, context, method)
        assert not estimated_phi.any() and quality[QUALITY["num_samples"]] == 0
    simulator.AdvanceTo(0.5)
    for method in ESTIMATORS:
        estimated_phi, estimated_offsets, quality = outputs(diagram, context, method)
        np.testing.assert_allclose(estimated_phi, phi, atol=1e-8 * np.abs(phi).max(), err_msg=method)
        np.testing.assert_allclose(estimated_offsets, offsets, atol=1e-8, err_msg=method)
        assert quality[QUALITY["num_samples"]] == 1000  # ticks at 0, 0.5, …, 499.5 ms; 500 ms is next
        assert quality[QUALITY["num_skipped"]] == 0
        assert 0 < quality[QUALITY["reciprocal_condition"]] <= 1
        assert quality[QUALITY["residual_rms_force"]] < 1e-6
        assert quality[QUALITY["residual_rms_torque"]] < 1e-6


def test_the_state_matches_the_numpy_estimator_fed_the_same_samples(rig):
    diagram, source, estimators, _, _ = rig
    simulator, context = start(diagram)
    simulator.AdvanceTo(0.05)
    state = estimators["rls"].GetMyContextFromRoot(context).get_discrete_state_vector().get_value()
    reference = RecursiveLeastSquares()
    probe = source.CreateDefaultContext()
    for t in np.arange(100) * PERIOD:
        probe.SetTime(t)
        wrench, a, alpha, omega, g = np.split(source.get_output_port().Eval(probe), [6, 9, 12, 15])
        reference.update(wrench, a, alpha, omega, g)
    np.testing.assert_allclose(state[:-2], reference.state_vector(), rtol=1e-12, atol=1e-12)
    assert state[-2] == 0 and state[-1] == 0


def test_reset_forgets_the_old_load_before_the_next_sample(rig):
    """A reset request at 50 ms: the RLS state is then what an estimator started from the
    estimate of that moment and fed only the samples from that tick on holds."""
    diagram, source, estimators, _, _ = rig
    simulator, context = start(diagram)
    simulator.AdvanceTo(0.05)
    theta = estimators["rls"].GetMyContextFromRoot(context).get_discrete_state_vector().get_value()[:16].copy()
    diagram.GetInputPort("reset").FixValue(context, [1.0])
    simulator.AdvanceTo(0.1)
    state = estimators["rls"].GetMyContextFromRoot(context).get_discrete_state_vector().get_value()
    reference = RecursiveLeastSquares()
    reference.start_from(theta)
    probe = source.CreateDefaultContext()
    for t in np.arange(100, 200) * PERIOD:
        probe.SetTime(t)
        wrench, a, alpha, omega, g = np.split(source.get_output_port().Eval(probe), [6, 9, 12, 15])
        reference.update(wrench, a, alpha, omega, g)
    np.testing.assert_allclose(state[:-2], reference.state_vector(), rtol=1e-12, atol=1e-12)
    assert state[-1] == 1.0


def test_enable_zero_freezes_the_estimate(rig):
    diagram = rig[0]
    simulator, context = start(diagram)
    simulator.AdvanceTo(0.02)
    frozen = {method: [x.copy() for x in outputs(diagram, context, method)] for method in ESTIMATORS}
    diagram.GetInputPort("enable").FixValue(context, [0.0])
    simulator.AdvanceTo(0.1)
    for method in ESTIMATORS:
        for before, after in zip(frozen[method], outputs(diagram, context, method)):
            np.testing.assert_array_equal(after, before)
    diagram.GetInputPort("enable").FixValue(context, [1.0])
    simulator.AdvanceTo(0.12)
    assert outputs(diagram, context, "rls")[2][QUALITY["num_samples"]] > frozen["rls"][2][QUALITY["num_samples"]]


def test_a_nan_sample_is_skipped_and_counted(rig):
    diagram, _, estimators, phi, _ = rig
    simulator, context = start(diagram)
    simulator.AdvanceTo(0.1)
    before = {method: [x.copy() for x in outputs(diagram, context, method)] for method in ESTIMATORS}
    disturbance = np.zeros(6)
    disturbance[4] = np.nan
    diagram.GetInputPort("wrench_disturbance").FixValue(context, disturbance)
    simulator.AdvanceTo(0.1 + PERIOD)                                 # exactly one tick
    for method in ESTIMATORS:
        estimated_phi, estimated_offsets, quality = outputs(diagram, context, method)
        np.testing.assert_array_equal(estimated_phi, before[method][0])
        assert quality[QUALITY["num_skipped"]] == 1
        assert quality[QUALITY["num_samples"]] == before[method][2][QUALITY["num_samples"]]
    diagram.GetInputPort("wrench_disturbance").FixValue(context, np.zeros(6))
    simulator.AdvanceTo(0.5)
    for method in ESTIMATORS:
        estimated_phi, _, quality = outputs(diagram, context, method)
        state = estimators[method].GetMyContextFromRoot(context).get_discrete_state_vector().get_value()
        assert np.isfinite(state).all()
        np.testing.assert_allclose(estimated_phi, phi, atol=1e-8 * np.abs(phi).max(), err_msg=method)
        assert quality[QUALITY["num_skipped"]] == 1


def test_no_direct_feedthrough(rig):
    diagram, _, estimators, _, _ = rig
    for estimator in estimators.values():
        for i in range(estimator.num_input_ports()):
            for o in range(estimator.num_output_ports()):
                assert not estimator.HasDirectFeedthrough(i, o)
    assert not any(diagram.HasDirectFeedthrough(i, o) for i in range(diagram.num_input_ports())
                   for o in range(diagram.num_output_ports()))


def test_ports_and_bad_parameters():
    system = LoadEstimatorSystem(method="rls", offsets=False)
    assert [system.get_input_port(i).get_name() for i in range(system.num_input_ports())] == [
        "wrench", "acceleration", "omega", "gravity", "enable", "reset"]
    assert [system.get_output_port(i).size() for i in range(3)] == [10, 6, len(QUALITY_NAMES)]
    with pytest.raises(ValueError, match="method must be one of"):
        LoadEstimatorSystem(method="kalman")
    with pytest.raises(ValueError, match="period"):
        LoadEstimatorSystem(period=0.0)
    with pytest.raises(ValueError, match="forgetting"):
        LoadEstimatorSystem(forgetting=2.0)
