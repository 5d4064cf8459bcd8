"""A recording from any lab: a YAML file (``Recording``, loaded with ``yaml_load_typed``) naming one
file per stream, each with its own clock. docs/recordings.md shows the format.

This module holds the schema and its checks that need no data (units, kinds, a stated R_SA being a
rotation, column counts); ``column_files`` reads the streams, ``recording_merge`` puts them onto
the wrench's timeline. Paths are relative to the YAML file. Errors are one line naming the YAML
file and the field.
"""


import dataclasses
from pathlib import Path

import numpy as np
import yaml
from pydrake.common.yaml import yaml_load_typed

from heft.analysis.csv_layout import DELIMITERS
from heft.analysis.yaml_tree import yaml_tree
from heft.systems.accelerometer_calibration import UNITS as ACCELEROMETER_UNITS
from heft.systems.accelerometer_calibration import AccelerometerCalibration
from heft.systems.identification.rotation_sampling import ROTATION_TOLERANCE, rotation_defects

ESTIMATE = "estimate"
"""The value of R_SA, bias, a clock's offset or the differentiation window that asks heft to estimate it."""

TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
"""A time column's unit → s."""

ORIENTATION_KINDS = {"rotation_matrix": (9,), "quaternion_wxyz": (4,), "quaternion_xyzw": (4,),
                     "joint_positions": (6, 7)}
"""Orientation kinds → their numbers of columns: R_WS row-major (r11, r12, …, r33); a unit quaternion
of R_WS either way round; the arm's joint angles (rad), R_WS from heft's model of ``robot`` (a bundled
arm, or ``custom``: the recording's ``arm``; ``diagrams.recording_kinematics``)."""


@dataclasses.dataclass
class Clock:
    """A stream's clock: a time ``column`` in ``unit`` (s | ms | us | ns), or evenly spaced rows at
    ``rate`` (Hz) from ``start`` (s). ``offset`` (s): how late this clock runs against the wrench's
    (a sample stamped t happened at t − offset on the wrench's clock); ``estimate`` asks heft to find
    it (the offset that makes V·φ̂ agree best with the measured wrench). The wrench's is 0."""
    column: str | None = None
    unit: str = "s"
    rate: float | None = None
    start: float = 0.0
    offset: float | str = 0.0


@dataclasses.dataclass
class StreamFile:
    """A stream's ``file`` (CSV or ``.parquet``, relative to the recording's YAML file) and, for a CSV, its
    ``delimiter``: , ; tab | or whitespace (runs of spaces or tabs); unset, it is detected from the
    header and the first rows (``csv_layout``)."""
    file: str = ""
    delimiter: str | None = None


@dataclasses.dataclass
class WrenchStream(StreamFile):
    """The force-torque sensor: [f; τ] (N, N·m) at S in S. ``exerted_on``: ``sensor`` (what the load
    exerts on the sensor, what drivers report) or ``load`` (heft's own sign, docs/design.md §4)."""
    time: Clock = dataclasses.field(default_factory=Clock)
    columns: list[str] = dataclasses.field(default_factory=lambda: ["fx", "fy", "fz", "tx", "ty", "tz"])
    exerted_on: str = "sensor"


