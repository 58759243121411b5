"""Lift error of a measured lobe referenced to its base circle (SI, m and rad).

The metrology fit takes the lift offset (and the run-out harmonic) from every sample, so
a smooth form error of the lobe (a lift a little too high everywhere) leaks into them and
the fit residual understates it. The lift error a gauge reports, and the one tolerances
are judged on, is measured - design with the offset (and run-out) taken from the base
circle alone: ``base_referenced``. ``local_deviation`` (residual minus its running
median) separates noise and spikes from smooth form errors.
"""
from __future__ import annotations

from typing import Any, Callable, Iterable, Iterator, Mapping

import numpy as np
from numpy.typing import NDArray
from scipy.ndimage import median_filter

from cam_metrology.metrology import block_lsq
from cam_metrology.metrology.lobe_columns import column_median, span
from cam_metrology.metrology.long_columns import (Buckets, bucket_count, median,
                                                  running_deviation)
from cam_metrology.metrology.spill import blank, is_long, release, seal, walk

#: gap between the lobe (design lift > 0) and the base-circle samples used [rad]
BASE_MARGIN = float(np.radians(2.0))
#: a sample this close to the margin's edge [rad] counts as outside the gap: on an
#: encoder grid a sample often lies exactly BASE_MARGIN from the lobe's first sample, and
#: which side its last bit falls on differs between CPUs (it moved the base fit by 8 nm)
EDGE_EPS = 1e-9
UM = 1e6


def local_deviation(x: NDArray[np.float64], r: NDArray[np.float64], *,
                    overwrite: bool = False) -> NDArray[np.float64]:
    """Residuals [m] minus their running median (9 samples in angle order): the noise
    part of the residuals; isolated spikes stand out, a smooth real form error (or a
    biased first fit) does not. ``overwrite``: ``r`` (float64) may be used for the
    result (one column less in memory for a feature of millions of samples). Long
    columns (``spill.is_long``) go through temporary files (``long_columns``):
    the same numbers, the result a spilled column when ``r`` is not overwritten."""
    if is_long(r.size):
        return _long_local_deviation(x, r, overwrite)
    if x.size < 2 or bool(np.all(x[1:] >= x[:-1])):   # in angle order already (tables)
        dev = r if overwrite and r.dtype == np.float64 else np.array(r, dtype=float)
        dev -= median_filter(dev, size=9, mode='nearest')
        return dev
    order = np.argsort(x, kind='stable')
    if order.size < 2**31:   # half the memory of the permutation while it is used
        order = order.astype(np.int32)
    ordered = r[order]
    dev = r if overwrite and r.dtype == np.float64 else np.empty_like(r, dtype=float)
    # the running median goes into dev's memory first (r is read only through ordered)
    median_filter(ordered, size=9, mode='nearest', output=dev)
    ordered -= dev
    dev[order] = ordered
    return dev


def _sorted(x: NDArray[np.float64]) -> bool:
    """True if ``x`` never decreases (read a block at a time)."""
    for a, b in walk(x.size - 1, x):
        if not bool(np.all(x[a + 1:b + 1] >= x[a:b])):
            return False
    return True


def _long_local_deviation(x: NDArray[np.float64], r: NDArray[np.float64],
                          overwrite: bool) -> NDArray[np.float64]:
    """``local_deviation`` of long columns: in angle order through ``Buckets`` (or
    directly when ``x`` is sorted), the deviations put back in sample order through
    buckets of sample numbers, written to ``r`` (``overwrite``) or a new column (spilled
    when long, writable like the in-memory result)."""
    n = r.size
    out = r if overwrite and r.dtype == np.float64 and r.flags.writeable else blank((n,))
    if _sorted(x):
        chunks: Iterator[tuple[NDArray[np.float64], NDArray[np.int64]]] = (
            (np.array(r[a:b], dtype=float), np.arange(a, b))
            for a, b in walk(n, r, step=block_lsq.BLOCK_ROWS))
        for dev, idx in running_deviation(chunks):
            out[idx[0]:idx[-1] + 1] = dev
            release(out)
        return out
    lo, hi = span(x)
    by_angle = Buckets([('x', 'f8'), ('r', 'f8'), ('i', 'i8')], 'x', lo, hi, bucket_count(n))
    by_row = Buckets([('i', 'f8'), ('d', 'f8')], 'i', 0.0, float(n), bucket_count(n))
    try:
        for a, b in walk(n, x, r):
            rows = np.empty(b - a, by_angle.dtype)
            rows['x'], rows['r'], rows['i'] = x[a:b], r[a:b], np.arange(a, b)
            by_angle.add(rows)
        for dev, idx in running_deviation((part['r'], part['i'])
                                          for part in by_angle.sorted()):
            back = np.empty(dev.size, by_row.dtype)
            back['i'], back['d'] = idx, dev
            by_row.add(back)
        for part in by_row.sorted():   # contiguous runs of sample numbers, in order
            first = int(part['i'][0])
            out[first:first + part.size] = part['d']
            release(out)
    finally:
        by_angle.close()
        by_row.close()
    return out


