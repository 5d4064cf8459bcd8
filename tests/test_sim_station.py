"""The simulated station: physics at the wrist sensor, the sheet spring, the
operator, the ports, and scenario files."""

import numpy as np
import pytest
from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix
from pydrake.multibody.math import SpatialAcceleration
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import JacobianWrtVariable
from pydrake.systems.analysis import Simulator

from heft.diagrams.scenario import IDEAL_STATION, NOISE_OFF, Scenario, layered, load_scenario, overrides_text
from heft.diagrams.mount import modes_on_fixed_sensor
from heft.diagrams.master_params import BUNDLED_MASTERS
from heft.diagrams.plants import AddSlave, MakeMasterPlant, mount_for
from heft.diagrams.stations.sim_station import MakeSimStation
from heft.systems.accelerometer_reading import motion_from_reading
from heft.systems.load_dynamics import InertialParameters, regressor
from heft.systems.station.operator_hand import (OperatorHand, hand_force_into, hand_record, hand_wrench_into,
                                               reference_into, smooth_sine_offset, stroke_windows)
from heft.systems.station.station_truth import frame_motion_into

STATION_PORTS = {
    "inputs": {"master.torque_commanded", "slave.position_commanded"},
    "outputs": {"master.position_measured", "master.velocity_estimated", "slave.position_measured",
                "slave.velocity_estimated", "ft.wrench_measured", "ft.acceleration_measured"},
}


def ideal(scenario: Scenario) -> Scenario:
    """``scenario`` in the ideal station with noise-free sensors."""
    return layered(scenario, overrides_text({**NOISE_OFF, **IDEAL_STATION}))


class Run:
    """A station with its simulator; ``step(q_cmd)`` advances one controller period."""

    def __init__(self, scenario: Scenario):
        self.scenario = scenario
        self.station = MakeSimStation(scenario)
        self.context = self.station.CreateDefaultContext()
        self.port = self.station.GetInputPort
        self.port("master.torque_commanded").FixValue(self.context, np.zeros(6))
        self.port("slave.position_commanded").FixValue(self.context, scenario.slave_initial_q)
        self.simulator = Simulator(self.station, self.context)
        self.simulator.Initialize()
        self.ticks = 0

    def out(self, name):
        return self.station.GetOutputPort(name).Eval(self.context).copy()

    def command(self, q_cmd=None, torque=None):
        if q_cmd is not None:
            self.port("slave.position_commanded").FixValue(self.context, q_cmd)
        if torque is not None:
            self.port("master.torque_commanded").FixValue(self.context, torque)

    def advance(self):
        # Stop half-way between sample instants, never on one (robust to round-off).
        self.ticks += 1
        self.simulator.AdvanceTo((self.ticks + 0.5) * self.scenario.controller_period)

    def step(self, q_cmd=None, torque=None):
        self.command(q_cmd, torque)
        self.advance()


@pytest.fixture(scope="module")
def free_space():
    return Run(layered(ideal(Scenario()), overrides_text({"environment.kind": "none"})))


@pytest.fixture(scope="module")
def sheet_spring():
    # the plate 5 mm below the ball at rest
    return Run(layered(ideal(Scenario()), overrides_text({"environment.plate_top_W": [0.552, 0.0, 0.075]})))



def test_a_frames_motion_is_drakes_shifted_spatial_acceleration_in_the_frame():
    """``frame_motion_into`` against Drake's ``SpatialAcceleration.Shift`` and rotations."""
    rng = np.random.default_rng(3)
    g_W = np.array([0.0, 0.0, -9.81])
    for _ in range(5):
        R_WB = RotationMatrix(RollPitchYaw(rng.uniform(-3, 3, 3)))
        w, alpha, a, p_BF = rng.normal(0, 3, (4, 3))
        motion = np.empty(12)
        frame_motion_into(R_WB.matrix(), w, alpha, a, p_BF, g_W, motion)
        A_WF = SpatialAcceleration(alpha, a).Shift(R_WB @ p_BF, w)
        R_BW = R_WB.inverse()
        expected = np.concatenate([R_BW @ x for x in (A_WF.translational(), A_WF.rotational(), w, g_W)])
        np.testing.assert_allclose(motion, expected, rtol=0, atol=1e-12)


