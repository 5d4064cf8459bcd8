"""What a wrist accelerometer reports, and the motion heft's dynamics take from it.

An accelerometer measures specific force: the acceleration of its own point A
relative to free fall, s = a_A − g (m/s²). Hanging still it reads |s| = 9.81 m/s²,
pointing up. The JR3's built-in accelerometer does, and so do the simulated
sensor and ``heft stand-in``: the station signal ``ft.acceleration_measured``
and the LCM sample's ``acceleration`` carry [s; α], α being the sensor's angular
acceleration (rad/s²), both in S's axes.

A sits inside the sensor at p_SA from S's origin (``AccelerometerConvention.p_SA``;
zero when the driver reports at S). Rigid-body kinematics move the reading to S:
a_S = a_A − α × p_SA − ω × (ω × p_SA), with ω the sensor's angular velocity from
the arm's encoders (a sensor that measures α but not ω, like the JR3's, needs it).

heft's dynamics (``load_dynamics``, Eq. 5) take S's kinematic acceleration a
and gravity g separately. The two conversions live here and nowhere else. The
load's wrench depends on a − g only, so a = s + g_S followed by V(a, α, ω, g_S)
gives V(s, α, ω, 0) exactly, whatever error the g_S from the robot's
kinematics has.

A lab whose driver already subtracts gravity (and publishes a) says so with
``includes_gravity = False`` (``AccelerometerParams``); the conversions then
leave gravity alone.
"""

import dataclasses
import functools

import numpy as np

from heft.systems.accelerometer_calibration import unit_factor
from heft.systems.accelerometer_convention import AT_S, AccelerometerConvention
from heft.systems.compiled import compiled, float_array, record_views
from heft.systems.tick_system import TickSystem


@functools.cache
def kernel_convention(convention: AccelerometerConvention) -> tuple:
    """(includes_gravity, p_SA, R_SA (3, 3), m/s² per unit of reading (the unit over the scale), bias (6: the
    linear channels' in their unit, then the angular channels' in rad/s²)): the convention as the kernels
    take it."""
    return (convention.includes_gravity, np.array(convention.p_SA), np.array(convention.R_SA),
            unit_factor(convention.unit) / convention.scale, np.array(convention.bias + convention.angular_bias))


_NO_ROTATION = np.zeros(3)


def _transport(linear, alpha, omega, p, sign: float) -> None:
    """``linear`` (…, 3) += sign·(α × p + ω × (ω × p)), in place: the acceleration of the point p
    from that of the origin (sign 1) or back (sign −1). One sample by ``transport_one``, a batch
    with numpy."""
    if omega is None:
        raise ValueError("a displaced accelerometer's reading moves to or from S only with ω (rad/s, in S)")
    if np.ndim(linear) > 1:
        linear += sign * (np.cross(alpha, p) + np.cross(omega, np.cross(omega, p)))
        return
    transport_one(linear, float_array(alpha), float_array(omega), float_array(p), sign)


@compiled("void(float64[:], float64[:], float64[:], float64[:], float64)")
def transport_one(linear, alpha, omega, p, sign) -> None:
    """``_transport`` of one sample (3,) in scalar arithmetic (it runs every tick of the controller)."""
    px, py, pz = p[0], p[1], p[2]
    ax, ay, az = alpha[0], alpha[1], alpha[2]
    wx, wy, wz = omega[0], omega[1], omega[2]
    vx, vy, vz = wy * pz - wz * py, wz * px - wx * pz, wx * py - wy * px  # ω × p
    linear[0] += sign * (ay * pz - az * py + wy * vz - wz * vy)
    linear[1] += sign * (az * px - ax * pz + wz * vx - wx * vz)
    linear[2] += sign * (ax * py - ay * px + wx * vy - wy * vx)


