"""A Diagram of ``TickSystem`` blocks stepped as one program, derived from its own graph.

``TickProgram(diagram)`` reads the blocks' declarations (``systems.tick_system``) and the Diagram's
connections, and lays every signal in one flat array (``signals``): each of the Diagram's inputs,
each calculation, and so each output port, is a slice of it; an input port is the slice of the
output it is connected to, so a connection costs nothing. Every block's state is a slice of one
flat array (``state``). A tick does what Drake's stepping of the Diagram does for its one periodic
discrete update: every calculation, in an order that respects what each reads (computed from the
graph; those nothing reads are left out); then every block's updates on a copy of the state; then the
copy becomes the state. A block that talks to the world outside (the hardware station) receives before
the calculations and publishes after the update, as Drake's unrestricted updates and publishes do. A
Diagram inside the Diagram is laid out flat, its ports resolved to the blocks behind them. Each
kernel is called with arrays bound once, so the program itself allocates nothing and builds no objects in a tick
(a block's kernel may: the hardware station's receive and send are Python).

A block added to the Diagram is in the program with nothing else to write, and
``tests/test_tick_program.py`` holds the two tick for tick equal.
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np
from pydrake.systems.framework import Diagram, InputPortIndex, OutputPortIndex

from heft.systems.compiled_program import Slice, compilable, compile_program
from heft.systems.tick_system import Reshaped, TickSystem


class TickProgram:
    """``diagram`` (of ``TickSystem`` blocks sharing one period) as one program (module docstring).

    ``input(name)`` is the array to write a Diagram input into before a tick (it keeps its value
    between ticks; an input no block needs a value for starts at the blocks' default);
    ``output(name)`` the array a Diagram output is read from: after ``tick``, a state output holds the
    state the tick left and a calculation what the tick computed from its inputs (before the update),
    as Drake's ``EvalUniquePeriodicDiscreteUpdate`` sees them. ``reset`` then ``initialize`` is Drake's
    ``ExecuteInitializationEvents`` on a default context with the inputs as they are. With ``compile`` (and every
    kernel compiled by numba), the calculations, the updates and the two together (``step``) each run as one
    compiled function generated from the program's order (``systems.compiled_program``); else each kernel is
    called from Python. The two agree to the bit."""

    def __init__(self, diagram: Diagram, compile: bool = True):
        self.diagram = diagram
        self._parent, self._connections = {}, {}
        blocks = self._leaves(diagram)
        for block in blocks:
            if not isinstance(block, TickSystem):
                raise TypeError(f"the Diagram's system {block.get_name()!r} ({type(block).__name__}) is not a "
                                "TickSystem: declare its computations as kernels (systems/tick_system.py)")
        periods = {block.tick_period for block in blocks if block.tick_period is not None}
        if len(periods) > 1:
            raise ValueError(f"the blocks of a program tick at one period; these have {sorted(periods)} s")
        self.period = periods.pop() if periods else None
        self.blocks = blocks

        # The state: each block's groups in one flat array, in the blocks' and their declarations' order.
        state_slices, size = {}, 0
        for block in blocks:
            for name, (_, initial) in block.tick_states.items():
                state_slices[block, name] = slice(size, size + initial.size)
                size += initial.size
        self.state, self._next, self.initial_state = np.zeros(size), np.zeros(size), np.zeros(size)
        for (block, name), where in state_slices.items():
            self.initial_state[where] = block.tick_states[name][1]

        # The signals: the Diagram's inputs, then every calculation.
        signal_slices, size = {}, 0
        self._input_slices = {}
        for i in range(diagram.num_input_ports()):
            port = diagram.get_input_port(i)
            self._input_slices[port.get_name()] = slice(size, size + port.size())
            size += port.size()
        for block in blocks:
            for name, calc in block.tick_calcs.items():
                signal_slices[block, name] = slice(size, size + calc.size)
                size += calc.size
        unconnected = {}
        for block in blocks:
            for name, tick_input in block.tick_inputs.items():
                if self._source(block, tick_input.port.get_index()) is None:
                    unconnected[block, name] = slice(size, size + tick_input.size)
                    size += tick_input.size
        self.signals = np.zeros(size)
        for (block, name), where in unconnected.items():
            default = block.tick_inputs[name].default
            if default is None:
                raise ValueError(f"the input {name!r} of {block.get_name()!r} is connected to nothing and has no "
                                 "default: connect it or export it")
            self.signals[where] = default
        self._state_slices, self._signal_slices, self._unconnected = state_slices, signal_slices, unconnected
        self._default_inputs()

        # The calculations something reads, in an order that computes what each reads first.
        order, done, visiting = [], set(), set()

        def visit(block, name):
            if (block, name) in done:
                return
            if (block, name) in visiting:
                raise ValueError(f"the calculation {name!r} of {block.get_name()!r} reads itself through the "
                                 "Diagram: an algebraic loop")
            visiting.add((block, name))
            for read in block.tick_calcs[name].depends:
                kind, _, what = read.partition(":")
                if kind == "calc":
                    visit(block, what)
                elif kind == "in":
                    source = self._source(block, block.tick_inputs[what].port.get_index())
                    if source is not None and source[0] is not None:
                        source_block, output = source
                        kind, _, calc = output.source.partition(":")
                        if kind == "calc":
                            visit(source_block, calc)
            visiting.discard((block, name))
            done.add((block, name))
            order.append((block, name))

        for block, name in self._needed_calculations():
            visit(block, name)
        self.calculation_order = [(block.get_name(), name) for block, name in order]
        calculations = [(block, block.tick_calcs[name].kernel, block.tick_calcs[name].args) for block, name in order]
        updates = [(block, kernel, args) for block in blocks for kernel, args in block.tick_updates]
        self._calcs = [self._bind(block, kernel, args, None) for block, kernel, args in calculations]
        self._updates = [self._bind(block, kernel, args, self._next) for block, kernel, args in updates]
        self.compiled = compile and compilable([kernel for _, kernel, _ in calculations + updates])
        """Whether a tick calls the calculations and updates compiled (``_compile``)."""
        if self.compiled:
            self._compile(calculations, updates)
        self._initializations = [self._bind(block, kernel, args, self._next) for block in blocks
                                 for kernel, args in block.tick_initializations]
        self._receives = [self._bind(block, kernel, args, self.state) for block in blocks
                          for kernel, args in block.tick_receives]
        self._publishes = [self._bind(block, kernel, args, None) for block in blocks
                           for kernel, args in block.tick_publishes]
        self.state[:] = self.initial_state

    def _needed_calculations(self) -> list:
        """(block, calculation) that an update, an initialization, a receive, a publish or a Diagram output reads
        directly (a publish reads what the tick calculated, before its update)."""
        needed = []

        def read(block, name):
            kind, _, what = name.partition(":")
            if kind == "calc":
                needed.append((block, what))
            elif kind == "in":
                source = self._source(block, block.tick_inputs[what].port.get_index())
                if source is not None and source[0] is not None and source[1].source.startswith("calc:"):
                    needed.append((source[0], source[1].source[len("calc:"):]))

        for block in self.blocks:
            for _, args in block.tick_updates + block.tick_initializations + block.tick_receives + block.tick_publishes:
                for name in args:
                    if isinstance(name, str | Reshaped):
                        read(block, name.name if isinstance(name, Reshaped) else name)
        for i in range(self.diagram.num_output_ports()):
            block, output = self._leaf_output(self.diagram, i)
            if output.source.startswith("calc:"):
                needed.append((block, output.source[len("calc:"):]))
        return needed

    def _default_inputs(self) -> None:
        """Each Diagram input at the default of the block inputs it feeds (zeros if they have none); a ValueError
        if they have different ones (which block's would hold is not for the program to choose)."""
        for i in range(self.diagram.num_input_ports()):
            name = self.diagram.get_input_port(i).get_name()
            defaults = [block.tick_inputs[block.get_input_port(index).get_name()].default
                        for block, index in self._input_sinks(self.diagram, i)]
            defaults = [default for default in defaults if default is not None]
            if any(not np.array_equal(default, defaults[0], equal_nan=True) for default in defaults[1:]):
                raise ValueError(f"the Diagram input {name!r} feeds block inputs of different defaults; connect it, "
                                 "or give them one default")
            if defaults:
                self.signals[self._input_slices[name]] = defaults[0]

    def _input_sinks(self, diagram: Diagram, i: int) -> list:
        """The leaf inputs (block, index) that ``diagram``'s input ``i`` feeds, down through the Diagrams inside."""
        sinks = []
        for system, index in diagram.GetInputPortLocators(InputPortIndex(i)):
            sinks += self._input_sinks(system, index) if isinstance(system, Diagram) else [(system, index)]
        return sinks

    def _leaves(self, diagram: Diagram) -> list:
        """The leaf systems of ``diagram`` and of the Diagrams inside it, each one's parent noted."""
        self._connections[diagram] = dict(diagram.connection_map())
        leaves = []
        for system in diagram.GetSystems():
            self._parent[system] = diagram
            leaves += self._leaves(system) if isinstance(system, Diagram) else [system]
        return leaves

    def _source(self, block, index):
        """What feeds ``block``'s input ``index`` (through any Diagrams it is inside): (block, ``TickOutput``),
        (None, the outermost Diagram's input name), or None."""
        parent = self._parent[block]
        key = (block, InputPortIndex(int(index)))
        if key in self._connections[parent]:
            return self._leaf_output(*self._connections[parent][key])
        for i in range(parent.num_input_ports()):
            for system, port in parent.GetInputPortLocators(InputPortIndex(i)):
                if system is block and int(port) == int(index):
                    if parent is self.diagram:
                        return None, parent.get_input_port(i).get_name()
                    return self._source(parent, i)
        return None

    def _leaf_output(self, system, index):
        """(block, ``TickOutput``) of ``system``'s output ``index``, down through the Diagrams it is."""
        while isinstance(system, Diagram):
            system, index = system.get_output_port_locator(OutputPortIndex(int(index)))
        return system, system.tick_outputs[system.get_output_port(index).get_name()]

    def _output_where(self, block, output) -> Slice:
        kind, _, what = output.source.partition(":")
        if kind == "x":
            where = self._state_slices[block, what]
            return Slice("state", where.start + output.start, where.start + output.stop)
        where = self._signal_slices[block, what]
        return Slice("signals", where.start + output.start, where.start + output.stop)

    def _where(self, block, name: str) -> Slice:
        """Which slice of which flat array (``signals``, ``state``, ``next_state``) ``block``'s array ``name`` is."""
        kind, _, what = name.partition(":")
        if kind == "in":
            source = self._source(block, block.tick_inputs[what].port.get_index())
            if source is None:
                where = self._unconnected[block, what]
            elif source[0] is None:
                where = self._input_slices[source[1]]
            else:
                return self._output_where(*source)
            return Slice("signals", where.start, where.stop)
        if kind in ("x", "next"):
            where = self._state_slices[block, what]
            return Slice("state" if kind == "x" else "next_state", where.start, where.stop)
        if kind == "calc":
            where = self._signal_slices[block, what]
            return Slice("signals", where.start, where.stop)
        raise ValueError(f"{block.get_name()!r}: unknown array {name!r}")

    def _arguments(self, block, args) -> list:
        """``args`` with each named array as its ``Slice`` (shaped if ``Reshaped``), other values as they are."""
        return [dataclasses.replace(self._where(block, arg.name), shape=arg.shape) if isinstance(arg, Reshaped)
                else self._where(block, arg) if isinstance(arg, str) else arg for arg in args]

    def _bind(self, block, kernel, args, next_state):
        arrays = {"signals": self.signals, "state": self.state, "next_state": next_state}
        values = []
        for arg in self._arguments(block, args):
            if isinstance(arg, Slice):
                view = arrays[arg.array][arg.start:arg.stop]
                values.append(view if arg.shape is None else view.reshape(arg.shape))
            else:
                values.append(arg)
        return functools.partial(kernel, *values)

    def _compile(self, calculations, updates) -> None:
        """The calculations, the updates and the two together as compiled functions (``systems.compiled_program``)."""
        constants, index = [], {}

        def described(block, args):
            described = []
            for arg in self._arguments(block, args):
                if not isinstance(arg, Slice):
                    if id(arg) not in index:
                        index[id(arg)] = len(constants)
                        constants.append(arg)
                    arg = index[id(arg)]
                described.append(arg)
            return described

        calls = {"calculate": [(kernel, described(block, args)) for block, kernel, args in calculations],
                 "update": [(kernel, described(block, args)) for block, kernel, args in updates]}
        *functions, bounds = compile_program(calls, constants)
        self._compiled_calculate, self._compiled_update, self._compiled_step = (
            functools.partial(function, self.signals, self.state, self._next, bounds, *constants)
            for function in functions)

    # --- running ------------------------------------------------------------------------

    def input(self, name: str) -> np.ndarray:
        """The Diagram input ``name``'s array (a view: write into it)."""
        return self.signals[self._input_slices[name]]

    def output(self, name: str) -> np.ndarray:
        """The Diagram output ``name``'s array (a view: read it after a tick)."""
        in_state, where = self.locate(name)
        return (self.state if in_state else self.signals)[where]

    def locate(self, name: str) -> tuple[bool, slice]:
        """Where the Diagram output ``name`` lies: (True, its slice of ``state``) or (False, of ``signals``)."""
        where = self._output_where(*self._leaf_output(self.diagram, self.diagram.GetOutputPort(name).get_index()))
        return where.array == "state", slice(where.start, where.stop)

    def block(self, name: str):
        """The block named ``name`` (at any depth of the Diagram)."""
        found = [block for block in self.blocks if block.get_name() == name]
        if len(found) != 1:
            raise KeyError(f"{len(found)} blocks are named {name!r} in the Diagram; name them apart")
        return found[0]

    def calculation(self, block_name: str, name: str) -> np.ndarray:
        """The calculation ``name`` of the block ``block_name`` as the last tick computed it (a view)."""
        return self.signals[self._signal_slices[self.block(block_name), name]]

    def block_state(self, block_name: str, state: str) -> np.ndarray:
        """The state ``state`` of the block ``block_name`` (a view)."""
        return self.state[self._state_slices[self.block(block_name), state]]

    def calculate(self) -> None:
        """Every calculation, from the inputs and the state as they are."""
        if self.compiled:
            self._compiled_calculate()
            return
        for calc in self._calcs:
            calc()

    def update(self) -> None:
        """Every block's update from the calculations and the state; the result becomes the state."""
        if self.compiled:
            self._compiled_update()
            return
        np.copyto(self._next, self.state)
        for update in self._updates:
            update()
        np.copyto(self.state, self._next)

    def step(self) -> None:
        """``calculate``, then ``update`` (compiled: one call)."""
        if self.compiled:
            self._compiled_step()
            return
        self.calculate()
        self.update()

    def receive(self) -> None:
        """Every block's receives (what came from outside) into the state."""
        for receive in self._receives:
            receive()

    def publish(self) -> None:
        """Every block's publishes (what the tick left, sent outside)."""
        for publish in self._publishes:
            publish()

    def tick(self) -> None:
        """One tick: ``receive``, ``step`` (``calculate``, ``update``), ``publish``."""
        self.receive()
        self.step()
        self.publish()

    def reset(self) -> None:
        """The state of a fresh context."""
        self.state[:] = self.initial_state

    def restart(self) -> None:
        """The state of a fresh context but that of the blocks ``kept_on_restart``."""
        for (block, _), where in self._state_slices.items():
            if not block.kept_on_restart:
                self.state[where] = self.initial_state[where]

    def initialize(self) -> None:
        """The blocks' initialization events on the inputs and the state as they are (Drake's
        ``ExecuteInitializationEvents``)."""
        self.calculate()
        np.copyto(self._next, self.state)
        for initialization in self._initializations:
            initialization()
        np.copyto(self.state, self._next)
