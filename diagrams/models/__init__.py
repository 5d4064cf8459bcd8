"""heft's own robot and load models (URDF), with primitive geometry only.

``model_path("rx90.urdf")`` gives the absolute path of a model file in this folder.
Numbers and their sources: SOURCES.md; inertias: make_tool_inertia.py.
"""

from __future__ import annotations

from pathlib import Path

_HERE = Path(__file__).resolve().parent
_MODEL_SUFFIXES = (".urdf", ".sdf")


def available_models() -> list[str]:
    """File names of the models in this folder."""
    return sorted(p.name for p in _HERE.iterdir() if p.suffix in _MODEL_SUFFIXES)


def model_path(name: str) -> str:
    """Absolute path of the model file ``name`` (e.g. "rx90.urdf") in this folder.

    Raises FileNotFoundError, listing the available models, if there is none."""
    path = _HERE / name
    if not path.is_file():
        raise FileNotFoundError(
            f"no model {name!r} in {_HERE}; available models: {', '.join(available_models())}")
    return str(path)
