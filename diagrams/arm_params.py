"""A lab's own slave arm, given by its URDF: the ``arm`` section of a scenario with ``robot: custom``
(``diagrams/urdf_arm.py`` reads it). Apart from the reader, so that a scenario loads without building
a plant."""

import dataclasses
from pathlib import Path

from pydrake.common.schema import Transform


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
    """The sensor frame S on the flange, in Drake's ``Transform`` schema (m; rotation e.g. ``!Rpy {deg: …}``)."""

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

    def urdf_path(self, relative_to=None) -> Path:
        """The URDF file: ``urdf`` itself if absolute, else taken from the folder ``relative_to``
        (the scenario file's; default the working directory)."""
        path = Path(self.urdf).expanduser()
        return path if path.is_absolute() or relative_to is None else Path(relative_to) / path
