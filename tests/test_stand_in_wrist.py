"""The stand-in as imperfect as the simulated station: its arm's velocities from the encoders (against
Drake's Diagram of the station's estimate), the gripper's states and timing on its channel, the load on
its compliant mount ringing at the grasp as Drake's plant of the same load does, and the truth of every
FT sample (the sensor's wrench and the object's share against Drake's dynamics; the published samples)."""

import json
import math

import lcm
import numpy as np
import pytest
from drake import lcmt_iiwa_command, lcmt_iiwa_status
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import FixedOffsetFrame, MultibodyForces, SpatialInertia
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import TrajectorySource
from pydrake.trajectories import PiecewisePolynomial

from heft.diagrams.cli import main
from heft.diagrams.plants import _add_compliant_mount, _add_load, mount_for
from heft.diagrams.scenario import Scenario, overrides_text, resolve_scenario
from heft.diagrams.stations.sim_station import settle_mount
from heft.diagrams.stations.stand_in import StandIn
from heft.diagrams.stations.stand_in_wrist import GRIPPER_CLOSING_S, GraspTimes, _Rows
from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.lcm_mailbox import LcmMailbox, pump
from heft.hardware_interface.ft_messages import decode_samples
from heft.hardware_interface.lcmtypes import heft_gripper_state
from heft.systems.drake_conventions import wrench_from_spatial_force
from heft.systems.station.encoders import AddEncoderVelocityEstimate
from heft.systems.load_dynamics import GRAVITY_W
from test_stand_in import DELTA, SlavePlant, quiet_scenario

CHANNELS = LcmChannels()
GRASP_AT, RELEASE_AT = 0.1, 0.6
HOLD_AT = GRASP_AT + GRIPPER_CLOSING_S


class Lab:
    """A ``StandIn`` on memq:// recording its truth, with a listener on every channel it publishes."""

    def __init__(self, scenario: Scenario, **kwargs):
        self.bus = lcm.LCM("memq://")
        self.stand_in = StandIn(scenario, self.bus, CHANNELS, record_truth=True, **kwargs)
        names = (CHANNELS.slave_status.name, CHANNELS.ft_sample.name, CHANNELS.gripper_state.name)
        self._boxes = {name: LcmMailbox(self.bus, name, keep=10**6) for name in names}
        self.messages = {name: [] for name in names}

    def run(self, until: float, dt: float = 0.001) -> None:
        for now in np.arange(dt, until + 1e-12, dt):
            self.stand_in.step(now)
            pump(self.bus)
        decoders = (lambda payload: [lcmt_iiwa_status.decode(payload)], decode_samples,
                    lambda payload: [heft_gripper_state.decode(payload)])
        for (name, box), decode in zip(self._boxes.items(), decoders):  # one message per FT sample
            self.messages[name] += [msg for payload in box.take() for msg in decode(payload)]


def quiet_grasp() -> Scenario:
    """The grasp scenario with ideal wrist sensors and the compliant mount on."""
    return resolve_scenario("grasp", overrides_text({
        "ft_sensor.noise": False, "ft_sensor.lowpass_cutoff": 0.0,
        "accelerometer.noise": False, "accelerometer.lowpass_cutoff": 0.0}))


@pytest.fixture(scope="module")
def grasped():
    """The arm still; the gripper closes at 0.1 s and lets go at 0.6 s; run to 0.8 s."""
    lab = Lab(quiet_grasp(), grasp=GraspTimes(GRASP_AT, RELEASE_AT))
    lab.run(0.8)
    return lab


# --- the arm's velocities ----------------------------------------------------------------------