@dataclasses.dataclass
class AccelerometerStream(StreamFile):
    """The accelerometer: 3 linear columns (+ 3 angular, rad/s², if it measures α) in its own axes A.
    ``unit`` g | m/s^2; ``includes_gravity``: it reports specific force a − g; ``R_SA`` its axes in S
    (v_S = R_SA·v_A) or ``estimate``; ``p_SA`` where it sits (m, in S); ``bias`` in its own axes and
    unit, or ``estimate``; ``scale`` the reading's gain (``accelerometer_calibration``: s_S =
    R_SA·(raw − bias)·unit/scale)."""
    time: Clock = dataclasses.field(default_factory=Clock)
    columns: list[str] = dataclasses.field(default_factory=lambda: ["ax", "ay", "az"])
    unit: str = "m/s^2"
    includes_gravity: bool = True
    R_SA: list[list[float]] | str = dataclasses.field(
        default_factory=lambda: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    p_SA: list[float] = dataclasses.field(default_factory=lambda: [0.0, 0.0, 0.0])
    bias: list[float] | str = dataclasses.field(default_factory=lambda: [0.0, 0.0, 0.0])
    scale: float = 1.0

    def calibration(self) -> AccelerometerCalibration:
        """The stated calibration; a ValueError if R_SA or the bias is still ``estimate``."""
        unresolved = [name for name in ("R_SA", "bias") if getattr(self, name) == ESTIMATE]
        if unresolved:
            raise ValueError(f"the accelerometer's {' and '.join(unresolved)} {'is' if len(unresolved) == 1 else 'are'}"
                             " 'estimate': calibrate it from static poses (`heft identify --recording`) and pass "
                             "that calibration, or state it in the recording")
        return AccelerometerCalibration(np.array(self.R_SA, dtype=float), np.array(self.bias, dtype=float),
                                        self.scale, self.unit)


@dataclasses.dataclass
class OrientationStream(StreamFile):
    """R_WS over time: ``kind`` (``ORIENTATION_KINDS``) and its columns; ``robot`` for joint_positions (a
    bundled arm's name, or ``custom``: the recording's ``arm``)."""
    time: Clock = dataclasses.field(default_factory=Clock)
    kind: str = "rotation_matrix"
    columns: list[str] = dataclasses.field(
        default_factory=lambda: ["r11", "r12", "r13", "r21", "r22", "r23", "r31", "r32", "r33"])
    robot: str | None = None


@dataclasses.dataclass
class AngularVelocityStream(StreamFile):
    """ω of S in the world, in S (rad/s), if recorded."""
    time: Clock = dataclasses.field(default_factory=Clock)
    columns: list[str] = dataclasses.field(default_factory=lambda: ["wx", "wy", "wz"])


DEFAULT_DIFFERENTIATION_WINDOW = 0.05
"""s: the differentiation window where it is left to estimate and nothing estimates it (identification, which has
no φ̂ yet to judge it by), and while `heft compensate` looks for it."""


@dataclasses.dataclass
class Differentiation:
    """The filter through which ω comes from the orientation and α from ω, when not recorded: a
    Savitzky–Golay polynomial of ``order`` over ``window`` seconds centred on each sample
    (zero-phase; at least order + 2 samples). ``window`` ``estimate`` (the default): `heft compensate` finds
    it (``analysis.differentiation_window``); elsewhere ``DEFAULT_DIFFERENTIATION_WINDOW``."""
    window: float | str = ESTIMATE
    order: int = 2

    @property
    def seconds(self) -> float:
        """The window in use (s): the stated one, else ``DEFAULT_DIFFERENTIATION_WINDOW``."""
        return DEFAULT_DIFFERENTIATION_WINDOW if self.window == ESTIMATE else float(self.window)


@dataclasses.dataclass
class StaticPoses(StreamFile):
    """A table of calibration poses, one row each (at rest, averaged): ``wrench`` (6 columns, the
    wrench stream's sign), optionally ``accelerometer`` (3 columns, raw as the accelerometer stream
    states), and the gravity direction either as ``gravity_S`` (3 columns, m/s² in S) or as
    ``orientation`` columns of ``orientation_kind`` (``ORIENTATION_KINDS``; ``robot`` for joints)."""
    wrench: list[str] = dataclasses.field(default_factory=lambda: ["fx", "fy", "fz", "tx", "ty", "tz"])
    accelerometer: list[str] | None = None
    gravity_S: list[str] | None = None
    orientation: list[str] | None = None
    orientation_kind: str = "rotation_matrix"
    robot: str | None = None


@dataclasses.dataclass
class Recording:
    """A recording (docs/recordings.md). ``gravity_W`` (m/s²) is gravity in the orientation's
    world frame. ``folder`` (set by ``load_recording``) is where relative paths start."""
    wrench: WrenchStream | None = None
    accelerometer: AccelerometerStream | None = None
    orientation: OrientationStream | None = None
    angular_velocity: AngularVelocityStream | None = None
    differentiation: Differentiation = dataclasses.field(default_factory=Differentiation)
    gravity_W: list[float] = dataclasses.field(default_factory=lambda: [0.0, 0.0, -9.81])
    static_poses: StaticPoses | None = None
    lcm_log: str | None = None
    """A log of `heft … --hardware --record`: the wrench, the accelerometer and the joint angles from heft's
    channels (``diagrams.recordings``); stream entries then give settings only (p_SA, robot, offsets)."""
    arm: dict | None = None
    """For joint angles of ``robot: custom``: the arm as a scenario's ``arm`` section gives it (urdf, base,
    flange, X_FS; ``diagrams/arm_params.py``), its URDF relative to this file; read by ``diagrams``."""
    folder: str = "."
    source: str = "recording"

    def path(self, relative: str) -> Path:
        """A file the recording names, relative to its YAML file."""
        return Path(self.folder) / relative

    def entries(self) -> dict:
        """{name: stream entry} of the stream entries present, the wrench first (with or without a file)."""
        return {name: getattr(self, name) for name in ("wrench", "accelerometer", "orientation", "angular_velocity")
                if getattr(self, name) is not None}

    def streams(self) -> dict:
        """{name: stream} of the time streams, those with a file; an entry without one gives settings only
        (the wrench's sign and the accelerometer's unit for static poses; p_SA, robot for an lcm_log)."""
        return {name: entry for name, entry in self.entries().items() if entry.file}


def load_recording(path) -> Recording:
    """Reads and checks a recording's YAML file; a ValueError of one line naming the file and field."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"recording file {path} does not exist")
    try:
        recording = _typed(yaml_tree(path.read_text()))
    except yaml.MarkedYAMLError as error:
        mark = error.problem_mark or error.context_mark
        raise ValueError(f"{path}, line {mark.line + 1}, column {mark.column + 1}: {error.problem or error.context}"
                         " (not YAML as docs/recordings.md shows it)") from None
    except (yaml.YAMLError, RuntimeError, ValueError, TypeError, AssertionError) as error:
        first = str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__
        raise ValueError(f"{path}: {first}") from None
    recording.folder = str(path.resolve().parent)
    recording.source = str(path)
    problem = _first_problem(recording)
    if problem:
        raise ValueError(f"{path}: {problem}")
    return recording


_OPTIONAL_PARTS = {"wrench": WrenchStream, "accelerometer": AccelerometerStream, "orientation": OrientationStream,
                   "angular_velocity": AngularVelocityStream, "static_poses": StaticPoses}


def _typed(data: dict) -> Recording:
    """``yaml_load_typed`` on the file's content, each optional part on its own (Drake's loader fills a
    dataclass field but cannot create one that defaults to None)."""
    if not isinstance(data, dict):
        raise ValueError("a recording is a YAML mapping of its streams (wrench, accelerometer, …)")
    parts = {name: data.pop(name) for name in list(data) if name in _OPTIONAL_PARTS}
    arm = data.pop("arm", None)
    if arm is not None and not isinstance(arm, dict):
        raise ValueError(f"arm must be a mapping of its fields (urdf, base, flange, X_FS) or null; got {arm!r}")
    recording = yaml_load_typed(schema=Recording, data=yaml.safe_dump(data)) if data else Recording()
    recording.arm = arm
    for name, value in parts.items():
        if value is not None:
            if not isinstance(value, dict):
                raise ValueError(f"{name} must be a mapping of its fields or null; got {value!r}")
            try:
                setattr(recording, name, yaml_load_typed(schema=_OPTIONAL_PARTS[name], data=yaml.safe_dump(value)))
            except (RuntimeError, ValueError, TypeError) as error:
                raise ValueError(f"{name}: {error}") from None
    return recording


def _clock_problem(name: str, clock: Clock, is_wrench: bool) -> str | None:
    if (clock.column is None) == (clock.rate is None):
        return f"{name}.time needs either a column (with its unit) or a rate (Hz), not both or neither"
    if clock.unit not in TIME_UNITS:
        return f"{name}.time.unit {clock.unit!r} is not a unit: use one of {', '.join(TIME_UNITS)}"
    if clock.rate is not None and not (np.isfinite(clock.rate) and clock.rate > 0):
        return f"{name}.time.rate must be a positive number of rows per second (Hz); got {clock.rate}"
    if isinstance(clock.offset, str) and clock.offset != ESTIMATE:
        return f"{name}.time.offset must be a number of seconds or '{ESTIMATE}'; got {clock.offset!r}"
    if is_wrench and clock.offset != 0.0:
        return "wrench.time.offset must be 0: the other streams' offsets are taken against the wrench's clock"
    return None


def _columns_problem(name: str, columns: list, counts: tuple[int, ...]) -> str | None:
    if len(columns) not in counts:
        return f"{name}.columns needs {' or '.join(map(str, counts))} column names; got {len(columns)}: {columns}"
    if len(set(columns)) != len(columns):
        return f"{name}.columns names a column twice: {columns}"
    return None


def _first_problem(recording: Recording) -> str | None:
    """The first problem of a recording that needs no data, or None."""
    if recording.wrench is None and recording.static_poses is None and recording.lcm_log is None:
        return "a recording needs a wrench stream, static_poses or an lcm_log"
    for name, entry in {**recording.entries(), "static_poses": recording.static_poses}.items():
        if entry is not None and entry.delimiter is not None and entry.delimiter not in DELIMITERS:
            return (f"{name}.delimiter {entry.delimiter!r} is not a separator: use one of , ; tab | whitespace "
                    "(or leave it out to have it detected)")
    for name, stream in recording.entries().items():
        if recording.lcm_log is not None:
            if stream.file:
                return f"{name}.file cannot be given with lcm_log: the log holds the streams"
            continue  # the stream's settings only; its file and clock come from the log
        if not stream.file:
            if recording.static_poses is not None:
                continue  # settings for the static poses (the wrench's sign, the accelerometer's unit)
            return f"{name}.file is missing: name the stream's CSV or Parquet file (relative to this YAML file)"
        problem = _clock_problem(name, stream.time, name == "wrench")
        if problem:
            return problem
    w, acc, ori, omega = recording.wrench, recording.accelerometer, recording.orientation, recording.angular_velocity
    checks = []
    if w is not None:
        checks += [_columns_problem("wrench", w.columns, (6,)),
                   None if w.exerted_on in ("sensor", "load") else
                   f"wrench.exerted_on {w.exerted_on!r} must be 'sensor' (what the load exerts on the sensor, as "
                   "drivers report) or 'load' (what the sensor exerts on the load)"]
    if acc is not None:
        checks += [_columns_problem("accelerometer", acc.columns, (3, 6)),
                   None if acc.unit in ACCELEROMETER_UNITS else
                   f"accelerometer.unit {acc.unit!r} is not a unit: use one of {', '.join(ACCELEROMETER_UNITS)}",
                   _rotation_problem("accelerometer.R_SA", acc.R_SA),
                   _vector_problem("accelerometer.p_SA", acc.p_SA, estimable=False),
                   _vector_problem("accelerometer.bias", acc.bias, estimable=True),
                   None if np.isfinite(acc.scale) and acc.scale > 0 else
                   f"accelerometer.scale must be a positive number; got {acc.scale}"]
    if ori is not None:
        checks.append(_orientation_problem("orientation", ori.kind, ori.columns, ori.robot, recording.arm))
    if omega is not None:
        checks.append(_columns_problem("angular_velocity", omega.columns, (3,)))
    poses = recording.static_poses
    if poses is not None:
        checks += [None if poses.file else "static_poses.file is missing",
                   _columns_problem("static_poses.wrench", poses.wrench, (6,)),
                   None if poses.accelerometer is None else
                   _columns_problem("static_poses.accelerometer", poses.accelerometer, (3,)),
                   None if (poses.gravity_S is None) != (poses.orientation is None) else
                   "static_poses needs the gravity direction: either gravity_S or orientation columns",
                   None if poses.gravity_S is None else
                   _columns_problem("static_poses.gravity_S", poses.gravity_S, (3,)),
                   None if poses.orientation is None else _orientation_problem(
                       "static_poses", poses.orientation_kind, poses.orientation, poses.robot, recording.arm,
                       "orientation_kind", "orientation")]
    checks.append(_vector_problem("gravity_W", recording.gravity_W, estimable=False))
    window = recording.differentiation.window
    checks.append(None if (window == ESTIMATE or (not isinstance(window, str) and np.isfinite(window) and window > 0))
                  and recording.differentiation.order >= 1 else
                  f"differentiation needs a window > 0 (s) or '{ESTIMATE}', and an order >= 1")
    return next((c for c in checks if c), None)


def _orientation_problem(name, kind, columns, robot, arm, kind_field="kind", columns_field="columns") -> str | None:
    if kind not in ORIENTATION_KINDS:
        return f"{name}.{kind_field} {kind!r} is not one of {', '.join(ORIENTATION_KINDS)}"
    if kind == "joint_positions" and not (isinstance(robot, str) and robot):
        return f"{name}.robot must name the arm for joint_positions (a bundled arm, or custom); got {robot!r}"
    if kind == "joint_positions" and robot == "custom" and arm is None:
        return f"{name}.robot custom needs the recording's arm section (urdf, base, flange, X_FS)"
    return _columns_problem(name if columns_field == "columns" else f"{name}.{columns_field}", columns,
                            ORIENTATION_KINDS[kind])


def _vector_problem(name: str, value, estimable: bool) -> str | None:
    if value == ESTIMATE and estimable:
        return None
    if isinstance(value, str) or len(value) != 3 or not np.isfinite(value).all():
        return f"{name} needs 3 finite numbers" + (f" or '{ESTIMATE}'" if estimable else "") + f"; got {value!r}"
    return None


def _rotation_problem(name: str, value) -> str | None:
    if value == ESTIMATE:
        return None
    R = np.array(value, dtype=float) if not isinstance(value, str) else None
    if R is None or R.shape != (3, 3) or not np.isfinite(R).all():
        return f"{name} needs a 3×3 rotation matrix (rows) or '{ESTIMATE}'; got {value!r}"
    defect = rotation_defects(R[None])[0]
    if defect > ROTATION_TOLERANCE:
        return (f"{name} is not a rotation matrix (RᵀR or det off the identity by {defect:.3g}, tolerance "
                f"{ROTATION_TOLERANCE:g}): give A's axes in S as the rows of a proper rotation")
    return None


def with_accelerometer_calibration(recording: Recording, calibration: AccelerometerCalibration) -> Recording:
    """A copy of ``recording`` whose accelerometer has ``calibration``'s R_SA, bias, scale and unit
    (e.g. found from static poses, or read from an estimate)."""
    acc = recording.accelerometer
    if acc is None:
        raise ValueError(f"{recording.source}: the recording has no accelerometer to calibrate")
    stated = dataclasses.replace(acc, R_SA=calibration.R_SA.tolist(), bias=calibration.bias.tolist(),
                                 scale=float(calibration.scale), unit=calibration.unit)
    return dataclasses.replace(recording, accelerometer=stated)


def with_clock_offsets(recording: Recording, offsets: dict) -> Recording:
    """A copy of ``recording`` with the clock offsets {stream name: s} stated."""
    changes = {}
    for name, offset in offsets.items():
        stream = getattr(recording, name)
        changes[name] = dataclasses.replace(stream, time=dataclasses.replace(stream.time, offset=float(offset)))
    return dataclasses.replace(recording, **changes)


def with_differentiation_window(recording: Recording, window: float) -> Recording:
    """A copy of ``recording`` with the differentiation ``window`` (s) stated."""
    return dataclasses.replace(recording, differentiation=dataclasses.replace(recording.differentiation,
                                                                              window=float(window)))
