"""A low-pass on the master's measured joint positions before the motion mapping (Fig. 4, master side).

The haptic device's encoders step by whole counts (the Phantom's ≈ 1.5e-4 rad). Passed on as they come, each
count is a step of the slave's desired pose, which the robot's own setpoint filter turns into a jump of the
joints' acceleration, and that rings a tool on its compliant mount. A second-order Butterworth low-pass at
``controller.motion.master_filter`` Hz (the estimator prefilter's recursion, ``prefilter_step``) smooths the
counts, within the tick, for the motion mapping (the force feedback's Jacobian stays the measured positions'). It
starts, and restarts after a non-finite sample, in the steady state of the position it gets.
"""

import math

import numpy as np

from heft.systems.compiled import compiled
from heft.systems.controller.estimator_prefilter import prefilter_step
from heft.systems.controller.master_kinematics import NUM_JOINTS
from heft.systems.station.sensor_models import lowpass_coefficients
from heft.systems.tick_system import TickSystem


@compiled("void(float64[:], float64[:], float64[:], float64[:])")
def filter_step_into(out, coefficients, state, sample) -> None:
    """The filter's state after ``sample`` (``prefilter_step`` from ``state``) into ``out``: the output first."""
    out[:] = state
    prefilter_step(coefficients, out, sample)


@compiled("void(float64[:], float64[:])")
def filter_commit(state, step) -> None:
    """``state`` ← the tick's ``step``."""
    state[:] = step


class MasterPositionFilter(TickSystem):
    """Input ``position`` q_M (6, rad) → output ``position`` (6, rad): q_M low-passed at ``cutoff`` (Hz), stepped
    every ``period`` (s). State: the last output, then the filter's two delay rows (``prefilter_step``)."""

    def __init__(self, cutoff: float, period: float):
        if not (math.isfinite(cutoff) and 0 < cutoff < 0.5 / period):
            raise ValueError(f"controller.motion.master_filter must lie between 0 and the controller's Nyquist "
                             f"frequency {0.5 / period:g} Hz (0: no filter); got {cutoff}")
        super().__init__(period)
        coefficients = lowpass_coefficients(cutoff, period)
        self.DeclareTickInput("position", NUM_JOINTS)
        self.DeclareTickState("filter", np.full(3 * NUM_JOINTS, np.nan))
        self.DeclareTickCalc("step", 3 * NUM_JOINTS, filter_step_into, "calc:step", coefficients, "x:filter",
                             "in:position")
        self.DeclareTickUpdate(filter_commit, "next:filter", "calc:step")
        self.DeclareTickOutput("position", "calc:step", 0, NUM_JOINTS)