def test_the_arms_velocities_are_the_stations_estimate_from_the_published_encoders():
    """Commanded DELTA away at 0.05 s: the published joint velocities are what the simulated station's
    estimate (Drake's DiscreteDerivative and LinearSystem, ``AddEncoderVelocityEstimate``) makes of the
    published, encoder-quantised positions, at every status; they lag the positions' own differences."""
    scenario = resolve_scenario("fig6")
    lab = Lab(scenario)
    lab.run(0.05)
    q0 = np.asarray(scenario.slave_initial_q)
    msg = lcmt_iiwa_command()
    msg.num_joints, msg.joint_position = 6, list(q0 + DELTA)
    lab.bus.publish(CHANNELS.slave_command.name, msg.encode())
    lab.run(0.15)
    statuses = lab.messages[CHANNELS.slave_status.name]
    period = 1.0 / CHANNELS.slave_status.rate
    positions = np.array([m.joint_position_measured for m in statuses[:1] + statuses])  # k·period; at rest at 0
    builder = DiagramBuilder()
    times = np.arange(len(positions)) * period
    source = builder.AddSystem(TrajectorySource(PiecewisePolynomial.ZeroOrderHold(
        np.append(times, times[-1] + period), np.column_stack((positions.T, positions[-1])))))
    builder.ExportOutput(AddEncoderVelocityEstimate(builder, source.get_output_port(), period,
                                                    scenario.slave_velocity_filter), "velocity")
    diagram = builder.Build()
    simulator = Simulator(diagram)
    expected = []
    for k in range(1, len(positions)):
        simulator.AdvanceTo((k + 0.5) * period)
        expected.append(diagram.GetOutputPort("velocity").Eval(simulator.get_context()).copy())
    expected, published = np.array(expected), np.array([m.joint_velocity_estimated for m in statuses])
    differences = np.diff(positions, axis=0) / period
    assert np.abs(published).max() > 1.0  # it moved
    np.testing.assert_allclose(published, expected, rtol=0, atol=1e-9 * np.abs(expected).max())
    assert np.abs(published - differences).max() > 0.03 * np.abs(differences).max()  # low-passed: it lags


# --- the gripper -------------------------------------------------------------------------------

def test_the_gripper_reports_open_closing_holding_open_on_its_clock(grasped):
    messages = grasped.messages[CHANNELS.gripper_state.name]
    utimes = np.array([m.utime for m in messages])
    np.testing.assert_array_equal(utimes, np.arange(1, 81) * 10_000)  # 100 Hz, stamped on the lab's clock
    grasp, hold, release = (round(t * 1e6) for t in (GRASP_AT, HOLD_AT, RELEASE_AT))
    for m in messages:
        expected = (heft_gripper_state.OPEN if m.utime < grasp or m.utime >= release else
                    heft_gripper_state.CLOSING if m.utime < hold else heft_gripper_state.HOLDING)
        assert m.state == expected and not m.error, m.utime
    widths = np.array([m.width for m in messages])
    assert widths[utimes < 100_000].min() == widths.max() > 0.06  # open
    closing = widths[(utimes >= 100_000) & (utimes < 300_000)]
    assert (np.diff(closing) < 0).all()  # the fingers close
    assert widths[(utimes >= 300_000) & (utimes < 600_000)] == pytest.approx(0.04)  # on the 40 mm cube
    assert grasped.stand_in.published[CHANNELS.gripper_state.name] == 80


def test_a_tool_has_no_gripper_and_bad_grasp_times_are_refused():
    bus = lcm.LCM("memq://")
    assert CHANNELS.gripper_state.name not in StandIn(quiet_scenario(), bus, CHANNELS).published
    with pytest.raises(ValueError, match="gripper_object"):
        StandIn(quiet_scenario(), bus, CHANNELS, grasp=GraspTimes(1.0))
    for grasp, field in ((GraspTimes(-1.0), "--grasp-at"), (GraspTimes(math.nan), "--grasp-at"),
                         (GraspTimes(2.0, 1.0), "--release-at")):
        with pytest.raises(ValueError, match=field):
            StandIn(quiet_grasp(), bus, CHANNELS, grasp=grasp)


# --- the truth ---------------------------------------------------------------------------------

