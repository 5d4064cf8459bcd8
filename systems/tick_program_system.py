"""A Diagram of ``TickSystem`` blocks as one LeafSystem that runs its ``TickProgram``.

``TickProgramSystem(diagram)`` has the Diagram's input and output ports (names and sizes; a state output
depends on the state alone, a calculated one on every input) and its one periodic update, and holds every
block's state in one discrete state group; each evaluation runs the blocks' kernels as the program does. It stands in
for the Diagram wherever a Simulator steps it beside other systems (the simulated station): the same
ticks, without a Python call into Drake per block and port. Outputs read together (a log) can be had as one
port (``gathered``): one evaluation instead of one per output.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Diagram, LeafSystem, ValueProducer

from heft.systems.tick_program import TickProgram


class TickProgramSystem(LeafSystem):
    """``diagram`` (of ``TickSystem`` blocks) as one LeafSystem (module docstring); ``program`` its
    ``TickProgram``. ``gathered`` names extra output ports, each the Diagram outputs it lists laid end to end."""

    def __init__(self, diagram: Diagram, gathered: dict[str, Sequence[str]] | None = None):
        super().__init__()
        self.program = program = TickProgram(diagram)
        outside = [block.get_name() for block in program.blocks if block.tick_receives or block.tick_publishes]
        if outside:
            raise ValueError(f"the blocks {outside} talk to the world outside (receive, publish): step their Diagram's "
                             "TickProgram in a real-time loop, not as one system in a Simulator")
        self._inputs = []
        for i in range(diagram.num_input_ports()):
            port = diagram.get_input_port(i)
            self._inputs.append((self.DeclareVectorInputPort(port.get_name(), port.size()),
                                 program.input(port.get_name()), program.input(port.get_name()).copy()))
        self._valued = [False] * len(self._inputs)  # whether each input had a value when last read
        self._defaulted = [False] * len(self._inputs)  # whether each input's array holds its default
        self._state = self.DeclareDiscreteState(program.initial_state)
        self._signals = self.DeclareCacheEntry(
            "signals", ValueProducer(allocate=lambda: AbstractValue.Make(np.zeros(program.signals.size)),
                                     calc=self._calculate),
            prerequisites_of_calc={self.all_input_ports_ticket(), self.xd_ticket()})
        for i in range(diagram.num_output_ports()):
            name = diagram.get_output_port(i).get_name()
            self._declare_output(name, [name])
        for name, names in (gathered or {}).items():
            self._declare_output(name, names)
        if program.period is not None:
            self.DeclarePeriodicDiscreteUpdateEvent(program.period, 0.0, self._update)
        self.DeclareInitializationDiscreteUpdateEvent(self._initialize)

    def _declare_output(self, name: str, names: Sequence[str]) -> None:
        """An output port ``name``: the Diagram outputs ``names`` end to end, from the state or the signals
        (depending on what they depend on)."""
        places = [self.program.locate(each) for each in names]
        from_state = np.concatenate([np.arange(where.start, where.stop) for in_state, where in places if in_state]
                                    + [np.zeros(0, dtype=int)])
        from_signals = np.concatenate([np.arange(where.start, where.stop) for in_state, where in places
                                       if not in_state] + [np.zeros(0, dtype=int)])
        positions, start = ([], []), 0
        for in_state, where in places:
            positions[0 if in_state else 1].append(np.arange(start, start + where.stop - where.start))
            start += where.stop - where.start
        to_state, to_signals = (np.concatenate(part + [np.zeros(0, dtype=int)]) for part in positions)
        if len(places) == 1:  # one contiguous slice
            in_state, where = places[0]
            if in_state:
                calc = lambda context, value: value.SetFromVector(  # noqa: E731
                    context.get_discrete_state(self._state).get_value()[where])
            else:
                calc = lambda context, value: value.SetFromVector(self._signals.Eval(context)[where])  # noqa: E731
        else:
            taken_state, taken_signals = np.empty(len(from_state)), np.empty(len(from_signals))  # no allocation a step

            def calc(context, value):
                out = value.get_mutable_value()
                if len(from_state):
                    context.get_discrete_state(self._state).get_value().take(from_state, out=taken_state)
                    out.put(to_state, taken_state)
                if len(from_signals):
                    self._signals.Eval(context).take(from_signals, out=taken_signals)
                    out.put(to_signals, taken_signals)
        prerequisites = ({self.xd_ticket()} if len(from_state) else set()) | (
            {self._signals.ticket()} if len(from_signals) else set())
        self.DeclareVectorOutputPort(name, start, calc, prerequisites_of_calc=prerequisites)

    def _load(self, context) -> None:
        """The program's inputs and state from ``context``'s (an unconnected input at its default). An input
        that had a value is read without asking again (a connection stays; Eval refuses one that has none); the
        default is written once, until a value replaces it."""
        valued, defaulted = self._valued, self._defaulted
        for i, (port, array, default) in enumerate(self._inputs):
            if valued[i]:
                try:
                    array[:] = port.Eval(context)
                    continue
                except RuntimeError:
                    valued[i] = False
            if port.HasValue(context):
                array[:], valued[i], defaulted[i] = port.Eval(context), True, False
            elif not defaulted[i]:
                array[:], defaulted[i] = default, True
        self.program.state[:] = context.get_discrete_state(self._state).get_value()

    def _calculate(self, context, value) -> None:
        self._load(context)
        self.program.calculate()
        value.get_mutable_value()[:] = self.program.signals

    def _update(self, context, discrete_state) -> None:
        program = self.program
        program.signals[:] = self._signals.Eval(context)
        state = discrete_state.get_mutable_value(self._state)  # holds the current state
        program.state[:] = state
        program.update()
        state[:] = program.state

    def _initialize(self, context, discrete_state) -> None:
        self._load(context)
        self.program.initialize()
        discrete_state.set_value(self._state, self.program.state)
