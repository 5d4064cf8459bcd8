"""Incremental encoders: joint angles quantised to whole counts."""

import numpy as np
from pydrake.systems.framework import LeafSystem


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
        q = self._input.Eval(context)
        output.SetFromVector(np.round(q / self.step) * self.step)