def test_the_hands_reference_and_impedance_against_drakes_rotations():
    """``reference_into`` and ``hand_wrench_into`` against Drake's ``RollPitchYaw`` and ``ToAngleAxis``."""
    rng = np.random.default_rng(8)
    R_ref, error, p_ref, w_ref, v_ref, quaternion, out = (np.empty(n) for n in ((3, 3), (3, 3), 3, 3, 3, 7, 6))
    scales = np.array([1.0, 0.5])
    for n in range(8):
        t, amplitude, rotation_amplitude = rng.uniform(0.0, 1.0), rng.normal(0, 0.05, 3), rng.normal(0, 0.4, 3)
        X_0 = RigidTransform(RotationMatrix(RollPitchYaw(rng.uniform(-3, 3, 3))), rng.normal(0, 0.3, 3))
        reference_into(t, 0.1, 2.5, scales, amplitude, rotation_amplitude, X_0.rotation().matrix(),
                       np.array(X_0.translation()), R_ref, p_ref, w_ref, v_ref)
        cycles = 2.5 * (t - 0.1)  # the reference's closed form: stroke k scaled by scales[k], the last repeating
        scale = scales[min(int(cycles), len(scales) - 1)] if t >= 0.1 else 0.0
        offset, rate = scale * (1 - np.cos(2 * np.pi * cycles)) / 2, scale * np.pi * 2.5 * np.sin(2 * np.pi * cycles)
        R_expected = RotationMatrix(RollPitchYaw(offset * rotation_amplitude)) @ X_0.rotation()
        np.testing.assert_allclose(R_ref, R_expected.matrix(), rtol=0, atol=1e-14)
        np.testing.assert_allclose(p_ref, X_0.translation() + offset * amplitude, rtol=0, atol=1e-15)
        np.testing.assert_allclose(np.concatenate((w_ref, v_ref)),
                                   rate * np.concatenate((rotation_amplitude, amplitude)))
        # The stylus anywhere, up to a half turn from the reference (n = 0: at it).
        R_WE = R_expected if n == 0 else RotationMatrix(RollPitchYaw(rng.uniform(-3, 3, 3)))
        p_WE, w_WE, v_WE = rng.normal(0, 0.3, (3, 3))
        hand_wrench_into(R_WE.matrix(), p_WE, w_WE, v_WE, R_ref, p_ref, w_ref, v_ref, 800.0, 15.0, 2.0, 0.05,
                         error, quaternion, out)
        angle_axis = (R_expected @ R_WE.inverse()).ToAngleAxis()
        tau = 2.0 * angle_axis.angle() * angle_axis.axis() + 0.05 * (w_ref - w_WE)
        f = 800.0 * (p_ref - p_WE) + 15.0 * (v_ref - v_WE)
        np.testing.assert_allclose(out, np.concatenate((tau, f)), rtol=0, atol=1e-11)


@pytest.mark.parametrize("master", sorted(BUNDLED_MASTERS))
def test_the_hand_takes_the_stylus_pose_and_twist_from_the_masters_state_as_drake_has_them(master):
    """``OperatorHand`` finds the stylus's pose and twist from the master's joints (its own kinematics): its force
    equals ``hand_force_into`` of Drake's pose and spatial velocity of the stylus body, at random states."""
    plant = MakeMasterPlant(master)
    stylus = plant.GetFrameByName("stylus").body()
    spec = Scenario().operator
    hand = OperatorHand(plant, stylus, spec)
    context, plant_context = hand.CreateDefaultContext(), plant.CreateDefaultContext()
    reference = hand_record(spec, plant.EvalBodyPoseInWorld(plant_context, stylus))
    rng = np.random.default_rng(4)
    for t in (0.0, 0.31, 0.47):
        state = np.concatenate((rng.uniform(-0.8, 0.8, plant.num_positions()),
                                rng.normal(0, 2, plant.num_velocities())))
        plant.SetPositionsAndVelocities(plant_context, state)
        hand.get_input_port().FixValue(context, state)
        context.SetTime(t)
        expected = np.empty(6)
        hand_force_into(t, plant.EvalBodyPoseInWorld(plant_context, stylus).GetAsMatrix34(),
                        plant.EvalBodySpatialVelocityInWorld(plant_context, stylus).get_coeffs(),
                        np.array(spec.stroke_scales, dtype=float), reference, expected)
        force, = hand.get_output_port().Eval(context)
        assert force.body_index == stylus.index()
        np.testing.assert_allclose(force.F_Bq_W.get_coeffs(), expected, rtol=0, atol=1e-9)
        assert np.abs(expected).max() > 1.0  # the stylus away from its reference