def base_model(table: Any, harmonic: bool,
               ) -> tuple[Callable[[Any], Any] | None, NDArray[np.bool_]]:
    """The base-circle reference of ``base_referenced``: the function of alpha [rad]
    giving the level [m] to subtract from the measured lift (None when fewer than 10
    base-circle samples: nothing is subtracted), and the mask of samples kept. A long
    (spilled) table is read a block of rows at a time; the masks are its only
    whole-table arrays in memory."""
    a, dev, first, last = _columns(table)
    dev = local_deviation(a, dev, overwrite=True)   # measured - design, consumed
    n = dev.size
    for k, e in walk(n, dev):
        np.abs(dev[k:e], out=dev[k:e])
    scale = max(1.4826 * column_median(dev), 1e-7)
    bad = np.empty(n, bool)
    for k, e in walk(n, dev):
        np.greater(dev[k:e], 5.0 * scale, out=bad[k:e])
    del dev
    if np.mean(bad) > 0.05:
        bad[:] = False
    base = ~bad
    if first >= 0:
        lo, hi = a[first], a[last]
        gap = BASE_MARGIN - EDGE_EPS
        for k, e in walk(n, table):
            ak = table[k:e, 0]
            base[k:e] &= (ak < lo - gap) | (ak > hi + gap)
    if np.count_nonzero(base) < 10:
        return None, ~bad

    def base_err() -> Iterator[tuple[NDArray[np.float64], NDArray[np.float64]]]:
        for k, e in walk(n, table, step=block_lsq.BLOCK_ROWS):
            rows, m = table[k:e], base[k:e]
            yield rows[:, 0][m], np.subtract(rows[:, 1], rows[:, 2])[m]

    if harmonic:   # c + a cos(alpha) + b sin(alpha), fitted a block at a time
        c, ca, cb = (float(v) for v in block_lsq.harmonic_fit(base_err()))
        return (lambda alpha: block_lsq.first_harmonic(alpha, c, ca, cb)), ~bad
    level = median(lambda: (err for _, err in base_err()))
    return (lambda alpha: level), ~bad


def _columns(table: Any) -> tuple[NDArray[np.float64], NDArray[np.float64], int, int]:
    """(alpha, measured - design) of a lift table, and the first and last row of design
    lift > 0 (-1, -1 when none), read a block of rows at a time (a spilled table gives
    back its pages as it is read). Alpha is a new column, or for a long table the
    table's own column (read as needed); measured - design a new column (spilled when
    long)."""
    n = table.shape[0]
    long = is_long(n)
    a = table[:, 0] if long else np.empty(n)
    err = blank((n,)) if long else np.empty(n)
    first = last = -1
    for k, e in walk(n, table, err, step=block_lsq.BLOCK_ROWS):
        rows = table[k:e]
        if not long:
            a[k:e] = rows[:, 0]
        np.subtract(rows[:, 1], rows[:, 2], out=err[k:e])
        on = np.flatnonzero(rows[:, 2] > 0)
        if on.size:
            first = k + int(on[0]) if first < 0 else first
            last = k + int(on[-1])
    return a, err, first, last


def _referenced_lift(table: Any, model: Callable[[Any], Any]) -> NDArray[np.float64]:
    """Measured lift [m] of the table minus the base-circle level, a block at a time."""
    a, m = table[:, 0], table[:, 1]
    out = np.empty(a.size)
    step = block_lsq.BLOCK_ROWS
    for k in range(0, a.size, step):
        out[k:k + step] = m[k:k + step] - model(a[k:k + step])
    return out


def base_referenced(table: Any, harmonic: bool) -> tuple[Any, Any]:
    """The lift table with the measured lift referenced to the base circle alone, and
    the mask of samples kept (isolated spikes dropped).

    The metrology fit takes its lift offset (and the run-out harmonic) from every sample,
    so a smooth form error of the lobe leaks into them (docs/tolerances.md). Here the
    deviation measured - design on the base circle (design lift 0, ``BASE_MARGIN`` away
    from the lobe) is fitted by ``c`` (+ ``a cos alpha + b sin alpha`` when ``harmonic``:
    a once-per-revolution run-out is a first harmonic in alpha too) and subtracted from
    the whole table (``base_model``). Spikes: deviation from the running median of 9
    samples above 5 x 1.4826 x its median absolute value (floored at 0.1 um), unless
    more than 5 % are."""
    model, kept = base_model(table, harmonic)
    if model is None:
        return table, kept
    out = np.empty((table.shape[0], 3))
    out[:, 0], out[:, 2] = table[:, 0], table[:, 2]
    out[:, 1] = _referenced_lift(table, model)
    return out, kept


