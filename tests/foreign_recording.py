"""A lab's recording in a layout heft did not choose, made from heft's simulated station (the
round trip of docs/recordings.md): what a user brings to `heft identify --recording` and `heft compensate`.

Nothing here uses heft's writers or its accelerometer conventions: the CSV files are written with
the csv module in this helper's own column names and order, the accelerometer's reading is turned
into "its own" axes and unit with plain numpy, and the sensor frame's orientation comes from
Drake's kinematics of the station's arm.

* the wrench at 700 Hz with µs stamps, as drivers report it (what the load exerts on the sensor);
* the accelerometer (linear axes only) at 250 Hz in g, its axes rotated against S by
  ``ACCELEROMETER_R_SA`` (not about one axis), a bias of ``ACCELEROMETER_BIAS_G`` (0.08 g on its y
  axis) besides the station's own, its clock ``ACCELEROMETER_CLOCK_LATE`` (6 ms) late: a sample
  taken at wrench-clock time t is stamped t + 6 ms;
* the orientation at 100 Hz as R_WS row-major, or (``orientation="joint_positions"``) the arm's
  joint angles; no angular velocity.

The run is `heft identify`'s default excitation in the default (realistic) station, resampled from
the station's 2 kHz sensor samples by linear interpolation; the static poses are 24 wrist poses
held still in the same station, each averaged over its last ``POSE_AVERAGE`` s.
"""

from __future__ import annotations

import csv
import dataclasses
from pathlib import Path

import numpy as np
import yaml
from pydrake.trajectories import PiecewisePolynomial
from scipy.spatial.transform import Rotation

from heft.diagrams.identify import Recording, design_excitation
from heft.diagrams.plants import MakeSlavePlant
from heft.diagrams.running.sim_identification import record_excitation
from heft.diagrams.scenario import Scenario
from heft.systems.identification.excitation import ExcitationSettings
from heft.systems.station.sensor_models import drift_offsets

G_UNIT = 9.80665                     # m/s² per g (standard gravity)
ACCELEROMETER_R_SA = Rotation.from_euler("xyz", [25.0, -40.0, 110.0], degrees=True).as_matrix()
ACCELEROMETER_BIAS_G = np.array([0.0, 0.08, 0.0])
ACCELEROMETER_CLOCK_LATE = 0.006     # s
WRENCH_RATE, ACCELEROMETER_RATE, ORIENTATION_RATE = 700.0, 250.0, 100.0
EPOCH_US = 1_764_150_000_000_000     # the lab's clocks count µs since 1970
# The static poses: the wrist (joints 5 and 6) about the scenario's start pose.
POSE_TILTS = (1.0, -0.9, 0.5, -0.45)                   # rad added to joint 5
POSE_TURNS = (-2.5, -1.5, -0.5, 0.5, 1.5, 2.5)         # rad added to joint 6
POSE_MOVE, POSE_HOLD, POSE_AVERAGE = 0.8, 0.6, 0.3     # s


@dataclasses.dataclass
class StaticPoses:
    """24 poses held still: per pose the station's averaged readings and the truth."""
    q: np.ndarray                 # (P, 6) rad
    R_WS: np.ndarray              # (P, 3, 3)
    wrench: np.ndarray            # (P, 6) on the load, averaged
    accelerometer: np.ndarray     # (P, 3) the station's reading (m/s², S's axes, at p_SA), averaged
    offsets_true: np.ndarray      # (P, 6) the wrench's offsets, averaged
    accelerometer_bias_S: np.ndarray  # (P, 3) the station's own accelerometer bias (m/s², in S)
    phi_true: np.ndarray          # (10,)

    @property
    def accelerometer_bias_true_g(self) -> np.ndarray:
        """The exported accelerometer's whole bias, in its own axes and g (averaged over the poses)."""
        return ACCELEROMETER_BIAS_G + self.accelerometer_bias_S.mean(axis=0) @ ACCELEROMETER_R_SA / G_UNIT


def sensor_orientations(scenario: Scenario, q) -> np.ndarray:
    """R_WS (N, 3, 3) of the arm's sensor frame S at joint angles ``q`` (N, 6), by Drake."""
    plant, parts = MakeSlavePlant(scenario)
    context = plant.CreateDefaultContext()
    out = np.empty((len(q), 3, 3))
    for i, angles in enumerate(np.asarray(q, dtype=float)):
        plant.SetPositions(context, parts.arm, angles)
        out[i] = plant.CalcRelativeTransform(context, plant.world_frame(), parts.S).rotation().matrix()
    return out


