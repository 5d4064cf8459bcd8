"""The `heft` command: entry point, --version, and the check job."""

import subprocess
import sys
from importlib.metadata import entry_points, version

import pytest

from heft.diagrams.cli import main


def run_heft(*args):
    return subprocess.run([sys.executable, "-m", "heft.diagrams.cli", *args],
                          capture_output=True, text=True, timeout=120)


def test_console_script_points_at_the_cli():
    (script,) = [e for e in entry_points(group="console_scripts") if e.name == "heft"]
    assert script.value == "heft.diagrams.cli:main"


def test_version_and_help():
    result = run_heft("--version")
    assert result.returncode == 0 and result.stdout.strip() == f"heft {version('heft-teleop')}"
    result = run_heft("--help")
    assert result.returncode == 0 and "check" in result.stdout and "bench" in result.stdout


def test_check_reports_agreement_with_drake(capsys):
    assert main(["check", "--seed", "3", "--duration", "0.2"]) == 0
    out = capsys.readouterr().out
    assert "200 samples" in out and "Eq. 4 matches Drake's dynamics" in out


def test_unknown_command_is_an_error():
    result = run_heft("fly")
    assert result.returncode == 2 and "invalid choice" in result.stderr


def test_bench_regressor_prints_both_sides(capsys):
    assert main(["bench", "regressor", "--batch", "1000"]) == 0
    out = capsys.readouterr().out
    assert "one sample (µs)" in out and "Drake/heft" in out
