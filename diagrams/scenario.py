"""Scenarios: everything a simulated run needs, as dataclasses loaded from YAML.

Load with :func:`resolve_scenario` (a bundled name or a file, optionally with
YAML text layered over it); change one with :func:`layered` (YAML text) or
:func:`overrides_text` (dotted field names → that text): the one override path
of the CLI, the sweeps and the tests. A malformed file or override gets a
ValueError naming the field. Units are SI; frames as docs/design.md §4 (W world, R slave
base, B master base).
"""


import dataclasses
import math
import typing
from pathlib import Path

import yaml

from pydrake.common.yaml import yaml_load_typed
from pydrake.multibody.plant import MultibodyPlantConfig
from pydrake.systems.analysis import SimulatorConfig

from heft.analysis.yaml_tree import yaml_tree
from heft.diagrams.arm_params import BUNDLED_ARMS, ROBOTS, ArmParams
from heft.diagrams.master_params import BUNDLED_MASTERS, DEFAULT_MASTER
from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.hardware_station_params import HardwareStationParams
from heft.hardware_interface.netft_params import NetFtParams
from heft.systems.controller.contact_threshold import ContactThresholdParams
from heft.systems.controller.load_estimation_params import LoadEstimationParams
from heft.systems.controller.feedback_mapping_params import FeedbackMappingParams
from heft.systems.controller.force_scaling_params import ForceScalingParams
from heft.systems.controller.motion_scaling_params import MotionScalingParams
from heft.systems.controller.offset_tracking_params import OffsetTrackingParams
from heft.systems.controller.passivity_params import PassivityParams
from heft.systems.station.sensor_params import AccelerometerParams, ForceTorqueSensorParams


@dataclasses.dataclass
class MountSpec:
    """How the load hangs below the sensor: rigidly (the paper's model), or on a compliant
    mount, a 6-DoF spring-damper between S and the load's frame (Drake's
    ``LinearBushingRollPitchYaw``; constants about and along S's axes at rest), as a tool on
    a wrist flange with an adapter plate is. A constant left out (null) is ``DEFAULT_MOUNT``'s,
    sized for the load (``diagrams/mount.py``: a load lighter than the paper's tool about an axis
    gets a proportionally softer mount there, so that it rocks where that tool does); a stated
    one is kept as stated, and the station refuses a mount its plant step cannot integrate. The
    compliance sits at ``at``; left out (null), at S, or nearer the load's centre of mass where the
    plant's step cannot integrate it at S (a compact mass far out on a stem)."""
    rigid: bool = False
    torque_stiffness: list[float] | None = None  # N·m/rad
    torque_damping: list[float] | None = None  # N·m·s/rad
    force_stiffness: list[float] | None = None  # N/m
    force_damping: list[float] | None = None  # N·s/m
    at: list[float] | None = None  # m, in S: the point whose rotation and translation the constants resist

    def validate(self) -> None:
        """Raises ValueError naming the first stated field that is out of range (none when rigid)."""
        if self.rigid:
            return
        for name, unit, positive in (("torque_stiffness", "N·m/rad", True), ("force_stiffness", "N/m", True),
                                     ("torque_damping", "N·m·s/rad", False), ("force_damping", "N·s/m", False)):
            value = getattr(self, name)
            if value is None:
                continue
            if len(value) != 3 or not all(math.isfinite(x) and (x > 0 if positive else x >= 0) for x in value):
                raise ValueError(f"{name} needs 3 numbers {'> 0' if positive else '>= 0'} ({unit})"
                                 + ("; set rigid true for a rigid mount" if positive else "") + f"; got {value}")
        if self.at is not None and (len(self.at) != 3 or not all(math.isfinite(x) for x in self.at)):
            raise ValueError(f"at needs 3 finite numbers (m, in S), or null to have it placed; got {self.at}")


DEFAULT_MOUNT = MountSpec(torque_stiffness=[3000.0, 3000.0, 3000.0], torque_damping=[0.85, 0.85, 0.4],
                          force_stiffness=[1e6, 1e6, 1e6], force_damping=[180.0, 180.0, 180.0])
