"""Exact medians and angle orderings of columns too long to hold twice (no rclpy).

A feature of 10 M samples has 80 MB columns; a sort by angle (``numpy.argsort``: an
int64 permutation and a gathered copy) or a median (``numpy.median``: a partitioned
copy) would hold two or three of them at once. Here the same numbers come from passes
over blocks of rows, the columns staying in temporary files (``spill``):

* ``median``: the exact ``numpy.median`` of values handed out a block at a time, by a
  radix selection on the bit patterns of the floats (each pass counts one 16-bit digit
  of the candidates; the candidates left are gathered and partitioned once they are
  few). Two to four passes over the values.
* ``Buckets``: rows partitioned by a monotone key (equal-width bins of the angle) into
  temporary files, appended in arrival order; each bucket sorted stably in memory gives
  the rows in ``angle_order`` (``numpy.argsort(key, kind='stable')``: the buckets cover
  increasing key ranges and keep arrival order within a bucket), without a permutation
  of the whole column and without reading it at random.
* ``running_deviation``: value minus the running median of 9 (``median_filter(size=9,
  mode='nearest')``) over values that arrive in order a chunk at a time (4 values of
  context carried across chunks: the same numbers as the whole column at once).
"""
from __future__ import annotations

from typing import Any, Callable, Iterable, Iterator

import numpy as np
from numpy.typing import NDArray
from scipy.ndimage import median_filter

from cam_metrology.metrology.spill import Spool

#: candidates of a radix selection gathered and partitioned in memory below this count
GATHER_MAX = 1 << 20
#: rows of a bucket in ``Buckets`` (about; 256 Ki rows of 3 float64 columns: 6 MB)
BUCKET_ROWS = 1 << 18
_SIGN = np.uint64(1 << 63)


def angle_order(key: NDArray[Any]) -> NDArray[np.intp]:
    """The order of a lift table's rows: by ``key`` (the angle, or its bucket), ties
    (samples of several revolutions at one encoder angle) in arrival order, i.e. stamp
    order (``numpy.argsort(key, kind='stable')``). The one order of a table on every path (a
    short feature in memory, a long one through ``Buckets``): the table's readers that
    look at neighbours (the base reference's running median, the card's area) give the
    same numbers on both, on every machine."""
    return np.argsort(key, kind='stable')


def sortable_keys(values: NDArray[np.float64]) -> NDArray[np.uint64]:
    """Unsigned 64-bit keys in the order of the float64 ``values`` (finite; -0.0 just
    below 0.0): the bit pattern with the sign bit set for positive numbers and all bits
    flipped for negative ones."""
    bits = np.ascontiguousarray(values, dtype=np.float64).view(np.uint64)
    neg = (bits & _SIGN) != 0
    return np.where(neg, ~bits, bits | _SIGN)


def _float_of(key: np.uint64) -> float:
    """The float64 of a key of ``sortable_keys``."""
    k = np.uint64(key)
    bits = k & ~_SIGN if k & _SIGN else ~k
    return float(np.array([bits], np.uint64).view(np.float64)[0])


def kth_smallest(blocks: Callable[[], Iterable[NDArray[np.float64]]], k: int) -> float:
    """The value of rank ``k`` (0-based) among the values of ``blocks()`` (a fresh
    iterator of float64 arrays on each call), selected 16 bits of the key at a time."""
    prefix, shift = np.uint64(0), 64
    while True:
        shift -= 16
        counts = np.zeros(1 << 16, np.int64)
        for part in blocks():
            key = sortable_keys(part)
            if shift < 48:
                key = key[(key >> np.uint64(shift + 16)) == prefix]
            digit = (key >> np.uint64(shift)) & np.uint64(0xFFFF)
            counts += np.bincount(digit.astype(np.int64), minlength=1 << 16)
        cum = np.cumsum(counts)
        j = int(np.searchsorted(cum, k, side='right'))
        k -= int(cum[j - 1]) if j else 0
        prefix = (prefix << np.uint64(16)) | np.uint64(j)
        if counts[j] <= GATHER_MAX or shift == 0:
            break
    chosen = [key[(key >> np.uint64(shift)) == prefix]
              for key in (sortable_keys(part) for part in blocks())]
    cand = np.concatenate(chosen) if chosen else np.zeros(0, np.uint64)
    return _float_of(np.partition(cand, k)[k])


