"""The named topics of heft's live view and MCAP files: one place for their names, schemas
and the mapping from a run's arrays (the keys of ``analysis.run_log``'s module docstring,
or of a simulation's log.npz) to messages.

Every topic is JSON-encoded with a JSON Schema. heft's own schemas are ``heft.*``; the 3-D
scene uses Foxglove's well-known ``foxglove.FrameTransforms`` and ``foxglove.SceneUpdate``
(which Foxglove and Lichtblick recognise by name in any encoding). A message holds ``t``
(s since the run's first row) and the fields below; a field whose array the run lacks is
left out, and a topic none of whose arrays it has is not written.

Frames: S the sensor (wrenches on the load, at S in S), R the arm's base (= world), B the
master's base, E the stylus. Poses for the scene (``pose_RS``, ``pose_BE``: [p (m); w, x, y,
z]) are the arm's and the master's forward kinematics of ``slave_q`` and ``master_q``
(``diagrams.scene_poses``).

``TOPICS`` (per row of the arrays) and ``EVENT_TOPICS`` (per LCM message: faults, rejected
messages, load commands and their answers) list them; docs/live_view.md shows the table.
"""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np

XYZ = ("x", "y", "z")
WXYZ = ("w", "x", "y", "z")
ARROW_SCALE = 0.005
"""Scene arrows: metres of shaft per newton."""
ALL = 0
"""A field's ``parts`` for an array of every entry from ``start`` (a robot's joints: 6 or 7)."""
MASTER_BASE_IN_R = (0.3, -0.8, 0.2)
"""Where the scene draws the master's base B in R (m; for display: the two robots side by side)."""


@dataclasses.dataclass(frozen=True)
class Field:
    """One field of a message: array ``key``'s entries from ``start``; ``parts`` None (a number),
    a tuple of names (an object of numbers), a count (an array of numbers) or ``ALL`` (an array of
    the rest)."""

    name: str
    key: str
    parts: tuple | int | None
    start: int = 0
    doc: str = ""

    def value(self, v: list):
        """The field's JSON value from its array's row ``v`` (a flat list)."""
        if self.parts is None:
            return _number(v[self.start])
        if isinstance(self.parts, int):
            return [_number(x) for x in v[self.start:None if self.parts == ALL else self.start + self.parts]]
        return {name: _number(v[self.start + i]) for i, name in enumerate(self.parts)}

    def schema(self) -> dict:
        number = {"type": ["number", "null"]}
        if self.parts is None:
            return {**number, "description": self.doc}
        if self.parts == ALL:
            return {"type": "array", "items": number, "description": self.doc}
        if isinstance(self.parts, int):
            return {"type": "array", "items": number, "minItems": self.parts, "maxItems": self.parts,
                    "description": self.doc}
        return {"type": "object", "properties": {name: number for name in self.parts}, "description": self.doc}


def _number(x: float) -> float | None:
    """``x`` as a JSON number; None (null) where it is not finite (a tick the log lacks)."""
    return x if math.isfinite(x) else None


@dataclasses.dataclass(frozen=True)
class Topic:
    """A topic of the run's rows: ``name``, its schema's name, what it shows and its fields."""

    name: str
    schema_name: str
    doc: str
    fields: tuple

    @property
    def keys(self) -> tuple:
        return tuple(dict.fromkeys(field.key for field in self.fields))

    def present(self, keys) -> bool:
        """Whether a run with arrays ``keys`` has any of this topic's."""
        return any(key in keys for key in self.keys)

    def message(self, t: float, row: dict) -> dict:
        """The message of one row (``row``: key → that row's entries as a flat list) at ``t`` (s)."""
        return {"t": t, **{field.name: field.value(row[field.key]) for field in self.fields if field.key in row}}

    def schema(self) -> dict:
        """The JSON Schema of ``schema_name`` (the same for every topic of that name)."""
        return {"title": self.schema_name, "type": "object",
                "properties": {"t": {"type": "number", "description": "s since the run's first row"},
                               **{field.name: field.schema() for field in self.fields}}}


