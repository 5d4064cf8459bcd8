"""Per-tick kernels compiled to machine code by numba, or run as the plain Python they are written in.

A kernel is a function of floats, ints and NumPy arrays that writes its results into arrays it is
given and allocates nothing. ``compiled`` compiles one with numba for the one signature it is given,
when its module is imported, never later (a real-time loop must not stop to compile), and caches the
machine code on disk (numba's ``cache=True``: beside the module, or in the user's cache directory
where the package is read-only), so a later process loads it in milliseconds. Without numba, or with
``HEFT_PURE_PYTHON=1`` in the environment, the kernels run as written: the same results, slower.
"""

from __future__ import annotations

import os

import numpy as np

try:
    import numba
except ImportError:  # a platform without numba's wheels
    numba = None

PURE_PYTHON = numba is None or os.environ.get("HEFT_PURE_PYTHON", "") == "1"
"""Whether the kernels run as plain Python."""


def compiled(signature: str):
    """A decorator: the kernel compiled for ``signature`` (numba's, e.g. ``"void(float64[:], float64)"``;
    arrays of any layout), or the kernel itself when ``PURE_PYTHON``."""
    def decorate(kernel):
        return kernel if PURE_PYTHON else numba.njit(signature, cache=True)(kernel)
    return decorate


def float_array(x):
    """``x`` as a float64 ndarray a kernel takes: itself when it is one (no copy), else a copy (a list,
    another dtype, or a read-only array, which the kernels' signatures do not admit)."""
    if type(x) is np.ndarray and x.dtype == np.float64 and x.flags.writeable:
        return x
    return np.array(x, dtype=float)
