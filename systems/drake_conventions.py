"""The one place where Drake's spatial vectors meet heft's conventions (docs/design.md §4).

Drake orders a SpatialForce as [τ; f], a SpatialAcceleration as [α; a] and a
spatial-velocity Jacobian's rows as [ω; v]; heft orders wrenches [f; τ],
accelerations [a; α] and Jacobian rows [v; ω].
"""

import numpy as np
from pydrake.multibody.math import SpatialForce


def wrench_from_spatial_force(F: SpatialForce) -> np.ndarray:
    """[f; τ] (6,) from a Drake SpatialForce, same frame and point."""
    return np.concatenate((F.translational(), F.rotational()))


def spatial_force_from_wrench(wrench) -> SpatialForce:
    """A Drake SpatialForce from [f; τ], same frame and point."""
    wrench = np.asarray(wrench, dtype=float)
    return SpatialForce(tau=wrench[3:], f=wrench[:3])


_SWAPPED = np.array([3, 4, 5, 0, 1, 2])


def swap_halves(x, axis: int = -1) -> np.ndarray:
    """Drake's order [rotational; translational] ↔ heft's [translational; rotational] for arrays
    of spatial-vector coefficients (an acceleration's [α; a] → [a; α], a Jacobian's rows
    [ω; v] → [v; ω] with ``axis`` 0): the two 3-blocks along ``axis`` exchanged (a new array;
    one indexed copy, a third of the cost of splitting and joining per tick)."""
    return np.take(x, _SWAPPED, axis=axis)