"""The paper's tool's mount: its first modes, rocking about x and y, at 49–50 Hz ("tens of Hz",
as tools on wrist flanges show; the JR3 itself is stiffer), twist at 90 Hz, the others at
126–144 Hz, with 4–9 % of critical damping (bolted joints); ``tests/test_sim_station.py``
checks the rocking mode in the station against the modal analysis. Assumed values, not
measured on a lab's tool; a softer mount (rocking at 37 Hz) makes the loop unstable in fig7
without the controller's notch (docs/scenarios.md)."""


MOUNT_ROCKING_HZ = 48.0
"""The first modes of the bundled loads on their mounts, rocking about S's x and y, lie at
46.2–50.2 Hz by modal analysis (the gripper alone at 60 Hz), and those of custom loads
lighter than the paper's tool near them, their mount sized for them (``diagrams/mount.py``);
the default controller feeds back the contact wrench through a notch here
(``ForceScalingParams.mount_notch``), as a lab would after a tap test.
``tests/test_sim_station.py`` and ``tests/test_mount_sizing.py`` check the modes."""


@dataclasses.dataclass
class LoadSpec:
    """What hangs on the wrist sensor, below its measuring frame S.

    kind: "tool" (the paper's 3.13 kg tool, Fig. 5), "gripper_object" (a gripper
    holding an object, for Eq. 14's η split), or "custom" (a rigid body given by
    the fields below, in S).
    """
    kind: str = "tool"
    mass: float = 1.0                       # kg, "custom" only
    com: list[float] = dataclasses.field(default_factory=lambda: [0.0, 0.0, 0.05])  # p_SC_S, m
    # Inertia about the COM, axes of S: [Ixx, Ixy, Ixz, Iyy, Iyz, Izz], kg·m².
    inertia_com: list[float] = dataclasses.field(default_factory=lambda: [1e-3, 0, 0, 1e-3, 0, 1e-3])
    # "gripper_object" only: the gripper closes on the object at this time (s) of a teleoperation
    # run, in free space; before it, and throughout identification, it holds nothing. inf: held always.
    grasp_at: float = math.inf
    mount: MountSpec = dataclasses.field(default_factory=MountSpec)


@dataclasses.dataclass
class EnvironmentSpec:
    """The sheet spring of Fig. 5: a plate on a vertical spring-damper, or nothing.

    kind: "sheet_spring" or "none". ``plate_top_W`` is the plate's top-centre in W
    at rest (m); the plate moves along W's z axis.
    """
    kind: str = "sheet_spring"
    stiffness: float = 5000.0               # N/m
    damping: float = 20.0                   # N·s/m
    plate_mass: float = 0.2                 # kg
    plate_size: list[float] = dataclasses.field(default_factory=lambda: [0.3, 0.06, 0.002])  # m
    plate_top_W: list[float] = dataclasses.field(default_factory=lambda: [0.55, 0.0, 0.05])


@dataclasses.dataclass
class OperatorSpec:
    """The simulated operator's hand: an impedance pulling the stylus tip along
    ``reference`` (smooth sines about the start pose, in B). Defaults are estimates of a
    relaxed grip on a stylus, inside the ranges reported for the hand/wrist holding a haptic
    device (Kuchenbecker, Park & Niemeyer, Haptics Symposium 2003: some 100s of N/m, a few
    N·s/m, a few 100 g); the arm's endpoint stiffness rises with co-contraction (Hogan,
    IEEE T-AC 1985)."""
    hand_mass: float = 0.3                  # kg, added at the stylus
    stiffness: float = 300.0                # N/m
    damping: float = 8.0                    # N·s/m
    rotational_stiffness: float = 2.0       # N·m/rad
    rotational_damping: float = 0.1         # N·m·s/rad: with 0.02, σ = 1 torque feedback limit-cycles
    amplitude: list[float] = dataclasses.field(default_factory=lambda: [0.0, 0.0, 0.03])  # m, in B
    frequency: float = 1.0                  # Hz
    rotation_amplitude: list[float] = dataclasses.field(default_factory=lambda: [0.0, 0.0, 0.0])  # rad
    # Each period of the reference is one stroke; stroke k is scaled by stroke_scales[k], the last repeating.
    stroke_scales: list[float] = dataclasses.field(default_factory=lambda: [1.0])
    start_time: float = 0.2                 # s before the hand starts moving


