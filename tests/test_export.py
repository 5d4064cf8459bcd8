"""`heft export`: both kinds of log as MCAP (read back with the `mcap` reader), Parquet and CSV.

The simulation's log is a short `heft simulate fig6` run made here; the hardware log is the
traffic of the controller against the stand-in on one memq:// bus (as tests/test_run_log.py),
written by the test's own subscriber. Every value is checked against the source: the log.npz's
arrays, or the LCM messages decoded here; the scene's sensor pose against Drake's plant.
"""

import collections
import json
import sys

import lcm
import numpy as np
import pyarrow.csv
import pyarrow.parquet
import pytest
import yaml
from heft.diagrams.cli import main
from heft.diagrams.plants import AddArmWithSensor
from heft.diagrams.scenario import overrides_text, resolve_scenario
from heft.diagrams.stations.sim_station import MakeSimStation
from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.lcm_mailbox import pump
from heft.hardware_interface.lcmtypes import heft_teleop_state
from mcap.reader import make_reader
from pydrake.multibody.plant import MultibodyPlant

WRENCHES = {"/wrench/measured": "wrench_measured", "/wrench/contact": "wrench_contact",
            "/wrench/noncontact": "wrench_noncontact", "/hand/mapped": "master_force",
            "/hand/applied": "master_force_applied"}
SIMULATION_TOPICS = {*WRENCHES, "/wrench/feedback", "/truth/contact", "/truth/noncontact", "/estimate/phi",
                     "/estimate/offsets", "/truth/phi", "/passivity", "/master/joint_state", "/master/command",
                     "/slave/joint_state",
                     "/slave/pose_desired", "/controller/status", "/scene/frames", "/scene/wrenches"}
HARDWARE_TOPICS = {*WRENCHES, "/passivity", "/master/joint_state", "/master/command", "/slave/joint_state",
                   "/slave/command", "/loop", "/scene/frames", "/scene/wrenches"}


def sensor_position(q) -> np.ndarray:
    """p_RS (m) of the RX90's sensor frame at joint angles ``q``, from Drake's own plant."""
    plant = MultibodyPlant(0.0)
    AddArmWithSensor(plant, "rx90")
    plant.Finalize()
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, q)
    return plant.CalcRelativeTransform(context, plant.GetFrameByName("rx90_base"),
                                       plant.GetFrameByName("S")).translation()


def read_mcap(path) -> dict:
    """topic → [(log time (ns), decoded JSON)] of every message in the MCAP at ``path``."""
    topics = collections.defaultdict(list)
    with open(path, "rb") as file:
        for schema, channel, message in make_reader(file).iter_messages(log_time_order=True):
            assert schema.encoding == "jsonschema" and channel.message_encoding == "json"
            topics[channel.topic].append((message.log_time, json.loads(message.data)))
    return topics


def wrench_of(messages) -> np.ndarray:
    return np.array([[m["force"][a] for a in "xyz"] + [m["torque"][a] for a in "xyz"] for _, m in messages],
                    dtype=float)


@pytest.fixture(scope="module")
def simulation_log(tmp_path_factory):
    """log.npz of 0.1 s of `heft simulate fig6` (σ = 1) with the true load as the estimate."""
    folder = tmp_path_factory.mktemp("simulation")
    station = MakeSimStation(resolve_scenario("fig6"))
    phi = station.GetOutputPort("truth.phi").Eval(station.CreateDefaultContext())
    estimate = folder / "estimate.yaml"
    estimate.write_text(yaml.safe_dump({"phi": np.asarray(phi).tolist(), "offsets": [0.0] * 6}))
    assert main(["simulate", "fig6", "--sigma", "1", "--duration", "0.1", "--estimate", str(estimate),
                 "--out", str(folder)]) == 0
    return folder / "log.npz"


