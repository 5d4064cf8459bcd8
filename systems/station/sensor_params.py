"""The settings of the simulated JR3's force-torque sensor and accelerometer (``sensor_models``,
whose docstring gives the measurement model): ``ft_sensor`` and ``accelerometer`` of a scenario,
apart from the models and their compiled kernels, so that a scenario loads without numba (``heft load``)."""

import dataclasses
import math

from heft.systems.accelerometer_convention import AccelerometerConvention

NUM_AXES = 6


@dataclasses.dataclass
class SixAxisSensorParams:
    """Settings common to both instruments. Each list has one entry per axis,
    in the instrument's port order and units (see the subclasses)."""

    noise: bool = True
    """Master switch: False turns every effect below off, so the output is the
    input sampled at t_k and held."""

    white_noise: bool = True
    """Adds white Gaussian noise of RMS `noise_rms`."""

    offsets: bool = True
    """Adds offsets, starting at `initial_offsets`."""

    drift: bool = True
    """Lets the offsets drift (needs `offsets`): the first-order approach to
    `drifted_offsets` plus the random walk; without it they stay at
    `initial_offsets`."""

    saturation: bool = True
    """Clips each axis to ±`full_scale` and raises its `saturated` flag."""

    quantization: bool = True
    """Rounds to the step full_scale / `counts_per_full_scale`."""

    sample_period: float = 0.0005
    """Sample period T (s). The JR3 samples at up to 8 kHz (1/8000 s); the default
    is the controller's 2 kHz, because a 2 kHz controller reading an 8 kHz
    sample-and-hold without a filter sees the same white noise, and each sample
    costs a Python event."""

    counts_per_full_scale: int = 16384
    """Resolution: counts between zero and full scale (JR3 DSP: 16384)."""

    drift_time_constant: float = 300.0
    """Time constant τ (s) of the approach to `drifted_offsets` (assumed)."""

    lowpass_cutoff: float = 500.0
    """Cut-off (Hz) of the sensor's own low-pass filter; 0 turns it off. The JR3 DSP's
    filter 1 is 500 Hz at 8 kHz sampling (recalled from the JR3 manual, not checked:
    docs/design.md §6). Must lie below the Nyquist frequency 1/(2T)."""

    seed: int = 0
    """Seed of the noise, 0 ≤ seed < 2⁶⁴. The force-torque sensor and the
    accelerometer use different streams even with the same seed."""

    def validate(self) -> None:
        """Raises ValueError naming the first field that is out of range."""
        for name in ("noise_rms", "full_scale", "initial_offsets", "drifted_offsets",
                     "offset_random_walk"):
            value = getattr(self, name)
            if len(value) != NUM_AXES:
                raise ValueError(f"{name} needs {NUM_AXES} entries, one per axis; got {len(value)}")
            if not all(math.isfinite(x) for x in value):
                raise ValueError(f"{name} must be finite; got {value}")
        for name in ("noise_rms", "offset_random_walk"):
            if min(getattr(self, name)) < 0:
                raise ValueError(f"{name} must be >= 0; got {getattr(self, name)}")
        if min(self.full_scale) <= 0:
            raise ValueError(f"full_scale must be > 0; got {self.full_scale}")
        for name in ("sample_period", "drift_time_constant"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be finite and > 0; got {value}")
        if not (math.isfinite(self.lowpass_cutoff) and 0 <= self.lowpass_cutoff < 0.5 / self.sample_period):
            raise ValueError(f"lowpass_cutoff must be 0 (off) or in (0, {0.5 / self.sample_period:g}) Hz, below "
                             f"the Nyquist frequency of sample_period {self.sample_period:g} s; "
                             f"got {self.lowpass_cutoff}")
        if self.counts_per_full_scale < 1:
            raise ValueError(f"counts_per_full_scale must be >= 1; got {self.counts_per_full_scale}")
        if not 0 <= self.seed < 2**64:
            raise ValueError(f"seed must lie in [0, 2**64); got {self.seed}")


@dataclasses.dataclass
class ForceTorqueSensorParams(SixAxisSensorParams):
    """The force-torque channels [fx, fy, fz, τx, τy, τz] in N and N·m."""

    noise_rms: list[float] = dataclasses.field(
        default_factory=lambda: [0.1, 0.1, 0.1, 0.005, 0.005, 0.005])
    """RMS of the white noise (N, N·m): the project's floor (docs/design.md §6)."""

    full_scale: list[float] = dataclasses.field(
        default_factory=lambda: [200.0, 200.0, 200.0, 12.0, 12.0, 12.0])
    """Measuring range ± (N, N·m): the 200 N / 12 N·m rating in the model code
    "200N12", taken for every axis (the datasheet was not available)."""

    initial_offsets: list[float] = dataclasses.field(
        default_factory=lambda: [2.0, -1.5, 3.0, 0.04, -0.03, 0.02])
    """Offsets at t = 0 (N, N·m): a few newtons, a few 0.01 N·m (assumed)."""

    drifted_offsets: list[float] = dataclasses.field(
        default_factory=lambda: [2.8, -0.9, 4.5, 0.06, -0.01, 0.035])
    """Offsets approached after warm-up (N, N·m) (assumed)."""

    offset_random_walk: list[float] = dataclasses.field(
        default_factory=lambda: [0.005, 0.005, 0.005, 0.0003, 0.0003, 0.0003])
    """Random-walk intensity q of the offsets (N/√s, N·m/√s): about 0.3 N and
    0.02 N·m of wander per hour (assumed)."""


@dataclasses.dataclass
class AccelerometerParams(SixAxisSensorParams):
    """The accelerometer channels [ax, ay, az, αx, αy, αz] in m/s² and rad/s². The model
    measures what its input carries; the station feeds it the reading of
    ``accelerometer_reading`` for ``includes_gravity``."""

    includes_gravity: bool = True
    """True: the linear channels report specific force a − g, as every accelerometer
    (the JR3's included) measures. False: the lab's driver already removes gravity and
    reports the kinematic a. The consumers (controller, identification) read this too."""

    position: list[float] = dataclasses.field(default_factory=lambda: [0.02, 0.01, -0.008])
    """Where the accelerometer sits, p_SA (m, in S): somewhere inside the 85 mm × 35 mm
    puck, off its axis (assumed; the JR3's placement is not published). The station
    measures there, the consumers move the reading to S (``accelerometer_reading``);
    [0, 0, 0] for a driver that reports at S."""

    noise_rms: list[float] = dataclasses.field(
        default_factory=lambda: [0.05, 0.05, 0.05, 0.5, 0.5, 0.5])
    """RMS of the white noise (m/s², rad/s²): the project's floor (docs/design.md §6)."""

    full_scale: list[float] = dataclasses.field(
        default_factory=lambda: [100.0, 100.0, 100.0, 1000.0, 1000.0, 1000.0])
    """Measuring range ± (m/s², rad/s²): assumed (≈ 10 g; no datasheet found)."""

    initial_offsets: list[float] = dataclasses.field(
        default_factory=lambda: [0.08, -0.05, 0.1, 0.3, -0.2, 0.25])
    """Biases at t = 0 (m/s², rad/s²) (assumed)."""

    drifted_offsets: list[float] = dataclasses.field(
        default_factory=lambda: [0.12, -0.02, 0.15, 0.4, -0.1, 0.3])
    """Biases approached after warm-up (m/s², rad/s²) (assumed)."""

    offset_random_walk: list[float] = dataclasses.field(
        default_factory=lambda: [0.001, 0.001, 0.001, 0.01, 0.01, 0.01])
    """Random-walk intensity q of the biases (m/s²/√s, rad/s²/√s) (assumed)."""

    R_SA: list[list[float]] = dataclasses.field(default_factory=lambda: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0],
                                                                          [0.0, 0.0, 1.0]])
    """Its axes A in S, rows of R_SA (v_S = R_SA·v_A): identity for one aligned with S, as the JR3's.
    The station reports in A's axes; the consumers turn the reading into S's."""

    unit: str = "m/s^2"
    """The unit of the linear channels: "m/s^2" or "g" (9.80665 m/s²); the angular ones are rad/s².
    ``noise_rms``, ``full_scale`` and the offsets are in the reading's own axes and units."""

    bias: list[float] = dataclasses.field(default_factory=lambda: [0.0, 0.0, 0.0])
    """The linear channels' bias as the lab knows it (A's axes, ``unit``): from its calibration
    (``heft identify --recording`` of static poses), or measured at rest by ``heft load --rezero``
    on hardware. The consumers subtract it; what the sensor model adds beside it (``initial_offsets``
    …) is what no calibration knows."""

    scale: float = 1.0
    """The linear channels' gain against the truth (1: as the datasheet says), from a calibration."""

    angular_bias: list[float] = dataclasses.field(default_factory=lambda: [0.0, 0.0, 0.0])
    """The angular channels' bias as the lab knows it (rad/s², A's axes): measured at rest by ``heft load
    --rezero``, where α is zero. The consumers subtract it, as ``bias``."""

    def validate(self) -> None:
        """Raises ValueError starting with the first wrong field's name."""
        super().validate()
        fields = {"position": {"p_SA": self.position}, "R_SA": {"R_SA": self.R_SA}, "unit": {"unit": self.unit},
                  "bias": {"bias": self.bias}, "scale": {"scale": self.scale},
                  "angular_bias": {"angular_bias": self.angular_bias}}
        for name, value in fields.items():
            try:
                AccelerometerConvention(**value)
            except (ValueError, TypeError) as error:
                raise ValueError(f"{name} is wrong: {error}") from None

    def convention(self) -> AccelerometerConvention:
        """What a reading means, for the consumers: gravity in it or not, where it is taken, how the
        instrument is mounted and what it reports in."""
        return AccelerometerConvention(self.includes_gravity, tuple(self.position), tuple(map(tuple, self.R_SA)),
                                       self.unit, tuple(self.bias), self.scale, tuple(self.angular_bias))