def test_station_exports_the_design_ports(free_space):
    station = free_space.station
    inputs = {station.get_input_port(i).get_name() for i in range(station.num_input_ports())}
    outputs = {station.get_output_port(i).get_name() for i in range(station.num_output_ports())}
    assert inputs == STATION_PORTS["inputs"]
    assert STATION_PORTS["outputs"] <= outputs
    assert {"truth.wrench_contact", "truth.wrench_noncontact", "truth.acceleration", "truth.omega",
            "truth.gravity_S", "truth.ft_offsets", "truth.phi"} <= outputs


def test_true_phi_is_the_papers_tool(free_space):
    phi = free_space.out("truth.phi")
    assert phi[0] == pytest.approx(3.13)
    assert InertialParameters.from_phi(phi).is_physical()


def test_free_space_sensor_reads_the_load_dynamics(free_space):
    """Slave swinging fast in free space: the weld reaction equals V(a, α, ω, g)·φ from
    the sensor frame's true motion (our regressor, Drake's accelerations), and the ideal
    sensors hold exactly what they sampled at the start of the step."""
    run = free_space
    q0 = np.array(run.scenario.slave_initial_q)
    phi = run.out("truth.phi")
    worst_physics, worst_sensor, peak_dynamic = 0.0, 0.0, 0.0
    for _ in range(600):
        t = run.context.get_time()
        run.command(q0 + 0.25 * (1 - np.cos(2 * np.pi * 2.0 * t)) * np.array([1, -1, 1, 1, 1, 1]))
        reaction, accel = run.out("truth.wrench_sensor"), run.out("truth.acceleration")
        omega, g = run.out("truth.omega"), run.out("truth.gravity_S")
        expected = regressor(accel[:3], accel[3:], omega, g) @ phi
        worst_physics = max(worst_physics, np.abs(reaction - expected).max())
        peak_dynamic = max(peak_dynamic, np.abs(reaction[:3] + 3.13 * g).max())
        run.advance()
        worst_sensor = max(worst_sensor, np.abs(run.out("ft.wrench_measured") - reaction).max(),
                           np.abs(run.out("ft.acceleration_measured") - np.hstack((accel[:3] - g, accel[3:]))).max())
        np.testing.assert_array_equal(run.out("truth.wrench_contact"), np.zeros(6))
    assert peak_dynamic > 5.0  # the motion was dynamic: inertial force beyond the weight
    assert worst_physics < 1e-6
    assert worst_sensor < 1e-9


def test_hanging_still_the_accelerometer_reads_one_g_upwards():
    """A real accelerometer reports specific force a − g: at rest, 9.81 m/s² pointing up."""
    run = Run(ideal(Scenario()))
    for _ in range(3):
        run.step()
    plant = run.station.GetSubsystemByName("slave_plant")
    R_WS = plant.GetFrameByName("S").CalcPoseInWorld(plant.GetMyContextFromRoot(run.context)).rotation().matrix()
    reading = run.out("ft.acceleration_measured")
    np.testing.assert_allclose(R_WS @ reading[:3], [0.0, 0.0, 9.81], atol=1e-3)
    np.testing.assert_allclose(reading[3:], 0.0, atol=1e-3)


def test_slave_servo_tracks_its_command(free_space):
    run = free_space
    target = np.array(run.scenario.slave_initial_q) + [0.05, -0.05, 0.05, 0.1, -0.1, 0.1]
    for _ in range(1000):
        run.step(target)
    np.testing.assert_allclose(run.out("truth.slave_position"), target, atol=2e-4)
    np.testing.assert_allclose(run.out("slave.velocity_estimated"), 0, atol=1e-3)
    step = 2 * np.pi / run.scenario.encoder_counts_per_rev
    measured = run.out("slave.position_measured")
    np.testing.assert_allclose(measured / step, np.round(measured / step), atol=1e-6)
    assert np.abs(measured - run.out("truth.slave_position")).max() <= step / 2 + 1e-12


def tip_lowered(scenario, depths):
    """Joint angles that move the tool tip straight down by each of ``depths`` (m),
    orientation kept (Newton steps on Drake's kinematics, warm-started)."""
    plant = MultibodyPlant(0.0)
    AddSlave(plant, scenario)
    plant.Finalize()
    context = plant.CreateDefaultContext()
    tip = plant.GetFrameByName("tool_tip")
    q = np.array(scenario.slave_initial_q, dtype=float)
    plant.SetPositions(context, q)
    X_start = tip.CalcPoseInWorld(context)
    solutions = []
    for dz in depths:
        for _ in range(10):
            plant.SetPositions(context, q)
            X = tip.CalcPoseInWorld(context)
            rotation_error = (X_start.rotation() @ X.rotation().inverse()).ToAngleAxis()
            error = np.concatenate((rotation_error.angle() * rotation_error.axis(),
                                    X_start.translation() - [0, 0, dz] - X.translation()))
            J = plant.CalcJacobianSpatialVelocity(context, JacobianWrtVariable.kQDot, tip, np.zeros(3),
                                                  plant.world_frame(), plant.world_frame())
            q = q + np.linalg.solve(J, error)
        solutions.append(q.copy())
    return solutions


