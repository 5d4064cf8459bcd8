"""The README's "Your own data" example, run as the README writes it (from the repository's root, the
output folder moved into the test's; `heft`'s arguments handed to its entry point)."""

import json
import shlex
from pathlib import Path

from recording_layouts import CONTACT_S, EPOCH_US, LATE

from heft.diagrams.cli import main

ROOT = Path(__file__).resolve().parents[1]
MARKER = "<!-- your-own-data-example -->"


def _example_command() -> list[str]:
    text = (ROOT / "README.md").read_text()
    block = text[text.index(MARKER):].split("```bash\n", 1)[1].split("```", 1)[0]
    return shlex.split(block.replace("\\\n", " "))


def test_the_readme_example_runs_and_finds_what_was_recorded(tmp_path, monkeypatch, capsys):
    command = _example_command()
    assert command[:2] == ["heft", "compensate"]
    out = command.index("--out") + 1
    command[out] = str(tmp_path / "example")
    monkeypatch.chdir(ROOT)
    assert main(command[1:]) == 0
    assert "clock offset of accelerometer: 6.0" in capsys.readouterr().out
    metrics = json.loads((tmp_path / "example" / "metrics.json").read_text())
    assert abs(metrics["choices"]["clock_offsets_s"]["accelerometer"]["offset_s"] - LATE) < 1e-3
    (interval,) = metrics["intervals"]
    start, end = (interval[k] - EPOCH_US * 1e-6 for k in ("start_s", "end_s"))
    assert abs(start - CONTACT_S[0]) < 0.02 and abs(end - CONTACT_S[1]) < 0.02
    rms = metrics["residual_rms_without_contact"]
    assert max(rms[a] for a in ("fx", "fy", "fz")) < 0.12  # the 0.1 N of noise the example carries
    assert (tmp_path / "example" / "compensated.csv").stat().st_size > 100_000
