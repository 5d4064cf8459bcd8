"""One override path: outside ``diagrams/scenario.py`` no code changes a scenario in place or by
``dataclasses.replace``; scenarios are changed only through ``layered`` (``overrides_text``,
``resolve_scenario(name, overrides)``, ``--set``). Read from the source with ``ast``: the package's
modules and the tests alike."""

import ast
from pathlib import Path

import pytest

from heft.diagrams.scenario import Scenario, layered, overrides_text

ROOT = Path(__file__).resolve().parents[1]
FOLDERS = ("systems", "hardware_interface", "analysis", "diagrams", "tests")
OVERRIDE_PATH = ROOT / "diagrams" / "scenario.py"


def _chain(node: ast.expr) -> tuple[list[str], bool]:
    """The names along an attribute/subscript chain, root first (``a.b[0].c`` → a, b, c), and
    whether it holds an attribute access."""
    names, has_attribute = [], False
    while isinstance(node, (ast.Attribute, ast.Subscript)):
        if isinstance(node, ast.Attribute):
            names.append(node.attr)
            has_attribute = True
        node = node.value
    if isinstance(node, ast.Name):
        names.append(node.id)
    return names[::-1], has_attribute


def _reaches(node: ast.expr, names: set[str]) -> bool:
    """True if the object ``node`` denotes is, or is reached through, one of ``names`` or a name
    containing "scenario"."""
    return any("scenario" in name.lower() or name in names for name in _chain(node)[0])


def _made_as_scenario(value: ast.expr) -> bool:
    """A call that makes a scenario: ``Scenario()``, ``layered(…)``, ``resolve_scenario(…)``, ``quiet_scenario()``…"""
    return isinstance(value, ast.Call) and (
        "scenario" in ast.unparse(value.func).lower() or ast.unparse(value.func) == "layered")


FUNCTIONS = (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)


def _own_nodes(scope: ast.AST):
    """The nodes of ``scope`` outside the functions nested in it (those are scopes of their own)."""
    for child in ast.iter_child_nodes(scope):
        yield child
        if not isinstance(child, FUNCTIONS):
            yield from _own_nodes(child)


def _scenario_names(scope: ast.AST, outer: set[str]) -> set[str]:
    """The names in ``scope`` that hold a scenario or a part of one: annotated as a ``Scenario``,
    bound to a new scenario (``custom = Scenario()``), to a part of one (``offsets =
    scenario.controller.offsets``), looping over parts (``for sensor in (scenario.ft_sensor, …)``)
    or so bound in an enclosing scope (``outer``) and not a parameter here."""
    parameters = {a.arg for a in ast.walk(scope.args) if isinstance(a, ast.arg)} if isinstance(scope, FUNCTIONS) \
        else set()
    names = outer - parameters
    for _ in range(3):  # aliases of aliases
        for node in [scope, *_own_nodes(scope)] if isinstance(scope, FUNCTIONS) else _own_nodes(scope):
            if isinstance(node, ast.arg) and node.annotation is not None \
                    and "Scenario" in ast.unparse(node.annotation):
                names.add(node.arg)
            elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name) \
                    and "Scenario" in ast.unparse(node.annotation):
                names.add(node.target.id)
            elif isinstance(node, ast.Assign) and (_made_as_scenario(node.value) or isinstance(
                    node.value, ast.Attribute) and _reaches(node.value, names)):
                names.update(t.id for t in node.targets if isinstance(t, ast.Name))
            elif isinstance(node, ast.For) and isinstance(node.target, ast.Name) \
                    and isinstance(node.iter, (ast.Tuple, ast.List)) \
                    and any(_reaches(e, names) for e in node.iter.elts if isinstance(e, ast.Attribute)):
                names.add(node.target.id)
    return names