def _wrench(name: str, key: str, doc: str) -> Topic:
    return Topic(name, "heft.Wrench", doc, (Field("force", key, XYZ, 0, "force (N)"),
                                            Field("torque", key, XYZ, 3, "torque (N·m)")))


def _phi(name: str, key: str, doc: str) -> Topic:
    return Topic(name, "heft.InertialParameters", doc, (
        Field("mass", key, None, 0, "m (kg)"), Field("first_moment", key, XYZ, 1, "m·c, about S in S (kg·m)"),
        Field("inertia", key, ("xx", "xy", "xz", "yy", "yz", "zz"), 4, "about S in S (kg·m²)"),
        Field("std", f"{key}_std", 10, 0, "the standard deviations of the ten, in φ's order (Eq. 6)")))


def _joints(name: str, schema_name: str, doc: str, **keys) -> Topic:
    units = {"position": "rad", "velocity": "rad/s", "torque": "N·m"}
    return Topic(name, schema_name, doc,
                 tuple(Field(field, key, ALL, 0, f"{field} ({units[field]})") for field, key in keys.items()))


TOPICS = (
    _wrench("/wrench/measured", "wrench_measured", "the sensor's wrench on the load, at S in S (N, N·m)"),
    _wrench("/wrench/contact", "wrench_contact", "the contact wrench (Eq. 13), on the load at S in S"),
    _wrench("/wrench/noncontact", "wrench_noncontact", "the non-contact wrench V·φ̂ (Eq. 5), on the load at S in S"),
    _wrench("/wrench/feedback", "wrench_feedback", "the wrench fed back, γ·contact + σ·non-contact (Fig. 2), in S"),
    _wrench("/hand/mapped", "master_force", "the wrench on the operator's hand at E in B, as mapped, before the PC"),
    _wrench("/hand/applied", "master_force_applied", "the wrench on the hand after the PC and the device's limits"),
    _wrench("/truth/contact", "wrench_contact_true", "the simulation's true contact wrench, at S in S"),
    _wrench("/truth/noncontact", "wrench_noncontact_true", "the simulation's true non-contact wrench, at S in S"),
    _phi("/estimate/phi", "phi_hat", "φ̂: the load's inertial parameters in use (Eq. 6), with their uncertainty"),
    _wrench("/estimate/offsets", "offsets_hat", "the sensor's offsets in use, on the load at S in S"),
    _phi("/truth/phi", "phi_true", "the simulation's true φ of the load"),
    Topic("/passivity", "heft.Passivity", "the passivity observer on the master port, after the PC", (
        Field("energy", "passivity_energy", ("translational", "rotational"), 0, "observed energy [E_t, E_r] (J)"),
        Field("damping", "passivity_damping", ("translational", "rotational"), 0,
              "damping applied [α_t (N·s/m), α_r (N·m·s/rad)]"))),
    _joints("/master/joint_state", "heft.JointState", "the Phantom's joints as the driver reads them",
            position="master_q", velocity="master_v"),
    _joints("/master/command", "heft.JointTorque", "the master's joint torques sent (watchdog gain applied)",
            torque="master_torque"),
    _joints("/slave/joint_state", "heft.JointState", "the arm's joints", position="slave_q", velocity="slave_v"),
    _joints("/slave/command", "heft.JointPosition", "the arm command sent", position="slave_q_commanded"),
    Topic("/slave/pose_desired", "heft.Pose", "the sensor's pose the motion scaling asks for, S in R", (
        Field("position", "pose_RS_desired", XYZ, 0, "p_RS (m)"),
        Field("orientation", "pose_RS_desired", WXYZ, 3, "R_RS as a unit quaternion"))),
    Topic("/loop", "heft.Loop", "the controller loop's timing and the watchdog", (
        Field("hold", "hold", None, 0, "the tick's duration the controller stepped with (s)"),
        Field("compute", "tick_compute", None, 0, "the tick's computing time (s)"),
        Field("gain", "gain", None, 0, "the watchdog's force gain (0..1)"),
        Field("starts", "starts", None, 0, "controller starts so far"))),
    Topic("/controller/status", "heft.ControllerStatus", "the controller's flags and scales", (
        Field("force_fault", "force_fault", None, 0, "the force scaling's fault flag"),
        Field("ik", "ik_status", ("reachable", "rejected"), 0, "this tick's pose reachable (1/0), ticks rejected"),
        Field("rezero", "rezero_status", None, 0, "the re-zero status code (systems.controller.offset_tracking)"),
        Field("scales", "scales", ("sigma", "gamma", "eta"), 0, "σ, γ, η in effect"))),
    Topic("/identify/excitation", "heft.Excitation", "`heft identify --hardware`'s excitation under way", (
        Field("phase", "excitation", None, 0, "0 waiting for healthy hardware, 1 approaching the start, 2 settling, "
                                              "3 exciting, 4 done, 5 aborted (ExcitationCommander's Phase)"),
        Field("time", "excitation", None, 1, "time into the excitation (s)"),
        Field("done", "excitation", None, 2, "the share of the excitation played (0..1)"))),
)
"""The topics of a run's rows, one message per row each."""
TOPIC_BY_NAME = {topic.name: topic for topic in TOPICS}