def simulate_excitation(scenario: Scenario, settings: ExcitationSettings | None = None) -> Recording:
    """`heft identify`'s excitation of ``scenario`` (its default settings) on the simulated station:
    the recording identify itself takes (2 kHz, sample-aligned)."""
    settings = settings or ExcitationSettings()
    trajectory = design_excitation(scenario, settings).trajectory
    return record_excitation(scenario, trajectory, 1.0 / settings.base_frequency)


@dataclasses.dataclass
class _HoldAndMove:
    """Joint targets held ``POSE_HOLD`` s each, moved between in ``POSE_MOVE`` s (cubic, at rest at
    both ends); what ``record_excitation`` commands."""
    start: np.ndarray
    targets: np.ndarray

    def windows(self) -> list[tuple[float, float]]:
        """(start, end) s of each target's averaging window."""
        ends = POSE_HOLD + (POSE_MOVE + POSE_HOLD) * np.arange(1, len(self.targets) + 1)
        return [(end - POSE_AVERAGE, end) for end in ends]

    @property
    def duration(self) -> float:
        return POSE_HOLD + (POSE_MOVE + POSE_HOLD) * len(self.targets)

    def to_drake(self, duration: float, samples: int) -> PiecewisePolynomial:
        times, knots = [0.0, POSE_HOLD], [self.start, self.start]
        for target in self.targets:
            times += [times[-1] + POSE_MOVE, times[-1] + POSE_MOVE + POSE_HOLD]
            knots += [target, target]
        knots = np.array(knots).T
        return PiecewisePolynomial.CubicHermite(times, knots, np.zeros_like(knots))


def simulate_static_poses(scenario: Scenario) -> StaticPoses:
    """The 24 poses (``POSE_TILTS`` × ``POSE_TURNS``) held in the simulated station."""
    start = np.asarray(scenario.slave_initial_q, dtype=float)
    targets = []
    for turn in POSE_TURNS:
        for tilt in POSE_TILTS:
            targets.append(start + [0, 0, 0, 0, tilt, turn])
    motion = _HoldAndMove(start, np.array(targets))
    recording = record_excitation(scenario, motion, motion.duration)
    windows = [(recording.t >= a) & (recording.t < b) for a, b in motion.windows()]

    def mean(values):
        return np.array([values[w].mean(axis=0) for w in windows])

    q = mean(recording.q)
    accelerometer = scenario.accelerometer
    times = np.array([recording.t[w] for w in windows])
    if accelerometer.noise and accelerometer.offsets:
        final = accelerometer.drifted_offsets if accelerometer.drift else accelerometer.initial_offsets
        bias = drift_offsets(times.ravel(), accelerometer.initial_offsets, final, accelerometer.drift_time_constant)
        bias = bias[:, :3].reshape(len(windows), -1, 3).mean(axis=1)
    else:
        bias = np.zeros((len(windows), 3))
    return StaticPoses(q=q, R_WS=sensor_orientations(scenario, q), wrench=mean(recording.wrench),
                       accelerometer=mean(recording.accel_measured[:, :3]), offsets_true=mean(recording.offsets_true),
                       accelerometer_bias_S=bias, phi_true=recording.phi_true)


# --- the lab's files -----------------------------------------------------------------

def to_lab_accelerometer(specific_force_S) -> np.ndarray:
    """The lab's accelerometer reading (g, its own axes) of a specific force in S (m/s²)."""
    return np.asarray(specific_force_S) @ ACCELEROMETER_R_SA / G_UNIT + ACCELEROMETER_BIAS_G


def _write_csv(path: Path, header: list[str], columns: list[np.ndarray], formats: list[str]) -> None:
    with path.open("w", newline="") as file:
        writer = csv.writer(file)
        writer.writerow(header)
        for row in zip(*columns):
            writer.writerow([fmt.format(value) for fmt, value in zip(formats, row)])


def _stamps_us(t) -> np.ndarray:
    return EPOCH_US + np.round(np.asarray(t) * 1e6).astype(np.int64)


def _orientation_columns(orientation: str, q, R_WS):
    """(names, columns, formats, the recording's orientation section's kind/columns)."""
    if orientation == "rotation_matrix":
        names = [f"R{i}{j}" for i in range(1, 4) for j in range(1, 4)]
        return names, list(R_WS.reshape(-1, 9).T), ["{:.12f}"] * 9
    if orientation == "joint_positions":
        names = [f"axis{j}_rad" for j in range(1, 7)]
        return names, list(np.asarray(q).T), ["{:.12f}"] * 6
    raise ValueError(f"orientation must be rotation_matrix or joint_positions; got {orientation!r}")


