"""The running controller's load model over LCM: re-zero, offset tracking, tool change, grasp.

``LoadCommandServer`` (in the controller's process) takes ``heft_load_command``
messages once per tick and answers each with a ``heft_load_status``; it also
publishes one when a re-zero finishes or is refused, and when the object grasped
has been learned for the estimator's learning window. A grasp or release comes from
``heft load --grasp``/``--release`` or from the gripper's driver
(``gripper_state_reader``, ``gripper``); both are served alike. ``send_load_command``
(``load_command_sender``, in ``heft load``) sends one command and waits for the answers.
"""

from __future__ import annotations

import math

import lcm
import numpy as np

from heft.systems.accelerometer_calibration import unit_factor
from heft.systems.accelerometer_reading import PLAUSIBLE_BIAS, bias_at_rest
from heft.systems.load_dynamics import checked_load
from heft.systems.controller.offset_tracking import COLLECTING, DONE, STATUS_TEXT
from heft.systems.controller.rls_load_estimator import AT_REST

from heft.hardware_interface.gripper_state_reader import GRASP

from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.lcm_mailbox import LcmMailbox
from heft.hardware_interface.load_command_sender import ACTIONS
from heft.hardware_interface.lcmtypes import heft_load_command, heft_load_status

MAX_EVENTS = 1000
"""Load commands a run's summary lists at most."""


def _listed(values) -> str:
    """``values`` as an answer shows them: [a, b, c], four significant digits."""
    return "[" + ", ".join(f"{x:.4g}" for x in values) + "]"