SCENE_FRAMES = "/scene/frames"
SCENE_WRENCHES = "/scene/wrenches"
SCENE_KEYS = ("pose_RS", "pose_BE")
SCENE_ARROWS = {"measured": ("S", "wrench_measured", (0.6, 0.6, 0.6)),
                "contact": ("S", "wrench_contact", (0.9, 0.2, 0.1)),
                "noncontact": ("S", "wrench_noncontact", (0.1, 0.4, 0.9)),
                "hand": ("E", "master_force_applied", (0.1, 0.7, 0.2))}
"""The scene's force arrows: name → (frame at whose origin it starts, wrench key, colour). A
hand's wrench is in B, drawn at E in B's axes."""
SCENE_DOC = {SCENE_FRAMES: "the frames R (arm base), S (sensor), B (master base), E (stylus)",
             SCENE_WRENCHES: "the forces as arrows: measured, contact, non-contact at S; the hand's at E ("
                             f"{ARROW_SCALE * 1000:g} mm/N)"}

FRAME_IDS = {"R": "arm_base", "S": "sensor", "B": "master_base", "E": "stylus"}


def scene_present(keys) -> bool:
    return all(key in keys for key in SCENE_KEYS)


def _timestamp(t: float) -> dict:
    ns = round(t * 1e9)
    return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}


def _transform(t, parent, child, p, q_wxyz) -> dict:
    return {"timestamp": _timestamp(t), "parent_frame_id": FRAME_IDS[parent], "child_frame_id": FRAME_IDS[child],
            "translation": dict(zip(XYZ, map(float, p), strict=True)),
            "rotation": {"x": float(q_wxyz[1]), "y": float(q_wxyz[2]), "z": float(q_wxyz[3]), "w": float(q_wxyz[0])}}


def _finite(values) -> bool:
    return all(map(math.isfinite, values))


def scene_frames(t: float, row: dict) -> dict:
    """``foxglove.FrameTransforms`` of one row (flat lists): B in R (fixed), S in R, E in B (where known)."""
    transforms = [_transform(t, "R", "B", MASTER_BASE_IN_R, (1.0, 0.0, 0.0, 0.0))]
    for parent, child, pose in (("R", "S", row["pose_RS"]), ("B", "E", row["pose_BE"])):
        if _finite(pose):  # a tick without the joints' message has no pose
            transforms.append(_transform(t, parent, child, pose[:3], pose[3:]))
    return {"transforms": transforms}


def _x_to(d, size: float) -> dict:
    """The unit quaternion (x, y, z, w) turning +x onto ``d`` (3) of length ``size`` > 0."""
    w = 1.0 + d[0] / size
    if w < 1e-9:  # opposite to +x: half a turn about z
        return {"x": 0.0, "y": 0.0, "z": 1.0, "w": 0.0}
    y, z = -d[2] / size, d[1] / size  # axis x̂ × d, angle from the half-way vector
    n = math.sqrt(y * y + z * z + w * w)
    return {"x": 0.0, "y": y / n, "z": z / n, "w": w / n}


