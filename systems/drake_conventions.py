"""The one place where Drake's spatial vectors meet heft's conventions (DESIGN §4).

Drake orders a SpatialForce as [τ; f] and a SpatialAcceleration as [α; a];
heft orders wrenches [f; τ] and accelerations [a; α].
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
