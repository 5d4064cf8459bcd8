"""A ``TickProgram``'s calculations and updates as compiled functions, generated from its order.

``compile_program(calls, constants)`` writes the source of ``calculate(signals, state, next_state, bounds,
*constants)``, ``update(…)`` and ``step(…)``: the first calls the kernels of the program's calculations (in the
program's order), the second those of its updates (in the blocks' order, between copying ``state`` into
``next_state`` and back), the third both, one after the other (a tick's one call from Python), on slices of the
three flat arrays whose bounds are read from ``bounds`` (so Diagrams of the same blocks wired alike share one
compiled function), and with the blocks' other arguments (records, parameters, scratch arrays) passed through.
numba compiles the three for the types of the arguments given, before any tick, and caches the machine code on disk
beside a source file named by a digest of the source and of every kernel (its name, signature and module's text),
so that a changed kernel is never linked stale; a kernel no file defines (a script's) has its program compiled
anew in each process. A tick is then one call from Python instead of one per kernel, with its arguments to type.
"""

from __future__ import annotations

import dataclasses
import hashlib
import inspect
import os
import sys
import types
from pathlib import Path

import numpy as np

from heft.systems.compiled import PURE_PYTHON, numba

ARRAYS = ("signals", "state", "next_state")
"""The flat arrays a kernel's named arguments are slices of, as the generated functions name them."""
FUNCTIONS = ("calculate", "update", "step")
"""The generated functions (module docstring), in ``compile_program``'s order."""


@dataclasses.dataclass(frozen=True)
class Slice:
    """The slice ``[start, stop)`` of the flat array ``array`` (one of ``ARRAYS``), seen with ``shape``
    (None: as it is)."""
    array: str
    start: int
    stop: int
    shape: tuple[int, ...] | None = None


def compilable(kernels) -> bool:
    """Whether every kernel is one numba compiled (``systems.compiled``), so that a generated function can call it."""
    return not PURE_PYTHON and all(isinstance(kernel, numba.core.registry.CPUDispatcher) for kernel in kernels)


def _source_file(kernel) -> Path | None:
    """The file that defines ``kernel``, if there is one (not a script's or a notebook's cell)."""
    try:
        path = Path(inspect.getsourcefile(kernel.py_func))
    except TypeError:
        return None
    return path if path.is_file() else None


def _source(calls: dict[str, list], constants: int, names: dict[int, str]) -> str:
    """The module source of ``calculate``, ``update`` and ``step`` (module docstring); ``calls[which]`` lists
    (kernel, args), an argument a ``Slice`` or a constant's index, ``names`` each kernel's global name by ``id``."""
    parameters = ", ".join([*ARRAYS, "bounds", *(f"c{i}" for i in range(constants))])
    bodies, bound = {}, 0
    for which in ("calculate", "update"):
        body = []
        if which == "update":
            body += ["    for i in range(state.shape[0]):", "        next_state[i] = state[i]"]
        for kernel, args in calls[which]:
            texts = []
            for arg in args:
                if isinstance(arg, Slice):
                    text = f"{arg.array}[bounds[{bound}]:bounds[{bound + 1}]]"
                    bound += 2
                    texts.append(text if arg.shape is None else f"{text}.reshape({arg.shape!r})")
                else:
                    texts.append(f"c{arg}")
            body += [f"    {names[id(kernel)]}({', '.join(texts)})"]
        if which == "update":
            body += ["    for i in range(state.shape[0]):", "        state[i] = next_state[i]"]
        bodies[which] = body
    bodies["step"] = bodies["calculate"] + bodies["update"]
    lines = []
    for which in FUNCTIONS:
        lines += [f"def {which}({parameters}):", *bodies[which], "    return", "", ""]
    return "\n".join(lines)


def compile_program(calls: dict[str, list], constants: list):
    """(calculate, update, step, bounds) for ``calls`` (``_source``) and ``constants``, compiled for the flat
    arrays' and the constants' types; ``bounds`` (int64) holds every ``Slice``'s start and stop in call order."""
    kernels = {id(kernel): kernel for which in calls.values() for kernel, _ in which}
    names = {key: f"k{i}" for i, key in enumerate(kernels)}
    body = _source(calls, len(constants), names)
    bounds = np.array([value for which in ("calculate", "update") for _, args in calls[which]
                       for arg in args if isinstance(arg, Slice) for value in (arg.start, arg.stop)], dtype=np.int64)
    files = [_source_file(kernel) for kernel in kernels.values()]
    namespace = {names[key]: kernel for key, kernel in kernels.items()}
    cache = all(files)
    if cache:
        # A file numba caches the machine code beside: named by the source and by each kernel (its name, its
        # compiled signature and its module's text), so that another kernel or a changed one is never linked stale.
        digest = hashlib.sha256(body.encode())
        for (key, kernel), path in zip(kernels.items(), files):
            function = kernel.py_func
            digest.update(f"{names[key]} {function.__module__}.{function.__qualname__} {kernel.signatures}".encode())
            digest.update(path.read_bytes())
        name = f"heft_program_{digest.hexdigest()[:20]}"
        path = Path(numba.config.CACHE_DIR) / "programs" / f"{name}.py"  # the kernels' (systems.compiled)
        if not path.exists():
            path.parent.mkdir(parents=True, exist_ok=True)
            partial = path.with_suffix(f".{os.getpid()}.part")
            partial.write_text(body)
            partial.replace(path)  # whole or not at all, should two processes write it at once
        module = sys.modules.get(name)
        if module is None:
            module = sys.modules[name] = types.ModuleType(name)  # where numba's cache finds its globals again
            vars(module).update(namespace)
            exec(compile(body, str(path), "exec"), vars(module))
        namespace = vars(module)
    else:
        # A kernel defined where no file holds it (a script, a notebook): compiled anew in each process.
        exec(compile(body, "<heft program>", "exec"), namespace)
    signature = tuple(numba.typeof(value) for value in (np.zeros(0), np.zeros(0), np.zeros(0), bounds, *constants))
    functions = []
    for which in FUNCTIONS:
        function = numba.njit(cache=cache)(namespace[which])
        function.compile(signature)
        function.disable_compile()  # a tick never stops to compile
        functions.append(function)
    return (*functions, bounds)
