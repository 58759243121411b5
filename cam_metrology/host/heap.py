"""The C heap of a long analysis: freed memory given back to the system (no rclpy).

numpy takes its arrays from the C allocator. With glibc, an array above the
allocator's "mmap threshold" is mapped on its own and returned to the system when
freed, but the threshold rises to the size of every such array freed (up to 32 MB),
so that the next arrays of a feature of millions of samples come from the heap, and
freed heap memory is kept by the process (its resident set grows with the holes).
``bounded_heap`` fixes the threshold at ``MMAP_THRESHOLD_BYTES`` (arrays of a block of
samples stay on the heap and are reused; whole-feature arrays are mapped and returned
when freed) and ``trim`` gives back the free pages of the heap (``malloc_trim``).
Both do nothing where the C library is not glibc.
"""
from __future__ import annotations

import ctypes
import ctypes.util
from functools import lru_cache
from typing import Any

#: arrays of at least this size [B] are mapped on their own (8 MiB: a feature of a
#: million samples and more; smaller arrays are reused from the heap, which is faster:
#: 1 MiB cost 20 % more CPU time on 200 000-sample features and no less memory)
MMAP_THRESHOLD_BYTES = 8 << 20
_M_MMAP_THRESHOLD = -3   # mallopt parameter number (glibc malloc.h)


@lru_cache(maxsize=1)
def _libc() -> Any:
    """glibc, or None (another C library, or none found)."""
    name = ctypes.util.find_library('c')
    try:
        lib = ctypes.CDLL(name) if name else None
    except OSError:
        return None
    if lib is None or not hasattr(lib, 'malloc_trim') or not hasattr(lib, 'mallopt'):
        return None
    return lib


@lru_cache(maxsize=1)
def bounded_heap() -> bool:
    """Fix the allocator's mmap threshold (once per process); True when set."""
    lib = _libc()
    return bool(lib is not None and lib.mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES))


def trim() -> None:
    """Give the free memory of the C heap back to the system (glibc ``malloc_trim``)."""
    lib = _libc()
    if lib is not None:
        lib.malloc_trim(0)
