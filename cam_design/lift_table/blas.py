"""Run small dense linear algebra on one BLAS thread.

The OpenBLAS builds bundled with numpy and scipy start one thread per core. On a busy
machine their spin-waiting threads make the small problems of this package (a
3600 x 150 least-squares fit, a 150 x 150 Cholesky) 100-1000 times slower than on one
thread (measured: 0.9 s against 0.01 s). ``single_thread_blas()`` sets both libraries
to one thread for the duration of a block and restores the previous count; it does
nothing if the libraries cannot be found. The environment variable
``OPENBLAS_NUM_THREADS=1`` set before numpy is imported has the same effect
process-wide.
"""
from __future__ import annotations

import contextlib
import ctypes
import glob
import os
from typing import Any, Iterator

_LIBS: list[tuple[Any, Any]] | None = None


def _openblas_handles() -> list[tuple[Any, Any]]:
    """(get, set) function pairs of every bundled OpenBLAS that exposes them."""
    global _LIBS
    if _LIBS is not None:
        return _LIBS
    found: list[tuple[Any, Any]] = []
    try:
        import numpy
        import scipy
        roots = [os.path.dirname(os.path.dirname(numpy.__file__)),
                 os.path.dirname(os.path.dirname(scipy.__file__))]
        paths = set()
        for root in roots:
            paths.update(glob.glob(os.path.join(root, '*.libs', 'libscipy_openblas*.so')))
        for path in sorted(paths):
            lib = ctypes.CDLL(path)
            for suffix in ('64_', '', '_64_'):
                get = getattr(lib, f'scipy_openblas_get_num_threads{suffix}', None)
                put = getattr(lib, f'scipy_openblas_set_num_threads{suffix}', None)
                if get is not None and put is not None:
                    get.restype = ctypes.c_int
                    put.argtypes = [ctypes.c_int]
                    found.append((get, put))
                    break
    except (OSError, ImportError):
        found = []
    _LIBS = found
    return found


@contextlib.contextmanager
def single_thread_blas() -> Iterator[None]:
    """Context manager: bundled OpenBLAS libraries on one thread inside the block."""
    handles = _openblas_handles()
    before = []
    for get, put in handles:
        before.append(int(get()))
        put(1)
    try:
        yield
    finally:
        for (_, put), count in zip(handles, before):
            put(count)