@dataclasses.dataclass
class ControllerSpec:
    """The teleoperation controller's settings (its rate is ``Scenario.controller_period``).

    ``load_estimate``: an estimate.yaml written by ``heft identify``; empty means the
    load is identified in simulation first (as in the paper's Sec. VI-B). The run's σ is
    ``force.sigma``, its one home (the σ values ``heft simulate`` compares are that command's
    study axis, laid over it run by run: ``diagrams.running.simulation``). ``contact``: when the
    contact estimate counts as contact, for offset tracking and the online estimator's gate alike.
    """
    load_estimate: str = ""
    motion: MotionScalingParams = dataclasses.field(default_factory=MotionScalingParams)
    # The contact fed back through a notch at the default mount's rocking mode (``MOUNT_ROCKING_HZ``).
    force: ForceScalingParams = dataclasses.field(
        default_factory=lambda: ForceScalingParams(mount_notch=MOUNT_ROCKING_HZ))
    feedback: FeedbackMappingParams = dataclasses.field(default_factory=FeedbackMappingParams)
    passivity: PassivityParams = dataclasses.field(default_factory=PassivityParams)
    offsets: OffsetTrackingParams = dataclasses.field(default_factory=OffsetTrackingParams)
    contact: ContactThresholdParams = dataclasses.field(default_factory=ContactThresholdParams)
    estimator: LoadEstimationParams = dataclasses.field(default_factory=LoadEstimationParams)
    # One-way communication delay (s) between controller and station, in each direction;
    # a whole number of controller periods.
    delay: float = 0.0


@dataclasses.dataclass
class LabSpec:
    """The lab's hardware, for the commands that talk to it over LCM (``teleop --hardware``,
    ``identify --hardware``, ``stand-in``, ``load``, ``bench lcm``): the LCM URLs and channels, and
    the hardware station's limits (its watchdog). One scenario file per lab, as Drake's
    ``hardware_sim`` keeps its ``lcm_buses`` and drivers in its scenario; the controller's rate is
    ``Scenario.controller_period``, and the limits the drivers' messages are checked against come
    from the scenario's robot models and sensors (``diagrams.device_limits``)."""
    lcm: LcmChannels = dataclasses.field(default_factory=LcmChannels)
    station: HardwareStationParams = dataclasses.field(default_factory=HardwareStationParams)
    netft: NetFtParams = dataclasses.field(default_factory=NetFtParams)
    """The wrist sensor as an ATI Net F/T (``heft driver netft``): its calibration and RDT port."""


