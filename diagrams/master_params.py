"""The haptic masters heft knows (``BUNDLED_MASTERS``): a URDF under ``diagrams/models`` whose transmissions
are the actuated axes, and the device's force limit. Apart from the plants, so that a scenario loads without
building one. Numbers and sources: ``diagrams/models/SOURCES.md``."""

import dataclasses


@dataclasses.dataclass(frozen=True)
class BundledMaster:
    """A master heft ships a model of (``diagrams/models/<name>.urdf``: base link ``phantom_base`` = B, stylus
    link ``stylus`` = E at the gimbal's centre, six joints; a joint with a ``<transmission>`` is actuated)."""
    name: str
    max_force: float | None = None
    """The largest force the device renders at E (N), ``controller.feedback.max_force`` where a scenario naming
    this master states none; None: the scenario's (its default is the Phantom Premium's)."""


DEFAULT_MASTER = "phantom_premium_6dof"
BUNDLED_MASTERS = {master.name: master for master in (
    BundledMaster(DEFAULT_MASTER),
    BundledMaster("touch", max_force=3.3),
)}
"""The bundled masters by name: the paper's Phantom Premium 1.5 6DoF (six actuated joints: force and torque)
and the 3D Systems Touch (three actuated joints and a passive, measured wrist: the force only)."""

