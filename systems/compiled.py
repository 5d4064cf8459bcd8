"""Per-tick kernels compiled to machine code by numba, or run as the plain Python they are written in.

A kernel is a function of floats, ints and NumPy arrays that writes its results into arrays it is
given and allocates nothing. ``compiled`` compiles one with numba for the one signature it is given,
when its module is imported, never later (a real-time loop must not stop to compile), and caches the
machine code on disk (numba's ``cache=True``), so a later process loads it in milliseconds. Without
numba, or with ``HEFT_PURE_PYTHON=1`` in the environment, the kernels run as written: the same
results, slower.

numba tells a cached kernel stale by its own source file only, not by the kernels it calls, which
it compiles into it: after an update that changed only a callee's module (a ``git pull``), the
caller would keep running the old callee, silently. So the cache lives in a directory named by a
digest of every module that defines kernels (``kernel_cache_dir``): any change to one compiles them
all afresh.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numpy as np

try:
    import numba
except ImportError:  # a platform without numba's wheels
    numba = None

PURE_PYTHON = numba is None or os.environ.get("HEFT_PURE_PYTHON", "") == "1"
"""Whether the kernels run as plain Python."""

KERNEL_PACKAGES = ("systems", "diagrams", "hardware_interface", "analysis")
"""The package's parts searched for modules that define kernels."""


def kernel_sources_digest(root: Path) -> str:
    """A digest (16 hex digits) of the name and the text of every module under ``root``'s
    ``KERNEL_PACKAGES`` that defines a kernel (holds ``@compiled(``)."""
    digest = hashlib.sha256()
    for package in KERNEL_PACKAGES:
        for path in sorted((root / package).rglob("*.py")):
            text = path.read_bytes()
            if b"@compiled(" in text:
                digest.update(path.relative_to(root).as_posix().encode() + b"\0" + text + b"\0")
    return digest.hexdigest()[:16]


def kernel_cache_dir(root: Path) -> Path:
    """Where the compiled kernels of the package at ``root`` are cached: ``heft-kernels-DIGEST``
    (``kernel_sources_digest``) under ``NUMBA_CACHE_DIR`` if set, else under the user's cache
    directory (``XDG_CACHE_HOME``, default ``~/.cache``)."""
    base = os.environ.get("NUMBA_CACHE_DIR") or Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return Path(base) / f"heft-kernels-{kernel_sources_digest(root)}"


if not PURE_PYTHON:
    numba.config.CACHE_DIR = str(kernel_cache_dir(Path(__file__).resolve().parent.parent))


def compiled(signature: str, **records: np.dtype):
    """A decorator: the kernel compiled for ``signature`` (numba's, e.g. ``"void(float64[:], float64)"``;
    arrays of any layout), or the kernel itself when ``PURE_PYTHON``. ``records`` names the structured
    dtypes the signature refers to: ``NAME[:]`` is an array of such records (one holds a block's arrays, so
    that a call passes them as one argument: ``record_views``)."""
    def decorate(kernel):
        if PURE_PYTHON:
            return kernel
        types = {**vars(numba.types), **{name: numba.from_dtype(dtype) for name, dtype in records.items()}}
        return numba.njit(eval(signature, {}, types), cache=True)(kernel)
    return decorate


def record_views(dtype: np.dtype) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """(record, views): a record array of one ``dtype`` (zeros), as a kernel of ``compiled(…, NAME=dtype)``
    takes it, and a view of each of its array fields by name, through which Python reads and writes them
    (a scalar field is ``record[name]``)."""
    record = np.zeros(1, dtype=dtype)
    return record, {name: record[name][0] for name in dtype.names if dtype[name].shape}


def float_array(x):
    """``x`` as a float64 ndarray a kernel takes: itself when it is one (no copy), else a copy (a list,
    another dtype, or a read-only array, which the kernels' signatures do not admit)."""
    if type(x) is np.ndarray and x.dtype == np.float64 and x.flags.writeable:
        return x
    return np.array(x, dtype=float)