class LoadCommandServer:
    """Serves load commands to ``controller`` (a ``diagrams.teleop_controller.TeleopController``) heard on ``bus``,
    answered on ``command_bus`` (default ``bus``); a new estimate must fit the sensor's range
    ``wrench_full_scale`` ([f; τ], N, N·m) and be physical (``checked_load``), else it is
    refused with the reason.

    ``serve(now_utime, healthy)`` once per tick: carries out every command that arrived and
    answers it; a re-zero is refused while the station is not healthy (the controller is
    not stepping). ``events`` lists what happened (utime, message) for the run's summary, the
    first ``MAX_EVENTS`` of them (a flood of commands grows nothing further)."""

    def __init__(self, bus: lcm.LCM, channels: LcmChannels, controller, wrench_full_scale,
                 command_bus: lcm.LCM | None = None):
        self._command_bus = bus if command_bus is None else command_bus
        self._full_scale = np.asarray(wrench_full_scale, dtype=float)
        self._channel, self._controller = channels.load_status.name, controller
        self._mail = LcmMailbox(bus, channels.load_command.name, keep=16)
        self._waiting: list[int] = []  # utimes of the re-zero commands whose outcome is not yet told
        self._at_rest = np.zeros(10)  # over the re-zero window: Σ accelerometer reading (6), Σ g_S (3), ticks
        self._window = 0.0  # the re-zero window's length (s) at the last tick
        self._requests_seen = controller.rezero_requests_seen
        self._grasps: list[int] = []  # utimes of the grasps whose object is still being learned
        self._estimates: list[int] = []  # utimes of the new estimates no tick has taken up yet
        self.events: list[tuple[int, str]] = []
        self.on_message = None
        """If set, called with (topic, message) for each command heard (``/load/command``) and each answer sent
        (``/load/status``): the live view's events (``analysis.topics.EVENT_TOPICS``)."""

    def serve(self, now_utime: int, healthy: bool, reading) -> None:
        """Once per tick, after the controller's step on the accelerometer's ``reading`` (6, as the driver
        sent it): carries out and answers the commands that arrived, and tells how a re-zero ended."""
        for payload in self._mail.take():
            try:
                command = heft_load_command.decode(payload)
            except Exception:  # whatever a malformed payload makes the generated decoder raise
                self._answer(now_utime, 0, False, "a message on the load command channel is not a heft_load_command")
                continue
            if self.on_message is not None:
                self.on_message("/load/command", command)
            accepted, message = self._apply(command, healthy, now_utime)
            if accepted is not None:
                self._answer(now_utime, command.utime, accepted, message)
        controller = self._controller
        if self._estimates and controller.estimates_taken == controller.estimates_requested:
            for utime in self._estimates:
                self._answer(now_utime, utime, True, f"new estimate in use: m = {controller.phi[0]:.4g} kg")
            self._estimates.clear()
        if healthy and controller.rezero_status == COLLECTING:  # the window advances with the steps
            self._average_at_rest(reading)
        seen = controller.rezero_requests_seen
        if seen > self._requests_seen and controller.rezero_status != COLLECTING:  # a re-zero ended
            self._requests_seen = seen
            status = controller.rezero_status
            message = STATUS_TEXT[status] + (self._calibrate_accelerometer() if status == DONE else "")
            for utime in self._waiting:
                self._answer(now_utime, utime, status == DONE, message)
            self._waiting.clear()
            self._at_rest[:], self._window = 0.0, 0.0
        if self._grasps and controller.estimator.since_reset >= controller.estimator.learning_window:
            message = self._object_learned()
            for utime in self._grasps:
                self._answer(now_utime, utime, True, message)
            self._grasps.clear()

    def _average_at_rest(self, reading) -> None:
        """Adds this tick's accelerometer reading and g_S to the re-zero window's sums (restarted with it)."""
        controller, sums = self._controller, self._at_rest
        if controller.rezero_elapsed < self._window:
            sums[:] = 0.0
        self._window = controller.rezero_elapsed
        sums[:6] += reading
        sums[6:9] += controller.gravity_S
        sums[9] += 1.0

    def _calibrate_accelerometer(self) -> str:
        """The accelerometer's biases measured over the re-zero window (``bias_at_rest``: the linear and the
        angular channels'), set in the controller; what was done, for the answer."""
        controller, sums = self._controller, self._at_rest
        if sums[9] == 0:
            return ""
        reading, gravity_S = sums[:6] / sums[9], sums[6:9] / sums[9]
        convention = controller.accelerometer
        bias = bias_at_rest(convention, reading, gravity_S)
        text = f"{_listed(bias[:3])} {convention.unit}"
        if np.abs(bias[:3]).max() * unit_factor(convention.unit) > PLAUSIBLE_BIAS:
            return (f"; accelerometer bias kept at {_listed(convention.bias)}: the reading at rest implies {text}, "
                    f"beyond any bias ({PLAUSIBLE_BIAS / 9.80665:g} g): check the scenario's accelerometer.R_SA and "
                    "unit against the IMU's mounting")
        controller.set_accelerometer_bias(bias, reading, gravity_S)
        return (f"; accelerometer bias {text} and {_listed(bias[3:])} rad/s^2 on its angular channels (was "
                f"{_listed(convention.bias)} and {_listed(convention.angular_bias)}) over {sums[9]:.0f} ticks")

    def gripper(self, now_utime: int, event: str) -> None:
        """Serves a grasp or release (``gripper_state_reader.GRASP``/``RELEASE``) the gripper's driver
        reported, as the same ``heft load`` action, answered with ``command_utime`` 0."""
        accepted, message = self._grasp_or_release(event == GRASP, 0)
        self._answer(now_utime, 0, accepted, f"gripper driver: {message}")

    def _object_learned(self) -> str:
        controller = self._controller
        if not controller.holding:
            return "the object was released before its learning window ended"
        estimator, gripper, phi = controller.estimator, controller.phi_gripper, controller.phi
        stale = (f"; {estimator.num_stale} ticks refused, their readings older than "
                 f"{1e3 * estimator.max_input_age:g} ms" if estimator.num_stale else "")
        if not estimator.num_samples:
            return (f"object not learned over {estimator.learning_window:g} s: no sample taken{stale}; until it is "
                    "(`heft load --grasp` again, the slave held still or moving steadily), its whole weight is felt as "
                    "contact")
        mass = phi[0] - gripper[0]
        centre = (phi[1:4] - gripper[1:4]) / mass if mass > 0 else [math.nan] * 3
        at_rest = estimator.program.block_state("phi_hat", "counters")[AT_REST] == estimator.num_samples
        return (f"object learned over {estimator.learning_window:g} s: m = {mass:.4g} kg, its centre of "
                f"mass at [" + ", ".join(f"{1e3 * x:.1f}" for x in centre) + "] mm in S "
                f"({estimator.num_samples} samples taken{stale}"
                + ("; at rest only: its centre of mass along gravity and its inertia are learned once the arm "
                   "moves" if at_rest else "") + ")")

    def _grasp_or_release(self, grasp: bool, utime: int) -> tuple[bool, str]:
        controller = self._controller
        try:
            controller.grasp() if grasp else controller.release()
        except ValueError as error:
            return False, f"{'grasp' if grasp else 'release'} refused: {error}"
        if not grasp:
            self._grasps.clear()
            gripper = controller.phi if controller.phi_gripper is None else controller.phi_gripper
            return True, f"released: back to the gripper's φ (m = {gripper[0]:.4g} kg)"
        self._grasps.append(utime)
        return True, (f"grasp: the gripper's φ kept (m = {controller.phi[0]:.4g} kg); learning the object for "
                      f"{controller.estimator.learning_window:g} s; η = {controller.scales[2]:g} of its non-contact "
                      "wrench fed back")

    def _apply(self, command, healthy: bool, now_utime: int) -> tuple[bool | None, str]:
        """Carries out ``command``: (accepted, the answer), or (None, "") for one answered later."""
        controller = self._controller
        if command.action == heft_load_command.REZERO:
            if not healthy:
                return False, "re-zero refused: the station is not healthy (forces off); ask again once it is"
            controller.request_rezero()
            self._waiting.append(command.utime)
            return True, STATUS_TEXT[COLLECTING]
        if command.action in (heft_load_command.TRACKING_ON, heft_load_command.TRACKING_OFF):
            on = command.action == heft_load_command.TRACKING_ON
            controller.set_tracking(on)
            return True, f"offset tracking {'on' if on else 'off'}"
        if command.action == heft_load_command.NEW_ESTIMATE:
            try:
                controller.set_load(*checked_load(command.phi, command.offsets, self._full_scale))
            except ValueError as error:
                return False, f"new estimate refused: {error}"
            for superseded in self._estimates:  # not yet taken up: the newest goes in, the others are told
                self._answer(now_utime, superseded, False, "new estimate superseded by a newer one before a tick "
                                                           "took it up")
            self._estimates[:] = [command.utime]  # answered once a tick has taken it up
            return None, ""
        if command.action in (heft_load_command.GRASP, heft_load_command.RELEASE):
            return self._grasp_or_release(command.action == heft_load_command.GRASP, command.utime)
        return False, (f"unknown load action {command.action}; "
                       f"send one of {', '.join(f'{v} ({k})' for k, v in ACTIONS.items())}")

    def _answer(self, now_utime: int, command_utime: int, accepted: bool, message: str) -> None:
        controller = self._controller
        status = heft_load_status()
        status.utime, status.command_utime, status.accepted, status.message = (
            now_utime, command_utime, accepted, message)
        status.rezero_status, status.tracking = controller.rezero_status, controller.tracking
        status.phi, status.offsets = controller.phi.tolist(), controller.offsets.tolist()
        self._command_bus.publish(self._channel, status.encode())
        if self.on_message is not None:
            self.on_message("/load/status", status)
        if len(self.events) < MAX_EVENTS:
            self.events.append((now_utime, message))