def reading_from_motion(acceleration, gravity, omega=None,
                        convention: AccelerometerConvention = AT_S) -> np.ndarray:
    """What the accelerometer reports, (6,) or (N, 6), for S's kinematic [a; α], gravity g and
    angular velocity ω ((3,) or (N, 3); only needed for a displaced accelerometer), all in S:
    [a_A − g; α], or [a_A; α] when the driver removes gravity, in its own axes and unit with its bias.
    One sample by ``reading_from_motion_into``."""
    if np.ndim(acceleration) == 1 and (omega is not None or not convention.displaced):
        reading = np.empty(6)
        reading_from_motion_into(reading, float_array(acceleration), float_array(gravity),
                                 _NO_ROTATION if omega is None else float_array(omega), *kernel_convention(convention))
        return reading
    reading = np.array(acceleration, dtype=float)
    if convention.displaced:
        _transport(reading[..., :3], reading[..., 3:], omega, convention.p_SA, 1.0)
    if convention.includes_gravity:
        reading[..., :3] -= gravity
    if convention.mounted:
        calibration = convention.calibration
        reading[..., :3] = calibration.reading_of(reading[..., :3])
        reading[..., 3:] = reading[..., 3:] @ calibration.R_SA + convention.angular_bias
    return reading


PLAUSIBLE_BIAS = 0.25 * 9.80665
"""The largest bias (m/s², each linear axis) taken for one: MEMS IMUs and the JR3's accelerometer stay
within a few tenths of a g (0.05–0.1 g class); a larger "bias" at rest is a mounting stated wrong (an axis
flipped, g taken for m/s²)."""


def bias_at_rest(convention: AccelerometerConvention, reading, gravity) -> np.ndarray:
    """The biases (6: the linear channels' in the accelerometer's axes and unit, the angular channels' in
    rad/s²) under which the convention explains ``reading`` (its mean at rest, 6) under ``gravity`` (3, m/s²
    in S): the reading less what the instrument without biases reports with S at rest (the angular
    channels' is the reading itself: α is zero at rest, exactly)."""
    unbiased = dataclasses.replace(convention, bias=(0.0, 0.0, 0.0), angular_bias=(0.0, 0.0, 0.0))
    return np.asarray(reading, dtype=float) - reading_from_motion(np.zeros(6), gravity, np.zeros(3), unbiased)


def motion_from_reading(out: np.ndarray, reading, gravity, omega=None,
                        convention: AccelerometerConvention = AT_S) -> np.ndarray:
    """S's kinematic [a; α] into ``out``, (6,) or (N, 6), from the accelerometer's ``reading`` (same
    shape), the gravity g that goes with it into the dynamics and the angular velocity ω ((3,) or
    (N, 3); only needed for a displaced accelerometer), all in S; returns ``out``. One sample by
    ``motion_from_reading_into``."""
    if np.ndim(out) == 1 and (omega is not None or not convention.displaced):
        motion_from_reading_into(out, float_array(reading), float_array(gravity),
                                 _NO_ROTATION if omega is None else float_array(omega), *kernel_convention(convention))
        return out
    calibration = convention.calibration
    reading = np.asarray(reading, dtype=float)
    out[..., :3] = calibration.to_sensor_axes(reading[..., :3])
    out[..., 3:] = (reading[..., 3:] - convention.angular_bias) @ calibration.R_SA.T
    if convention.includes_gravity:
        out[..., :3] += gravity
    if convention.displaced:
        _transport(out[..., :3], out[..., 3:], omega, convention.p_SA, -1.0)
    return out


@compiled("void(float64[:], float64[:], float64[:], float64[:], boolean, float64[:], float64[:, :], float64, "
          "float64[:])")
def motion_from_reading_into(out, reading, gravity, omega, includes_gravity, p_SA, R_SA, u, bias) -> None:
    """``motion_from_reading`` of one sample, the convention as ``kernel_convention`` gives it (the
    mounting as ``AccelerometerCalibration.to_sensor_axes``, in scalar arithmetic)."""
    for i in range(3):
        out[i] = u * (R_SA[i, 0] * (reading[0] - bias[0]) + R_SA[i, 1] * (reading[1] - bias[1])
                      + R_SA[i, 2] * (reading[2] - bias[2]))
        out[3 + i] = (R_SA[i, 0] * (reading[3] - bias[3]) + R_SA[i, 1] * (reading[4] - bias[4])
                      + R_SA[i, 2] * (reading[5] - bias[5]))
    if includes_gravity:
        for i in range(3):
            out[i] += gravity[i]
    if p_SA[0] != 0.0 or p_SA[1] != 0.0 or p_SA[2] != 0.0:
        transport_one(out[:3], out[3:], omega, p_SA, -1.0)


