"""Large lift tables kept out of the process's memory (no rclpy).

A lobe measured over many revolutions leaves a lift table of 24 B a sample (alpha,
measured and design lift, float64): 48 MB for 2 M samples, and the report, the cam
cards and the plots need the table of every feature at the end. ``spill`` moves a
table of at least ``SPILL_BYTES`` into an unlinked temporary file, memory-mapped
(``numpy.memmap``: the same float64 values, read like any array); the operating
system holds its pages in the page cache and writes them to disk when memory is
short. Pages that a reader touched count in the resident set until ``release`` gives
them back (the data stay in the file), so a consumer that walks every table releases
each one after use: only the table in use is resident. Smaller tables stay in memory.
"""
from __future__ import annotations

import mmap
import tempfile
from typing import Any, Iterable

import numpy as np
from numpy.typing import NDArray

#: tables of at least this many bytes are spilled (8 MiB: about 350 000 samples)
SPILL_BYTES = 8 * 2**20


def spill(table: NDArray[Any] | None, min_bytes: int = SPILL_BYTES) -> NDArray[Any] | None:
    """``table`` itself when small (or None), else a read-only memory-mapped copy of it
    in an unlinked temporary file (deleted when the array is garbage-collected)."""
    if table is None or isinstance(table, np.memmap) or table.nbytes < min_bytes:
        return table
    with tempfile.TemporaryFile(prefix='cam_bench_table_') as f:
        f.truncate(table.nbytes)
        mapped = np.memmap(f, dtype=table.dtype, mode='r+', shape=table.shape)
    mapped[...] = table   # the mapping keeps its own descriptor of the file
    mapped.flags.writeable = False
    release(mapped)
    return mapped


def release(*tables: NDArray[Any] | None | Iterable[Any]) -> None:
    """Give back the resident pages of spilled tables (the data stay in their file and
    are read again on the next access); arrays in memory and None are left alone.
    Accepts tables, or iterables (dict values, lists) of them."""
    for item in tables:
        if isinstance(item, np.ndarray) or item is None:
            _release_one(item)
        else:
            for t in item:
                _release_one(t)


def _release_one(table: Any) -> None:
    mm = getattr(table, '_mmap', None)
    if isinstance(table, np.memmap) and isinstance(mm, mmap.mmap):
        mm.madvise(mmap.MADV_DONTNEED)