def test_a_simulation_log_as_mcap_holds_every_row_on_every_topic(simulation_log, tmp_path):
    assert main(["export", str(simulation_log), "--to", "mcap", "--out", str(tmp_path)]) == 0
    topics = read_mcap(tmp_path / "log.mcap")
    log = np.load(simulation_log)
    n = len(log["t"])
    assert set(topics) == SIMULATION_TOPICS
    assert {topic: len(messages) for topic, messages in topics.items()} == {topic: n for topic in topics}
    for topic, key in {**WRENCHES, "/wrench/feedback": "wrench_feedback", "/truth/contact": "wrench_contact_true",
                       "/estimate/offsets": "offsets_hat"}.items():
        np.testing.assert_array_equal(wrench_of(topics[topic]), log[key], err_msg=topic)
    times = np.array([time for time, _ in topics["/wrench/contact"]])
    np.testing.assert_array_equal(times, np.round(log["t"] * 1e9))
    phi = topics["/estimate/phi"]
    np.testing.assert_array_equal([m["mass"] for _, m in phi], log["phi_hat"][:, 0])
    np.testing.assert_array_equal([m["inertia"]["zz"] for _, m in phi], log["phi_hat"][:, 9])
    np.testing.assert_array_equal([m["torque"] for _, m in topics["/master/command"]], log["master_torque"])
    np.testing.assert_array_equal([[m["energy"]["translational"], m["damping"]["rotational"]]
                                   for _, m in topics["/passivity"]],
                                  np.c_[log["passivity_energy"][:, 0], log["passivity_damping"][:, 1]])
    np.testing.assert_array_equal([m["position"] for _, m in topics["/master/joint_state"]], log["master_q"])
    np.testing.assert_array_equal([m["scales"]["sigma"] for _, m in topics["/controller/status"]], log["scales"][:, 0])
    for k in (0, n // 2, n - 1):  # the scene's sensor frame where Drake puts S at the logged angles
        (transform,) = [x for x in topics["/scene/frames"][k][1]["transforms"] if x["child_frame_id"] == "sensor"]
        np.testing.assert_allclose([transform["translation"][a] for a in "xyz"],
                                   sensor_position(log["slave_q"][k]), atol=1e-9)
    with open(tmp_path / "log.mcap", "rb") as file:
        (metadata,) = make_reader(file).iter_metadata()
    assert metadata.name == "heft" and float(metadata.metadata["sigma"]) == 1.0


@pytest.mark.parametrize("form", ["parquet", "csv"])
def test_a_simulation_log_as_tables(simulation_log, tmp_path, form):
    assert main(["export", str(simulation_log), "--to", form, "--out", str(tmp_path)]) == 0
    log = np.load(simulation_log)
    read = pyarrow.parquet.read_table if form == "parquet" else pyarrow.csv.read_csv
    table = read(tmp_path / "log" / f"wrench.contact.{form}").to_pydict()
    np.testing.assert_array_equal(table["t"], log["t"])
    np.testing.assert_array_equal(table["log_time_ns"], np.round(log["t"] * 1e9))
    np.testing.assert_array_equal(np.c_[[table[f"force.{a}"] for a in "xyz"]].T, log["wrench_contact"][:, :3])
    joints = read(tmp_path / "log" / f"master.joint_state.{form}").to_pydict()
    np.testing.assert_array_equal(np.c_[[joints[f"velocity[{i}]"] for i in range(6)]].T, log["master_v"])
    assert len({path.name for path in (tmp_path / "log").iterdir()}) == len(SIMULATION_TOPICS) - 1 + 1  # heft.json


@pytest.fixture(scope="module")
def hardware_log(tmp_path_factory):
    """The LCM log of 0.15 s of the controller against the stand-in, teleop state on, clutch held from 0.05 s."""
    from test_hardware_teleop import Lab
    from test_run_log import Recorder

    lab = Lab(resolve_scenario("fig6", overrides_text({"operator.start_time": 0.0})), clutch_at=0.05)
    recorder = Recorder(lab.bus)
    lab.run(0.15)
    pump(lab.bus)
    return recorder.write(tmp_path_factory.mktemp("hardware") / "teleop.lcmlog")


def test_a_hardware_log_as_mcap_holds_every_tick_and_every_message(hardware_log, tmp_path):
    assert main(["export", str(hardware_log), "--out", str(tmp_path)]) == 0
    topics = read_mcap(tmp_path / "teleop.mcap")
    channels = LcmChannels()
    events = collections.defaultdict(list)
    for event in lcm.EventLog(str(hardware_log), "r"):
        events[event.channel].append(event)
    ticks = sorted((heft_teleop_state.decode(e.data) for e in events[channels.teleop_state.name]),
                   key=lambda msg: msg.utime)
    assert len(ticks) > 200
    assert {channels.station_status.name, channels.ft_sample.name} <= set(events)
    assert set(topics) == HARDWARE_TOPICS | {f"/lcm/{name}" for name in events} | {"/faults"}
    for name, logged in events.items():  # every message of every channel, in the log's order and time
        exported = topics[f"/lcm/{name}"]
        assert [time for time, _ in exported] == [1000 * e.timestamp for e in logged], name
    for topic in HARDWARE_TOPICS:
        assert len(topics[topic]) == len(ticks), topic
    exported = [m for _, m in topics[f"/lcm/{channels.teleop_state.name}"]]
    first = heft_teleop_state.decode(events[channels.teleop_state.name][0].data)
    assert exported[0]["wrench_contact"] == list(first.wrench_contact) and exported[0]["utime"] == first.utime
    np.testing.assert_array_equal(wrench_of(topics["/wrench/contact"]), [tick.wrench_contact for tick in ticks])
    np.testing.assert_array_equal(wrench_of(topics["/hand/applied"]), [tick.applied_wrench for tick in ticks])
    np.testing.assert_array_equal([m["energy"]["rotational"] for _, m in topics["/passivity"]],
                                  [tick.energy[1] for tick in ticks])
    np.testing.assert_array_equal([time for time, _ in topics["/loop"]], [1000 * tick.utime for tick in ticks])
    np.testing.assert_array_equal([m["hold"] for _, m in topics["/loop"]], [tick.dt for tick in ticks])
    statuses = [m for _, m in topics["/faults"]]
    assert len(statuses) == len(events[channels.station_status.name])
    assert set(statuses[-1]["channels"]) >= {"master_state", "slave_status", "ft_sample"}


def test_without_the_view_extra_mcap_and_the_view_say_how_to_install(simulation_log, tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "foxglove", None)  # as if foxglove-sdk were not installed
    assert main(["export", str(simulation_log), "--out", str(tmp_path)]) == 2
    assert main(["simulate", "fig6", "--view", "--duration", "0.01"]) == 2
    lines = [line for line in capsys.readouterr().err.splitlines() if "pip install 'heft-teleop[view]'" in line]
    assert len(lines) == 2 and not (tmp_path / "log.mcap").exists()
    assert main(["export", str(simulation_log), "--to", "csv", "--out", str(tmp_path)]) == 0  # pyarrow's