@dataclasses.dataclass
class Scenario:
    """One simulated station and run. ``experiment`` names which of the paper's
    experiments it replays ("fig6", "fig7", "fig8"), choosing metrics and figure; "" for none."""
    experiment: str = ""
    robot: str = "rx90"                     # the slave: a bundled arm (``BUNDLED_ARMS``) or "custom"
    arm: ArmParams = dataclasses.field(default_factory=ArmParams)  # robot "custom" only: the lab's arm
    # The slave's start posture (rad, one angle per joint). A robot stated without it (in a file, or laid over
    # one) starts in its own (``BundledArm.start``; ``with_arm_defaults``); a custom arm needs it stated.
    slave_initial_q: list[float] = dataclasses.field(default_factory=lambda: list(BUNDLED_ARMS["rx90"].start))
    master: str = DEFAULT_MASTER            # the haptic master: a bundled one (``BUNDLED_MASTERS``)
    master_initial_q: list[float] = dataclasses.field(default_factory=lambda: [0.0] * 6)  # rad
    load: LoadSpec = dataclasses.field(default_factory=LoadSpec)
    environment: EnvironmentSpec = dataclasses.field(default_factory=EnvironmentSpec)
    ft_sensor: ForceTorqueSensorParams = dataclasses.field(default_factory=ForceTorqueSensorParams)
    accelerometer: AccelerometerParams = dataclasses.field(default_factory=AccelerometerParams)
    operator: OperatorSpec = dataclasses.field(default_factory=OperatorSpec)
    controller: ControllerSpec = dataclasses.field(default_factory=ControllerSpec)
    lab: LabSpec = dataclasses.field(default_factory=LabSpec)
    # The slave's discrete MultibodyPlant (Drake's config; its time_step and output port sampling are the master
    # plant's too):
    # SAP with the lagged approximation, point contact (ContactWrenchAtSensor sums point contacts).
    plant: MultibodyPlantConfig = dataclasses.field(default_factory=lambda: MultibodyPlantConfig(
        time_step=0.0005, contact_model="point", discrete_contact_approximation="lagged",
        use_sampled_output_ports=False))
    # How a simulation runs (Drake's config, ApplySimulatorConfig): target_realtime_rate 1 paces it
    # to the wall clock; the defaults run as fast as they can.
    simulator: SimulatorConfig = dataclasses.field(default_factory=SimulatorConfig)
    controller_period: float = 0.0005       # s, 2 kHz (on hardware too: the loop's rate)
    # N·m/rad, the robot's own joint loop, one per joint; empty: ringing at ``SERVO_FREQUENCY``. A robot stated
    # without it takes its own (``BundledArm.servo_stiffness``), as the start posture.
    slave_servo_stiffness: list[float] = dataclasses.field(
        default_factory=lambda: list(BUNDLED_ARMS["rx90"].servo_stiffness))
    slave_servo_damping_ratio: float = 1.0
    slave_setpoint_bandwidth: float = 20.0  # Hz, the robot controller's setpoint filter
    encoder_counts_per_rev: float = 2.0 ** 20  # slave; the master's is in the model notes
    # The arm controller's joint velocity estimate: the encoders' backward difference at the plant's
    # step through a first-order low-pass of this cut-off (Hz); 0: the true velocity (ideal).
    slave_velocity_filter: float = 100.0
    duration: float = 2.0                   # s

    def validate(self) -> "Scenario":
        """Raises ValueError naming the first field that is out of range."""
        def need(ok, field, what):
            if not ok:
                raise ValueError(f"scenario field '{field}' {what}")
        need(self.experiment in ("", "fig6", "fig7", "fig8"), "experiment",
             f"must be '', 'fig6', 'fig7' or 'fig8', not {self.experiment!r}")
        force = self.controller.force
        need(force.eta == 1.0 or force.phi_gripper is not None or math.isfinite(self.load.grasp_at)
             or self.controller.estimator.mode == "online",
             "controller.force.eta", f"= {force.eta:g} would do nothing: η acts only with a gripper/object "
             "split; give controller.force.phi_gripper (the gripper's φ, Eq. 6), use a load with a grasp "
             "(load.grasp_at: the gripper is identified alone), learn the load online "
             "(controller.estimator.mode: online; on hardware a grasp over LCM splits it) or leave η at 1")
        need(self.master in BUNDLED_MASTERS, "master",
             f"must be one of {', '.join(BUNDLED_MASTERS)}, not {self.master!r}")
        need(self.robot in ROBOTS, "robot", f"must be one of {', '.join(ROBOTS)}, not {self.robot!r}")
        if self.robot == "custom":
            try:
                self.arm.validate()
            except ValueError as error:  # its message starts with the field's name
                field, _, what = str(error).partition(" ")
                raise ValueError(f"scenario field 'arm.{field}' {what} (robot: custom)") from None
            need(len(self.slave_initial_q) > 0, "slave_initial_q",
                 "needs the custom arm's start posture, one angle per joint (rad)")
        else:
            need(not (self.arm.urdf or self.arm.base or self.arm.flange), "arm",
                 f"describes a custom arm: give it with robot: custom, not robot: {self.robot}")
            joints = len(BUNDLED_ARMS[self.robot].start)
            need(len(self.slave_initial_q) == joints, "slave_initial_q",
                 f"needs {joints} joint angles (rad) for the {self.robot}; got {len(self.slave_initial_q)}")
            need(len(self.slave_servo_stiffness) in (0, joints), "slave_servo_stiffness",
                 f"needs {joints} gains (N·m/rad) for the {self.robot}, or none (from its inertias)")
        need(len(self.master_initial_q) == 6, "master_initial_q", "needs 6 joint angles (rad)")
        need(self.load.kind in ("tool", "gripper_object", "custom"), "load.kind",
             f"must be 'tool', 'gripper_object' or 'custom', not {self.load.kind!r}")
        need(len(self.load.com) == 3, "load.com", "needs 3 numbers (m)")
        need(math.isinf(self.load.grasp_at) or (self.load.kind == "gripper_object" and self.load.grasp_at > 0),
             "load.grasp_at", "is a time > 0 (s) for a 'gripper_object' load only")
        need(len(self.load.inertia_com) == 6, "load.inertia_com", "needs 6 numbers [Ixx, Ixy, Ixz, Iyy, Iyz, Izz]")
        need(self.environment.kind in ("sheet_spring", "none"), "environment.kind",
             f"must be 'sheet_spring' or 'none', not {self.environment.kind!r}")
        need(self.environment.stiffness > 0, "environment.stiffness", "must be > 0 (N/m)")
        need(self.environment.damping >= 0, "environment.damping", "must be >= 0 (N·s/m)")
        need(self.environment.plate_mass > 0, "environment.plate_mass", "must be > 0 (kg)")
        need(len(self.environment.plate_size) == 3 and min(self.environment.plate_size) > 0,
             "environment.plate_size", "needs 3 positive sizes (m)")
        need(len(self.environment.plate_top_W) == 3, "environment.plate_top_W", "needs 3 numbers (m)")
        op = self.operator
        for name in ("hand_mass", "stiffness", "damping", "rotational_stiffness", "rotational_damping"):
            need(getattr(op, name) >= 0, f"operator.{name}", "must be >= 0")
        need(len(op.amplitude) == 3, "operator.amplitude", "needs 3 numbers (m)")
        need(len(op.rotation_amplitude) == 3, "operator.rotation_amplitude", "needs 3 numbers (rad)")
        need(len(op.stroke_scales) >= 1 and all(math.isfinite(x) and x >= 0 for x in op.stroke_scales),
             "operator.stroke_scales", "needs at least one finite scale >= 0")
        need(math.isfinite(self.plant.time_step) and self.plant.time_step > 0, "plant.time_step",
             "must be finite and > 0 (s): the station's plants are discrete")
        need(self.plant.contact_model == "point", "plant.contact_model",
             f"must be 'point' (the contact truth sums point contacts); got {self.plant.contact_model!r}")
        need(self.controller_period > 0, "controller_period", "must be > 0 (s)")
        need(self.controller.motion.master_filter < 0.5 / self.controller_period, "controller.motion.master_filter",
             f"must lie below the controller's Nyquist frequency {0.5 / self.controller_period:g} Hz (0: no filter); "
             f"got {self.controller.motion.master_filter}")
        need(self.controller.motion.master_notch < 0.5 / self.controller_period, "controller.motion.master_notch",
             f"must lie below the controller's Nyquist frequency {0.5 / self.controller_period:g} Hz (0: no notch); "
             f"got {self.controller.motion.master_notch}")
        steps = self.controller.delay / self.controller_period
        need(math.isfinite(steps) and steps >= 0 and abs(steps - round(steps)) < 1e-6, "controller.delay",
             f"must be >= 0 and a whole number of controller periods ({self.controller_period:g} s); "
             f"got {self.controller.delay!r} s")
        need(all(math.isfinite(k) and k > 0 for k in self.slave_servo_stiffness), "slave_servo_stiffness",
             "needs gains > 0 (N·m/rad)")
        need(self.duration > 0, "duration", "must be > 0 (s)")
        need(math.isfinite(self.slave_velocity_filter) and self.slave_velocity_filter >= 0, "slave_velocity_filter",
             "must be >= 0 (Hz; 0: the true velocity)")
        for name, params in (("ft_sensor", self.ft_sensor), ("accelerometer", self.accelerometer),
                             ("load.mount", self.load.mount), ("lab.station.watchdog", self.lab.station.watchdog)):
            try:
                params.validate()
            except ValueError as error:  # its message starts with the field's name
                field, _, what = str(error).partition(" ")
                raise ValueError(f"scenario field '{name}.{field}' {what}") from None
        need(self.slave_setpoint_bandwidth > 0, "slave_setpoint_bandwidth", "must be > 0 (Hz)")
        need(math.isfinite(self.duration), "duration", "must be finite")
        return self