def scene_wrenches(t: float, row: dict) -> dict:
    """``foxglove.SceneUpdate`` of one row: one entity per arrow of ``SCENE_ARROWS`` the row has
    (an empty one for a zero or unknown force, so that the arrow disappears)."""
    entities = []
    for name, (frame, key, rgb) in SCENE_ARROWS.items():
        if key not in row:
            continue
        force = row[key][:3]
        if frame == "E":  # the hand's force is in B: drawn from E's origin, in B's axes
            frame, origin = "B", row["pose_BE"][:3]
        else:
            origin = (0.0, 0.0, 0.0)
        size = math.sqrt(sum(f * f for f in force)) if _finite(force) and _finite(origin) else 0.0
        arrows = [] if size == 0.0 else [{
            "pose": {"position": dict(zip(XYZ, origin, strict=True)), "orientation": _x_to(force, size)},
            "shaft_length": ARROW_SCALE * size, "shaft_diameter": 0.008, "head_length": 0.03, "head_diameter": 0.02,
            "color": {"r": rgb[0], "g": rgb[1], "b": rgb[2], "a": 1.0}}]
        entities.append({"timestamp": _timestamp(t), "frame_id": FRAME_IDS[frame], "id": name,
                         "lifetime": {"sec": 0, "nsec": 0}, "frame_locked": True, "metadata": [],
                         "arrows": arrows, "cubes": [], "spheres": [], "cylinders": [], "lines": [],
                         "triangles": [], "texts": [], "models": []})
    return {"deletions": [], "entities": entities}


def _object(properties: dict, description: str = "") -> dict:
    return {"type": "object", "properties": properties, "description": description}


_NUMBER, _STRING = {"type": "number"}, {"type": "string"}
_TIME = _object({"sec": {"type": "integer"}, "nsec": {"type": "integer"}})
_VECTOR3 = _object({name: _NUMBER for name in XYZ})
_QUATERNION = _object({name: _NUMBER for name in ("x", "y", "z", "w")})
_FRAME_TRANSFORM = _object({"timestamp": _TIME, "parent_frame_id": _STRING, "child_frame_id": _STRING,
                            "translation": _VECTOR3, "rotation": _QUATERNION})
_ARROW = _object({"pose": _object({"position": _VECTOR3, "orientation": _QUATERNION}), "shaft_length": _NUMBER,
                  "shaft_diameter": _NUMBER, "head_length": _NUMBER, "head_diameter": _NUMBER,
                  "color": _object({name: _NUMBER for name in "rgba"})})
_LIST = {"type": "array", "items": {"type": "object"}}
SCENE_SCHEMAS = {
    SCENE_FRAMES: ("foxglove.FrameTransforms",
                   _object({"transforms": {"type": "array", "items": _FRAME_TRANSFORM}}, SCENE_DOC[SCENE_FRAMES])),
    SCENE_WRENCHES: ("foxglove.SceneUpdate", _object({
        "deletions": _LIST,
        "entities": {"type": "array", "items": _object({
            "timestamp": _TIME, "frame_id": _STRING, "id": _STRING, "lifetime": _TIME,
            "frame_locked": {"type": "boolean"}, "metadata": _LIST, "arrows": {"type": "array", "items": _ARROW},
            **{kind: _LIST for kind in ("cubes", "spheres", "cylinders", "lines", "triangles", "texts", "models")}})},
    }, SCENE_DOC[SCENE_WRENCHES])),
}
"""The scene topics' well-known schemas, as JSON Schema of the fields heft writes."""


@dataclasses.dataclass(frozen=True)
class EventTopic:
    """A topic of messages that come when they come (LCM messages, not rows): ``name``, its
    schema's name, what it shows; messages made by ``lcm_messages``."""

    name: str
    schema_name: str
    doc: str


EVENT_TOPICS = (
    EventTopic("/faults", "heft.StationStatus", "the hardware station's health, faults and the messages it "
                                                  "rejected, per channel and reason (heft_station_status)"),
    EventTopic("/load/command", "heft.LoadCommand", "the operator's load commands (heft_load_command)"),
    EventTopic("/load/status", "heft.LoadStatus", "the controller's answers to load commands (heft_load_status)"),
)
"""Topics of rare messages: the station's status, the load commands and their answers."""


