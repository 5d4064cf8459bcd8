"""The load model the controller feeds back through: φ̂ held, a new tool's taken at run time, and the grasp's
split of φ̂ into the gripper's and the object's (Eq. 14).

``FixedLoad`` holds φ̂ (10; Eq. 6) and replaces it with a new estimate ([counter, φ, offsets],
``offset_tracking.ESTIMATE_SIZE``) when the counter rises. ``GraspSplit`` follows the gripper (``holding``,
1 while an object is held): at the grasp it keeps φ̂ in use as the gripper's φ_gr, splits it off for force
scaling and asks the online estimator for a new load; at the release it returns φ̂ to φ_gr (a restart of
the estimator from it) and the split to what it was before, both in one tick. A new estimate passes through
it to the estimator and to the offsets, which change in the tick φ̂ does. Both keep their state when the controller
restarts (``kept_on_restart``).
"""

from __future__ import annotations

import numpy as np

from heft.systems.compiled import compiled
from heft.systems.controller.offset_tracking import ESTIMATE_SIZE
from heft.systems.tick_system import TickSystem


@compiled("void(float64[:], float64[:], float64[:])")
def fixed_load_update(phi, seen, estimate) -> None:
    """φ̂ (10) ← the ``estimate``'s when its counter passes ``seen`` (1)."""
    if estimate[0] > seen[0]:
        seen[0] = estimate[0]
        for i in range(10):
            phi[i] = estimate[1 + i]


class FixedLoad(TickSystem):
    """φ̂ (output ``phi``, 10) from ``phi``, replaced by each new ``estimate`` (input, ``ESTIMATE_SIZE``;
    unconnected, none), updated every ``period`` s."""

    kept_on_restart = True

    def __init__(self, phi, period: float):
        super().__init__(period)
        self.DeclareTickInput("estimate", ESTIMATE_SIZE, np.zeros(ESTIMATE_SIZE))
        self.DeclareTickState("phi", phi)
        self.DeclareTickState("estimates_seen", [0.0])
        self.DeclareTickUpdate(fixed_load_update, "next:phi", "next:estimates_seen", "in:estimate")
        self.DeclareTickOutput("phi", "x:phi")


HOLDING, GRASPS, ESTIMATES_SEEN, RESTARTS, RELEASING = range(5)
"""The split's counters and flags: an object held (1/0), grasps so far, new estimates seen, restarts asked for,
a release under way (the estimator restarting from φ_gr this tick)."""
SPLIT_SIZE = 5 + 10 + 10 + 1 + 2 * ESTIMATE_SIZE
"""``GraspSplit``'s state: the counters, φ_gr in use, φ_gr given (the scenario's, zeros if none), the split in
use (1/0), the restart asked of the estimator ([counter, φ, zeros]), the last new estimate passed on
([counter, φ, offsets], for the offsets to change in the tick φ̂ does)."""
PHI_GRIPPER, GIVEN, SPLIT = slice(5, 15), slice(15, 25), 25
RESTART, ESTIMATE = slice(26, 26 + ESTIMATE_SIZE), slice(26 + ESTIMATE_SIZE, 26 + 2 * ESTIMATE_SIZE)


@compiled("void(float64[:], float64[:], float64[:], float64[:])")
def grasp_update(state, holding, phi, estimate) -> None:
    """One tick of ``GraspSplit`` on its ``state`` (``SPLIT_SIZE``): ``holding`` (1) the gripper's, ``phi`` (10)
    φ̂ in use, ``estimate`` a new one (``ESTIMATE_SIZE``). A release and a new estimate reach the estimator at
    the next tick's update; the split (at a release) and the offsets (a new estimate's) change with it."""
    if state[RELEASING] > 0.5:  # the estimator restarts from φ_gr in this tick: the split given comes back
        state[RELEASING] = 0.0
        given = 0.0
        for i in range(10):
            state[PHI_GRIPPER.start + i] = state[GIVEN.start + i]
            given += abs(state[GIVEN.start + i])
        state[SPLIT] = 1.0 if given > 0.0 else 0.0
    held = holding[0] > 0.5
    if held and state[HOLDING] < 0.5:  # the grasp: φ̂ in use is the gripper's
        state[HOLDING], state[GRASPS], state[SPLIT] = 1.0, state[GRASPS] + 1.0, 1.0
        for i in range(10):
            state[PHI_GRIPPER.start + i] = phi[i]
    elif not held and state[HOLDING] > 0.5:  # the release: the estimator back to the gripper's φ
        state[HOLDING], state[RESTARTS], state[RELEASING] = 0.0, state[RESTARTS] + 1.0, 1.0
        state[RESTART.start] = state[RESTARTS]
        for i in range(ESTIMATE_SIZE - 1):
            state[RESTART.start + 1 + i] = state[PHI_GRIPPER.start + i] if i < 10 else 0.0
    if estimate[0] > state[ESTIMATES_SEEN]:  # a new tool: the estimator starts from it, the offsets with it
        state[ESTIMATES_SEEN], state[RESTARTS] = estimate[0], state[RESTARTS] + 1.0
        state[RESTART.start] = state[RESTARTS]
        for i in range(ESTIMATE_SIZE):
            state[ESTIMATE.start + i] = estimate[i]
            if i > 0:
                state[RESTART.start + i] = estimate[i]


