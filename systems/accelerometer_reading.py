"""What a wrist accelerometer reports, and the motion heft's dynamics take from it.

An accelerometer measures specific force: the acceleration of S's origin relative
to free fall, s = a − g (m/s², in S). Hanging still it reads |s| = 9.81 m/s²,
pointing up. The JR3's built-in accelerometer does, and so do the simulated
sensor and ``heft stand-in``: the station signal ``ft.acceleration_measured``
and the LCM sample's ``acceleration`` carry [s; α], α being S's angular
acceleration (rad/s²), both in S.

heft's dynamics (``load_dynamics``, Eq. 5) take S's kinematic acceleration a
and gravity g separately. The two conversions live here and nowhere else. The
load's wrench depends on a − g only, so a = s + g_S followed by V(a, α, ω, g_S)
gives V(s, α, ω, 0) exactly, whatever error the g_S from the robot's
kinematics has.

A lab whose driver already subtracts gravity (and publishes a) says so with
``includes_gravity = False`` (``AccelerometerParams``); the conversions then
pass the reading through.
"""

import numpy as np
from pydrake.systems.framework import LeafSystem


def reading_from_motion(acceleration, gravity, includes_gravity: bool = True) -> np.ndarray:
    """What the accelerometer reports, (6,) or (N, 6), for S's kinematic [a; α] and gravity g
    ((3,) or (N, 3)), all in S: [a − g; α], or [a; α] when the driver removes gravity."""
    reading = np.array(acceleration, dtype=float)
    if includes_gravity:
        reading[..., :3] -= gravity
    return reading


def motion_from_reading(out: np.ndarray, reading, gravity, includes_gravity: bool = True) -> np.ndarray:
    """S's kinematic [a; α] into ``out``, (6,) or (N, 6), from the accelerometer's ``reading`` (same
    shape) and the gravity g ((3,) or (N, 3)) that goes with it into the dynamics, all in S;
    returns ``out``."""
    out[...] = reading
    if includes_gravity:
        out[..., :3] += gravity
    return out


class AccelerometerToMotion(LeafSystem):
    """``motion_from_reading`` as a block: inputs ``reading`` (6) and ``gravity`` (3, g in S),
    output ``acceleration`` (6, kinematic [a; α] in S), for the blocks that take the kinematic
    motion (the load estimator and its gate)."""

    def __init__(self, includes_gravity: bool):
        super().__init__()
        self._includes_gravity = includes_gravity
        self._reading = self.DeclareVectorInputPort("reading", 6)
        self._gravity = self.DeclareVectorInputPort("gravity", 3)
        self.DeclareVectorOutputPort("acceleration", 6, self._calc)

    def _calc(self, context, output):
        motion_from_reading(output.get_mutable_value(), self._reading.Eval(context), self._gravity.Eval(context),
                            self._includes_gravity)