def median(blocks: Callable[[], Iterable[NDArray[np.float64]]]) -> float:
    """``numpy.median`` of the finite values of ``blocks()`` (a fresh iterator of
    float64 arrays on each call), exactly: the middle value, or the mean of the two
    middle values; NaN when there are none."""
    n = sum(int(part.size) for part in blocks())
    if n == 0:
        return float('nan')
    if n <= GATHER_MAX:   # few: gathered
        return float(np.median(np.concatenate(list(blocks()))))
    if n % 2:
        return kth_smallest(blocks, n // 2)
    lo, hi = kth_smallest(blocks, n // 2 - 1), kth_smallest(blocks, n // 2)
    return float(np.mean(np.array([lo, hi])))


class Buckets:
    """Rows (a structured dtype) partitioned by a key into ``count`` temporary files by
    equal-width bins of [lo, hi]; ``sorted`` hands the buckets back in key order, each
    sorted stably by the key (module doc)."""

    def __init__(self, dtype: Any, key: str, lo: float, hi: float, count: int) -> None:
        self.dtype = np.dtype(dtype)
        self.key = key
        self.count = max(int(count), 1)
        self.lo = float(lo)
        self.width = (float(hi) - self.lo) / self.count if hi > lo else 1.0
        self._spools: dict[int, Spool] = {}

    def bucket_of(self, key: NDArray[np.float64]) -> NDArray[np.int64]:
        """Bucket of each key: non-decreasing in the key."""
        b = np.floor((key - self.lo) / self.width).astype(np.int64)
        return np.clip(b, 0, self.count - 1, out=b)

    def add(self, rows: NDArray[Any]) -> None:
        """Append ``rows`` (of ``dtype``) to their buckets, in their order."""
        b = self.bucket_of(rows[self.key])
        order = angle_order(b)
        b = b[order]
        cuts = np.flatnonzero(b[1:] != b[:-1]) + 1
        for lo, hi in zip(np.concatenate(([0], cuts)), np.concatenate((cuts, [b.size]))):
            if hi > lo:
                which = int(b[lo])
                spool = self._spools.get(which)
                if spool is None:
                    spool = self._spools[which] = Spool(self.dtype)
                spool.append(rows[order[lo:hi]])

    def sorted(self) -> Iterator[NDArray[Any]]:
        """The buckets in key order, each read into memory (its file deleted) and
        sorted stably by the key: together, the rows in stable key order."""
        for which in sorted(self._spools):
            spool = self._spools.pop(which)
            rows = np.array(spool.column())
            yield rows[angle_order(rows[self.key])]

    def close(self) -> None:
        """Drop the buckets not read."""
        for spool in self._spools.values():
            spool.close()
        self._spools.clear()


def bucket_count(size: int) -> int:
    """Buckets of about ``BUCKET_ROWS`` rows for ``size`` rows."""
    return max(1, -(-int(size) // BUCKET_ROWS))


def run_means(blocks: Iterable[tuple[NDArray[np.bool_], NDArray[np.float64],
                                     NDArray[np.float64]]],
              ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]]:
    """Means of two columns over runs of consecutive rows, and the rows in each run,
    from blocks ``(new, u, v)``: ``new`` True where a row starts a run (False at a
    block's first row: the previous block's last run goes on). The sums of
    ``numpy.bincount`` over the whole columns, exactly: a run going on enters the next
    block's sums as their first term, so every sum adds in the same order."""
    out_u: list[NDArray[np.float64]] = []
    out_v: list[NDArray[np.float64]] = []
    out_n: list[NDArray[np.int64]] = []
    carry: tuple[float, float, int] | None = None   # sums and count of the open run
    for new, u, v in blocks:
        if u.size == 0:
            continue
        group = np.cumsum(new) - int(new[0])   # the block's first run numbered 0
        if carry is not None and not new[0]:   # the open run goes on
            group = np.concatenate(([0], group))
            u, v = np.concatenate(([carry[0]], u)), np.concatenate(([carry[1]], v))
            count = np.bincount(group)
            count[0] += carry[2] - 1
        else:
            if carry is not None:
                out_u.append(np.array([carry[0]]))
                out_v.append(np.array([carry[1]]))
                out_n.append(np.array([carry[2]]))
            count = np.bincount(group)
        su = np.asarray(np.bincount(group, u), dtype=float)   # (float sums: typed)
        sv = np.asarray(np.bincount(group, v), dtype=float)
        out_u.append(su[:-1])
        out_v.append(sv[:-1])
        out_n.append(count[:-1])
        carry = (float(su[-1]), float(sv[-1]), int(count[-1]))
    if carry is not None:
        out_u.append(np.array([carry[0]]))
        out_v.append(np.array([carry[1]]))
        out_n.append(np.array([carry[2]]))
    if not out_n:
        return np.zeros(0), np.zeros(0), np.zeros(0, np.int64)
    count = np.concatenate(out_n).astype(np.int64)
    return np.concatenate(out_u) / count, np.concatenate(out_v) / count, count


def running_deviation(chunks: Iterable[tuple[NDArray[np.float64], NDArray[Any]]],
                      ) -> Iterator[tuple[NDArray[np.float64], NDArray[Any]]]:
    """For values in order, handed out as chunks ``(values, payload)`` (payload: an
    array of one entry per value, carried along), yield ``(values - running median of 9,
    payload)`` in the same order: ``median_filter(size=9, mode='nearest')`` of the whole
    sequence, computed a chunk at a time (the last 4 values of a chunk wait for the
    next one; 4 values before them are carried as context)."""
    left = np.zeros(0)
    pend_v, pend_p = np.zeros(0), None
    for v, p in chunks:
        if v.size == 0:
            continue
        work = np.concatenate((left, pend_v, v))
        pay = p if pend_p is None else np.concatenate((pend_p, p))
        med = median_filter(work, size=9, mode='nearest')
        stop = work.size - 4   # medians of the last 4 need the next chunk
        start = left.size
        if stop > start:
            yield work[start:stop] - med[start:stop], pay[:stop - start]
            left = work[max(stop - 4, 0):stop]
            pend_v, pend_p = work[stop:], pay[stop - start:]
        else:
            pend_v, pend_p = work[start:], pay
            left = work[:start]
    if pend_p is not None and pend_v.size:
        work = np.concatenate((left, pend_v))
        med = median_filter(work, size=9, mode='nearest')
        yield work[left.size:] - med[left.size:], pend_p
