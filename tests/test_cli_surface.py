"""The `heft` command line as one surface: every command's --help, the shared options meaning the same
everywhere, distinct exit statuses, progress off a terminal, `heft init lab`, and the packaging."""

import argparse
import csv
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from heft.diagrams.cli import build_analyze_parser, build_parser, main
from heft.diagrams.commands import exit_status
from heft.diagrams.commands.options import OUT_HELP, SCENARIO_HELP

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "docs" / "example_recording"


def _commands(parser: argparse.ArgumentParser, path=()) -> list:
    """(words, parser) of every command and subcommand under ``parser``."""
    found = [(path, parser)]
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                if name != "analyze":  # its own parser, below
                    found += _commands(sub, (*path, name))
    return found


ALL_COMMANDS = _commands(build_parser()) + _commands(build_analyze_parser(), ("analyze",))


def _option(parser, flag):
    return next((a for a in parser._actions if flag in a.option_strings), None)


def test_every_command_answers_help(capsys):
    for words, _ in ALL_COMMANDS:
        with pytest.raises(SystemExit) as done:
            main([*words, "--help"])
        assert done.value.code == 0, words
        text = capsys.readouterr().out
        assert "usage: heft" in text and "exit statuses:" in text, words


def test_out_and_scenario_mean_the_same_everywhere():
    with_out = with_scenario = 0
    for words, parser in ALL_COMMANDS:
        out, scenario = _option(parser, "--out"), _option(parser, "--scenario")
        if out is not None:
            with_out += 1
            assert out.metavar == "DIR" and out.help.startswith(OUT_HELP), (words, out.help)
        if scenario is not None:
            with_scenario += 1
            assert scenario.metavar == "NAME|FILE" and scenario.help.startswith(SCENARIO_HELP), words
        noise = _option(parser, "--noise")
        assert noise is None or noise.choices == ("on", "off"), words
    assert with_out >= 15 and with_scenario >= 12


def test_simulate_takes_the_scenario_either_way(capsys):
    args = build_parser().parse_args(["simulate", "fig6"])
    from heft.diagrams.commands.simulate import chosen_scenario

    assert chosen_scenario(args) == "fig6"
    assert chosen_scenario(build_parser().parse_args(["simulate", "--scenario", "fig7"])) == "fig7"
    assert main(["simulate", "fig6", "--scenario", "fig7"]) == exit_status.USAGE
    assert "give the scenario once" in capsys.readouterr().err


def test_an_out_that_is_a_file_is_refused(tmp_path, capsys):
    (tmp_path / "summary.json").write_text("{}")
    assert main(["picture", "--format", "dot", "--out", str(tmp_path / "summary.json")]) == exit_status.USAGE
    assert "--out names a folder" in capsys.readouterr().err


def test_exit_statuses_are_distinct():
    statuses = [exit_status.OK, exit_status.CHECK_FAILED, exit_status.USAGE, exit_status.FIT_REFUSED,
                exit_status.HARDWARE_FAULT, exit_status.LOAD_REFUSED, exit_status.TIMEOUT]
    assert len(set(statuses)) == len(statuses) == len(exit_status.STATUSES)
    readme = (ROOT / "README.md").read_text()
    for status, meaning in exit_status.STATUSES.items():
        assert f"| {status} |" in readme, meaning


def test_a_refused_fit_exits_apart_from_a_usage_error(tmp_path, capsys):
    """Static poses one of which is 3 N off along z disagree beyond the sensor's noise: the fit is
    refused (3), where a missing recording is bad input (2)."""
    rows = list(csv.reader((EXAMPLE / "poses.csv").open()))
    rows[3][3] = str(float(rows[3][3]) + 3.0)
    with (tmp_path / "poses.csv").open("w", newline="") as file:
        csv.writer(file).writerows(rows)
    (tmp_path / "poses.yaml").write_text((EXAMPLE / "poses.yaml").read_text())
    out = tmp_path / "identify"
    assert main(["-q", "identify", "--recording", str(tmp_path / "poses.yaml"), "--out", str(out)]) \
        == exit_status.FIT_REFUSED
    assert "fit refused: " in capsys.readouterr().err and not (out / "estimate.yaml").exists()
    assert main(["identify", "--recording", str(tmp_path / "absent.yaml"), "--out", str(out)]) == exit_status.USAGE
    assert "error: " in capsys.readouterr().err
    result = subprocess.run([sys.executable, "-m", "heft.diagrams.cli", "identify", "--metod", "tls"],
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == exit_status.USAGE


def test_progress_lines_when_stderr_is_a_file(tmp_path):
    """`heft compensate` with stderr to a file: plain progress lines with an ETA, no carriage returns;
    -q: none."""
    from drake_motion import PAPER_TOOL

    estimate = tmp_path / "estimate.yaml"
    estimate.write_text(yaml.safe_dump({"phi": PAPER_TOOL.to_phi().tolist(),
                                        "offsets": [1.5, -2.0, 3.0, 0.1, -0.05, 0.02]}))
    command = [sys.executable, "-m", "heft.diagrams.cli", "compensate", "--recording",
               str(EXAMPLE / "recording.yaml"), "--estimate", str(estimate), "--out", str(tmp_path / "out")]
    for quiet in (False, True):
        with (tmp_path / "stderr.txt").open("w") as stderr:
            done = subprocess.run([*command, *(["-q"] if quiet else [])], stdout=subprocess.DEVNULL, stderr=stderr,
                                  timeout=300)
        assert done.returncode == 0
        lines = (tmp_path / "stderr.txt").read_text()
        if quiet:
            assert "compensate:" not in lines
        else:
            assert "\r" not in lines
            progress = [line for line in lines.splitlines() if line.startswith("compensate: ")]
            assert progress and "100%" in progress[-1] and all("ETA" in line for line in progress), lines


def test_dask_without_the_cluster_extra_says_how_to_install(monkeypatch):
    import importlib.util

    from heft.diagrams.commands.options import dask_address

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "distributed" else real(name, *a))
    with pytest.raises(argparse.ArgumentTypeError, match=r"pip install 'heft-teleop\[cluster\]'"):
        dask_address("tcp://localhost:8786")