def export_recording(folder, scenario: Scenario, run: Recording | None = None, poses: StaticPoses | None = None,
                     orientation: str = "rotation_matrix") -> Path:
    """Writes the lab's files for ``run`` (its three streams, module docstring) and ``poses`` (one row
    each: the averaged wrench on the sensor's sign, the accelerometer in g in its own axes, the
    orientation) to ``folder``, and the recording YAML (docs/recordings.md) that names them: what the
    lab states about its instruments (the accelerometer's unit and position; its orientation, bias and
    clock offset left to estimate). Returns the YAML's path."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    accelerometer = {"unit": "g", "includes_gravity": True, "R_SA": "estimate",
                     "p_SA": [float(x) for x in scenario.accelerometer.position], "bias": "estimate"}
    document = {"wrench": {"exerted_on": "sensor"}, "accelerometer": accelerometer}
    if run is not None:
        document.update(_export_streams(run, scenario, folder, orientation))
        document["accelerometer"] = {**document["accelerometer"], **accelerometer}
    if poses is not None:
        document["static_poses"] = _export_poses(poses, folder, orientation, scenario.robot)
    document["gravity_W"] = [0.0, 0.0, -9.81]
    path = folder / "recording.yaml"
    path.write_text(yaml.safe_dump(document, sort_keys=False))
    return path


def _export_streams(recording: Recording, scenario: Scenario, folder: Path, orientation: str) -> dict:
    t, end = recording.t, recording.t[-1]

    def resample(values, times):
        return np.column_stack([np.interp(times, t, column) for column in np.asarray(values).T])

    t_wrench = np.arange(0.0, end, 1.0 / WRENCH_RATE)
    on_sensor = -resample(recording.wrench, t_wrench)     # the driver's sign: what the load exerts on the sensor
    fx, fy, fz, tx, ty, tz = on_sensor.T
    _write_csv(folder / "ft.csv", ["stamp_us", "status", "Fz", "Fx", "Fy", "Tx", "Tz", "Ty"],
               [_stamps_us(t_wrench), np.zeros(len(t_wrench), dtype=int), fz, fx, fy, tx, tz, ty],
               ["{:d}", "{:d}"] + ["{:.6f}"] * 6)

    t_accel = np.arange(0.01, end - 0.01, 1.0 / ACCELEROMETER_RATE)
    reading = to_lab_accelerometer(resample(recording.accel_measured[:, :3], t_accel))
    _write_csv(folder / "imu.csv", ["seq", "imu_time_us", "acc_z_g", "acc_x_g", "acc_y_g"],
               [np.arange(len(t_accel)), _stamps_us(t_accel + ACCELEROMETER_CLOCK_LATE),
                reading[:, 2], reading[:, 0], reading[:, 1]], ["{:d}", "{:d}"] + ["{:.7f}"] * 3)

    stride = int(round(1.0 / (ORIENTATION_RATE * (t[1] - t[0]))))
    q = recording.q[::stride]
    names, columns, formats = _orientation_columns(orientation, q, sensor_orientations(scenario, q))
    _write_csv(folder / "robot.csv", ["time_us"] + names, [_stamps_us(t[::stride])] + columns, ["{:d}"] + formats)
    pose = {"file": "robot.csv", "time": {"column": "time_us", "unit": "us"}, "kind": orientation, "columns": names}
    if orientation == "joint_positions":
        pose["robot"] = scenario.robot
    return {"wrench": {"file": "ft.csv", "time": {"column": "stamp_us", "unit": "us"},
                       "columns": ["Fx", "Fy", "Fz", "Tx", "Ty", "Tz"], "exerted_on": "sensor"},
            "accelerometer": {"file": "imu.csv", "time": {"column": "imu_time_us", "unit": "us", "offset": "estimate"},
                              "columns": ["acc_x_g", "acc_y_g", "acc_z_g"]},
            "orientation": pose}


def _export_poses(poses: StaticPoses, folder: Path, orientation: str, robot: str) -> dict:
    fx, fy, fz, tx, ty, tz = (-poses.wrench).T
    reading = to_lab_accelerometer(poses.accelerometer)
    names, columns, formats = _orientation_columns(orientation, poses.q, poses.R_WS)
    _write_csv(folder / "poses.csv", ["pose", "Tx", "Ty", "Tz", "Fx", "Fy", "Fz", "ax_g", "ay_g", "az_g"] + names,
               [np.arange(1, len(fx) + 1), tx, ty, tz, fx, fy, fz, *reading.T, *columns],
               ["{:d}"] + ["{:.6f}"] * 6 + ["{:.7f}"] * 3 + formats)
    section = {"file": "poses.csv", "wrench": ["Fx", "Fy", "Fz", "Tx", "Ty", "Tz"],
               "accelerometer": ["ax_g", "ay_g", "az_g"], "orientation": names, "orientation_kind": orientation}
    if orientation == "joint_positions":
        section["robot"] = robot
    return section


def export_teleop_run(folder, scenario: Scenario, log: dict, angular: bool = False, wrench_rate: float | None = None,
                      accelerometer_rate: float | None = None) -> Path:
    """Writes a closed-loop run's log (``heft.diagrams.running.simulation.run_teleop``) in the lab's layout
    to ``folder``: the 2 kHz sensor samples of the run (or the wrench at ``wrench_rate`` and the
    accelerometer at ``accelerometer_rate`` Hz, linearly interpolated from them), each stream with its own
    stamps (µs) — the wrench on the sensor's sign, the accelerometer's linear axes in g in its own axes
    (``to_lab_accelerometer``), stamped ``ACCELEROMETER_CLOCK_LATE`` late, the arm's joint angles at every
    sample — and the recording YAML, which states the accelerometer's orientation, bias and position and
    leaves its clock offset to estimate. Returns the YAML's path."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    t = np.asarray(log["t"])

    def at_rate(values, rate):
        if rate is None:
            return t, np.asarray(values)
        times = np.arange(0.0, t[-1], 1.0 / rate)
        return times, np.column_stack([np.interp(times, t, column) for column in np.asarray(values).T])

    t_w, wrench = at_rate(log["wrench_measured"], wrench_rate)
    fx, fy, fz, tx, ty, tz = (-wrench).T
    _write_csv(folder / "ft.csv", ["stamp_us", "status", "Fz", "Fx", "Fy", "Tx", "Tz", "Ty"],
               [_stamps_us(t_w), np.zeros(len(t_w), dtype=int), fz, fx, fy, tx, tz, ty],
               ["{:d}", "{:d}"] + ["{:.6f}"] * 6)
    t_a, accel = at_rate(log["accel_measured"], accelerometer_rate)
    reading = to_lab_accelerometer(accel[:, :3])
    accelerometer_columns = ["acc_x_g", "acc_y_g", "acc_z_g"]
    values = [reading[:, 2], reading[:, 0], reading[:, 1]]
    if angular:  # the JR3's angular channels (rad/s²), in the accelerometer's axes
        accelerometer_columns += ["alpha_x", "alpha_y", "alpha_z"]
        values += list((accel[:, 3:] @ ACCELEROMETER_R_SA).T)
    _write_csv(folder / "imu.csv", ["seq", "imu_time_us", "acc_z_g", "acc_x_g", "acc_y_g"] + accelerometer_columns[3:],
               [np.arange(len(t_a)), _stamps_us(t_a + ACCELEROMETER_CLOCK_LATE)] + values,
               ["{:d}", "{:d}"] + ["{:.7f}"] * len(values))
    names, columns, formats = _orientation_columns("joint_positions", log["slave_q"], None)
    _write_csv(folder / "robot.csv", ["time_us"] + names, [_stamps_us(t)] + columns, ["{:d}"] + formats)
    document = {
        "wrench": {"file": "ft.csv", "time": {"column": "stamp_us", "unit": "us"},
                   "columns": ["Fx", "Fy", "Fz", "Tx", "Ty", "Tz"], "exerted_on": "sensor"},
        "accelerometer": {"file": "imu.csv", "time": {"column": "imu_time_us", "unit": "us", "offset": "estimate"},
                          "columns": accelerometer_columns, "unit": "g", "includes_gravity": True,
                          "R_SA": ACCELEROMETER_R_SA.tolist(),
                          "p_SA": [float(x) for x in scenario.accelerometer.position],
                          "bias": ACCELEROMETER_BIAS_G.tolist()},
        "orientation": {"file": "robot.csv", "time": {"column": "time_us", "unit": "us"}, "kind": "joint_positions",
                        "columns": names, "robot": scenario.robot},
        "gravity_W": [0.0, 0.0, -9.81]}
    path = folder / "recording.yaml"
    path.write_text(yaml.safe_dump(document, sort_keys=False))
    return path
