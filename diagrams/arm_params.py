"""The slave arms heft knows: the bundled ones by name (``BUNDLED_ARMS``), and a lab's own, given by its
URDF: the ``arm`` section of a scenario with ``robot: custom`` (``diagrams/urdf_arm.py`` reads it). Apart
from the reader, so that a scenario loads without building a plant."""

import dataclasses
import math
from pathlib import Path

from pydrake.common.schema import Transform

from heft.diagrams.models.make_tool_inertia import RX60, RX90


@dataclasses.dataclass
class ArmParams:
    """The arm's URDF and the frames heft needs in it; loadable with ``yaml_load_typed``."""

    urdf: str = ""
    """The URDF file; a relative path is taken from the scenario file's folder."""

    base: str = ""
    """The link whose frame is the slave base R (z up: heft welds it at the world's origin)."""

    flange: str = ""
    """The link whose frame is the flange F, on the chain of joints below ``base``."""

    X_FS: Transform = dataclasses.field(default_factory=Transform)
    """The sensor frame S on the flange, in Drake's ``Transform`` schema (m; rotation e.g. ``!Rpy {deg: …}``);
    the wrist sensor's body is placed so that its measuring frame lies there."""

    payload: float = math.inf
    """The arm's rated payload (kg): identification refuses a load heavier than this (default: not checked)."""

    def validate(self) -> None:
        """Raises ValueError naming the first field that is missing or not usable."""
        for name in ("urdf", "base", "flange"):
            if not getattr(self, name):
                raise ValueError(f"{name} must name {'a URDF file' if name == 'urdf' else 'a link of the URDF'}")
        if self.X_FS.base_frame not in (None, "", self.flange):
            raise ValueError(f"X_FS is the sensor frame in the flange '{self.flange}'; "
                             f"got a base_frame {self.X_FS.base_frame!r}")
        if not self.X_FS.IsDeterministic():
            raise ValueError("X_FS must be a fixed transform, not a random one")
        if not self.payload > 0:
            raise ValueError(f"payload must be > 0 (kg); got {self.payload}")

    def urdf_path(self, relative_to=None) -> Path:
        """The URDF file: ``urdf`` itself if absolute, else taken from the folder ``relative_to``
        (the scenario file's; default the working directory)."""
        path = Path(self.urdf).expanduser()
        return path if path.is_absolute() or relative_to is None else Path(relative_to) / path


@dataclasses.dataclass(frozen=True)
class BundledArm:
    """An arm heft ships a model of (``diagrams/models/<name>.urdf``: base link ``<name>_base`` = R, flange
    link ``flange`` = F, the JR3 welded on F; numbers and sources in ``diagrams/models/SOURCES.md``)."""
    name: str
    start: tuple
    """The start posture (rad): S 0.55 m in front of the base and 0.41 m above it, z pointing down, where
    fig6, fig7, fig8 and the excitation (±0.5 rad about it) stay within the joint limits."""
    payload: float
    """The rated payload (kg, SOURCES.md)."""
    servo_stiffness: tuple = ()
    """The robot controller's joint stiffness (N·m/rad); empty: ``SERVO_FREQUENCY``'s."""
    translation_scale: float | None = None
    """The master-to-slave motion scale (``controller.motion.translation_scale``) at which the bundled
    experiments' strokes (fig6's vertical, fig7's horizontal: 2 × 70 mm at 2.5 Hz at the RX90's 2) keep every
    joint within its speed limit from ``start``; None: the scenario's."""


BUNDLED_ARMS = {arm.name: arm for arm in (
    BundledArm("rx90", (0.0, 0.5, 1.8, 0.0, 0.84, 0.0), RX90.payload_max, (4e4, 4e4, 2e4, 2e3, 2e3, 5e2)),
    BundledArm("rx60", (0.0, 0.5, 1.8, 0.0, 0.84, 0.0), RX60.payload_max, (4e4, 4e4, 2e4, 2e3, 2e3, 5e2)),
    BundledArm("ur5e", (2.897, -1.460, 1.602, -1.714, -1.570, 1.327), 5.0, translation_scale=1.4),
    BundledArm("iiwa14", (0.0, 0.476, 0.0, -1.553, 0.0, 1.110, 0.0), 14.0, translation_scale=0.5),
)}
"""The bundled arms by name."""

ROBOTS = (*BUNDLED_ARMS, "custom")
"""What a scenario's ``robot`` may be: a bundled arm, or ``custom`` with an ``arm`` section."""

SERVO_FREQUENCY = 15.0
"""Hz: where an arm states no servo stiffness, each joint's is M_jj·(2π·15 Hz)², M_jj its inertia (arm and
payload in the start pose), so that every joint loop rings at 15 Hz; the RX90's own gains ring at 11–50 Hz."""
