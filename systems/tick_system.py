"""A LeafSystem whose every computation is a kernel on named arrays.

A block of the controller declares what it reads (inputs), what it holds (discrete state), what it
computes from them within a tick (calculations, which output ports show) and how its state moves at
each tick (updates) and at initialization: each a kernel (``systems.compiled``) and the names of the
arrays it takes. ``TickSystem`` turns the declarations into an ordinary Drake LeafSystem (ports, cache
entries, discrete state, periodic and initialization events), which any Diagram and Simulator step as
usual. ``systems.tick_program.TickProgram`` reads the same declarations off a Diagram of such blocks
and its connections, and steps the whole on buffers that the connections share, with the Diagram's
semantics: one source of each block's arithmetic, two ways to run it, tested equal.

A kernel's arguments are named by strings:

- ``"in:NAME"``: the input port NAME (an array of its size);
- ``"x:NAME"``: the state NAME as the tick found it (read it only);
- ``"next:NAME"``: the state NAME to write (holding, on entry, its value as the tick found it);
  a receive writes the state itself, before the tick's calculations;
- ``"calc:NAME"``: the calculation NAME (its own result when it is being computed);
- ``Reshaped(name, shape)``: one of those seen with another shape (e.g. a 36-vector as 6 × 6);

anything else (an array, a number, a record) is passed as it is, the same object every tick.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import LeafSystem, ValueProducer

from heft.systems.compiled import compiled, float_array


@dataclasses.dataclass(frozen=True)
class Reshaped:
    """The array ``name`` (``"in:…"``, ``"x:…"``, ``"next:…"``, ``"calc:…"``) seen with ``shape``."""
    name: str
    shape: tuple[int, ...]


@dataclasses.dataclass(frozen=True)
class TickInput:
    port: object
    size: int
    default: np.ndarray | None
    """The value when nothing is connected (None: the input must be connected)."""


@dataclasses.dataclass(frozen=True)
class TickCalc:
    """``kernel(*args)`` writes the calculation ``name`` (``size`` floats) from ``depends``
    (the ``"in:…"``, ``"x:…"`` and ``"calc:…"`` names it reads)."""
    name: str
    size: int
    kernel: object
    args: tuple
    depends: tuple[str, ...]


@dataclasses.dataclass(frozen=True)
class TickOutput:
    """Output port ``port_name`` shows the slice ``[start, stop)`` of a state (``source`` ``"x:NAME"``) or
    of a calculation (``"calc:NAME"``)."""
    port_name: str
    source: str
    start: int
    stop: int


def _names(args) -> tuple[str, ...]:
    return tuple(arg.name if isinstance(arg, Reshaped) else arg for arg in args
                 if isinstance(arg, str | Reshaped))


class TickSystem(LeafSystem):
    """A LeafSystem declared as kernels on named arrays (module docstring), updated every ``period`` s
    (None: a block of calculations alone, which has no state). A block whose state outlives a restart of the
    controller (what it learned of the load) sets ``kept_on_restart`` (``TickProgram.restart``)."""

    kept_on_restart = False

    def __init__(self, period: float | None):
        super().__init__()
        self.tick_period = period
        self.tick_inputs: dict[str, TickInput] = {}
        self.tick_states: dict[str, tuple[int, np.ndarray]] = {}
        self.tick_calcs: dict[str, TickCalc] = {}
        self.tick_outputs: dict[str, TickOutput] = {}
        self.tick_updates: list[tuple] = []
        self.tick_initializations: list[tuple] = []
        self.tick_receives: list[tuple] = []
        self.tick_publishes: list[tuple] = []
        self._caches: dict[str, object] = {}
        self._update_declared = self._initialization_declared = False

    # --- declarations -------------------------------------------------------------------

    def DeclareTickInput(self, name: str, size: int, default=None):
        """An input port of ``size`` floats; ``default`` (floats) is its value while unconnected."""
        port = self.DeclareVectorInputPort(name, size)
        default = None if default is None else np.array(default, dtype=float).reshape(size)
        self.tick_inputs[name] = TickInput(port, size, default)
        return port

    def DeclareTickState(self, name: str, initial) -> int:
        """A discrete state group, ``initial`` its value in a fresh context."""
        initial = np.array(initial, dtype=float).ravel()
        index = self.DeclareDiscreteState(initial)
        self.tick_states[name] = (index, initial)
        return index

    def DeclareTickCalc(self, name: str, size: int, kernel, *args) -> None:
        """A calculation of ``size`` floats, ``kernel(*args)`` writing ``"calc:NAME"`` among its ``args``,
        recomputed in a tick whenever what it reads changed (a cache entry)."""
        reads = tuple(n for n in _names(args) if n != f"calc:{name}")
        calc = TickCalc(name, size, kernel, tuple(args), reads)
        self.tick_calcs[name] = calc
        tickets = set()
        for read in reads:
            kind, _, what = read.partition(":")
            if kind == "in":
                tickets.add(self.tick_inputs[what].port.ticket())
            elif kind == "x":
                tickets.add(self.discrete_state_ticket(self.tick_states[what][0]))
            elif kind == "calc":
                tickets.add(self._caches[what].ticket())
            else:
                raise ValueError(f"a calculation reads inputs, state and calculations; {read!r} is none of them")
        self._caches[name] = self.DeclareCacheEntry(
            name, ValueProducer(allocate=lambda: AbstractValue.Make(np.zeros(size)),
                                calc=lambda context, value: self._calculate(calc, context, value)),
            prerequisites_of_calc=tickets)

    def DeclareTickOutput(self, port_name: str, source: str, start: int = 0, stop: int | None = None):
        """An output port showing the slice ``[start, stop)`` (default: all) of ``source``: a state
        (``"x:NAME"``, no feedthrough) or a calculation (``"calc:NAME"``)."""
        kind, _, what = source.partition(":")
        if kind == "x":
            index, initial = self.tick_states[what]
            stop = initial.size if stop is None else stop
            if (start, stop) == (0, initial.size):
                port = self.DeclareStateOutputPort(port_name, index)
            else:
                port = self.DeclareVectorOutputPort(
                    port_name, stop - start, lambda context, value: value.SetFromVector(
                        context.get_discrete_state(index).get_value()[start:stop]),
                    prerequisites_of_calc={self.discrete_state_ticket(index)})
        elif kind == "calc":
            stop = self.tick_calcs[what].size if stop is None else stop
            cache = self._caches[what]
            port = self.DeclareVectorOutputPort(
                port_name, stop - start,
                lambda context, value: value.SetFromVector(cache.Eval(context)[start:stop]),
                prerequisites_of_calc={cache.ticket()})
        else:
            raise ValueError(f"an output shows a state or a calculation; {source!r} is neither")
        self.tick_outputs[port_name] = TickOutput(port_name, source, start, stop)
        return port

    def DeclareTickUpdate(self, kernel, *args) -> None:
        """``kernel(*args)`` moves the ``"next:…"`` states at every tick; a block's updates run in the
        order declared, after every calculation of the tick."""
        self.tick_updates.append((kernel, tuple(args)))
        if not self._update_declared:
            self.DeclarePeriodicDiscreteUpdateEvent(self.tick_period, 0.0,
                                                    lambda context, state: self._run(self.tick_updates, context,
                                                                                     state))
            self._update_declared = True

    def DeclareTickInitialization(self, kernel, *args) -> None:
        """``kernel(*args)`` sets the ``"next:…"`` states at initialization, from the inputs then."""
        self.tick_initializations.append((kernel, tuple(args)))
        if not self._initialization_declared:
            self.DeclareInitializationDiscreteUpdateEvent(
                lambda context, state: self._run(self.tick_initializations, context, state))
            self._initialization_declared = True

    def DeclareTickReceive(self, kernel, *args) -> None:
        """``kernel(*args)`` takes in what came from outside (a driver's messages) into the ``"next:…"`` states at
        the start of every tick, before any calculation: Drake's unrestricted update, which precedes the
        discrete ones."""
        self.tick_receives.append((kernel, tuple(args)))
        self.DeclarePeriodicUnrestrictedUpdateEvent(
            self.tick_period, 0.0, lambda context, state: self._run(
                [(kernel, args)], context, state.get_mutable_discrete_state()))

    def DeclareTickPublish(self, kernel, *args) -> None:
        """``kernel(*args)`` sends what the tick left (``"in:…"``, ``"x:…"``) outside, at the end of every tick:
        Drake's publish, which follows the updates."""
        self.tick_publishes.append((kernel, tuple(args)))
        self.DeclarePeriodicPublishEvent(self.tick_period, 0.0,
                                         lambda context: self._run([(kernel, args)], context, None))

    # --- the Drake shell ---------------------------------------------------------------

    def _array(self, name: str, context, discrete_state=None, own=None):
        kind, _, what = name.partition(":")
        if kind == "in":
            tick_input = self.tick_inputs[what]
            if tick_input.default is not None and not tick_input.port.HasValue(context):
                return tick_input.default
            return float_array(tick_input.port.Eval(context))
        if kind == "x":
            return float_array(context.get_discrete_state(self.tick_states[what][0]).get_value())
        if kind == "next":
            return discrete_state.get_mutable_value(self.tick_states[what][0])
        if own is not None and what == own[0]:
            return own[1]
        return float_array(self._caches[what].Eval(context))

    def _arguments(self, args, context, discrete_state=None, own=None) -> list:
        values = []
        for arg in args:
            if isinstance(arg, Reshaped):
                values.append(self._array(arg.name, context, discrete_state, own).reshape(arg.shape))
            elif isinstance(arg, str):
                values.append(self._array(arg, context, discrete_state, own))
            else:
                values.append(arg)
        return values

    def _calculate(self, calc: TickCalc, context, value) -> None:
        calc.kernel(*self._arguments(calc.args, context, own=(calc.name, value.get_mutable_value())))

    def _run(self, steps, context, discrete_state) -> None:
        for kernel, args in steps:
            kernel(*self._arguments(args, context, discrete_state))


class TickConstant(TickSystem):
    """A constant vector ``value`` on the output port ``value`` (held as state: a context may change it)."""

    def __init__(self, value):
        super().__init__(None)
        self.DeclareTickState("value", value)
        self.DeclareTickOutput("value", "x:value")


@compiled("void(float64[:], float64[:], float64[:])")
def sum_into(out, u0, u1) -> None:
    """``out`` = ``u0`` + ``u1``."""
    for i in range(out.shape[0]):
        out[i] = u0[i] + u1[i]


class TickSum(TickSystem):
    """The sum of two vectors of ``size``: inputs ``u0`` and ``u1``, output ``sum``."""

    def __init__(self, size: int):
        super().__init__(None)
        self.DeclareTickInput("u0", size)
        self.DeclareTickInput("u1", size)
        self.DeclareTickCalc("sum", size, sum_into, "calc:sum", "in:u0", "in:u1")
        self.DeclareTickOutput("sum", "calc:sum")
