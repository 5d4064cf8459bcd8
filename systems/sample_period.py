"""The controller's sample period: its default and the one check of it.

Blocks are built with the period they tick at (a builder's argument, from the
scenario's ``controller_period``), never from their parameter sets, so a
scenario states the rate once.
"""

import math

DEFAULT_PERIOD = 0.0005
"""2 kHz (s): the paper's haptic loop runs above 2 kHz."""


def require_period(period: float) -> float:
    """``period`` (s), or a ValueError unless it is finite and > 0."""
    if not (math.isfinite(period) and period > 0):
        raise ValueError(f"period must be finite and > 0 (s); got {period}")
    return period
