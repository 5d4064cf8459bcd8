"""Regenerates the Python LCM types of this folder from its ``*.lcm`` files.

Run ``python -m heft.hardware_interface.lcmtypes.regenerate`` after editing a
``.lcm`` file, and commit the result. Steps:

1. ``lcm-gen -p`` (from the ``lcm`` pip package, found beside the running
   interpreter or on PATH) writes package ``heft_lcmtypes`` into a temporary
   folder as ``heft_lcmtypes/{__init__,<type>}.py``.
2. Post-step: the files move up one level, so this folder itself is the
   package (``heft.hardware_interface.lcmtypes``). lcm-gen's ``__init__.py``
   already imports its modules relatively (``from .x import x``); a type that
   nests another emits an absolute ``import heft_lcmtypes``, which would not
   resolve inside ``heft``, so such output is refused rather than committed.

``tests/test_hardware_ft_receiver.py`` checks that the committed modules are
byte for byte what this produces.
"""

import pathlib
import shutil
import subprocess
import sys
import tempfile

HERE = pathlib.Path(__file__).resolve().parent
LCM_PACKAGE = "heft_lcmtypes"


def lcm_gen_executable() -> str:
    """Path of ``lcm-gen``: beside the interpreter (a venv's bin/) or on PATH."""
    beside = pathlib.Path(sys.executable).parent / "lcm-gen"
    found = str(beside) if beside.exists() else shutil.which("lcm-gen")
    if found is None:
        raise FileNotFoundError("lcm-gen not found; install the `lcm` pip package")
    return found


def regenerate(out_dir: pathlib.Path = HERE) -> list[str]:
    """Writes the generated modules into ``out_dir``; returns their file names."""
    sources = sorted(str(p) for p in HERE.glob("*.lcm"))
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run([lcm_gen_executable(), "-p", "--ppath", tmp, *sources], check=True)
        names = []
        for module in sorted((pathlib.Path(tmp) / LCM_PACKAGE).glob("*.py")):
            text = module.read_text()
            if f"import {LCM_PACKAGE}" in text:
                raise ValueError(f"{module.name}: absolute `import {LCM_PACKAGE}` (a nested type); "
                                 "make it package-relative before committing")
            (pathlib.Path(out_dir) / module.name).write_text(text)
            names.append(module.name)
    return names


if __name__ == "__main__":
    print("\n".join(regenerate()))
