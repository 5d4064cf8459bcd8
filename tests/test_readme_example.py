"""The README's "your own recording" quickstart, run as the README writes it (from the repository's root,
the output folders moved into the test's; `heft`'s arguments handed to its entry point): static poses →
`heft identify --recording` → `heft compensate` on docs/example_recording."""

import json
import shlex
from pathlib import Path

import yaml
from recording_layouts import CONTACT_S, EPOCH_US, LATE

from heft.diagrams.cli import main

ROOT = Path(__file__).resolve().parents[1]
MARKER = "<!-- your-own-data-example -->"
PAPER_TOOL_MASS = 3.13  # kg


def _example_commands() -> list[list[str]]:
    """The commands of the bash block after ``MARKER``, one per line (continuations joined)."""
    text = (ROOT / "README.md").read_text()
    block = text[text.index(MARKER):].split("```bash\n", 1)[1].split("```", 1)[0]
    return [shlex.split(line) for line in block.replace("\\\n", " ").splitlines() if line.strip()]


def _moved(command: list[str], outputs: dict, folder: Path) -> list[str]:
    """``command`` with its ``--out`` (and any earlier command's output it reads) under ``folder``."""
    command = [outputs.get(argument, argument) for argument in command]
    for argument in command:
        for old, new in outputs.items():
            if argument.startswith(old + "/"):
                command[command.index(argument)] = new + argument[len(old):]
    out = command.index("--out") + 1
    outputs[command[out]] = str(folder / Path(command[out]).name)
    command[out] = outputs[command[out]]
    return command


def test_the_readme_example_runs_and_finds_what_was_recorded(tmp_path, monkeypatch, capsys):
    """The tool's mass from the poses, then the clock offset and the one contact from the run."""
    commands = _example_commands()
    assert [command[:2] for command in commands] == [["heft", "identify"], ["heft", "compensate"]]
    monkeypatch.chdir(ROOT)
    outputs = {}
    identify, compensate = (_moved(command, outputs, tmp_path) for command in commands)
    assert main(identify[1:]) == 0
    estimate = tmp_path / "identify" / "estimate.yaml"
    assert compensate[compensate.index("--estimate") + 1] == str(estimate)
    assert abs(yaml.safe_load(estimate.read_text())["mass"] - PAPER_TOOL_MASS) < 1e-3
    assert "the inertia is not identifiable from poses at rest" in capsys.readouterr().out
    assert main(compensate[1:]) == 0
    metrics = json.loads((tmp_path / "compensate" / "metrics.json").read_text())
    # The poses cannot give the inertia: the torques it leaves out move the clock offset found by < 2 ms.
    assert abs(metrics["choices"]["clock_offsets_s"]["accelerometer"]["offset_s"] - LATE) < 2e-3
    (interval,) = metrics["intervals"]
    start, end = (interval[k] - EPOCH_US * 1e-6 for k in ("start_s", "end_s"))
    assert abs(start - CONTACT_S[0]) < 0.02 and abs(end - CONTACT_S[1]) < 0.02
    rms = metrics["residual_rms_without_contact"]
    assert max(rms[a] for a in ("fx", "fy", "fz")) < 0.6  # the noise's 0.1 N, and the clock offset's error
    assert (tmp_path / "compensate" / "compensated.csv").stat().st_size > 100_000