def drake_grasp(scenario: Scenario, times):
    """Drake's own continuous plant of the scenario's gripper and object on its mount below S held still
    where the arm's start pose puts it (``SlavePlant``), the mount settled under the gripper alone, the
    object's inertia there from t = 0: at ``times`` (s), the sensor's wrench on the load (the plate's
    weld reaction) and the object's (its inverse dynamics as a free body of its own plant at the motion
    the first plant gives it), [f; τ] at S in S."""
    slave = SlavePlant(scenario)
    slave.set_state(scenario.slave_initial_q)
    X_WS = slave.X_WS()
    builder = DiagramBuilder()
    plant = builder.AddSystem(MultibodyPlant(time_step=0.0))
    S = plant.AddFrame(FixedOffsetFrame("S", plant.world_frame(), X_WS))
    bodies, _ = _add_load(plant, scenario.load)
    weld, joint = _add_compliant_mount(plant, S, bodies[0], mount_for(scenario))
    plant.mutable_gravity_field().set_gravity_vector(GRAVITY_W)
    plant.Finalize()
    diagram = builder.Build()
    simulator = Simulator(diagram)
    simulator.get_mutable_integrator().set_target_accuracy(1e-10)
    context = plant.GetMyMutableContextFromRoot(simulator.get_mutable_context())
    obj = plant.GetBodyByName("object")
    obj.SetSpatialInertiaInBodyFrame(context, SpatialInertia.Zero())
    settle_mount(plant, context, joint)
    obj.SetSpatialInertiaInBodyFrame(context, obj.default_spatial_inertia())

    alone = MultibodyPlant(time_step=0.0)  # the object as a free body
    free = alone.AddRigidBody("object", obj.default_spatial_inertia())
    alone.mutable_gravity_field().set_gravity_vector(GRAVITY_W)
    alone.Finalize()
    alone_context, forces = alone.CreateDefaultContext(), MultibodyForces(alone)
    R_SW = X_WS.rotation().inverse()
    sensor, object_wrench = [], []
    for t in times:
        simulator.AdvanceTo(t)
        sensor.append(wrench_from_spatial_force(plant.get_reaction_forces_output_port().Eval(context)[weld.index()]))
        X_WB = plant.EvalBodyPoseInWorld(context, obj)
        alone.SetFreeBodyPose(alone_context, free, X_WB)
        alone.SetFreeBodySpatialVelocity(alone_context, free, plant.EvalBodySpatialVelocityInWorld(context, obj))
        A = plant.EvalBodySpatialAccelerationInWorld(context, obj)
        alone.CalcForceElementsContribution(alone_context, forces)  # gravity
        tau = alone.CalcInverseDynamics(alone_context, np.concatenate((A.rotational(), A.translational())), forces)
        torque_W, f_W = tau[:3], tau[3:]  # about the object's origin Bo, in W
        f_S = R_SW @ f_W
        p_SBo = X_WS.inverse() @ X_WB.translation()
        object_wrench.append(np.concatenate((f_S, R_SW @ torque_W + np.cross(p_SBo, f_S))))
    return np.array(sensor), np.array(object_wrench)


def test_the_truth_rings_at_the_grasp_as_drakes_plant_of_the_same_load(grasped):
    """From the moment the gripper holds (0.3 s) to the release, the truth's sensor wrench and the
    object's share follow Drake's plant of the same gripper, object and mount to 0.5 % of the ringing; φ
    is the gripper's, then gripper and object, then the gripper's again."""
    truth = grasped.stand_in.truth.arrays()
    t = truth["utime"] * 1e-6
    steps = truth["sample_counter"] % 4 == 0  # the arm's steps (2 kHz): the samples between them hold
    holding = steps & (t >= HOLD_AT - 1e-9) & (t < RELEASE_AT - 1e-9)
    phi, phi_gripper = truth["phi"], truth["phi_gripper"]
    np.testing.assert_array_equal(phi[t < HOLD_AT - 1e-9], np.broadcast_to(phi_gripper, phi[t < HOLD_AT - 1e-9].shape))
    np.testing.assert_array_equal(phi[t >= RELEASE_AT], np.broadcast_to(phi_gripper, phi[t >= RELEASE_AT].shape))
    assert phi_gripper[0] == pytest.approx(1.73710386) and phi[holding][0, 0] == pytest.approx(1.73710386 + 0.5024)
    np.testing.assert_array_equal(truth["wrench_noncontact_object"][~((t >= HOLD_AT - 1e-9) & (t < RELEASE_AT))], 0)
    np.testing.assert_array_equal(truth["wrench_contact"], 0.0)

    sensor, object_wrench = drake_grasp(quiet_grasp(), (truth["utime"][holding] - round(HOLD_AT * 1e6)) * 1e-6)
    for ours, drake in ((truth["wrench_noncontact"][holding], sensor),
                        (truth["wrench_noncontact_object"][holding], object_wrench)):
        ringing = drake - drake[-1]
        assert np.abs(ringing[:, :3]).max() > 1.0  # N: the object's weight set the mount ringing
        for axes in (slice(0, 3), slice(3, 6)):
            assert np.abs(ours[:, axes] - drake[:, axes]).max() < 0.005 * np.abs(ringing[:, axes]).max()