def test_contact_with_the_sheet_spring(sheet_spring):
    """Pressing the ball into the plate: the sensor reads V·φ plus the contact wrench,
    the contact force is vertical and equals the spring's k·deflection at rest."""
    run = sheet_spring
    plant = run.station.GetSubsystemByName("slave_plant")
    plant_context = plant.GetMyContextFromRoot(run.context)
    slide = plant.GetJointByName("plate_slide")
    phi = run.out("truth.phi")
    # 15 mm straight down in 1.5 s (5 mm gap, then 10 mm into the spring), then hold.
    waypoints = tip_lowered(run.scenario, np.linspace(0, 0.015, 31))
    for k in range(3000):
        s = min(k / 1500, 1.0) * 30
        i = min(int(s), 29)
        run.step(waypoints[i] + (s - i) * (waypoints[i + 1] - waypoints[i]))
        reaction, contact = run.out("truth.wrench_sensor"), run.out("truth.wrench_contact")
        accel, omega, g = run.out("truth.acceleration"), run.out("truth.omega"), run.out("truth.gravity_S")
        np.testing.assert_allclose(reaction, regressor(accel[:3], accel[3:], omega, g) @ phi + contact, atol=1e-6)
    deflection = -slide.get_translation(plant_context)
    assert deflection > 0.005  # the plate was pushed down by several millimetres
    R_WS = plant.GetFrameByName("S").CalcPoseInWorld(plant_context).rotation().matrix()
    f_env_W = -R_WS @ run.out("truth.wrench_contact")[:3]  # the plate's push on the ball
    k = run.scenario.environment.stiffness
    assert f_env_W[2] == pytest.approx(k * deflection, rel=0.02)
    assert abs(f_env_W[1]) < 1e-6 * f_env_W[2]  # the motion is in the arm's x-z plane
    assert abs(f_env_W[0]) < f_env_W[2]  # the rest is friction, inside the cone (μ ≤ 1)


def stylus_height(run):
    master = run.station.GetSubsystemByName("master_plant")
    context = master.GetMyContextFromRoot(run.context)
    return master.EvalBodyPoseInWorld(context, master.GetBodyByName("stylus")).translation()[2]


def operator_run(amplitude_z):
    return Run(layered(ideal(Scenario()), overrides_text({
        "environment.kind": "none", "operator.amplitude": [0.0, 0.0, amplitude_z], "operator.frequency": 0.5,
        "operator.start_time": 0.0})))


def test_operator_pulls_the_stylus_along_its_reference():
    """Device torque off: the stylus follows the hand's reference up by 2 cm."""
    run = operator_run(0.02)
    z0 = stylus_height(run)
    for _ in range(2000):  # half a period: the reference is at its top, at rest
        run.step()
    assert stylus_height(run) - z0 == pytest.approx(0.02, abs=0.002)


def test_each_stroke_has_its_own_depth_and_the_reference_stays_smooth():
    """Stroke k of the reference reaches stroke_scales[k] of the amplitude (the last scale
    repeating); position and rate are continuous where one stroke hands over to the next
    (both strokes end and start at rest at the start pose)."""
    amplitude, f, t0, scales = np.array([0.0, 0.0, -0.05]), 2.0, 0.1, [1.0, 0.75]
    assert stroke_windows(t0, f, 1.6) == [(0.1, 0.6), (0.6, 1.1), (1.1, 1.6)]
    for (start, end), scale in zip(stroke_windows(t0, f, 1.6), [1.0, 0.75, 0.75]):
        offset, rate = smooth_sine_offset(0.5 * (start + end), t0, f, amplitude, scales)
        np.testing.assert_allclose(offset, scale * amplitude, atol=1e-15)
        np.testing.assert_allclose(rate, 0.0, atol=1e-15)
    peak_rate = np.pi * f * 0.05
    for boundary in (0.6, 1.1):
        before = smooth_sine_offset(boundary - 1e-9, t0, f, amplitude, scales)
        after = smooth_sine_offset(boundary, t0, f, amplitude, scales)
        for a, b in zip(before, after):
            np.testing.assert_allclose(a, b, atol=1e-7 * peak_rate)
    assert not smooth_sine_offset(t0 - 1e-9, t0, f, amplitude, scales)[0].any()