def with_arm_defaults(scenario: Scenario, stated: dict, robot_before: str) -> Scenario:
    """``scenario`` (changed in place), whose YAML ``stated`` its fields, with its robot's own start posture,
    servo gains and motion scale (``BundledArm``) where ``stated`` names a robot other than ``robot_before``
    and not them; a custom arm brings none (its start posture must then be stated, its gains come from its
    inertias, the motion scale stays the scenario's)."""
    if stated.get("robot", robot_before) == robot_before:
        return scenario
    arm = BUNDLED_ARMS.get(scenario.robot)
    if "slave_initial_q" not in stated:
        scenario.slave_initial_q = list(arm.start) if arm else []
    if "slave_servo_stiffness" not in stated:
        scenario.slave_servo_stiffness = list(arm.servo_stiffness) if arm else []
    motion = (stated.get("controller") or {}).get("motion") or {}
    if arm and arm.translation_scale is not None and "translation_scale" not in motion:
        scenario.controller.motion.translation_scale = arm.translation_scale
    return scenario


def with_master_defaults(scenario: Scenario, stated: dict, master_before: str) -> Scenario:
    """``scenario`` (changed in place) with its master's force limit (``BundledMaster.max_force``) as
    ``controller.feedback.max_force`` where ``stated`` names a master other than ``master_before`` and not
    that limit."""
    if stated.get("master", master_before) == master_before:
        return scenario
    feedback = (stated.get("controller") or {}).get("feedback") or {}
    master = BUNDLED_MASTERS.get(scenario.master)
    if master and master.max_force is not None and "max_force" not in feedback:
        scenario.controller.feedback.max_force = master.max_force
    return scenario


