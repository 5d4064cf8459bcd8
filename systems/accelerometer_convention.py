"""What a wrist accelerometer's reading means (``AccelerometerConvention``): gravity in it or not,
where it is taken and how the instrument is mounted and reports. Plain numpy, no Drake types; the
conversions it governs are ``accelerometer_reading``'s, kept apart with their compiled kernels so
that a scenario (``AccelerometerParams``) loads without numba (``heft load``)."""

import dataclasses

import numpy as np

from heft.systems.accelerometer_calibration import AccelerometerCalibration


_IDENTITY = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


@dataclasses.dataclass(frozen=True)
class AccelerometerConvention:
    """How a reading relates to S's motion: whether it holds gravity (specific force), where the
    accelerometer sits, p_SA (m, in S), and how it is mounted and reports (``accelerometer_calibration``):
    its axes A in S, ``R_SA`` (v_S = R_SA·v_A; rows), the ``unit`` of its linear channels ("m/s^2" or
    "g"; the angular ones report rad/s²), their ``bias`` (A's axes, its unit) and ``scale`` (their gain),
    and the angular channels' ``angular_bias`` (rad/s², A's axes). A reading r = [r_a; r_α] is in A's
    axes: s_S = R_SA·(r_a − bias)·u/scale, α_S = R_SA·(r_α − angular_bias)."""
    includes_gravity: bool = True
    p_SA: tuple[float, float, float] = (0.0, 0.0, 0.0)
    R_SA: tuple = _IDENTITY
    unit: str = "m/s^2"
    bias: tuple[float, float, float] = (0.0, 0.0, 0.0)
    scale: float = 1.0
    angular_bias: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self):
        p = tuple(float(x) for x in self.p_SA)
        if len(p) != 3 or not np.isfinite(p).all():
            raise ValueError(f"the accelerometer's position p_SA needs 3 finite numbers (m, in S); got {self.p_SA}")
        object.__setattr__(self, "p_SA", p)
        angular = tuple(float(x) for x in self.angular_bias)
        if len(angular) != 3 or not np.isfinite(angular).all():
            raise ValueError(f"the accelerometer's angular_bias needs 3 finite numbers (rad/s², its own axes); "
                             f"got {self.angular_bias}")
        object.__setattr__(self, "angular_bias", angular)
        calibration = AccelerometerCalibration(self.R_SA, self.bias, self.scale, self.unit)  # checks them
        object.__setattr__(self, "_calibration", calibration)
        object.__setattr__(self, "R_SA", tuple(tuple(float(x) for x in row) for row in calibration.R_SA))
        object.__setattr__(self, "bias", tuple(float(x) for x in calibration.bias))
        object.__setattr__(self, "scale", calibration.scale)

    @property
    def displaced(self) -> bool:
        return any(self.p_SA)

    @property
    def calibration(self) -> AccelerometerCalibration:
        """The mounting as ``accelerometer_calibration``'s model of the linear channels."""
        return self._calibration

    @property
    def mounted(self) -> bool:
        """Whether the reading is not already S's axes in m/s² without a bias."""
        return (self.R_SA != _IDENTITY or self.unit != "m/s^2" or any(self.bias) or self.scale != 1.0
                or any(self.angular_bias))

    def __str__(self) -> str:
        what = "specific force a − g" if self.includes_gravity else "gravity-free a"
        text = f"accelerometer reads {what} at p_SA = [{', '.join(f'{x:g}' for x in self.p_SA)}] m in S"
        if self.mounted:
            rows = "; ".join(", ".join(f"{x:.4g}" for x in row) for row in self.R_SA)
            text += (f", its axes R_SA = [{rows}], in {self.unit} with a bias of "
                     f"[{', '.join(f'{x:.4g}' for x in self.bias)}] {self.unit}")
            if any(self.angular_bias):
                text += f" and [{', '.join(f'{x:.4g}' for x in self.angular_bias)}] rad/s^2 on its angular channels"
        return text + " (scenario accelerometer)"


AT_S = AccelerometerConvention()
"""A specific-force reading at S's origin."""