def referenced_rows(table: Any, feature: Mapping[str, Any]) -> NDArray[np.float64]:
    """The rows ``feature_referenced`` keeps, as a new (k, 3) table (alpha [rad],
    base-referenced measured lift [m], design lift [m]): the values of
    ``ref[good]``, built a block of rows at a time without the referenced copy of the
    whole table (a spilled table gives back its pages block by block); a long one is
    itself spilled (``spill.blank``): read it a block at a time (``spill.walk``)."""
    model, kept = base_model(table, bool(feature.get('runout_fitted')))
    out = blank((int(np.count_nonzero(kept)), 3))
    pos = 0
    for a, b in walk(table.shape[0], table, out, step=block_lsq.BLOCK_ROWS):
        rows = table[a:b][kept[a:b]]
        if model is not None:
            rows[:, 1] = rows[:, 1] - model(rows[:, 0])
        out[pos:pos + rows.shape[0]] = rows
        pos += rows.shape[0]
    return seal(out)


def referenced_error_stats(table: Any, harmonic: bool, good: NDArray[np.bool_],
                           ) -> dict[str, float] | None:
    """``lift_error_stats`` of ``base_referenced(table, harmonic)`` over the samples it
    keeps and ``good``, without the referenced table (a block of rows at a time)."""
    model, kept = base_model(table, harmonic)
    kept &= good
    if not is_long(table.shape[0]):   # a short table: whole columns
        if model is None:
            return lift_error_stats(table, kept)
        err = _referenced_lift(table, model)
        err -= table[:, 2]
        return error_stats(err, table[:, 2], kept)

    def blocks() -> Iterator[tuple[NDArray[np.float64], NDArray[np.float64],
                                   NDArray[np.bool_]]]:
        for a, b in walk(table.shape[0], table, step=block_lsq.BLOCK_ROWS):
            rows = table[a:b]
            lift = rows[:, 1] if model is None else rows[:, 1] - model(rows[:, 0])
            yield lift - rows[:, 2], rows[:, 2], kept[a:b]

    return error_stats_blocks(blocks())


def feature_referenced(table: Any, feature: Mapping[str, Any]) -> tuple[Any, Any]:
    """``base_referenced`` of a lobe's (alpha, measured, design) table with the run-out
    harmonic exactly when its report entry ``feature`` says the run-out was fitted (the
    rule the report, the verdict, the cards and the plots share). A spilled table
    (``spill``) gives back the pages this read touched: a consumer walking every
    feature holds one table at a time."""
    from cam_metrology.metrology.spill import release

    out = base_referenced(table, bool(feature.get('runout_fitted')))
    release(table)
    return out


def lift_error_stats(table: Any, good: NDArray[np.bool_]) -> dict[str, float] | None:
    """max_plus, max_minus, rms [um] of measured - design over the lobe (design > 0) of a
    (alpha, measured, design) table, samples ``good``; None without lobe samples."""
    return error_stats(table[:, 1] - table[:, 2], table[:, 2], good)


def error_stats(err: NDArray[np.float64], design: NDArray[np.float64],
                good: NDArray[np.bool_]) -> dict[str, float] | None:
    """``lift_error_stats`` of the columns: ``err`` = measured - design [m] and the
    design lift [m] of every sample (``error_stats_blocks`` of one block)."""
    return error_stats_blocks([(err, design, good)])


def error_stats_blocks(blocks: Iterable[tuple[NDArray[np.float64], NDArray[np.float64],
                                              NDArray[np.bool_]]],
                       ) -> dict[str, float] | None:
    """``error_stats`` of columns handed out as blocks ``(err, design, good)``: the same
    maxima, the rms summed block by block (equal to rounding)."""
    hi, lo, total, count = -np.inf, np.inf, 0.0, 0
    for err, design, good in blocks:
        e = err[(design > 0) & good]
        if e.size:
            hi, lo = max(hi, float(np.max(e))), min(lo, float(np.min(e)))
            total += float(e @ e)
            count += e.size
    if count == 0:
        return None
    return {'max_plus': hi * UM, 'max_minus': lo * UM,
            'rms': float(np.sqrt(total / count)) * UM}