@compiled("void(float64[:], float64[:], float64[:])")
def grasp_reset_into(out, state, reset) -> None:
    """The estimator's new-load counter (1): the grasps and the restarts so far plus the ``reset`` requests from
    outside (a restart is a new load too: the gate's learning window opens)."""
    out[0] = state[GRASPS] + state[RESTARTS] + reset[0]


@compiled("void(float64[:], float64[:], float64[:])")
def grasps_into(out, state, reset) -> None:
    """The new loads of unknown φ (1, a counter): the grasps so far plus the ``reset`` requests from outside (a
    release and a new tool's estimate are known loads)."""
    out[0] = state[GRASPS] + reset[0]


class GraspSplit(TickSystem):
    """The grasp's split of φ̂ (module docstring), updated every ``period`` s; ``phi_gripper`` the gripper's
    φ_gr given by the scenario (None: none, the load fed back as one body until a grasp).

    Inputs: ``holding`` (1; unconnected 0), ``phi`` (10, φ̂ in use), ``estimate`` (``ESTIMATE_SIZE``; unconnected
    none), ``reset`` (1: new loads requested from outside; unconnected 0). Outputs: ``phi_gripper`` (10) and
    ``split`` (1) for force scaling, ``estimator_reset`` (1, a counter) and ``estimator_restart``
    (``ESTIMATE_SIZE``) for the online estimator, ``new_load`` (1, a counter of the new loads among them whose φ
    is unknown: ``grasps_into``), ``estimate`` (``ESTIMATE_SIZE``) for the offsets, ``holding`` (1)."""

    kept_on_restart = True

    def __init__(self, phi_gripper, period: float):
        super().__init__(period)
        state = np.zeros(SPLIT_SIZE)
        if phi_gripper is not None:
            state[PHI_GRIPPER] = state[GIVEN] = phi_gripper
            state[SPLIT] = 1.0
        self.DeclareTickInput("holding", 1, [0.0])
        self.DeclareTickInput("phi", 10)
        self.DeclareTickInput("estimate", ESTIMATE_SIZE, np.zeros(ESTIMATE_SIZE))
        self.DeclareTickInput("reset", 1, [0.0])
        self.DeclareTickState("state", state)
        self.DeclareTickUpdate(grasp_update, "next:state", "in:holding", "in:phi", "in:estimate")
        self.DeclareTickCalc("reset", 1, grasp_reset_into, "calc:reset", "x:state", "in:reset")
        self.DeclareTickOutput("phi_gripper", "x:state", PHI_GRIPPER.start, PHI_GRIPPER.stop)
        self.DeclareTickOutput("split", "x:state", SPLIT, SPLIT + 1)
        self.DeclareTickOutput("estimator_restart", "x:state", RESTART.start, RESTART.stop)
        self.DeclareTickOutput("estimate", "x:state", ESTIMATE.start, ESTIMATE.stop)
        self.DeclareTickOutput("estimator_reset", "calc:reset")
        self.DeclareTickCalc("new_load", 1, grasps_into, "calc:new_load", "x:state", "in:reset")
        self.DeclareTickOutput("new_load", "calc:new_load")
        self.DeclareTickOutput("holding", "x:state", HOLDING, HOLDING + 1)
