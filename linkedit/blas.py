"""One BLAS thread while many small dense products run.

The solvers multiply and factorize thousands of small matrices (tens of rows) per call. OpenBLAS,
which NumPy and SciPy ship, splits a product across all cores from a few thousand entries on;
on a shared 2-core machine its threads then wait for each other and one such product costs up
to 100× its single-threaded time (measured: 7.6 ms instead of 0.08 ms for a (3120, 10) ×
(10, 36) product under load). :func:`single_threaded` sets the bundled OpenBLAS libraries to
one thread for a block and restores them after; it does nothing where they cannot be found
(another BLAS, another platform).
"""

from __future__ import annotations

import ctypes
import glob
import os
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from functools import cache

#: thread setters / getters of the OpenBLAS builds NumPy and SciPy bundle (64-bit and 32-bit integer ABIs)
_NAMES = (("scipy_openblas_set_num_threads64_", "scipy_openblas_get_num_threads64_"),
          ("scipy_openblas_set_num_threads", "scipy_openblas_get_num_threads"),
          ("openblas_set_num_threads", "openblas_get_num_threads"))


@cache
def _controls() -> tuple[tuple[Callable[[int], object], Callable[[], int]], ...]:
    """(set, get) function pairs of every bundled OpenBLAS library found."""
    import numpy
    import scipy

    found: list[tuple[Callable[[int], object], Callable[[], int]]] = []
    for package in (numpy, scipy):
        libs = os.path.join(os.path.dirname(os.path.dirname(package.__file__ or "")), f"{package.__name__}.libs")
        for path in sorted(glob.glob(os.path.join(libs, "*openblas*"))):
            try:
                lib = ctypes.CDLL(path)
            except OSError:
                continue
            for setter, getter in _NAMES:
                if hasattr(lib, setter) and hasattr(lib, getter):
                    found.append((getattr(lib, setter), getattr(lib, getter)))
                    break
    return tuple(found)


@contextmanager
def single_threaded() -> Iterator[None]:
    """Run the block with every bundled OpenBLAS on one thread (module docstring)."""
    controls = _controls()
    before = [get() for _, get in controls]
    for set_threads, _ in controls:
        set_threads(1)
    try:
        yield
    finally:
        for (set_threads, _), n in zip(controls, before):
            set_threads(n)