def _check_fields(data, schema, path=""):
    """Checks raw YAML ``data`` against dataclass ``schema`` so that every error
    names its field (dotted path) and what was expected."""
    if not isinstance(data, dict):
        raise ValueError(f"field '{path or '<top>'}' must be a mapping of field names to values")
    fields = {f.name: f for f in dataclasses.fields(schema)}
    hints = typing.get_type_hints(schema)
    for key, value in data.items():
        name = f"{path}{key}"
        if key not in fields:
            raise ValueError(f"unknown field '{name}'; known fields here: {', '.join(fields)}")
        hint = hints[key]
        if dataclasses.is_dataclass(hint):
            _check_fields(value, hint, name + ".")
        elif typing.get_origin(hint) is list and typing.get_origin(typing.get_args(hint)[0]) is list:  # rows
            if not isinstance(value, list) or not all(isinstance(row, list) and all(
                    isinstance(v, (int, float)) and not isinstance(v, bool) for v in row) for row in value):
                raise ValueError(f"field '{name}' must be a list of rows of numbers, got {value!r}")
        elif typing.get_origin(hint) is list:
            if not isinstance(value, list) or not all(
                    isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
                raise ValueError(f"field '{name}' must be a list of numbers, got {value!r}")
        elif hint is float and (not isinstance(value, (int, float)) or isinstance(value, bool)):
            raise ValueError(f"field '{name}' must be a number, got {value!r}")
        elif hint is int and (not isinstance(value, int) or isinstance(value, bool)):
            raise ValueError(f"field '{name}' must be an integer, got {value!r}")
        elif hint is bool and not isinstance(value, bool):
            raise ValueError(f"field '{name}' must be true or false, got {value!r}")
        elif hint is str and not isinstance(value, str):
            raise ValueError(f"field '{name}' must be a string, got {value!r}")


SCENARIO_DIR = Path(__file__).resolve().parent / "scenarios"
"""The bundled scenarios (fig6, fig7, fig8, …)."""


def scenario_path(name_or_path: str) -> Path:
    """The file of a bundled scenario by name, or ``name_or_path`` itself."""
    path = Path(name_or_path)
    if not path.suffix:
        path = SCENARIO_DIR / f"{name_or_path}.yaml"
        if not path.is_file():
            bundled = sorted(p.stem for p in SCENARIO_DIR.glob("*.yaml"))
            raise ValueError(f"no bundled scenario {name_or_path!r}; bundled: {', '.join(bundled)}")
    return path


def resolve_scenario(name_or_path: str, overrides: str = "") -> Scenario:
    """A bundled scenario by name or a YAML file by path, with the YAML text ``overrides``
    (``layered``) laid over it."""
    scenario = load_scenario(scenario_path(name_or_path))
    return layered(scenario, overrides) if overrides.strip() else scenario


def layered(scenario: Scenario, text: str) -> Scenario:
    """A copy of ``scenario`` with the YAML ``text`` laid over it: any subset of a scenario
    file's fields, nested as there (``"{controller: {force: {gamma: 0.5}}, duration: 3}"``);
    the fields it leaves out keep ``scenario``'s values, but for a new ``robot``'s start posture, servo
    gains and motion scale (``with_arm_defaults``) and a new ``master``'s force limit (``with_master_defaults``).
    Validated; errors name the field."""
    try:
        stated = yaml_tree(text)
        _check_fields(stated, Scenario)
        laid = with_arm_defaults(yaml_load_typed(schema=Scenario, data=text, defaults=scenario), stated,
                                 scenario.robot)
        return with_master_defaults(laid, stated, scenario.master).validate()
    except yaml.YAMLError as error:
        raise ValueError(f"scenario override {text!r} is not valid YAML: {error}") from None
    except ValueError as error:
        raise ValueError(f"scenario override {text!r}: {error}") from None


NOISE_OFF = {"ft_sensor.noise": False, "accelerometer.noise": False}
"""For ``overrides_text``: both sensor models without disturbances (filtered, sampled and held only)."""

IDEAL_STATION = {"load.mount.rigid": True, "ft_sensor.lowpass_cutoff": 0.0, "accelerometer.lowpass_cutoff": 0.0,
                 "accelerometer.position": [0.0, 0.0, 0.0], "slave_velocity_filter": 0.0,
                 "controller.force.mount_notch": 0.0}
"""For ``overrides_text``: the ideal station, the paper's model exactly: the load welded to the
sensor, no sensor filter, the accelerometer at S, the arm's true joint velocities, and so a
controller without the mount notch. The default (realistic) station has all of them; noise,
offsets and their drift are ``NOISE_OFF``'s."""


def overrides_text(values: dict) -> str:
    """The YAML text for ``layered`` that sets each dotted field name of ``values`` (e.g.
    ``{"controller.force.gamma": 0.5}``) to its value; a value of None is left out."""
    tree: dict = {}
    for path, value in values.items():
        if value is None:
            continue
        *parents, leaf = path.split(".")
        node = tree
        for name in parents:
            node = node.setdefault(name, {})
        node[leaf] = value.item() if hasattr(value, "item") else value
    return yaml.safe_dump(tree, default_flow_style=True).strip() if tree else ""


def load_scenario(path) -> Scenario:
    """Reads a scenario YAML file; errors name the file and the offending field."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"scenario file {path} does not exist")
    text = path.read_text()
    try:
        stated = yaml_tree(text)
        _check_fields(stated, Scenario)
        scenario = with_master_defaults(with_arm_defaults(yaml_load_typed(schema=Scenario, data=text), stated,
                                                          Scenario().robot), stated, DEFAULT_MASTER)
        if scenario.arm.urdf:  # a relative path is taken from the file's folder
            scenario.arm.urdf = str(scenario.arm.urdf_path(path.parent))
        return scenario.validate()
    except yaml.YAMLError as error:
        raise ValueError(f"scenario file {path} is not valid YAML: {error}") from None
    except ValueError as error:
        raise ValueError(f"scenario file {path}: {error}") from None
