"""The C, C++ and Java LCM types committed for the lab's drivers (hardware_interface/lcmtypes/drivers)
are byte for byte what lcm-gen makes of the .lcm files, and each compiles against the lcm pip
package's headers and jar."""

import pathlib
import shutil
import subprocess

import lcm
import pytest

from heft.hardware_interface.lcmtypes import regenerate

LCM_ROOT = pathlib.Path(lcm.__file__).resolve().parent.parent
"""site-packages, where the lcm pip package puts include/lcm and share/java/lcm.jar."""
DRIVERS = pathlib.Path(__file__).resolve().parent.parent / "hardware_interface" / "lcmtypes" / "drivers"
"""The types as the repository commits them (an installed heft does not carry them)."""


def test_committed_driver_types_are_regenerated_byte_for_byte(tmp_path):
    written = regenerate.regenerate_for_drivers(tmp_path)
    committed = sorted(str(path.relative_to(DRIVERS)) for language in regenerate.DRIVER_LANGUAGES
                       for path in (DRIVERS / language).rglob("*") if path.is_file())
    assert sorted(written) == committed
    assert len(written) == 4 * len(list(regenerate.HERE.glob("*.lcm")))  # .h, .c, .hpp, .java per type
    for name in written:
        assert (tmp_path / name).read_bytes() == (DRIVERS / name).read_bytes(), name


@pytest.mark.parametrize("language", ["c", "cpp", "java"])
def test_driver_types_compile(language, tmp_path):
    drivers, include = DRIVERS, LCM_ROOT / "include"
    if language == "java":
        jar, javac = LCM_ROOT / "share" / "java" / "lcm.jar", shutil.which("javac")
        if javac is None or not jar.exists():
            pytest.skip("needs javac and the lcm pip package's lcm.jar")
        command = [javac, "-cp", str(jar), "-d", str(tmp_path), *map(str, (drivers / "java").rglob("*.java"))]
    elif language == "c":
        if shutil.which("gcc") is None:
            pytest.skip("needs gcc")
        command = ["gcc", "-fsyntax-only", "-Wall", "-Werror", "-I", str(include),
                   *map(str, (drivers / "c").glob("*.c"))]
    else:
        if shutil.which("g++") is None:
            pytest.skip("needs g++")
        every = tmp_path / "every.cpp"
        every.write_text("".join(f'#include "{path.relative_to(drivers / "cpp")}"\n'
                                 for path in sorted((drivers / "cpp").rglob("*.hpp"))))
        command = ["g++", "-fsyntax-only", "-std=c++11", "-Wall", "-Werror", "-I", str(include), "-I",
                   str(drivers / "cpp"), str(every)]
    result = subprocess.run(command, capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