def test_operator_yields_to_a_rendered_force_by_its_stiffness():
    """A constant 2 N downward force rendered through Jᵀ moves the held stylus by F/k."""
    run = operator_run(0.0)
    scenario = run.scenario
    z = stylus_height(run)
    master = run.station.GetSubsystemByName("master_plant")
    master_context = master.GetMyContextFromRoot(run.context)
    stylus = master.GetBodyByName("stylus")
    J = master.CalcJacobianTranslationalVelocity(master_context, JacobianWrtVariable.kV, stylus.body_frame(),
                                                 np.zeros(3), master.world_frame(), master.world_frame())
    force = np.array([0.0, 0.0, -2.0])
    for _ in range(1500):
        run.step(torque=J.T @ force)
    assert z - stylus_height(run) == pytest.approx(2.0 / scenario.operator.stiffness, rel=0.05)


def test_custom_and_gripper_loads_give_their_parameters():
    custom = layered(Scenario(), overrides_text({
        "load.kind": "custom", "load.mass": 1.2, "load.com": [0.01, 0.02, 0.08],
        "load.inertia_com": [0.004, 0.0, 0.0, 0.005, 0.0, 0.003]}))
    plant = MultibodyPlant(0.0)
    parts = AddSlave(plant, custom)
    plant.Finalize()
    M = plant.CalcSpatialInertia(plant.CreateDefaultContext(), parts.S, [b.index() for b in parts.load_bodies])
    expected = InertialParameters(1.2, [0.01, 0.02, 0.08], np.diag([0.004, 0.005, 0.003]))
    np.testing.assert_allclose(M.CalcRotationalInertia().CopyToFullMatrix3(), expected.inertia_origin, atol=1e-12)
    gripper = layered(Scenario(), overrides_text({"load.kind": "gripper_object"}))
    station = MakeSimStation(ideal(gripper))
    context = station.CreateDefaultContext()
    phi, phi_gripper = (station.GetOutputPort(n).Eval(context) for n in ("truth.phi", "truth.phi_gripper"))
    obj = InertialParameters.from_phi(phi) - InertialParameters.from_phi(phi_gripper)
    assert obj.mass == pytest.approx(0.5024, rel=1e-6) and obj.is_physical()


def test_non_physical_custom_load_is_rejected():
    scenario = layered(Scenario(), overrides_text({
        "load.kind": "custom", "load.inertia_com": [0.001, 0, 0, 0.001, 0, 0.01]}))  # violates the triangle inequality
    with pytest.raises(ValueError, match="load are not physical: triangle inequality"):
        MakeSimStation(scenario)


# --- scenario files -----------------------------------------------------------

def test_scenario_file_round_trip(tmp_path):
    path = tmp_path / "s.yaml"
    path.write_text("robot: rx60\nload: {kind: custom, mass: 2.0}\nenvironment: {kind: none}\n"
                    "ft_sensor: {noise: false}\noperator: {stiffness: 250.0}\n")
    scenario = load_scenario(path)
    assert scenario.robot == "rx60" and scenario.load.mass == 2.0 and scenario.environment.kind == "none"
    assert scenario.ft_sensor.noise is False and scenario.operator.stiffness == 250.0


@pytest.mark.parametrize("text,field", [
    ("operator: {stiffness: soft}\n", "operator.stiffness"),
    ("load: {knd: tool}\n", "load.knd"),
    ("environment: {stiffness: -5.0}\n", "environment.stiffness"),
    ("slave_initial_q: [0, 1]\n", "slave_initial_q"),
    ("robot: kuka\n", "robot"),
    ("ft_sensor: {noise_rms: 0.1}\n", "ft_sensor.noise_rms"),
    ("load: {mount: {torque_stiffness: [3000, 0, 3000]}}\n", "load.mount.torque_stiffness"),
    ("load: {mount: {force_damping: [1, 1]}}\n", "load.mount.force_damping"),
    ("accelerometer: {position: [0.1, 0.2]}\n", "accelerometer.position"),
    ("ft_sensor: {lowpass_cutoff: 1500.0}\n", "ft_sensor.lowpass_cutoff"),
    ("slave_velocity_filter: -1.0\n", "slave_velocity_filter"),
])
def test_malformed_scenario_names_the_field(tmp_path, text, field):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(ValueError, match=f"'{field}'"):
        load_scenario(path)


