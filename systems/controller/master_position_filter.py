"""Filters on the master's measured joint positions before the motion mapping (Fig. 4, master side).

The haptic device's encoders step by whole counts (the Phantom's ≈ 1.5e-4 rad). Passed on as they come, each
count is a step of the slave's desired pose, which the robot's own setpoint filter turns into a jump of the
joints' acceleration, white above its 20 Hz, and that rings a tool on its compliant mount's translational
modes (about 90–150 Hz). Two second-order stages, each optional, in this order (the estimator prefilter's
recursion, ``prefilter_step``, one after the other within the tick), for the motion mapping only (the force
feedback's Jacobian stays the measured positions'):

- a Butterworth low-pass at ``controller.motion.master_filter`` Hz (off by default: its delay in the motion's band
  costs the contact loop margin);
- a notch at ``controller.motion.master_notch`` Hz of quality ``master_notch_quality`` (off by default; at the
  mount's translational modes): it takes the counts out where they ring the tool and leaves the motion's band,
  where the contact loop lives (its unstable mode is near 7 Hz), all but untouched (5° there).

Each stage has unit gain at rest; it starts, and restarts after a non-finite sample, in the steady state of the
position it gets.
"""

import math

import numpy as np

from scipy.signal import iirnotch

from heft.systems.compiled import compiled
from heft.systems.controller.estimator_prefilter import prefilter_step
from heft.systems.controller.master_kinematics import NUM_JOINTS
from heft.systems.station.sensor_models import lowpass_coefficients
from heft.systems.tick_system import TickSystem

STAGE_SIZE = 3 * NUM_JOINTS
"""One stage's state: its last output, then its two delay rows (``prefilter_step``)."""


@compiled("void(float64[:], float64[:, :], float64[:], float64[:])")
def filter_step_into(out, coefficients, state, sample) -> None:
    """The stages' state after ``sample`` into ``out``: stage i (``coefficients[i]``, (b0, b1, b2, a1, a2)) steps
    ``prefilter_step`` from its part of ``state`` on the output of stage i − 1 (the first on ``sample``)."""
    out[:] = state
    width = sample.shape[0]
    prefilter_step(coefficients[0], out[0:3 * width], sample)
    for i in range(1, coefficients.shape[0]):
        prefilter_step(coefficients[i], out[3 * width * i:3 * width * (i + 1)],
                       out[3 * width * (i - 1):3 * width * (i - 1) + width])


@compiled("void(float64[:], float64[:])")
def filter_commit(state, step) -> None:
    """``state`` ← the tick's ``step``."""
    state[:] = step


def notch_stage(frequency: float, quality: float, period: float) -> np.ndarray:
    """(b0, b1, b2, a1, a2) of the second-order notch at ``frequency`` (Hz) of ``quality`` (``scipy.signal.iirnotch``;
    a0 = 1) at sample ``period`` (s)."""
    b, a = iirnotch(frequency, quality, fs=1.0 / period)
    return np.concatenate((b, a[1:]))


def filter_stages(cutoff: float, notch: float, notch_quality: float, period: float) -> np.ndarray:
    """The stages' coefficients, (count, 5): the low-pass at ``cutoff`` Hz, then the notch at ``notch`` Hz, each
    left out at 0 (none: (0, 5))."""
    nyquist = 0.5 / period
    for name, value in (("master_filter", cutoff), ("master_notch", notch)):
        if not (math.isfinite(value) and 0 <= value < nyquist):
            raise ValueError(f"controller.motion.{name} must lie between 0 and the controller's Nyquist frequency "
                             f"{nyquist:g} Hz (0: none); got {value}")
    if notch > 0 and not (math.isfinite(notch_quality) and notch_quality > 0):
        raise ValueError(f"controller.motion.master_notch_quality must be finite and > 0; got {notch_quality}")
    stages = [lowpass_coefficients(cutoff, period)] if cutoff > 0 else []
    stages += [notch_stage(notch, notch_quality, period)] if notch > 0 else []
    return np.array(stages, dtype=float).reshape(-1, 5)


class MasterPositionFilter(TickSystem):
    """Input ``position`` q_M (6, rad) → output ``position`` (6, rad): q_M low-passed at ``cutoff`` (Hz), then
    notched at ``notch`` (Hz, quality ``notch_quality``), each stage left out at 0 (at least one is needed),
    stepped every ``period`` (s). State: per stage, its last output, then its two delay rows (``prefilter_step``)."""

    def __init__(self, cutoff: float, period: float, notch: float = 0.0, notch_quality: float = 0.7):
        stages = filter_stages(cutoff, notch, notch_quality, period)
        if not len(stages):
            raise ValueError("controller.motion.master_filter and master_notch are both 0: no filter to make")
        super().__init__(period)
        size = STAGE_SIZE * len(stages)
        self.DeclareTickInput("position", NUM_JOINTS)
        self.DeclareTickState("filter", np.full(size, np.nan))
        self.DeclareTickCalc("step", size, filter_step_into, "calc:step", stages, "x:filter", "in:position")
        self.DeclareTickUpdate(filter_commit, "next:filter", "calc:step")
        self.DeclareTickOutput("position", "calc:step", size - STAGE_SIZE, size - STAGE_SIZE + NUM_JOINTS)
