"""Filters on the master's measured joint positions before the motion mapping (Fig. 4, master side).

The haptic device's encoders step by whole counts (the Phantom's ≈ 1.5e-4 rad). Passed on as they come, each
count is a step of the slave's desired pose, which the robot's own setpoint filter turns into a jump of the
joints' acceleration, white above its 20 Hz, and that rings a tool on its compliant mount's translational
modes (about 90–150 Hz). Two second-order stages, each optional, in this order (the estimator prefilter's
recursion, ``prefilter_step``, one after the other within the tick), for the motion mapping only (the force
feedback's Jacobian stays the measured positions'):

- a Butterworth low-pass at ``controller.motion.master_filter`` Hz (off by default: its delay in the motion's band
  costs the contact loop margin);
- a notch at ``controller.motion.master_notch`` Hz of quality ``master_notch_quality`` (on by default, at the
  mount's translational modes): it takes the counts out where they ring the tool and leaves the motion's band,
  where the contact loop lives (its unstable mode is near 7 Hz), all but untouched (5° there).

Each stage has unit gain at rest; it starts, and restarts after a non-finite sample, in the steady state of the
position it gets.

A tick that comes k periods after the last (``hold``, s: the loop paused, its ticks skipped; ``CATCH_UP_FROM``
tells a skipped tick from the loop's jitter) steps the stages k times, on the positions linearly between the last
sample and this one, so that their clock keeps the time that passed. Stepped once, the stages would take the
skipped time as not passed: a step of the position by the motion over the skipped ticks, which the notch
answers with a dip of the output that takes back, in all, the motion over its DC group delay 1/(Q·2π·f₀)
(2.1 ms at 110 Hz, Q 0.7) on top of the skipped ticks' own, and rings the mount.
At most ``MAX_CATCH_UP`` periods are caught up.
"""

import math

import numpy as np

from heft.systems.compiled import compiled
from heft.systems.controller.estimator_prefilter import prefilter_step
from heft.systems.controller.force_scaling import notch_coefficients
from heft.systems.controller.master_kinematics import NUM_JOINTS
from heft.systems.station.sensor_models import lowpass_coefficients
from heft.systems.tick_system import TickSystem

STAGE_SIZE = 3 * NUM_JOINTS
"""One stage's state: its last output, then its two delay rows (``prefilter_step``)."""
MAX_CATCH_UP = 40
"""Periods a late tick catches up at most (20 ms at 2 kHz with the station's default watchdog)."""
CATCH_UP_FROM = 1.75
"""Periods a tick must come after the last for the filter to step twice: the real-time loop starts a tick up to half
a period late and a quarter early without skipping one (``diagrams.running.realtime``), so closer is jitter."""


@compiled("void(float64[:, :], float64[:], float64[:])")
def stages_step(coefficients, state, sample) -> None:
    """Stage i (``coefficients[i]``, (b0, b1, b2, a1, a2)) steps ``prefilter_step`` in place on its part of
    ``state`` on the output of stage i − 1 (the first on ``sample``)."""
    width = sample.shape[0]
    prefilter_step(coefficients[0], state[0:3 * width], sample)
    for i in range(1, coefficients.shape[0]):
        prefilter_step(coefficients[i], state[3 * width * i:3 * width * (i + 1)],
                       state[3 * width * (i - 1):3 * width * (i - 1) + width])


@compiled("void(float64[:], float64[:, :], float64[:], float64[:])")
def filter_step_into(out, coefficients, state, sample) -> None:
    """The stages' state after ``sample`` into ``out`` (``stages_step`` from ``state``)."""
    out[:] = state
    stages_step(coefficients, out, sample)


@compiled("void(float64[:], float64[:, :], float64[:], float64[:], float64[:], float64[:], float64, float64[:])")
def filter_catch_up_into(out, coefficients, state, last, sample, hold, period, scratch) -> None:
    """The stages' state after a tick ``hold[0]`` s after the last into ``out``: k = ⌊hold/period + 2 −
    ``CATCH_UP_FROM``⌋ steps (1 to ``MAX_CATCH_UP``) from ``state``, the first k − 1 on the positions linearly
    between ``last`` (the last tick's sample) and ``sample`` (one step if ``last`` is not finite), the last on
    ``sample``; ``scratch`` (as ``sample``) for the positions between."""
    out[:] = state
    k = min(max(math.floor(hold[0] / period + 2.0 - CATCH_UP_FROM), 1), MAX_CATCH_UP) if math.isfinite(hold[0]) else 1
    for i in range(last.shape[0]):
        if not math.isfinite(last[i]):
            k = 1
    for j in range(1, k):
        for i in range(sample.shape[0]):
            scratch[i] = last[i] + (sample[i] - last[i]) * j / k
        stages_step(coefficients, out, scratch)
    stages_step(coefficients, out, sample)


@compiled("void(float64[:], float64[:], float64[:], float64[:])")
def filter_commit(state, last, step, sample) -> None:
    """``state`` ← the tick's ``step``, ``last`` ← its ``sample``."""
    state[:] = step
    last[:] = sample


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
    stages += [notch_coefficients(notch, notch_quality, period, "controller.motion.master_notch")[:5]] if notch > 0 \
        else []
    return np.array(stages, dtype=float).reshape(-1, 5)


class MasterPositionFilter(TickSystem):
    """Inputs ``position`` q_M (6, rad) and ``hold`` (1, s since the last tick; default ``period``) → output
    ``position`` (6, rad): q_M low-passed at ``cutoff`` (Hz), then notched at ``notch`` (Hz, quality
    ``notch_quality``), each stage left out at 0 (at least one is needed), stepped every ``period`` (s), a late
    tick catching up the periods it covers (module docstring). State ``filter``: per stage, its last output,
    then its two delay rows (``prefilter_step``); ``last``: the last tick's q_M."""

    def __init__(self, cutoff: float, period: float, notch: float = 0.0, notch_quality: float = 0.7):
        stages = filter_stages(cutoff, notch, notch_quality, period)
        if not len(stages):
            raise ValueError("controller.motion.master_filter and master_notch are both 0: no filter to make")
        super().__init__(period)
        size = STAGE_SIZE * len(stages)
        self.DeclareTickInput("position", NUM_JOINTS)
        self.DeclareTickInput("hold", 1, [period])
        self.DeclareTickState("filter", np.full(size, np.nan))
        self.DeclareTickState("last", np.full(NUM_JOINTS, np.nan))
        self.DeclareTickCalc("step", size, filter_catch_up_into, "calc:step", stages, "x:filter", "x:last",
                             "in:position", "in:hold", float(period), np.zeros(NUM_JOINTS))
        self.DeclareTickUpdate(filter_commit, "next:filter", "next:last", "calc:step", "in:position")
        self.DeclareTickOutput("position", "calc:step", size - STAGE_SIZE, size - STAGE_SIZE + NUM_JOINTS)