def test_the_published_samples_are_the_truth_through_the_sensor(grasped):
    """Without noise or filter, each published FT sample is its truth with offsets, in the sensor's
    sign (heft's ports: [f; τ] on the load; the JR3 reports the load on the sensor)."""
    truth = grasped.stand_in.truth.arrays(grasped.stand_in.ft_samples_due)
    samples = grasped.messages[CHANNELS.ft_sample.name]
    assert len(truth["sample_counter"]) == 6400  # 0.8 s at 8 kHz; sample 6400 opens a message not yet sent
    assert len(samples) == 6399 and [m.sample_counter for m in samples] == list(truth["sample_counter"][:6399])
    np.testing.assert_array_equal([m.utime for m in samples], truth["utime"][:6399])
    published = -np.array([m.wrench for m in samples])
    expected = (truth["wrench_noncontact"] + truth["wrench_contact"] + truth["ft_offsets"])[:6399]
    np.testing.assert_allclose(published, expected, rtol=0, atol=1e-3)  # the JR3's counts: 200 N / 16384


def test_the_cli_writes_the_truth_beside_the_summary(tmp_path):
    assert main(["stand-in", "--scenario", "grasp", "--lcm-url", "memq://", "--duration", "0.05",
                 "--grasp-at", "0.01", "--rt-priority", "0", "--out", str(tmp_path)]) == 0
    summary = json.loads((tmp_path / "stand_in.json").read_text())
    assert summary["truth"] == "stand_in.truth.npz" and CHANNELS.gripper_state.name in summary["published"]
    truth = np.load(tmp_path / "stand_in.truth.npz")
    counters = truth["sample_counter"]
    assert len(counters) >= 0.05 * 8000 and (np.diff(counters) == 1).all() and counters[0] == 1
    np.testing.assert_array_equal(truth["utime"], np.round(counters / 8000 * 1e6))
    assert truth["phi"].shape == (len(counters), 10) and truth["phi_gripper"].shape == (10,)
    for name in ("wrench_noncontact", "wrench_noncontact_object", "wrench_contact", "ft_offsets"):
        assert truth[name].shape == (len(counters), 6)
    # The grasp at 0.01 s holds from 0.21 s, after this run: the gripper alone.
    np.testing.assert_array_equal(truth["phi"], np.broadcast_to(truth["phi_gripper"], truth["phi"].shape))


def test_the_mount_rings_while_the_arm_moves_and_rests_on_the_weight():
    """The same command with the tool welded at S and on its mount: while the arm accelerates the two
    differ by the mount's ringing; at rest again both carry the tool's weight alike."""
    published = []
    for rigid in (True, False):
        scenario = quiet_scenario({"load.mount.rigid": rigid})
        lab = Lab(scenario)
        lab.run(0.05)
        msg = lcmt_iiwa_command()
        msg.num_joints, msg.joint_position = 6, list(np.asarray(scenario.slave_initial_q) + DELTA)
        lab.bus.publish(CHANNELS.slave_command.name, msg.encode())
        lab.run(1.0)
        published.append(np.array([m.wrench for m in lab.messages[CHANNELS.ft_sample.name]]))
    welded, mounted = published
    assert np.abs(mounted - welded)[:, :3].max() > 1.0  # N
    np.testing.assert_allclose(mounted[-1], welded[-1], atol=2e-2)  # N, N·m: settled (4 % damped, 0.95 s)


def test_the_truths_rows_come_back_in_order_across_its_blocks(monkeypatch):
    """The truth keeps its rows in blocks that are never copied while the lab runs; read back, they are
    the rows appended, in order, whatever the appends' sizes against the blocks'."""
    monkeypatch.setattr(_Rows, "BLOCK", 5)
    rows, appended = _Rows(3), []
    for k in (1, 4, 0, 7, 5, 2, 11):
        chunk = np.random.default_rng(k).normal(size=(k, 3))
        rows.append(chunk)
        appended.append(chunk)
        np.testing.assert_array_equal(rows.array(), np.concatenate(appended))
    assert len(rows.array()) == 30
