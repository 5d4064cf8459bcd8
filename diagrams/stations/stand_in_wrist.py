"""The stand-in lab's wrist: the JR3's sampled measurement, the motion of its frame S (``SerialChain``),
the load on its compliant mount (``mount.MountUnderMovingSensor``), the gripper that grasps and
releases the scenario's object, and the truth of every sensor sample (``TruthRecord``).

Wrenches here are heft's (docs/design.md §4): [f; τ] the sensor exerts on the load, at S, in S (N, N·m);
the JR3 driver publishes them negated (``stand_in``).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from heft.diagrams import mount
from heft.diagrams.plants import MakeSlavePlant, mount_for, phi_about_S
from heft.diagrams.scenario import Scenario
from heft.hardware_interface.lcmtypes import heft_gripper_state
from heft.systems.accelerometer_reading import reading_from_motion
from heft.systems.compiled import compiled
from heft.systems.load_dynamics import GRAVITY_W, regressor_into
from heft.systems.serial_chain import ACCELERATION, GRAVITY, OMEGA, SerialChain, chain_dtype, chain_kinematics
from heft.systems.station.sensor_models import (NUM_AXES, HeldLowpass, SixAxisMeasurement, SixAxisSensorParams, lowpass,
                                        lowpass_coefficients)
from heft.systems.serial_chain import CHAIN_JOINTS

GRIPPER_CLOSING_S = 0.2
"""How long (s) the gripper's fingers take from open to closed on the object (assumed: a Schunk
PG 70 class servo-electric gripper closes its 15 mm per jaw in a few tenths of a second)."""
GRIPPER_OPEN_WIDTH_M = 0.07
"""Finger opening when open (m; assumed, the PG 70's 2 × 35 mm stroke, recalled)."""
OBJECT_WIDTH_M = 0.04
"""Finger opening when holding (m): the 40 mm steel cube of ``gripper_object.urdf``."""
_AT_TIME = 1e-9
"""Event times are reached this close (s; round-off of k/rate)."""
_NOISE_BLOCK = 64
"""Sensor samples whose noise and offsets are drawn at once."""


class SixAxisSampler:
    """``sensor_models.SixAxisMeasurement`` of one instrument sampled every ``period`` s:
    sample j (t = j·period, j ≥ 1) with the draws of sample index j, as the simulated
    sensor's; offsets and noise are drawn ``_NOISE_BLOCK`` samples at a time. Its input is
    held over ``held_count`` samples at a time, mostly (the arm's step)."""

    def __init__(self, params: SixAxisSensorParams, stream: int, period: float, held_count: int):
        self._model, self._period = SixAxisMeasurement(params, stream, period), period
        self._lowpass = lowpass_coefficients(params.lowpass_cutoff, period)  # the sensor's filter at this rate
        self._held_lowpass = None if self._lowpass is None else HeldLowpass(self._lowpass, held_count)
        self._lowpass_state = np.full((2, NUM_AXES), np.nan)
        self._walk = np.zeros(NUM_AXES)
        # Offsets and offsets + noise of samples start, start + 1, ...
        self._start, self._offsets, self._disturbance = 1, np.zeros((0, NUM_AXES)), np.zeros((0, NUM_AXES))
        self._filtered, self._measured, self._saturated = np.empty((3, held_count, NUM_AXES))

    def _draw_block(self, keep_from: int) -> None:
        """Appends the next ``_NOISE_BLOCK`` samples, forgetting those before ``keep_from``."""
        first = self._start + len(self._offsets)
        index = np.arange(first, first + _NOISE_BLOCK)
        offsets, disturbance, self._walk = self._model.disturbance(index * self._period, self._model.normals(index),
                                                                   self._walk)
        drop = max(0, min(keep_from, first) - self._start)
        self._offsets = np.concatenate((self._offsets[drop:], offsets))
        self._disturbance = np.concatenate((self._disturbance[drop:], disturbance))
        self._start += drop

    def sample(self, first: int, count: int, value: np.ndarray):
        """(measured, offsets o_j, saturated flags (0/1)), each (count, 6), of samples
        j = first … first + count − 1 of the true ``value`` (6,); ``first`` ≥ 1 never decreases.
        The arrays are overwritten by the next call."""
        while first + count > self._start + len(self._offsets):
            self._draw_block(first)
        rows = slice(first - self._start, first - self._start + count)
        if count != len(self._filtered):
            self._filtered, self._measured, self._saturated = np.empty((3, count, NUM_AXES))
        held = self._held_lowpass
        if held is not None and count == held.count and not math.isnan(self._lowpass_state[0, 0]):
            held.measure(self._model, self._lowpass_state, value, self._disturbance[rows], self._measured,
                         self._saturated)
            return self._measured, self._offsets[rows], self._saturated
        filtered = self._filtered
        if self._lowpass is None:
            filtered[:] = value
        else:
            filtered[:] = lowpass(self._lowpass, self._lowpass_state, np.repeat(value[np.newaxis], count, axis=0))
        filtered += self._disturbance[rows]
        self._model.measure(filtered, self._measured, self._saturated)
        return self._measured, self._offsets[rows], self._saturated


@dataclasses.dataclass(frozen=True)
class GraspTimes:
    """When the gripper closes on the object (``grasp_at``, s; inf: it holds it from the start, as a
    "gripper_object" load without ``load.grasp_at``) and opens again (``release_at``, s; inf: never).
    Its fingers close for ``GRIPPER_CLOSING_S``; the object weighs on the sensor from then (HOLDING)
    until the release (OPEN at once: the object is let go)."""

    grasp_at: float = math.inf
    release_at: float = math.inf

    def validate(self) -> None:
        """Raises ValueError saying which time is wrong and what to give."""
        if not (self.grasp_at > 0):  # NaN too
            raise ValueError(f"--grasp-at must be a time > 0 (s) or inf; got {self.grasp_at}")
        if not (self.release_at > 0) or (math.isfinite(self.grasp_at) and not self.release_at > self.grasp_at):
            raise ValueError(f"--release-at must be a time (s) after the grasp at {self.grasp_at:g} s, or inf; "
                             f"got {self.release_at}")

    def holding(self, t: float) -> bool:
        """Whether the object weighs on the sensor at ``t`` (s)."""
        return t + _AT_TIME < self.release_at and (math.isinf(self.grasp_at)
                                                   or t + _AT_TIME >= self.grasp_at + GRIPPER_CLOSING_S)

    def state(self, t: float) -> int:
        """The driver's state at ``t`` (s): ``heft_gripper_state`` OPEN, CLOSING or HOLDING."""
        if self.holding(t):
            return heft_gripper_state.HOLDING
        if self.grasp_at <= t + _AT_TIME and t + _AT_TIME < self.release_at:
            return heft_gripper_state.CLOSING
        return heft_gripper_state.OPEN

    def width(self, t: float) -> float:
        """The finger opening (m) at ``t`` (s): closing linearly from open to the object's width."""
        state = self.state(t)
        if state == heft_gripper_state.CLOSING:
            closed = (t - self.grasp_at) / GRIPPER_CLOSING_S
            return GRIPPER_OPEN_WIDTH_M + closed * (OBJECT_WIDTH_M - GRIPPER_OPEN_WIDTH_M)
        return OBJECT_WIDTH_M if state == heft_gripper_state.HOLDING else GRIPPER_OPEN_WIDTH_M


@compiled("void(float64[:, :], float64[:], float64[:])")
def _regressor_times(V, phi, out) -> None:
    """``out`` = V·φ (6) of a regressor ``V`` (6, 10) and inertial parameters ``phi`` (10)."""
    for r in range(6):
        total = 0.0
        for j in range(10):
            total += V[r, j] * phi[j]
        out[r] = total


def _rigid_wrench(chain, q, qd, qdd, phi, V, rigid) -> None:
    """S's motion at joint positions ``q`` (rad), velocities ``qd`` (rad/s) and accelerations ``qdd``
    (rad/s²) into the ``chain``'s arrays (``chain_kinematics`` on a ``SerialChain.record``), the regressor
    ``V`` (6, 10, Eq. 5) of that motion and ``rigid`` = V·φ (6), the wrench that moves a load of ``phi``
    (10, about S) rigidly with S."""
    c = chain[0]
    motion = c["motion"]
    chain_kinematics(c["axes"], c["points"], c["M_R"], c["M_p"], q, qd, qdd, c["gravity_B"], c["R"], c["p"], c["J"],
                     motion, c["work"])
    regressor_into(motion[0:3], motion[3:6], motion[6:9], motion[9:12], V)
    _regressor_times(V, phi, rigid)


rigid_wrench = {n: compiled("void(CHAIN[:], float64[:], float64[:], float64[:], float64[:], float64[:, :], float64[:])",
                            CHAIN=chain_dtype(n))(_rigid_wrench) for n in CHAIN_JOINTS}
"""``_rigid_wrench`` compiled for each arm's chain record, by its number of joints."""


@compiled("void(float64[:, :], float64[:], float64[:, :], float64[:], float64[:])")
def object_wrench(V, phi, inertia, deflection_acceleration, out) -> None:
    """``out`` = V·φ + M·ξ̈ (6): the wrench that moves an object of ``phi`` (10, about S) and spatial
    ``inertia`` M (6, 6, heft's order) with the load frame L, from S's regressor ``V`` and L's
    ``deflection_acceleration`` ξ̈ (6) against S."""
    _regressor_times(V, phi, out)
    for r in range(6):
        total = 0.0
        for c in range(6):
            total += inertia[r, c] * deflection_acceleration[c]
        out[r] += total


class Wrist:
    """The slave arm with its wrist sensor and load, evaluated at each of the arm's steps
    (``period`` s): the motion of S from the joint state, the load on its compliant mount (the
    scenario's ``MountSpec``, sized to the load as the simulated station's, ``mount_for``; welded at S
    for ``load.mount.rigid``), the gripper holding the object per ``grasp``.

    Readable after ``update``: ``wrench`` (what the sensor exerts on the load: w_S, the load's
    non-contact wrench moved to S, as there is no contact), ``wrench_object`` (the object's share, the
    simulated station's ``truth.wrench_noncontact_object``: V at L's motion times φ − φ_gripper while
    holding, else zero), ``acceleration`` ([a; α] of S in W, expressed in S; m/s², rad/s²),
    ``reading`` (what the accelerometer reports, ``accelerometer_reading``), ``phi`` (φ about S of
    what the sensor carries, Eq. 6: the gripper alone or with its object), ``phi_gripper``."""

    def __init__(self, scenario: Scenario, period: float, grasp: GraspTimes, q0):
        plant, parts = MakeSlavePlant(scenario)
        self._chain = SerialChain(plant, plant.world_frame(), parts.S, GRAVITY_W)
        self._rigid_wrench = rigid_wrench[self._chain.num_joints]
        self._accelerometer = scenario.accelerometer.convention()
        self._grasp = grasp
        phi_load = phi_about_S(plant, parts.S, parts.load_bodies)
        self.phi_gripper = (phi_about_S(plant, parts.S, parts.gripper_bodies) if parts.gripper_bodies
                            else np.zeros(10))
        self.phis = {True: phi_load, False: self.phi_gripper}
        """φ of what the sensor carries while the gripper holds the object, and while not."""
        self.holding = grasp.holding(0.0)
        self.phi = self.phis[self.holding]
        self._phi_object = phi_load - self.phi_gripper if parts.gripper_bodies else None  # a tool: none
        if self._phi_object is not None:
            self._object_inertia = mount.inertia_in_wrench_order(self._phi_object)
        self.wrench, self.wrench_object, self._V = np.zeros(6), np.zeros(6), np.zeros((6, 10))
        self.acceleration, self.reading = np.zeros(6), np.zeros(6)
        self._rigid, self._rigid_before, self._deflection_acceleration = np.zeros(6), np.zeros(6), np.zeros(6)
        if scenario.load.mount.rigid:
            self._mounts = None
        else:
            constants = mount_for(scenario)
            self._mounts = {holding: mount.MountUnderMovingSensor(constants, phi, period)
                            for holding, phi in self.phis.items() if phi[0] > 0}  # a tool: always "holding"
            self._motion(q0, np.zeros(len(q0)), np.zeros(len(q0)))
            self._mount_state = self._mounts[self.holding].at_rest(self._rigid)  # settled under the load
        self._rigid_before[:] = self._rigid

    def _motion(self, q, qd, qdd) -> np.ndarray:
        """Sets ``acceleration``, ``reading`` and the rigid wrench V·φ from the joint state; returns V."""
        chain, V = self._chain, self._V
        self._rigid_wrench(chain.record, q, qd, qdd, self.phi, V, self._rigid)
        self.acceleration[:] = chain.motion[ACCELERATION]
        self.reading[:] = reading_from_motion(self.acceleration, chain.motion[GRAVITY], chain.motion[OMEGA],
                                              self._accelerometer)
        return V

    def update(self, t: float, q, qd, qdd) -> None:
        """Evaluates the wrist at time ``t`` (s) and joint positions ``q`` (rad), velocities ``qd``
        (rad/s), accelerations ``qdd`` (rad/s²), once per step: the mount stepped on from the last call
        (one period before; at the first, at rest) under the load it carried meanwhile, S's motion going
        linearly from that call's to this one's; then the gripper's state at ``t`` (a grasp or a
        release takes effect now)."""
        V = self._motion(q, qd, qdd)
        if self._mounts is None:
            self.wrench[:] = self._rigid
            self._deflection_acceleration[:] = 0.0
        else:
            self._mounts[self.holding].step(self._mount_state, self._rigid_before, self._rigid, self.wrench,
                                            self._deflection_acceleration)
        holding = self._grasp.holding(t)
        if holding != self.holding:
            self.holding, self.phi = holding, self.phis[holding]
            self._motion(q, qd, qdd)  # the rigid wrench of the new load
            if self._mounts is None:
                self.wrench[:] = self._rigid
            else:  # the same deflection, under the new load
                self._mounts[holding].deflection_acceleration(self.wrench, self._rigid, self._deflection_acceleration)
        self._rigid_before[:] = self._rigid
        if holding and self._phi_object is not None:  # the object moves with L
            object_wrench(V, self._phi_object, self._object_inertia, self._deflection_acceleration, self.wrench_object)
        else:
            self.wrench_object[:] = 0.0


class _Rows:
    """Rows of ``width`` numbers appended in blocks allocated as they fill and never copied while
    running: a growing array copied whole at each doubling stalled the stand-in's step 1.6 ms at
    4.1 s of a run, and its messages went out 1.3 ms late."""

    BLOCK = 16384

    def __init__(self, width: int):
        self._blocks, self._used = [np.empty((self.BLOCK, width))], 0  # rows used in the last block

    def append(self, rows: np.ndarray) -> None:
        """Appends ``rows`` (k, width)."""
        while len(rows):
            block = self._blocks[-1]
            if self._used == len(block):
                block = np.empty_like(block)
                self._blocks.append(block)
                self._used = 0
            taken = min(len(rows), len(block) - self._used)
            block[self._used:self._used + taken] = rows[:taken]
            rows, self._used = rows[taken:], self._used + taken

    def array(self) -> np.ndarray:
        """All rows appended, (n, width), in one new array."""
        return np.concatenate(self._blocks[:-1] + [self._blocks[-1][:self._used]])


LATE_STEPS = 1.5
"""A command the arm steps on is late when computed from a state older than this many of its steps: on
time, the tick that answers the arm's status of one step sends the command its next step takes."""


class TruthRecord:
    """What the stand-in's wrist sensor carried at each of its samples, one row per sample it took
    (published or lost), in heft's convention (the module's): the samples between two of the arm's
    steps carry that step's truth, as the sensor's input is held. ``save`` writes a compressed
    NumPy archive (``numpy.load``) with ``sample_counter`` (N,) and ``utime`` (N, µs on the stand-in's
    clock), as in the published ``heft_ft_sample``; ``phi`` (N, 10, Eq. 6: what the sensor carries);
    ``wrench_noncontact``, ``wrench_noncontact_object``, ``wrench_contact`` (N, 6: the load's own
    wrench, the object's share of it, and contact, zero: the stand-in has no environment);
    ``ft_offsets`` (N, 6, the offsets inside the measurement); ``phi_gripper`` (10); and
    ``arm_late_steps`` (n, 2: utime, age, µs), the arm's steps whose command was computed from a state
    more than ``LATE_STEPS`` of its steps old (as through a pause of the controller: the arm holds its
    last command; the age of a command is its step's time less that of the master state named by the
    master command of the same tick, ``heft_haptic_command.master_utime``, the two paired by their
    ``utime``). Kept per arm step while running (a few µs), expanded to samples when read."""

    def __init__(self, rate: float, phis: dict[bool, np.ndarray], arm_rate: float):
        self._rate, self._phis = rate, phis  # ``Wrist.phis``: holding the object, and not
        self._late_age = LATE_STEPS / arm_rate
        self._steps = _Rows(15)  # first sample, count, holding, wrench, wrench_object
        self._offsets = _Rows(NUM_AXES)
        self._step = np.zeros(15)
        self._arm_late = []

    def add(self, first: int, count: int, wrist: Wrist, offsets: np.ndarray) -> None:
        """Samples ``first`` … ``first + count − 1`` of the sensor (at ``rate`` Hz) on the ``wrist``'s
        present truth, with their ``offsets`` (count, 6)."""
        step = self._step
        step[0], step[1], step[2] = first, count, wrist.holding
        step[3:9], step[9:15] = wrist.wrench, wrist.wrench_object
        self._steps.append(step[None, :])
        self._offsets.append(offsets)

    def arm_step(self, t: float, age: float) -> None:
        """The arm stepped at ``t`` (s) on a command computed from a state ``age`` s old."""
        if age > self._late_age:
            self._arm_late.append((t, age))

    def arrays(self, through: int | None = None) -> dict[str, np.ndarray]:
        """The record as named arrays (the archive's), of the samples up to counter ``through`` (the
        last the lab's clock reached; the sensor samples ahead to the arm's next step), else all."""
        steps = self._steps.array()
        counts = steps[:, 1].astype(np.int64)
        rows = np.repeat(np.arange(len(steps)), counts)
        counters = np.repeat(steps[:, 0].astype(np.int64), counts) + (
            np.arange(len(rows)) - np.repeat(np.cumsum(counts) - counts, counts))
        keep = slice(None) if through is None else counters <= through
        rows, counters = rows[keep], counters[keep]
        holding = steps[rows, 2].astype(bool)
        late = np.round(np.array(self._arm_late, dtype=float).reshape(-1, 2) * 1e6).astype(np.int64)
        if through is not None:
            late = late[late[:, 0] <= round(through / self._rate * 1e6)]
        return {"sample_counter": counters, "utime": np.round(counters / self._rate * 1e6).astype(np.int64),
                "arm_late_steps": late, "phi": np.where(holding[:, None], self._phis[True], self._phis[False]),
                "wrench_noncontact": steps[rows, 3:9], "wrench_noncontact_object": steps[rows, 9:15],
                "wrench_contact": np.zeros((len(rows), 6)), "ft_offsets": self._offsets.array()[keep],
                "phi_gripper": self._phis[False]}

    def save(self, path, through: int | None = None) -> None:
        """Writes ``arrays(through)`` to ``path`` (a .npz)."""
        np.savez_compressed(path, **self.arrays(through))