def test_scenario_that_is_not_yaml(tmp_path):
    path = tmp_path / "broken.yaml"
    path.write_text("robot: rx90\n  load: [\n")
    with pytest.raises(ValueError, match="not valid YAML"):
        load_scenario(path)
    with pytest.raises(ValueError, match="does not exist"):
        load_scenario(tmp_path / "missing.yaml")


def test_overrides_are_yaml_laid_over_the_scenario():
    """One override path: dotted names → YAML → laid over the scenario; the rest is kept."""
    from heft.diagrams.scenario import layered, overrides_text, resolve_scenario

    base = resolve_scenario("fig6")
    changed = resolve_scenario("fig6", overrides_text({"controller.force.gamma": 0.5, "duration": 3.0,
                                                       "controller.force.eta": None}))
    assert (changed.controller.force.gamma, changed.duration) == (0.5, 3.0)
    assert changed.controller.force.eta == base.controller.force.eta
    assert changed.operator == base.operator and changed.controller.motion == base.controller.motion
    assert base.controller.force.gamma == 1.0  # the base is not touched
    with pytest.raises(ValueError, match="controller.delay"):
        layered(base, "{controller: {delay: 0.0001}}")  # not a whole number of periods


def test_the_grasp_adds_the_objects_weight_at_the_sensor_and_in_the_truth():
    """A gripper_object load with a grasp: holding nothing, the sensor carries the gripper's
    weight and truth.phi is the gripper's; holding, both grow by the object (Drake's reaction)."""
    from heft.diagrams.scenario import overrides_text, resolve_scenario
    from heft.diagrams.stations.sim_station import set_holding

    scenario = resolve_scenario("grasp", overrides_text({"ft_sensor.noise": False, "accelerometer.noise": False}))
    run = Run(scenario)
    weights = []
    for holding in (False, True):
        set_holding(run.station, run.context, holding)
        for _ in range(400):
            run.step()
        weights.append((np.linalg.norm(run.out("truth.wrench_sensor")[:3]), run.out("truth.phi")[0]))
    m_gripper = run.out("truth.phi_gripper")[0]
    (w_empty, m_empty), (w_full, m_full) = weights
    assert m_empty == pytest.approx(m_gripper) and m_full == pytest.approx(m_gripper + 0.5024, rel=1e-6)
    assert w_empty == pytest.approx(9.81 * m_empty, rel=1e-3) and w_full == pytest.approx(9.81 * m_full, rel=1e-3)


def test_drakes_own_configs_live_in_the_scenario():
    """plant (MultibodyPlantConfig) and simulator (SimulatorConfig) load like any field, keep the
    defaults they are not given, and a contact model the truth cannot sum is refused by name."""
    from heft.diagrams.scenario import layered, resolve_scenario

    scenario = resolve_scenario("fig6", "{plant: {time_step: 0.001}, simulator: {target_realtime_rate: 1.0}}")
    assert scenario.plant.time_step == 0.001 and scenario.plant.contact_model == "point"
    assert scenario.simulator.target_realtime_rate == 1.0
    station = MakeSimStation(scenario)
    assert station.GetSubsystemByName("slave_plant").time_step() == 0.001
    with pytest.raises(ValueError, match="plant.contact_model"):
        layered(scenario, "{plant: {contact_model: hydroelastic}}")


# --- the realistic station ------------------------------------------------------------------

@pytest.fixture
def compliant():
    """The default (realistic) station, noise-free sensors, free space, at its start (a test steps it)."""
    scenario = layered(Scenario(), overrides_text({**NOISE_OFF, "environment.kind": "none"}))
    assert not scenario.load.mount.rigid
    return Run(scenario)


def test_on_its_compliant_mount_the_load_starts_at_rest_under_its_weight(compliant):
    """The mount starts at its static sag (no ringing when the run begins): the sensor reads the
    tool's weight from the first step on, f = −m·g_S (closed form), steady to a micro-newton."""
    run = compliant
    readings = []
    for _ in range(200):
        run.step()
        readings.append(run.out("truth.wrench_sensor"))
    readings = np.array(readings)
    np.testing.assert_allclose(readings[:, :3], np.tile(-3.13 * run.out("truth.gravity_S"), (200, 1)), atol=1e-5)
    assert np.ptp(readings, axis=0).max() < 1e-6


