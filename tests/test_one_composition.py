"""Fig. 4 is wired in one place: ``MakeTeleopController`` (with ``AddOnlineLoadEstimator``) builds the controller's
blocks and connects them; the hardware loop and the simulation both step what it builds; no module calls a
block's kernels in an order of its own. Read off the package's source with ``ast``."""

import ast
from pathlib import Path

import pytest

from heft.systems.tick_system import TickSystem

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = [path for folder in ("systems", "diagrams", "hardware_interface", "analysis")
           for path in (ROOT / folder).rglob("*.py")]
WIRING = {"diagrams/teleop.py", "diagrams/online_estimation.py"}
"""The modules that build the controller's Diagram."""


def controller_blocks() -> dict[str, str]:
    """Every TickSystem subclass ``systems/`` defines (the controller's blocks; a station's are elsewhere): name →
    the module defining it."""
    import importlib

    blocks = {}
    for path in (ROOT / "systems").rglob("*.py"):
        module = importlib.import_module("heft." + ".".join(path.relative_to(ROOT).with_suffix("").parts))
        for name, value in vars(module).items():
            if isinstance(value, type) and issubclass(value, TickSystem) and value.__module__ == module.__name__:
                blocks[name] = path.relative_to(ROOT).as_posix()
    return blocks


def calls(path: Path) -> set[str]:
    """The names this module calls (``f(…)`` and ``x.f(…)``)."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Call):
            names.add(node.func.id if isinstance(node.func, ast.Name) else getattr(node.func, "attr", ""))
    return names


@pytest.fixture(scope="module")
def blocks():
    found = controller_blocks()
    assert {"MotionScaling", "ForceScalingElimination", "PassivityController", "OffsetTracker", "GraspSplit",
            "RlsLoadEstimator"} <= set(found), found
    return found


def test_only_the_controller_builder_makes_the_controllers_blocks(blocks):
    """A block is made where it is defined (its tests aside), in the builders of the controller, or — the
    kinematics, which identification also uses — there."""
    shared = {"MasterKinematics", "SlaveKinematics", "AccelerometerToMotion", "TickConstant", "TickSum"}
    for path in PACKAGE:
        where = path.relative_to(ROOT).as_posix()
        if where in WIRING:
            continue
        made = calls(path) & set(blocks)
        made -= {name for name in made if blocks[name] == where}
        made -= shared
        assert not made, f"{where} makes the controller's blocks {sorted(made)}: wire them in MakeTeleopController"


def test_no_module_calls_the_blocks_kernels_in_an_order_of_its_own(blocks):
    """The kernels a block declares (its calculations and updates) are called by its module and by
    ``TickProgram`` only, through the declarations; never composed by hand elsewhere."""
    import importlib

    declared = set()
    for where in blocks.values():
        module = importlib.import_module("heft." + where.removesuffix(".py").replace("/", "."))
        source = (ROOT / where).read_text()
        for node in ast.walk(ast.parse(source)):
            if isinstance(node, ast.Call) and getattr(node.func, "attr", "") in (
                    "DeclareTickCalc", "DeclareTickUpdate", "DeclareTickInitialization"):
                for argument in node.args:
                    if isinstance(argument, ast.Name) and callable(getattr(module, argument.id, None)):
                        declared.add(argument.id)
    assert {"force_evaluation", "force_update", "motion_tick", "ik_update", "passivity_update",
            "offset_tracker_update", "rls_update", "grasp_update"} <= declared, declared
    for path in PACKAGE:
        where = path.relative_to(ROOT).as_posix()
        called = calls(path) & declared
        defined = {node.name for node in ast.walk(ast.parse(path.read_text())) if isinstance(node, ast.FunctionDef)}
        assert called <= defined, f"{where} calls the blocks' kernels {sorted(called - defined)} by hand"


def test_hardware_and_simulation_step_what_the_builder_builds():
    """The real-time loop's controller and the simulation's are programs of ``MakeTeleopController``'s Diagram,
    each connected to its station by the one function."""
    for where, made in (("diagrams/teleop_controller.py", "TickProgram"),
                        ("diagrams/teleop_simulation.py", "TickProgramSystem")):
        names = calls(ROOT / where)
        assert {"MakeTeleopController", made, "ConnectControllerToStation"} <= names, where


def test_the_hardware_station_has_the_simulated_stations_ports():
    """Swap the station, keep the controller: the lab's station System offers what the simulated one does."""
    import lcm

    from heft.diagrams.device_limits import device_limits
    from heft.diagrams.scenario import resolve_scenario
    from heft.diagrams.stations.sim_station import MakeSimStation
    from heft.hardware_interface.channels import LcmChannels
    from heft.hardware_interface.hardware_station import HardwareStation
    from heft.hardware_interface.hardware_station_system import HardwareStationSystem
    from heft.systems.station_ports import CLUTCH, STATION_INPUTS_DRIVEN, STATION_OUTPUTS_READ

    scenario = resolve_scenario("fig6")
    simulated = MakeSimStation(scenario)
    hardware = HardwareStationSystem(HardwareStation(lcm.LCM("memq://"), LcmChannels(), device_limits(scenario)),
                                     scenario.controller_period)
    for station in (simulated, hardware):
        for name in (*STATION_OUTPUTS_READ, CLUTCH):
            assert station.GetOutputPort(name).size() == (1 if name == CLUTCH else 6), name
        for name in STATION_INPUTS_DRIVEN:
            assert station.GetInputPort(name).size() == 6, name
    assert {hardware.get_input_port(i).get_name() for i in range(hardware.num_input_ports())} == \
        set(STATION_INPUTS_DRIVEN)