def row_topics(keys) -> list[str]:
    """The names of the row topics a run with arrays ``keys`` has, in ``TOPICS`` order, the scene last."""
    names = [topic.name for topic in TOPICS if topic.present(keys)]
    return names + ([SCENE_FRAMES, SCENE_WRENCHES] if scene_present(keys) else [])


def schema_of(name: str) -> tuple[str, dict, str]:
    """(schema name, JSON Schema, what the topic shows) of the row or event topic ``name``."""
    if name in SCENE_SCHEMAS:
        return (*SCENE_SCHEMAS[name], SCENE_DOC[name])
    for topic in TOPICS:
        if topic.name == name:
            return topic.schema_name, topic.schema(), topic.doc
    for topic in EVENT_TOPICS:
        if topic.name == name:
            return topic.schema_name, {"title": topic.schema_name, "type": "object"}, topic.doc
    raise KeyError(f"no topic {name}")


ESTIMATOR_STATE, ESTIMATOR_PRIOR = "phi_hat_rls", "phi_hat_prior"
"""Keys of a row that give ``phi_hat_std``: the online estimator's state (``RlsLoadEstimator``'s, the
``state_vector`` of a ``RecursiveLeastSquares`` on φ alone) and its prior covariance (1)."""


def phi_hat_std(state, prior_covariance: float) -> np.ndarray:
    """The standard deviations of the online estimator's φ̂ (10; kg, kg·m, kg·m²) from its ``state``:
    its covariance (``RecursiveLeastSquares.covariance``, the sandwich with the residual's variance per
    wrench axis), inf (null) where the data do not determine it, every entry before a few samples."""
    from heft.systems.identification.recursive_estimation import RecursiveLeastSquares

    estimator = RecursiveLeastSquares(offsets=False, initial_covariance=prior_covariance)
    estimator.load_state_vector(state)
    with np.errstate(invalid="ignore"):
        return np.sqrt(np.diag(estimator.covariance))


def row_messages(t: float, row: dict, names) -> list[tuple[str, dict]]:
    """(topic, message) of one row (``row``: key → that row's entries, at ``t`` s) on each topic of ``names``;
    ``phi_hat_std`` derived from the estimator's state where the row has it (``ESTIMATOR_STATE``)."""
    if ESTIMATOR_STATE in row and "phi_hat_std" not in row:
        row = {**row, "phi_hat_std": phi_hat_std(row[ESTIMATOR_STATE], float(np.ravel(row[ESTIMATOR_PRIOR])[0]))}
    row = {key: np.ravel(value).tolist() for key, value in row.items() if key not in (ESTIMATOR_STATE, ESTIMATOR_PRIOR)}
    out = []
    for name in names:
        if name == SCENE_FRAMES:
            out.append((name, scene_frames(t, row)))
        elif name == SCENE_WRENCHES:
            out.append((name, scene_wrenches(t, row)))
        else:
            out.append((name, TOPIC_BY_NAME[name].message(t, row)))
    return out


def per_row(arrays: dict) -> dict:
    """The arrays of ``arrays`` with one entry per row of ``t`` (a log's constants, e.g. ``sigma``, left out)."""
    n = len(arrays["t"])
    return {key: np.asarray(value) for key, value in arrays.items()
            if np.ndim(value) >= 1 and len(value) == n and key != "t"}


def run_messages(arrays: dict, t0: int = 0):
    """(time (ns), topic, message) of every row of a run's ``arrays``, row by row, the rows' topics in
    ``row_topics`` order; the time is ``t0`` (ns) + the row's ``t``."""
    rows = per_row(arrays)
    names = row_topics(rows)
    t = np.asarray(arrays["t"], dtype=float)
    for k in range(len(t)):
        row = {key: value[k] for key, value in rows.items()}
        for name, message in row_messages(float(t[k]), row, names):
            yield t0 + round(t[k] * 1e9), name, message


def encode(message: dict) -> bytes:
    """A message as the JSON bytes the topics carry (NaN never occurs: fields write null)."""
    return json.dumps(message, separators=(",", ":"), allow_nan=False).encode()