def test_on_a_compliant_mount_the_sensor_reads_the_load_frames_dynamics_not_S(compliant):
    """Swinging the arm, the load rocks on its mount: the weld's reaction (Drake) is V·φ of the
    load frame's own motion moved to S (``truth.wrench_noncontact``), while V·φ of S's motion,
    what the paper's model and the controller compute, misses newtons of it."""
    run = compliant
    q0 = np.array(run.scenario.slave_initial_q)
    phi = run.out("truth.phi")
    worst_truth, worst_rigid_model = 0.0, 0.0
    for _ in range(600):
        t = run.context.get_time()
        run.command(q0 + 0.25 * (1 - np.cos(2 * np.pi * 2.0 * t)) * np.array([1, -1, 1, 1, 1, 1]))
        reaction = run.out("truth.wrench_sensor")
        worst_truth = max(worst_truth, np.abs(reaction - run.out("truth.wrench_noncontact")).max())
        accel, omega, g = run.out("truth.acceleration"), run.out("truth.omega"), run.out("truth.gravity_S")
        worst_rigid_model = max(worst_rigid_model,
                                np.abs(reaction - regressor(accel[:3], accel[3:], omega, g) @ phi)[:3].max())
        run.advance()
    assert worst_truth < 1e-6
    assert worst_rigid_model > 0.5


def test_on_a_compliant_mount_the_objects_share_is_its_own_dynamics():
    """The gripper holding its object rocks on the mount: ``truth.wrench_noncontact_object`` is
    the wrench the gripper exerts on the object (Drake's reaction at their weld) moved to S's
    origin in S, while V·φ_object of S's own motion misses part of it."""
    run = Run(layered(Scenario(), overrides_text({**NOISE_OFF, "environment.kind": "none",
                                                  "load.kind": "gripper_object"})))
    plant = run.station.GetSubsystemByName("slave_plant")
    obj = plant.GetBodyByName("object")
    (weld,) = [plant.get_joint(j) for j in plant.GetJointIndices()
               if plant.get_joint(j).child_body() is obj]
    S = plant.GetFrameByName("S")
    phi_object = run.out("truth.phi") - run.out("truth.phi_gripper")
    assert phi_object[0] > 0.4  # held: the object's 0.5 kg
    q0 = np.array(run.scenario.slave_initial_q)
    worst_truth, worst_rigid_model = 0.0, 0.0
    for _ in range(600):
        t = run.context.get_time()
        run.command(q0 + 0.25 * (1 - np.cos(2 * np.pi * 2.0 * t)) * np.array([1, -1, 1, 1, 1, 1]))
        context = plant.GetMyContextFromRoot(run.context)
        F_Jc = plant.get_reaction_forces_output_port().Eval(context)[int(weld.index())]
        X_SJc = plant.CalcRelativeTransform(context, S, weld.frame_on_child())
        f = X_SJc.rotation() @ F_Jc.translational()
        tau = X_SJc.rotation() @ F_Jc.rotational() + np.cross(X_SJc.translation(), f)
        on_object = np.concatenate((f, tau))
        worst_truth = max(worst_truth, np.abs(on_object - run.out("truth.wrench_noncontact_object")).max())
        accel, omega, g = run.out("truth.acceleration"), run.out("truth.omega"), run.out("truth.gravity_S")
        worst_rigid_model = max(worst_rigid_model, np.abs(
            on_object - regressor(accel[:3], accel[3:], omega, g) @ phi_object)[:3].max())
        run.advance()
    print(f"object's share: truth within {worst_truth:.1e} N of Drake's reaction; V·φ_object of S's motion "
          f"off by {worst_rigid_model:.2f} N")
    assert worst_truth < 1e-6
    assert worst_rigid_model > 0.5


def test_the_accelerometer_sits_where_the_scenario_says():
    """The realistic station's accelerometer is displaced from S: its reading (its filter off) is
    the specific force of that point (Drake's S acceleration shifted there), and the conversion
    back to S recovers S's own motion."""
    run = Run(layered(Scenario(), overrides_text({**NOISE_OFF, "environment.kind": "none",
                                                  "accelerometer.lowpass_cutoff": 0.0})))
    q0 = np.array(run.scenario.slave_initial_q)
    convention = run.scenario.accelerometer.convention()
    assert convention.displaced
    worst, peak = 0.0, 0.0
    for _ in range(300):
        t = run.context.get_time()
        run.command(q0 + 0.3 * (1 - np.cos(2 * np.pi * 2.0 * t)) * np.array([1, 1, 1, 1, 1, 1]))
        accel, omega, g = run.out("truth.acceleration"), run.out("truth.omega"), run.out("truth.gravity_S")
        run.advance()
        reading = run.out("ft.acceleration_measured")
        shifted = SpatialAcceleration(accel[3:], accel[:3]).Shift(np.array(convention.p_SA), omega)
        worst = max(worst, np.abs(reading[:3] - (shifted.translational() - g)).max())
        worst = max(worst, np.abs(motion_from_reading(np.empty(6), reading, g, omega, convention) - accel).max())
        peak = max(peak, np.linalg.norm(np.cross(omega, np.cross(omega, convention.p_SA))))
    assert worst < 1e-9
    assert peak > 0.01  # the displacement mattered (m/s²)