def test_init_lab_writes_a_file_the_lab_commands_take(tmp_path, capsys):
    from heft.diagrams.commands.options import require_lab_settings, scenario_from

    assert main(["init", "lab", "--robot", "rx60", "--out", str(tmp_path)]) == 0
    lab = tmp_path / "lab.yaml"
    text = lab.read_text()
    assert text.count("MEASURE") >= 2 and text.startswith("# heft lab file")
    args = build_parser().parse_args(["teleop", "--hardware", "--scenario", str(lab)])
    scenario = scenario_from(args)
    require_lab_settings(args, "accelerometer.position", "controller.force.mount_notch")  # stated, so no refusal
    assert scenario.robot == "rx60" and scenario.lab.lcm.command_lcm_url().endswith(":7668?ttl=0")
    assert main(["init", "lab", "--out", str(tmp_path)]) == exit_status.USAGE  # never overwritten silently
    assert "--force" in capsys.readouterr().err
    assert main(["init", "lab", "--out", str(tmp_path / "labs" / "mine.yaml")]) == 0
    assert (tmp_path / "labs" / "mine.yaml").read_text().startswith("# heft lab file")


@pytest.mark.parametrize("robot", ["ur5e", "iiwa14"])
def test_init_lab_writes_a_file_of_any_bundled_arm_that_loads(tmp_path, robot):
    """The arm's own start posture and motion scale, stated; its channels' joints are the arm's."""
    from heft.diagrams.arm_params import BUNDLED_ARMS
    from heft.diagrams.commands.options import scenario_from
    from heft.diagrams.device_limits import device_limits

    assert main(["init", "lab", "--robot", robot, "--out", str(tmp_path)]) == 0
    text = (tmp_path / "lab.yaml").read_text()
    arm = BUNDLED_ARMS[robot]
    assert f"carry its {len(arm.start)} joints" in text
    scenario = scenario_from(build_parser().parse_args(["stand-in", "--scenario", str(tmp_path / "lab.yaml")]))
    assert scenario.robot == robot and scenario.slave_initial_q == list(arm.start)
    assert scenario.controller.motion.translation_scale == arm.translation_scale
    assert len(device_limits(scenario).slave_velocity) == len(arm.start)


def test_the_package_installs_no_dask():
    """dask is the cluster extra's alone (pyproject), and the installed metadata says the same."""
    tomllib = pytest.importorskip("tomllib")
    from importlib.metadata import requires

    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert not any("dask" in dependency for dependency in project["dependencies"])
    assert any(d.startswith("dask[distributed]") for d in project["optional-dependencies"]["cluster"])
    assert any(dependency.startswith("tqdm") for dependency in project["dependencies"])
    installed = [r for r in requires("heft-teleop") if r.startswith("dask")]
    assert all('extra == "cluster"' in r for r in installed), installed
    assert (ROOT / "LICENSE").read_text().startswith("BSD 3-Clause License")


@pytest.mark.slow
def test_pip_install_resolves_no_dask(tmp_path):
    """What `pip install .` would install, resolved without installing (pip's --dry-run --report)."""
    report = tmp_path / "report.json"
    done = subprocess.run([sys.executable, "-m", "pip", "install", "--dry-run", "--ignore-installed", "--quiet",
                           "--report", str(report), str(ROOT)], capture_output=True, text=True, timeout=600)
    if done.returncode != 0:
        pytest.skip(f"pip could not resolve here (no package index?): {done.stderr.strip()[-300:]}")
    names = {item["metadata"]["name"].lower() for item in json.loads(report.read_text())["install"]}
    assert "heft-teleop" in names and "tqdm" in names
    assert not names & {"dask", "distributed"}, sorted(names)


def test_progress_bar_counts_to_its_total(tmp_path):
    """Off a terminal a line each tenth and one at the end, with the ETA."""
    import io
    import logging

    from heft.diagrams.progress import ProgressBar

    logging.getLogger("heft").setLevel(logging.INFO)
    stream = io.StringIO()
    bar = ProgressBar(200.0, "work", stream=stream)
    for done in np.linspace(0, 200, 41):
        bar.update(done)
    bar.close()
    lines = stream.getvalue().splitlines()
    assert 10 <= len(lines) <= 11 and lines[-1].startswith("work: 100%") and all("ETA" in line for line in lines)


def test_verbose_shows_debug_lines_and_quiet_only_errors(capsys):
    """-v shows how the scenario was made, -q leaves only the error; either stands anywhere."""
    command = ["load", "--rezero", "--lcm-url", "memq://", "--timeout", "0"]
    assert main(["-v", *command]) == exit_status.TIMEOUT
    verbose = capsys.readouterr()
    assert "scenario fig6" in verbose.out and "laid over it: {lab: {lcm: {lcm_url: 'memq://'}}}" in verbose.out
    assert main(command) == exit_status.TIMEOUT
    assert "scenario fig6" not in capsys.readouterr().out
    assert main([*command, "-q"]) == exit_status.TIMEOUT
    quiet = capsys.readouterr()
    assert quiet.out == "" and "heft load: timeout: " in quiet.err
