"""The layering of docs/design.md §2, read from the source's imports with ``ast``: no module imports a
layer above its own, and every import of heft's own code is absolute (``heft.…``).

Between the top-level folders, each imports only those to its left:
systems ← hardware_interface ← analysis ← diagrams. Inside ``diagrams/``: the builders (its
top-level modules, ``stations/`` and ``models/``) ← ``running`` ← ``studies`` ← ``commands`` ←
``cli``. A module may import its own layer. The LCM types lcm-gen writes are left as generated.
"""

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FOLDERS = ("systems", "hardware_interface", "analysis", "diagrams")
DIAGRAM_LAYERS = ("builders", "running", "studies", "commands", "cli")
LCM_TYPES = Path("hardware_interface", "lcmtypes")  # lcm-gen writes __init__.py and heft_*.py here


def _generated(relative: Path) -> bool:
    return relative.parent == LCM_TYPES and (relative.name == "__init__.py" or relative.name.startswith("heft_"))


def layer(parts: tuple[str, ...]) -> tuple[int, int] | None:
    """(folder rank, rank inside diagrams/) of the module at ``parts`` below the package root
    (e.g. ("diagrams", "running", "simulation")), or None for a module outside the layers."""
    if not parts or parts[0] not in FOLDERS:
        return None
    if parts[0] != "diagrams":
        return FOLDERS.index(parts[0]), 0
    inner = parts[1] if len(parts) > 1 else ""
    if inner in DIAGRAM_LAYERS[1:]:
        return FOLDERS.index("diagrams"), DIAGRAM_LAYERS.index(inner)
    return FOLDERS.index("diagrams"), 0  # a top-level builder, stations/, models/ or the package itself


def _imported(node) -> list[str]:
    """The dotted names an import statement reaches (``from a import b``: a.b, b maybe a module)."""
    if isinstance(node, ast.Import):
        return [alias.name for alias in node.names]
    if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
        return [f"{node.module}.{alias.name}" for alias in node.names]
    return []


def layering_violations(root: Path) -> list[str]:
    """Every upward import and every relative import in the tree at ``root`` (a checkout: the
    folders of ``FOLDERS`` installed as ``heft.<folder>``), one line each, as
    "path:line: what is wrong"; lcm-gen's output is left as written."""
    problems = []
    for folder in FOLDERS:
        for path in sorted((root / folder).rglob("*.py")):
            relative = path.relative_to(root)
            if _generated(relative):
                continue
            here = layer(relative.with_suffix("").parts)
            for node in ast.walk(ast.parse(path.read_text(), str(path))):
                if isinstance(node, ast.ImportFrom) and node.level > 0:
                    problems.append(f"{relative}:{node.lineno}: relative import; write it as heft.…")
                for name in _imported(node):
                    parts = tuple(name.split("."))
                    there = layer(parts[1:]) if parts[0] == "heft" else None
                    if there is not None and there > here:
                        problems.append(f"{relative}:{node.lineno}: imports {name}, a layer above its own")
    return problems


def test_the_tree_keeps_its_layers():
    assert layering_violations(ROOT) == []


def test_the_layers_are_where_the_design_puts_them():
    assert layer(("systems", "load_dynamics")) < layer(("hardware_interface", "channels"))
    assert layer(("hardware_interface", "channels")) < layer(("analysis", "run_log"))
    assert layer(("analysis", "run_log")) < layer(("diagrams", "plants"))
    assert layer(("diagrams", "plants")) == layer(("diagrams", "stations", "sim_station")) \
        == layer(("diagrams", "models", "make_tool_inertia"))
    assert layer(("diagrams", "plants")) < layer(("diagrams", "running", "simulation")) \
        < layer(("diagrams", "studies", "apparent_mass")) < layer(("diagrams", "commands", "simulate")) \
        < layer(("diagrams", "cli"))


def _tree(root: Path, files: dict[str, str]) -> Path:
    for name, text in files.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return root


def test_a_planted_upward_import_is_reported(tmp_path):
    root = _tree(tmp_path, {
        "systems/core.py": "import numpy as np\n",
        "systems/leaky.py": "def f():\n    from heft.diagrams.scenario import Scenario\n",
        "hardware_interface/ok.py": "from heft.systems.core import np\n",
        "analysis/upward.py": "import heft.diagrams.plants\n",
        "diagrams/plants.py": "from heft.systems import core\nfrom heft.analysis import upward\n",
        "diagrams/stations/station.py": "from heft.diagrams import plants, running\n",
        "diagrams/identify.py": "from heft.diagrams.running.progress import ProgressBar\n",
        "diagrams/running/progress.py": "from heft.diagrams.plants import x\n",
        "diagrams/studies/sweep.py": "from heft.diagrams.commands.bench import run\n",
        "diagrams/commands/bench.py": "from heft.diagrams.cli import main\nfrom heft.diagrams.studies import sweep\n",
        "diagrams/cli.py": "from heft.diagrams.commands import bench\n",
    })
    assert sorted(layering_violations(root)) == sorted([
        "systems/leaky.py:2: imports heft.diagrams.scenario.Scenario, a layer above its own",
        "analysis/upward.py:1: imports heft.diagrams.plants, a layer above its own",
        "diagrams/identify.py:1: imports heft.diagrams.running.progress.ProgressBar, a layer above its own",
        "diagrams/stations/station.py:1: imports heft.diagrams.running, a layer above its own",
        "diagrams/commands/bench.py:1: imports heft.diagrams.cli.main, a layer above its own",
        "diagrams/studies/sweep.py:1: imports heft.diagrams.commands.bench.run, a layer above its own",
    ])


def test_a_relative_import_is_reported(tmp_path):
    root = _tree(tmp_path, {"systems/a.py": "x = 1\n", "systems/b.py": "from .a import x\n",
                            "hardware_interface/lcmtypes/__init__.py": "from .heft_t import heft_t\n",
                            "hardware_interface/lcmtypes/regenerate.py": "from .heft_t import heft_t\n"})
    assert layering_violations(root) == [
        "systems/b.py:1: relative import; write it as heft.…",
        "hardware_interface/lcmtypes/regenerate.py:1: relative import; write it as heft.…"]