@pytest.mark.parametrize("kind", ["tool", "gripper_object"])
def test_the_default_mount_notch_sits_at_the_bundled_loads_rocking_modes(kind):
    """``MOUNT_ROCKING_HZ``, where the default controller notches the contact wrench, lies within
    5 % of both rocking modes (the two lowest) of each bundled load on the default mount."""
    from heft.diagrams.scenario import MOUNT_ROCKING_HZ

    scenario = layered(Scenario(), overrides_text({"load.kind": kind, "environment.kind": "none"}))
    station = MakeSimStation(scenario)
    found = modes_on_fixed_sensor(station.GetOutputPort("truth.phi").Eval(station.CreateDefaultContext()),
                                  mount_for(scenario))
    np.testing.assert_allclose(found.frequencies[:2], MOUNT_ROCKING_HZ, rtol=0.05)


def test_the_load_rings_on_its_mount_at_the_mounts_rocking_mode():
    """Tapped about S's x axis, the load rocks on its mount at the frequency of the mount's modal
    analysis (closed form: the generalized eigenproblem K·x = ω²·M·x of the bushing's stiffness and
    the load's spatial inertia about S), the arm's servo made a hundred times stiffer so that the
    sensor is nearly the fixed base the analysis assumes."""
    stiff_servo = [100 * k for k in Scenario().slave_servo_stiffness]
    scenario = layered(Scenario(), overrides_text({**NOISE_OFF, "environment.kind": "none",
                                                   "slave_servo_stiffness": stiff_servo}))
    run = Run(scenario)
    found = modes_on_fixed_sensor(run.out("truth.phi"), mount_for(scenario))
    rocking_x = np.argmax(np.abs(found.shapes[0]) / np.linalg.norm(found.shapes, axis=0))
    expected = found.frequencies[rocking_x]
    assert 20 < expected < 100  # "tens of Hz"

    plant = run.station.GetSubsystemByName("slave_plant")
    plant.GetJointByName("mount").set_angular_velocity(plant.GetMyMutableContextFromRoot(run.context),
                                                       [0.05, 0.0, 0.0])
    torque = []
    for _ in range(1000):
        run.step()
        torque.append(run.out("truth.wrench_sensor")[3])
    torque = np.array(torque) - np.mean(torque)
    period = scenario.controller_period
    frequencies = np.fft.rfftfreq(8 * len(torque), period)
    spectrum = np.abs(np.fft.rfft(torque * np.hanning(len(torque)), 8 * len(torque)))
    band = frequencies > 10.0  # above the arm's own slow motion
    measured = frequencies[band][np.argmax(spectrum[band])]
    print(f"rocking mode: {measured:.1f} Hz in the station, {expected:.1f} Hz by modal analysis")
    assert measured == pytest.approx(expected, rel=0.03)


def test_a_gripper_set_empty_at_the_start_starts_at_rest_on_its_mount():
    """The station is built holding the object; a run that starts before the grasp takes the
    object away at the start (``set_holding(..., at_start=True)``): the mount settles again to the
    gripper's own sag, so at the start the sensor reads the gripper's weight alone (not the
    spring force of the holding sag, the object's 4.9 N more). (The arm's servo then takes up
    the weight its feed-forward expected, which moves it a little.)"""
    from heft.diagrams.stations.sim_station import set_holding

    scenario = layered(Scenario(), overrides_text({**NOISE_OFF, "environment.kind": "none",
                                                   "load.kind": "gripper_object", "load.grasp_at": 1.0}))
    station = MakeSimStation(scenario)
    context = station.CreateDefaultContext()
    station.GetInputPort("master.torque_commanded").FixValue(context, np.zeros(6))
    station.GetInputPort("slave.position_commanded").FixValue(context, scenario.slave_initial_q)
    set_holding(station, context, False, at_start=True)
    gripper_mass = station.GetOutputPort("truth.phi_gripper").Eval(context)[0]
    g_S = station.GetOutputPort("truth.gravity_S").Eval(context)
    np.testing.assert_allclose(station.GetOutputPort("truth.wrench_sensor").Eval(context)[:3], -gripper_mass * g_S,
                               atol=1e-6)