@compiled("void(float64[:], float64[:], float64[:], float64[:], boolean, float64[:], float64[:, :], float64, "
          "float64[:])")
def reading_from_motion_into(out, acceleration, gravity, omega, includes_gravity, p_SA, R_SA, u, bias) -> None:
    """``reading_from_motion`` of one sample into ``out`` (6), the convention as ``kernel_convention`` gives it:
    ``motion_from_reading_into`` undone (the mounting, where there is one, as
    ``AccelerometerCalibration.reading_of``, in scalar arithmetic)."""
    for i in range(6):
        out[i] = acceleration[i]
    if p_SA[0] != 0.0 or p_SA[1] != 0.0 or p_SA[2] != 0.0:
        transport_one(out[:3], acceleration[3:], omega, p_SA, 1.0)
    if includes_gravity:
        for i in range(3):
            out[i] -= gravity[i]
    mounted = u != 1.0
    for i in range(3):
        for k in range(3):
            mounted = mounted or R_SA[i, k] != (1.0 if i == k else 0.0)
    for i in range(6):
        mounted = mounted or bias[i] != 0.0
    if not mounted:
        return
    f0, f1, f2, a0, a1, a2 = out[0], out[1], out[2], out[3], out[4], out[5]
    for j in range(3):  # r = R_SAᵀ·s / u + bias, α in A's axes + the angular channels' bias
        out[j] = (f0 * R_SA[0, j] + f1 * R_SA[1, j] + f2 * R_SA[2, j]) / u + bias[j]
        out[3 + j] = a0 * R_SA[0, j] + a1 * R_SA[1, j] + a2 * R_SA[2, j] + bias[3 + j]


CONVENTION = np.dtype([("includes_gravity", float), ("p_SA", float, 3), ("R_SA", float, (3, 3)), ("u", float),
                       ("bias", float, 6)])
"""An accelerometer's convention as one record (``kernel_convention``'s fields)."""


def convention_record(convention: AccelerometerConvention) -> np.ndarray:
    """``convention`` as a ``CONVENTION`` record (``kernel_convention``)."""
    record, arrays = record_views(CONVENTION)
    includes_gravity, arrays["p_SA"][:], arrays["R_SA"][:], record["u"], arrays["bias"][:] = kernel_convention(
        convention)
    record["includes_gravity"] = float(includes_gravity)
    return record


@compiled("void(float64[:], float64[:], float64[:], float64[:], CONVENTION[:])", CONVENTION=CONVENTION)
def motion_into(out, reading, gravity, omega, convention) -> None:
    """``motion_from_reading_into`` with the ``convention`` record."""
    c = convention[0]
    motion_from_reading_into(out, reading, gravity, omega, c["includes_gravity"] > 0.5, c["p_SA"], c["R_SA"], c["u"],
                             c["bias"])


@compiled("void(float64[:], float64[:], float64[:], float64[:], CONVENTION[:])", CONVENTION=CONVENTION)
def reading_into(out, acceleration, gravity, omega, convention) -> None:
    """``reading_from_motion_into`` with the ``convention`` record."""
    c = convention[0]
    reading_from_motion_into(out, acceleration, gravity, omega, c["includes_gravity"] > 0.5, c["p_SA"], c["R_SA"],
                             c["u"], c["bias"])


class AccelerometerToMotion(TickSystem):
    """``motion_from_reading`` as a block: inputs ``reading`` (6), ``gravity`` (3, g in S) and
    ``omega`` (3, ω in S), output ``acceleration`` (6, kinematic [a; α] in S), for the blocks that
    take the kinematic motion (the load estimator and its gate)."""

    def __init__(self, convention: AccelerometerConvention):
        super().__init__(None)
        self.convention = convention_record(convention)
        self.DeclareTickInput("reading", 6)
        self.DeclareTickInput("gravity", 3)
        self.DeclareTickInput("omega", 3)
        self.DeclareTickCalc("acceleration", 6, motion_into, "calc:acceleration", "in:reading", "in:gravity",
                             "in:omega", self.convention)
        self.DeclareTickOutput("acceleration", "calc:acceleration")