def _changed(node: ast.AST) -> list[ast.expr]:
    """The objects ``node`` changes in place: ``x.a = …`` changes x, ``x.a[i] = …`` changes x.a
    (``scenarios[name] = …`` fills a dict); ``setattr(x, …)`` and ``dataclasses.replace(x, …)``
    (a changed copy) too."""
    if isinstance(node, ast.Call) and node.args \
            and ast.unparse(node.func) in ("replace", "dataclasses.replace", "setattr"):
        return [node.args[0]]
    targets = node.targets if isinstance(node, (ast.Assign, ast.Delete)) else \
        [node.target] if isinstance(node, (ast.AugAssign, ast.AnnAssign)) else []
    flat = [e for t in targets for e in (t.elts if isinstance(t, (ast.Tuple, ast.List)) else [t])]
    return [t.value for t in flat if isinstance(t, ast.Attribute) or isinstance(t, ast.Subscript) and _chain(t)[1]]


def scenario_mutations(source: str, filename: str = "<source>") -> list[str]:
    """``file:line: code`` for each place in ``source`` that assigns to (or ``setattr``s) an
    attribute or item of a scenario or of its parts, or ``dataclasses.replace``s one; each scope
    (module, function) knows its own scenario names and those of the scopes around it."""
    found = []

    def visit(scope, outer):
        names = _scenario_names(scope, outer)
        for node in _own_nodes(scope):
            if isinstance(node, FUNCTIONS):
                visit(node, names)
            elif any(_reaches(value, names) for value in _changed(node)):
                found.append(f"{filename}:{node.lineno}: {ast.unparse(node).splitlines()[0]}")

    visit(ast.parse(source, filename), set())
    return found


def test_no_scenario_is_changed_outside_the_override_path():
    sources = [p for folder in FOLDERS for p in sorted((ROOT / folder).rglob("*.py")) if p != OVERRIDE_PATH]
    assert len(sources) > 100  # the whole tree was read
    found = [hit for path in sources for hit in scenario_mutations(path.read_text(), str(path.relative_to(ROOT)))]
    assert not found, "change scenarios with layered(scenario, overrides_text({...})) only:\n" + "\n".join(found)


@pytest.mark.parametrize("planted", [
    "scenario.duration = 1.0",
    "scenario.controller.force.sigma = 0.5",
    "lab.scenario.operator.amplitude = [0, 0, 0]",
    "scenario.ft_sensor.noise, scenario.duration = False, 1.0",
    "scenario.ft_sensor.white_noise = other.white_noise = False",
    "base_scenario.controller.sigmas[0] = 0.3",
    "scenario.duration += 1.0",
    "dataclasses.replace(scenario, duration=1.0)",
    "replace(self.scenario.controller, delay=0.0)",
    "setattr(scenario.operator, 'frequency', 2.0)",
    "def configure(s: Scenario):\n    s.operator.frequency = 2.0",
    "offsets = scenario.controller.offsets\noffsets.tracking = False",
    "custom = Scenario()\ncustom.load.kind = 'custom'",
    "gripper = layered(Scenario(), '')\ngripper.load.kind = 'gripper_object'",
    "for sensor in (scenario.ft_sensor, scenario.accelerometer):\n    sensor.noise = False",
])
def test_the_checker_finds_a_planted_change(planted):
    assert len(scenario_mutations(planted)) == 1


@pytest.mark.parametrize("allowed", [
    "scenario = layered(scenario, overrides_text({'duration': 1.0}))",
    "self.scenario = scenario",
    "scenarios[name] = resolve_scenario(name)",
    "settings.duration = scenario.duration",
    "msg.utime = 5",
    "dataclasses.replace(params(scenario), sigma=0.0)",
    "text.replace('scenario', 'x')",
    "settings = ExcitationSettings.quick()\nsettings.duration = 2.0",
    "def f():\n    offsets = scenario.controller.offsets\ndef g(offsets):\n    offsets.x = 1",
])
def test_the_checker_leaves_other_code_alone(allowed):
    assert scenario_mutations(allowed) == []


def test_the_override_path_takes_optional_lists_and_checks_rows():
    """An optional list (the mount's constants) is laid over like any list; a matrix (R_SA) must
    still be rows of numbers."""
    stiff = layered(Scenario(), overrides_text({"load.mount.torque_stiffness": [3000.0, 3000.0, 3000.0]}))
    assert stiff.load.mount.torque_stiffness == [3000.0, 3000.0, 3000.0]
    with pytest.raises(ValueError, match="accelerometer.R_SA' must be a list of rows of numbers"):
        layered(Scenario(), overrides_text({"accelerometer.R_SA": [1.0, 0.0, 0.0]}))
