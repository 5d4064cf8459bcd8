"""A Diagram of ``TickSystem`` blocks as one LeafSystem that runs its ``TickProgram``.

``TickProgramSystem(diagram)`` has the Diagram's input and output ports (names and sizes; a state output
depends on the state alone, a calculated one on every input) and its one periodic update, and holds every
block's state in one discrete state group; each evaluation runs the blocks' kernels as the program does. It stands in
for the Diagram wherever a Simulator steps it beside other systems (the simulated station): the same
ticks, without a Python call into Drake per block and port.
"""

from __future__ import annotations

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Diagram, LeafSystem, ValueProducer

from heft.systems.tick_program import TickProgram


class TickProgramSystem(LeafSystem):
    """``diagram`` (of ``TickSystem`` blocks) as one LeafSystem (module docstring); ``program`` its
    ``TickProgram``."""

    def __init__(self, diagram: Diagram):
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
        self._state = self.DeclareDiscreteState(program.initial_state)
        self._signals = self.DeclareCacheEntry(
            "signals", ValueProducer(allocate=lambda: AbstractValue.Make(np.zeros(program.signals.size)),
                                     calc=self._calculate),
            prerequisites_of_calc={self.all_input_ports_ticket(), self.xd_ticket()})
        for i in range(diagram.num_output_ports()):
            name = diagram.get_output_port(i).get_name()
            in_state, where = program.locate(name)
            if in_state:
                self.DeclareVectorOutputPort(
                    name, where.stop - where.start, lambda context, value, where=where: value.SetFromVector(
                        context.get_discrete_state(self._state).get_value()[where]),
                    prerequisites_of_calc={self.xd_ticket()})
            else:
                self.DeclareVectorOutputPort(
                    name, where.stop - where.start, lambda context, value, where=where: value.SetFromVector(
                        self._signals.Eval(context)[where]),
                    prerequisites_of_calc={self._signals.ticket()})
        if program.period is not None:
            self.DeclarePeriodicDiscreteUpdateEvent(program.period, 0.0, self._update)
        self.DeclareInitializationDiscreteUpdateEvent(self._initialize)

    def _load(self, context) -> None:
        """The program's inputs and state from ``context``'s (an unconnected input at its default)."""
        for port, array, default in self._inputs:
            array[:] = port.Eval(context) if port.HasValue(context) else default
        self.program.state[:] = context.get_discrete_state(self._state).get_value()

    def _calculate(self, context, value) -> None:
        self._load(context)
        self.program.calculate()
        value.get_mutable_value()[:] = self.program.signals

    def _update(self, context, discrete_state) -> None:
        program = self.program
        program.signals[:] = self._signals.Eval(context)
        program.state[:] = context.get_discrete_state(self._state).get_value()
        program.update()
        discrete_state.set_value(self._state, program.state)

    def _initialize(self, context, discrete_state) -> None:
        self._load(context)
        self.program.initialize()
        discrete_state.set_value(self._state, self.program.state)
