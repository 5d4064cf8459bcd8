"""The controller of Fig. 4 as one computation per tick, for the hardware's real-time loop.

``RealtimeTeleopController`` composes the same block cores as the per-block
Diagram (``diagrams.teleop.MakeTeleopController``) — master kinematics, slave
kinematics, motion scaling, slave IK, force scaling/elimination, feedback
mapping, passivity controller — in one ``step`` per tick, with the measured
tick duration ``dt`` (s) wherever a block uses its period: slews, speed limits,
the fault decay, the passivity observer's hold. The arithmetic of each block
lives in its own module as a kernel; this one only orders the calls, in a kernel
of its own (``controller_step``: one call from Python a tick), and holds the state
a Diagram Context would hold, in one record (``STEP_STATE``). With
``controller.estimator.mode: online`` φ̂ is learned in the loop
(``online_estimator``, the Diagram's gate, prefilter and RLS), and a grasp
(``grasp``/``release``) splits it into the gripper's φ_gr and the object's, as the
simulation's grasp does (Eq. 14).

Timing against the per-block Diagram: there every block is sampled at the same
tick, so the slave command of tick k is computed from the desired pose of tick
k − 1. Here motion scaling and IK run in sequence within the tick, so the slave
command leaves one tick earlier; the master torque is the same tick in both.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix
from pydrake.multibody.plant import MultibodyPlant

from heft.systems.accelerometer_reading import (AccelerometerConvention, kernel_convention, motion_from_reading,
                                                motion_from_reading_into)
from heft.systems.contact_threshold import ContactThresholdParams
from heft.systems.load_estimation_params import LoadEstimationParams
from heft.systems.compiled import compiled, float_array, record_views
from heft.systems.feedback_mapping import FeedbackMappingParams, rendered_wrench_into, rotation_product_into
from heft.systems.force_scaling import (
    CONTACT,
    EVALUATION_SIZE,
    FAULT,
    FEEDBACK,
    MEMORY_SIZE,
    NONCONTACT,
    ForceScalingParams,
    decay_factor,
    evaluate_into,
    initial_memory,
    next_memory_and_scales_into,
    notch_coefficients,
)
from heft.systems.master_kinematics import BASE_FRAME, STYLUS_FRAME
from heft.systems.serial_chain import GRAVITY, OMEGA, SerialChain, chain_dtype, chain_kinematics
from heft.systems.motion_scaling import IDENTITY_POSE, MotionScalingParams, motion_scaling_step
from heft.systems.online_estimator import OnlineLoadEstimator
from heft.systems.load_dynamics import GRAVITY_W, checked_load, regressor
from heft.systems.offset_tracking import (KERNEL_SETTINGS, OFFSETS, REQUESTS, STATE_SIZE, STATUS, TRACKING,
                                          WINDOW_TIME, OffsetTrackingParams, initial_state, offsets_update_into,
                                          restart_rezero_window)
from heft.systems.passivity_controller import PassivityParams, master_torque_into
from heft.systems.pose_vectors import POSE_SIZE, pose_into
from heft.systems.rx_inverse_kinematics import UNREACHABLE, RxKinematics
from heft.systems.slave_inverse_kinematics import IK_STEP, IkStep, ik_step
from heft.systems.slave_kinematics import NUM_JOINTS


class RealtimeTeleopController:
    """Fig. 4 in one ``step`` per tick (module docstring).

    ``master`` is the finalized Phantom plant (frames ``phantom_base`` B and ``stylus`` E),
    ``slave`` a finalized plant of arm + wrist sensor with frames ``base_frame`` (R) and
    ``S``; ``kinematics`` the arm's closed-form IK, ``X_FS`` the pose of S in the flange
    (the tool frame T of the motion mapping is S); ``phi`` (10) and ``offsets`` (6) the
    load model φ̂ and [f_o; τ_o] (N, N·m). Every step brings its own ``dt``; the mount notch
    is designed for the nominal ``period`` (s), kept as ``period``.

    After ``step``: ``torque`` τ_M (6, N·m) and ``position`` q̄_S (6, rad; one array, overwritten by each
    step), plus what the per-block Diagram logs: ``wrench_feedback``/``wrench_contact``/``wrench_noncontact``
    (6 each, at S in S), ``master_wrench`` (6, on the hand at E in B, as mapped),
    ``applied_wrench`` (6, as applied after the passivity controller and the device
    limits), ``pose_RS_desired`` (7), ``energy``/``damping`` (2 each, the passivity
    observer's), ``reachable``, ``force_fault``, ``scales`` (3: σ, γ, η in effect). The
    requested σ, γ, η are ``force``'s; the load model changes at run time through
    ``request_rezero``, ``set_tracking``, ``set_load``, ``grasp`` and ``release``.
    ``contact`` (``controller.contact``) judges contact for offset tracking and the estimator's gate;
    ``estimator`` (``controller.estimator``) fixes φ̂ or learns it online (``estimator``: the
    ``OnlineLoadEstimator``, None when fixed).
    """

    def __init__(self, master: MultibodyPlant, slave: MultibodyPlant, base_frame: str, kinematics: RxKinematics,
                 X_FS: RigidTransform, phi, offsets, motion: MotionScalingParams, force: ForceScalingParams,
                 feedback: FeedbackMappingParams, passivity: PassivityParams, offsets_tracking: OffsetTrackingParams,
                 contact: ContactThresholdParams, accelerometer: AccelerometerConvention, period: float,
                 estimator: LoadEstimationParams | None = None):
        for params in (motion, force, feedback, passivity, offsets_tracking, contact):
            params.validate()
        phi, offsets = checked_load(phi, offsets)
        self._master = SerialChain(master, master.GetFrameByName(BASE_FRAME), master.GetFrameByName(STYLUS_FRAME))
        self._slave = SerialChain(slave, slave.GetFrameByName(base_frame), slave.GetFrameByName("S"),
                                  GRAVITY_W)  # R = W
        self._kinematics, self._ik_step = kinematics, IkStep(kinematics, X_FS.inverse())
        online = estimator is not None and estimator.mode == "online"
        self.estimator = OnlineLoadEstimator(estimator, contact, phi, period) if online else None
        self._phi = self.estimator.phi if online else phi.copy()  # the estimator's, updated in place
        self._state, arrays = record_views(STEP_STATE)
        self._arrays = arrays
        self._offset_state = arrays["offset_state"]
        self._offset_state[:] = initial_state(offsets, offsets_tracking)
        self._offsets = self._offset_state[OFFSETS]  # a view: updated in place by offsets_update_into
        self._rezero_requests = 0
        self.period = period
        notch = notch_coefficients(force.mount_notch, force.mount_notch_quality, period)
        if notch is not None:
            arrays["notch"][:], self._state["notched"] = notch, 1.0
        self._phi_gripper_given = None if force.phi_gripper is None else np.array(force.phi_gripper, dtype=float)
        self._phi_gripper = self._phi_gripper_given
        self._phi_gripper_held = np.zeros(10)  # φ_gr while an object is held
        self._motion = motion
        arrays["R_RB"][:] = RotationMatrix(RollPitchYaw(motion.R_RB)).matrix()
        arrays["R_BR"][:] = arrays["R_RB"].T  # R_RB's one home is the motion scaling's
        if passivity.enabled:
            arrays["max_damping"][:] = passivity.max_translational_damping, passivity.max_rotational_damping
        self._requested = (float(force.sigma), float(force.gamma), float(force.eta))
        settings = {"translation_scale": motion.translation_scale, "rotation_scale": motion.rotation_scale,
                    "fault_decay_time": force.fault_decay_time, "slew_rate": force.slew_rate,
                    "sigma": force.sigma, "gamma": force.gamma, "eta": force.eta,
                    "contact_force": contact.force, "contact_torque": contact.torque,
                    "force_scale": feedback.force_scale, "torque_scale": feedback.torque_scale,
                    "max_force": feedback.max_force, "max_torque": feedback.max_torque,
                    **{name: getattr(offsets_tracking, name) for name in KERNEL_SETTINGS}}
        for name, value in settings.items():
            self._state[name] = value
        self._accelerometer, self._convention = accelerometer, kernel_convention(accelerometer)
        self._evaluation, self._motion_S = arrays["evaluation"], arrays["motion_S"]
        self.torque, self.master_wrench, self.applied_wrench = arrays["torque"], arrays["master_wrench"], \
            arrays["applied_wrench"]
        self.energy, self.damping, self.scales = arrays["energy"], arrays["damping"], arrays["scales"]
        self.pose_RS_desired = arrays["pose_RS_desired"]
        self.reachable = True
        self.started = False

    def start(self, slave_position) -> None:
        """The state a fresh per-block Diagram has at initialization, with the slave measured
        at ``slave_position`` (6, rad): the desired pose is the slave's, the command is its
        position within the joint limits, the clutch disengaged, observers and memories empty."""
        slave_position = np.asarray(slave_position, dtype=float)
        if slave_position.shape != (NUM_JOINTS,) or not np.isfinite(slave_position).all():
            raise ValueError(f"the slave's start position must be {NUM_JOINTS} finite joint angles; "
                             f"got {slave_position}")
        self._slave.update(slave_position)
        arrays = self._arrays
        pose_into(self._slave.R, self._slave.p, self.pose_RS_desired)
        arrays["motion_memory"][:] = np.concatenate(([0.0, self._motion.translation_scale,
                                                      self._motion.rotation_scale], IDENTITY_POSE, IDENTITY_POSE))
        arrays["position"][:] = np.clip(slave_position, self._kinematics.lower, self._kinematics.upper)
        self.reachable = True
        arrays["force_memory"][:] = initial_memory()
        self.scales[:] = self._requested
        for name in ("energy", "damping", "torque", "master_wrench", "applied_wrench", "dissipated"):
            arrays[name][:] = 0.0
        if self.estimator is not None:
            self.estimator.restart_prefilter()
        self.started = True

    @property
    def position(self) -> np.ndarray | None:
        """q̄_S (6, rad): the slave command of the last step (one array, overwritten by each); None before
        ``start``."""
        return self._arrays["position"] if self.started else None

    def step(self, dt: float, master_position, master_velocity, slave_position, slave_velocity, wrench,
             acceleration, clutch: bool, input_age: float = 0.0) -> None:
        """One tick of ``dt`` s (≥ 0) on the station's readings: q_M, q̇_M (rad, rad/s), q_S, q̇_S
        (rad, rad/s), the wrench [f; τ] the sensor exerts on the load and the accelerometer's reading
        (``accelerometer_reading``; in S's axes), the clutch engaged, the oldest of them ``input_age`` s
        old (the online estimator does not learn from stale readings: ``OnlineLoadEstimator.step``).
        Updates ``torque``, ``position`` and the logged signals."""
        if not self.started:
            raise RuntimeError("RealtimeTeleopController.step before start(): start it from the measured "
                               "slave position once the station is healthy")
        phi_gripper = self._phi_gripper
        status = controller_step(
            dt, float_array(master_position), float_array(master_velocity), float_array(slave_position),
            float_array(slave_velocity), float_array(wrench), float_array(acceleration), clutch,
            self._rezero_requests, self._phi, _NO_GRIPPER if phi_gripper is None else phi_gripper,
            phi_gripper is not None, *self._convention, self._state, self._master.record, self._slave.record,
            self._ik_step.record)
        self.reachable = not status & UNREACHABLE
        if self.estimator is not None:  # φ̂ for the next tick
            evaluation, slave_motion = self._evaluation, self._slave.motion
            self.estimator.step(dt, evaluation[CONTACT], evaluation[NONCONTACT], self._motion_S,
                                slave_motion[OMEGA], slave_motion[GRAVITY], evaluation[FAULT] > 0.5, input_age)

    @property
    def wrench_feedback(self) -> np.ndarray:
        return self._evaluation[FEEDBACK]

    @property
    def wrench_contact(self) -> np.ndarray:
        return self._evaluation[CONTACT]

    @property
    def wrench_noncontact(self) -> np.ndarray:
        return self._evaluation[NONCONTACT]

    @property
    def force_fault(self) -> bool:
        return self._evaluation[FAULT] > 0.5

    # --- the load model at run time (offset_tracking) ----------------------------------

    @property
    def phi(self) -> np.ndarray:
        """φ̂ in use (10; Eq. 6)."""
        return self._phi

    @property
    def offsets(self) -> np.ndarray:
        """The offsets in use (6; N, N·m), tracked and re-zeroed as ``offset_tracking`` describes."""
        return self._offsets

    @property
    def rezero_status(self) -> int:
        """The re-zero status code (``offset_tracking.STATUS_TEXT``)."""
        return int(self._offset_state[STATUS])

    @property
    def rezero_requests_seen(self) -> int:
        """How many re-zero requests a step has taken up so far."""
        return int(self._offset_state[REQUESTS])

    @property
    def rezero_elapsed(self) -> float:
        """How long (s) the re-zero window under way has averaged (it restarts at 0)."""
        return float(self._offset_state[WINDOW_TIME])

    @property
    def gravity_S(self) -> np.ndarray:
        """Gravity in S (3, m/s²) at the slave's joints of the last step."""
        return self._slave.motion[GRAVITY]

    @property
    def accelerometer(self) -> AccelerometerConvention:
        """The accelerometer's convention in use, its bias as last measured (``set_accelerometer_bias``)."""
        return self._accelerometer

    def set_accelerometer_bias(self, bias, reading, gravity_S) -> None:
        """The accelerometer's biases (6: the linear channels' in its own axes and unit, the angular
        channels' in rad/s²; ``bias_at_rest``) from the next step on. The offsets measured at rest with the
        old biases, over readings averaging ``reading`` (6) under ``gravity_S`` (3, m/s² in S), hold the
        load's wrench of those biases: they give it back, o += (V_old − V_new)·φ̂ there, so the contact
        wrench at rest stays what it was."""
        new = dataclasses.replace(self._accelerometer, bias=tuple(float(x) for x in bias[:3]),
                                  angular_bias=tuple(float(x) for x in bias[3:]))
        gravity_S, at_rest = np.asarray(gravity_S, dtype=float), np.zeros(3)
        for convention, sign in ((self._accelerometer, 1.0), (new, -1.0)):
            motion = motion_from_reading(np.empty(6), reading, gravity_S, at_rest, convention)
            self._offsets += sign * (regressor(motion[:3], motion[3:], at_rest, gravity_S) @ self._phi)
        self._accelerometer, self._convention = new, kernel_convention(new)

    @property
    def tracking(self) -> bool:
        return bool(self._offset_state[TRACKING] > 0.5)

    def request_rezero(self) -> None:
        """Starts a re-zero at the next step (refused there if the slave moves or touches)."""
        self._rezero_requests += 1

    def set_tracking(self, on: bool) -> None:
        self._offset_state[TRACKING] = 1.0 if on else 0.0

    def set_load(self, phi, offsets) -> None:
        """A new tool: φ̂ (10) and offsets (6) from the next step on (``checked_load``, as at the
        start; a ValueError changes nothing); online, the estimator starts from it as from a new
        load. A re-zero under way restarts its window, so that it averages only with the new φ̂."""
        phi, offsets = checked_load(phi, offsets)
        if self.estimator is not None:
            self.estimator.start_from(phi)
        self._phi[:] = phi
        self._offsets[:] = offsets
        restart_rezero_window(self._offset_state)

    # --- the grasp (Eq. 14) --------------------------------------------------------------

    @property
    def holding(self) -> bool:
        """An object is held (since ``grasp``, until ``release``)."""
        return self._phi_gripper is self._phi_gripper_held

    @property
    def phi_gripper(self) -> np.ndarray | None:
        """φ_gr of the Eq. 14 split in use (10), or None (the load as one body)."""
        return self._phi_gripper

    def grasp(self) -> None:
        """The gripper closed on an object: φ̂ in use is kept as the gripper's φ_gr, the estimator
        learns the whole load from the next step (a new load: its learning window opens) and
        φ̂ − φ_gr is the object's, whose non-contact wrench is fed back scaled by η. A
        ValueError changes nothing: with the estimate fixed, or while already holding."""
        if self.estimator is None:
            raise ValueError("a grasp needs the load estimator online to learn the object; run the controller with "
                             "--set '{controller: {estimator: {mode: online}}}'")
        if self.holding:
            raise ValueError("the gripper already holds an object; release it first")
        self._phi_gripper_held[:] = self._phi
        self._phi_gripper = self._phi_gripper_held
        self.estimator.new_load()

    def release(self) -> None:
        """The gripper opened: φ̂ returns to the gripper's φ_gr kept at the grasp, from which the
        estimator starts as from a new load; the split returns to what it was before the grasp.
        A ValueError (nothing held) changes nothing."""
        if not self.holding:
            raise ValueError("the gripper holds nothing to release")
        self.estimator.start_from(self._phi_gripper_held)
        self._phi_gripper = self._phi_gripper_given



_NO_GRIPPER = np.zeros(10)

STEP_STATE = np.dtype(
    [(name, float, size) for name, size in (
        ("pose_BE", POSE_SIZE), ("pose_RS", POSE_SIZE), ("pose_scratch", POSE_SIZE),
        ("motion_memory", 3 + 2 * POSE_SIZE), ("pose_RS_desired", POSE_SIZE), ("position", NUM_JOINTS),
        ("evaluation", EVALUATION_SIZE), ("scales", 3), ("force_memory", MEMORY_SIZE), ("notch", 7),
        ("force_scratch", (7, 10)), ("offset_state", STATE_SIZE), ("motion_S", 6), ("R_RB", (3, 3)),
        ("R_BR", (3, 3)), ("R_BS", (3, 3)), ("master_wrench", 6), ("energy", 2), ("max_damping", 2),
        ("torque", NUM_JOINTS), ("applied_wrench", 6), ("damping", 2), ("dissipated", 2), ("twist", 6))]
    + [(name, float) for name in ("translation_scale", "rotation_scale", "fault_decay_time", "slew_rate", "notched",
                                  "sigma", "gamma", "eta", "contact_force", "contact_torque", "force_scale",
                                  "torque_scale", "max_force", "max_torque", *KERNEL_SETTINGS)])
"""What the controller holds for ``controller_step`` (a Diagram Context's share): the blocks' memories
and outputs, their scratch, and the settings (the notch's coefficients if ``notched``; the motion
mapping's R_RB and its transpose; the passivity controller's largest damping, zero when it is off)."""
_CHAIN, _IK = chain_dtype(NUM_JOINTS), IK_STEP


@compiled("int64(float64, float64[:], float64[:], float64[:], float64[:], float64[:], float64[:], boolean, int64, "
          "float64[:], float64[:], boolean, boolean, float64[:], float64[:, :], float64, float64[:], STATE[:], "
          "CHAIN[:], CHAIN[:], IK[:])", STATE=STEP_STATE, CHAIN=_CHAIN, IK=_IK)
def controller_step(dt, master_position, master_velocity, slave_position, slave_velocity, wrench, reading, clutch,
                    rezero_requests, phi, phi_gripper, split, includes_gravity, p_SA, R_SA, u, bias, state, master,
                    slave, ik):
    """``RealtimeTeleopController.step`` but the estimator's, as one kernel: the block kernels in the order
    of Fig. 4, on the controller's ``state`` (``STEP_STATE``), the two chains' (``SerialChain.record``) and
    the IK's (``IkStep.record``), in place. The accelerometer's convention as ``kernel_convention`` gives it.
    Returns the slave IK's status; leaves S's kinematic [a; α] from the reading in ``motion_S``."""
    s, m, a, k = state[0], master[0], slave[0], ik[0]  # item access: numba's records and numpy's alike
    R_RS, slave_motion = a["R"], a["motion"]
    chain_kinematics(m["axes"], m["points"], m["M_R"], m["M_p"], master_position, m["zeros"], m["zeros"],
                     m["gravity_B"], m["R"], m["p"], m["J"], m["motion"], m["work"])
    chain_kinematics(a["axes"], a["points"], a["M_R"], a["M_p"], slave_position, slave_velocity, a["zeros"],
                     a["gravity_B"], R_RS, a["p"], a["J"], slave_motion, a["work"])
    omega_S, gravity_S = slave_motion[OMEGA], slave_motion[GRAVITY]
    pose_BE, pose_RS, desired, position = s["pose_BE"], s["pose_RS"], s["pose_RS_desired"], s["position"]
    pose_into(m["R"], m["p"], pose_BE)
    pose_into(R_RS, a["p"], pose_RS)

    # Motion scaling, then the slave IK on this tick's desired pose.
    motion_scaling_step(s["motion_memory"], desired, pose_BE, clutch, pose_RS, s["translation_scale"],
                        s["rotation_scale"], s["R_RB"], s["pose_scratch"])
    status = ik_step(k["dh"], k["lower"], k["upper"], k["velocity"], k["band"], desired, k["R_TF"], k["p_TF"],
                     position, dt, position, k["work"])

    # Force scaling/elimination, offsets, feedback mapping, passivity controller.
    evaluation, offset_state, memory, scales = s["evaluation"], s["offset_state"], s["force_memory"], s["scales"]
    notch, notched = s["notch"], s["notched"] > 0.5
    evaluate_into(evaluation, wrench, reading, omega_S, gravity_S, phi, offset_state[OFFSETS], scales, memory,
                  decay_factor(dt, s["fault_decay_time"]), phi_gripper, split, includes_gravity, p_SA, R_SA, u, bias,
                  notch, notched, s["force_scratch"])
    next_memory_and_scales_into(memory, scales, evaluation, s["sigma"], s["gamma"], s["eta"], s["slew_rate"] * dt,
                                notch, notched)
    offsets_update_into(offset_state, evaluation[CONTACT], evaluation[FAULT] > 0.5, slave_velocity, dt,
                        s["rest_joint_speed"], s["rezero_window"], s["rezero_force"], s["rezero_torque"],
                        s["time_constant"], s["max_force_rate"], s["max_torque_rate"], s["contact_force"],
                        s["contact_torque"], float(rezero_requests))
    motion_from_reading_into(s["motion_S"], reading, gravity_S, omega_S, includes_gravity, p_SA, R_SA, u, bias)
    R_BS = s["R_BS"]
    rotation_product_into(s["R_BR"], R_RS, R_BS)
    max_force, max_torque, wrench_B = s["max_force"], s["max_torque"], s["master_wrench"]
    rendered_wrench_into(evaluation[FEEDBACK], R_BS, s["force_scale"], s["torque_scale"], max_force, max_torque,
                         wrench_B)
    master_torque_into(wrench_B, master_velocity, m["J"], s["energy"], dt, s["max_damping"], max_force, max_torque,
                       s["torque"], s["applied_wrench"], s["damping"], s["dissipated"], s["twist"])
    return status
