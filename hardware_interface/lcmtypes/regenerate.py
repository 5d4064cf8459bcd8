"""Regenerates the LCM types of this folder from its ``*.lcm`` files: Python here, and C, C++ and
Java for the lab's drivers in ``drivers/`` (its README says how to build and use them).

Run ``python -m heft.hardware_interface.lcmtypes.regenerate`` after editing a
``.lcm`` file, and commit the result. Steps for Python:

1. ``lcm-gen -p`` (from the ``lcm`` pip package, found beside the running
   interpreter or on PATH) writes package ``heft_lcmtypes`` into a temporary
   folder as ``heft_lcmtypes/{__init__,<type>}.py``.
2. Post-step: the files move up one level, so this folder itself is the
   package (``heft.hardware_interface.lcmtypes``). lcm-gen's ``__init__.py``
   already imports its modules relatively (``from .x import x``); a type that
   nests another emits an absolute ``import heft_lcmtypes``, which would not
   resolve inside ``heft``, so such output is refused rather than committed.

``tests/test_hardware_ft_receiver.py`` checks that the committed modules are
byte for byte what this produces, ``tests/test_lcmtypes_for_drivers.py`` the same of ``drivers/``.
"""

import pathlib
import shutil
import subprocess
import sys
import tempfile

HERE = pathlib.Path(__file__).resolve().parent
LCM_PACKAGE = "heft_lcmtypes"
DRIVERS = HERE / "drivers"
"""Where the C (``c/``), C++ (``cpp/``) and Java (``java/``) types are committed."""
DRIVER_LANGUAGES = {"c": ["-c", "--c-cpath", "{out}", "--c-hpath", "{out}"],
                    "cpp": ["-x", "--cpp-std", "c++11", "--cpp-hpath", "{out}"],
                    "java": ["-j", "--jpath", "{out}"]}
"""lcm-gen's options per language, ``{out}`` the language's folder."""


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


def regenerate_for_drivers(out_dir: pathlib.Path = DRIVERS) -> list[str]:
    """Writes the C, C++ and Java types into ``out_dir``/{c,cpp,java}, each folder emptied first;
    returns their paths relative to ``out_dir``."""
    sources = sorted(str(p) for p in HERE.glob("*.lcm"))
    written = []
    for language, options in DRIVER_LANGUAGES.items():
        folder = pathlib.Path(out_dir) / language
        shutil.rmtree(folder, ignore_errors=True)
        folder.mkdir(parents=True)
        subprocess.run([lcm_gen_executable(), *(option.format(out=folder) for option in options), *sources],
                       check=True)
        written += sorted(str(path.relative_to(out_dir)) for path in folder.rglob("*") if path.is_file())
    return written


if __name__ == "__main__":
    print("\n".join(regenerate() + regenerate_for_drivers()))
