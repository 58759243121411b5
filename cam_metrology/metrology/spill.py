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

The samples of a long feature take the same way before they are analysed: a
``Spool`` appends the chunks of one column to a temporary file as they arrive from
the bag (nothing of the column in memory) and maps the whole column read-only at the
end of the feature; ``blank`` is a writable spilled table filled a block of rows at a
time (``walk`` gives back the pages of each block once written or read).
"""
from __future__ import annotations

import mmap
import tempfile
from typing import Any, Iterable, Iterator

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


class Spool:
    """One column of ``dtype`` appended chunk by chunk to an unlinked temporary file
    (the chunks are not kept); ``column`` maps the whole of it read-only."""

    def __init__(self, dtype: Any) -> None:
        self.dtype = np.dtype(dtype)
        self.size = 0
        self._file: Any = tempfile.TemporaryFile(prefix='cam_bench_column_')

    def append(self, chunk: NDArray[Any]) -> None:
        """Write ``chunk`` (converted to the spool's dtype) after what is there."""
        part = np.ascontiguousarray(chunk, dtype=self.dtype)
        self._file.write(part.data)
        self.size += part.size

    def column(self) -> NDArray[Any]:
        """The column written so far as a read-only memory map (the file is deleted
        with the array); the spool is closed."""
        f, self._file = self._file, None
        if self.size == 0:
            f.close()
            return np.zeros(0, self.dtype)
        f.flush()
        with f:
            mapped = np.memmap(f, dtype=self.dtype, mode='r', shape=(self.size,))
        return mapped

    def close(self) -> None:
        """Drop what was written (a spool that is not turned into a column)."""
        if self._file is not None:
            self._file.close()
            self._file = None


def spooled(column: NDArray[Any], min_bytes: int = SPILL_BYTES) -> NDArray[Any]:
    """``column`` itself when small or already mapped, else a read-only mapped copy of
    it written a block at a time (``Spool``)."""
    if isinstance(column, np.memmap) or column.nbytes < min_bytes:
        return column
    spool = Spool(column.dtype)
    for a, b in walk(column.size):
        spool.append(column[a:b])
    return spool.column()


def is_long(rows: int, itemsize: int = 8) -> bool:
    """True when a column of ``rows`` rows of ``itemsize`` bytes is long enough
    (``SPILL_BYTES``) to be spilled and read a block at a time."""
    return rows * itemsize >= SPILL_BYTES


def blank(shape: tuple[int, ...], dtype: Any = float,
          min_bytes: int | None = None) -> NDArray[Any]:
    """An uninitialised array of ``shape``: in memory when smaller than ``min_bytes``
    (default ``SPILL_BYTES``), else a writable map of an unlinked temporary file
    (``seal`` makes it read-only once filled)."""
    dt = np.dtype(dtype)
    min_bytes = SPILL_BYTES if min_bytes is None else min_bytes
    nbytes = int(np.prod(shape)) * dt.itemsize
    if nbytes < min_bytes or nbytes == 0:
        return np.empty(shape, dt)
    with tempfile.TemporaryFile(prefix='cam_bench_table_') as f:
        f.truncate(nbytes)
        return np.memmap(f, dtype=dt, mode='r+', shape=shape)


def seal(table: NDArray[Any]) -> NDArray[Any]:
    """A filled ``blank``: read-only, its pages given back; returned for chaining."""
    if isinstance(table, np.memmap):
        table.flags.writeable = False
        release(table)
    return table


#: rows of a block in ``walk``: 64 Ki rows (512 KiB of a float64 column)
WALK_ROWS = 1 << 16


def walk(size: int, *mapped: NDArray[Any] | None,
         step: int = WALK_ROWS) -> Iterator[tuple[int, int]]:
    """Row ranges (start, stop) of ``step`` rows over ``size`` rows; after each block
    the pages touched in the spilled arrays ``mapped`` are given back (``release``),
    so a pass over them holds one block resident, not the whole column."""
    for a in range(0, size, step):
        yield a, min(a + step, size)
        release(mapped)
