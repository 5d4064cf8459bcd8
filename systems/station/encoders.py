"""Incremental encoders: joint angles quantised to whole counts, and a robot controller's joint
velocity estimate from them (as a Drake block for the simulated station, as a per-sample core for
the stand-in lab: one filter, ``velocity_lowpass_keep``)."""

import math

import numpy as np
from pydrake.systems.framework import DiagramBuilder, LeafSystem
from pydrake.systems.primitives import DiscreteDerivative, LinearSystem

from heft.systems.compiled import compiled


class EncoderQuantizer(LeafSystem):
    """Input ``position`` (n, rad) → output ``position`` rounded to 2π/counts_per_rev."""

    def __init__(self, size: int, counts_per_rev: float):
        super().__init__()
        if not counts_per_rev > 0:
            raise ValueError(f"counts_per_rev must be > 0; got {counts_per_rev}")
        self.step = 2 * np.pi / counts_per_rev  # rad per count
        self._input = self.DeclareVectorInputPort("position", size)
        self.DeclareVectorOutputPort("position", size, self._calc)

    def _calc(self, context, output):
        quantize_into(self._input.Eval(context), self.step, output.get_mutable_value())


@compiled("void(float64[:], float64, float64[:])")
def quantize_into(position, step, out) -> None:
    """Each of ``position`` rounded to the nearest whole multiple of ``step`` (rad per count), into ``out``."""
    for k in range(position.shape[0]):
        out[k] = np.round(position[k] / step) * step


def velocity_lowpass_keep(period: float, cutoff_hz: float) -> float:
    """The share e^(−2π·f_c·T) of the last estimate that the velocity estimate's first-order low-pass
    of ``cutoff_hz`` (Hz) keeps each sample ``period`` (s) (its exact discretisation)."""
    if not (period > 0 and cutoff_hz > 0):
        raise ValueError(f"period and cutoff_hz must be > 0; got {period}, {cutoff_hz}")
    return math.exp(-2 * math.pi * cutoff_hz * period)


class EncoderVelocityEstimator:
    """``AddEncoderVelocityEstimate`` one sample at a time, for a driver outside a Diagram:
    ``update(q_k)`` returns v_k = v_{k−1} + (1 − keep)·((q_k − q_{k−1})/T − v_{k−1}) (rad/s), starting
    at rest at ``initial_position`` (rad; the Diagram's first two samples are zero alike when the
    joints start at rest there). Updates its own arrays in place: returns the same array each time."""

    def __init__(self, initial_position, period: float, cutoff_hz: float):
        keep = velocity_lowpass_keep(period, cutoff_hz)
        self._keep, self._gain = keep, (1 - keep) / period
        self._previous = np.array(initial_position, dtype=float)
        self.velocity = np.zeros_like(self._previous)

    def update(self, position: np.ndarray) -> np.ndarray:
        """The estimate after the encoder-quantised ``position`` (rad) of the next sample."""
        velocity_estimate_step(self._previous, self.velocity, position, self._keep, self._gain)
        return self.velocity


@compiled("void(float64[:], float64[:], float64[:], float64, float64)")
def velocity_estimate_step(previous, velocity, position, keep, gain) -> None:
    """``EncoderVelocityEstimator.update`` in place: v ← keep·v + gain·(q − q_prev) (gain = (1 − keep)/T),
    then q_prev ← q, for the ``position`` q of each joint."""
    for k in range(position.shape[0]):
        velocity[k] = velocity[k] * keep + (position[k] - previous[k]) * gain
        previous[k] = position[k]


def AddEncoderVelocityEstimate(builder: DiagramBuilder, position, period: float, cutoff_hz: float):
    """A robot controller's joint velocity estimate from its encoders, added to ``builder``:
    every ``period`` s the backward difference of the output port ``position`` (n, rad,
    encoder-quantised; Drake's ``DiscreteDerivative``, zero over its first two samples) through
    a first-order low-pass of ``cutoff_hz`` (exact discretisation: v_k = v_{k−1} + (1 − e^(−2π·f_c·T))·
    (Δq_k/T − v_{k−1}), a ``LinearSystem`` whose output takes this tick's difference). Returns the
    velocity port (n, rad/s); no feedthrough from ``position``."""
    keep = velocity_lowpass_keep(period, cutoff_hz)
    size = position.size()
    derivative = builder.AddSystem(DiscreteDerivative(size, period))
    identity = np.eye(size)
    lowpass = builder.AddSystem(LinearSystem(keep * identity, (1 - keep) * identity, keep * identity,
                                             (1 - keep) * identity, period))
    builder.Connect(position, derivative.get_input_port())
    builder.Connect(derivative.get_output_port(), lowpass.get_input_port())
    return lowpass.get_output_port()
