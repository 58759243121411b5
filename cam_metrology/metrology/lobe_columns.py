"""Whole-feature columns of a lobe's analysis built and read a block at a time (no rclpy).

A feature of 10 M samples has 80 MB columns. Its samples arrive spilled to temporary
files (``spill``); the columns the analysis derives from them (the angle from the
coarse nose, the base-circle reference, the lift table in angle order) are spilled
too when long, written and read a block of rows at a time, so that the analysis holds
boolean masks and one block, not columns. Every function gives the values of the
whole-column expression it replaces (the lift table's order: a stable sort by angle).
"""
from __future__ import annotations

from typing import Any, Callable, Iterable, Iterator

import numpy as np
from numpy.typing import NDArray

from cam_metrology.metrology import block_lsq
from cam_metrology.metrology.long_columns import Buckets, angle_order, bucket_count, median
from cam_metrology.metrology.spill import blank, release, seal, walk

Lift = Callable[[NDArray[np.float64], int], NDArray[np.float64]]


def column_of(size: int, fill: Callable[[int, int], NDArray[Any]], *sources: Any,
              dtype: Any = float) -> NDArray[Any]:
    """A new column of ``size`` rows (spilled when long: ``spill.blank``; still writable,
    ``spill.seal`` when done), its rows [a, b) set to ``fill(a, b)`` a block at a time;
    the pages of the spilled ``sources`` and of the column are given back after each
    block."""
    out = blank((size,), dtype)
    for a, b in walk(size, out, *sources):
        out[a:b] = fill(a, b)
    return out


def selected(column: NDArray[Any], mask: NDArray[np.bool_]) -> NDArray[Any]:
    """``column[mask]`` (in memory; the rows of a 2-D table), gathered a block at a
    time."""
    parts = [column[a:b][mask[a:b]] for a, b in walk(column.shape[0], column)]
    return np.concatenate(parts) if parts else column[:0].copy()


def masked(column: NDArray[Any], mask: NDArray[np.bool_]) -> NDArray[Any]:
    """``column[mask]`` as a new column (spilled when long), a block at a time."""
    count = int(np.count_nonzero(mask))
    out = blank((count,), column.dtype)
    pos = 0
    for a, b in walk(column.size, column, out):
        part = column[a:b][mask[a:b]]
        out[pos:pos + part.size] = part
        pos += part.size
    return seal(out)


def mask_of(size: int, test: Callable[[int, int], NDArray[np.bool_]],
            *sources: Any) -> NDArray[np.bool_]:
    """A boolean array of ``size`` whose rows [a, b) are ``test(a, b)``, a block at a
    time (spilled ``sources`` give back their pages)."""
    out = np.empty(size, bool)
    for a, b in walk(size, *sources):
        out[a:b] = test(a, b)
    return out


def masked_median(column: NDArray[np.float64], mask: NDArray[np.bool_]) -> float:
    """``numpy.median(column[mask])`` without the gathered copy (``long_columns``)."""
    def blocks() -> Iterator[NDArray[np.float64]]:
        for a, b in walk(column.size, column):
            yield column[a:b][mask[a:b]]
    return median(blocks)


def column_median(column: NDArray[np.float64]) -> float:
    """``numpy.median(column)`` read a block at a time (``long_columns.median``)."""
    return median(lambda: (column[a:b] for a, b in walk(column.size, column)))


def span(column: NDArray[np.float64]) -> tuple[float, float]:
    """(min, max) of a column, a block at a time."""
    lo, hi = np.inf, -np.inf
    for a, b in walk(column.size, column):
        if b > a:
            lo, hi = min(lo, float(np.min(column[a:b]))), max(hi, float(np.max(column[a:b])))
    return lo, hi


def short_lift_table(x: NDArray[np.float64], d: float, theta: NDArray[np.float64],
                     s: NDArray[np.float64], c: float, runout: tuple[float, float],
                     law: Lift, good: NDArray[np.bool_]
                     ) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """``lift_table`` of a short feature, in memory, in the same order (``angle_order``:
    ties in stamp order)."""
    alpha = x - d
    order = angle_order(alpha)
    table = np.empty((alpha.size, 3))
    table[:, 0] = alpha[order]
    wave = block_lsq.first_harmonic(theta[order], 0.0, *runout)
    table[:, 1] = s[order] - c - wave
    table[:, 2] = law(table[:, 0], 0)
    return table, good[order]


def lift_table(x: NDArray[np.float64], d: float, theta: NDArray[np.float64],
               s: NDArray[np.float64], c: float, runout: tuple[float, float], law: Lift,
               good: NDArray[np.bool_]) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """The lift table (alpha = x - d [rad], measured s - c - run-out harmonic [m],
    design lift [m]) in the order of a stable sort by alpha, and ``good`` in that
    order: the rows pass through ``long_columns.Buckets`` (angle bins in temporary
    files), the table is written in order to a spilled array (``spill.blank``)."""
    n = x.size
    lo, hi = span(x)
    rows = Buckets([('alpha', 'f8'), ('theta', 'f8'), ('s', 'f8'), ('good', '?')], 'alpha',
                   lo - d, hi - d, bucket_count(n))
    try:
        for a, b in walk(n, x, theta, s):
            part = np.empty(b - a, rows.dtype)
            part['alpha'] = x[a:b] - d
            part['theta'], part['s'], part['good'] = theta[a:b], s[a:b], good[a:b]
            rows.add(part)
        table = blank((n, 3))
        good_sorted = np.empty(n, bool)
        pos = 0
        for part in rows.sorted():
            for k in range(0, part.size, block_lsq.BLOCK_ROWS):
                p = part[k:k + block_lsq.BLOCK_ROWS]
                e = pos + p.size
                table[pos:e, 0] = p['alpha']
                wave = block_lsq.first_harmonic(p['theta'], 0.0, *runout)
                table[pos:e, 1] = p['s'] - c - wave
                table[pos:e, 2] = law(table[pos:e, 0], 0)   # elementwise: the same
                good_sorted[pos:e] = p['good']
                pos = e
                release(table)
    finally:
        rows.close()
    return seal(table), good_sorted


#: half-widths [rad] of the rows kept around the design's peak and its events for the
#: cam card and the table checks: wider than their local windows (3 deg at the peak,
#: 1 deg at an event), which are all they read besides the area
PEAK_WINDOW, EVENT_WINDOW = float(np.radians(3.5)), float(np.radians(1.5))


def card_rows(table: NDArray[np.float64], law: Any, heights: Iterable[float],
              ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(alpha [rad], lift [m]) of a lift table as two contiguous columns: for a long
    (spilled) table only the rows within ``PEAK_WINDOW`` of ``law``'s peak and
    ``EVENT_WINDOW`` of its events at ``heights`` [m], gathered a block at a time (the
    card and the table checks with the design as reference fit only those rows: the
    same numbers, the area aside: ``support_area``); a short table whole."""
    from cam_design.cam_card import law_events, law_peak
    from cam_design.errors import InputError

    if not isinstance(table, np.memmap) or law is None:
        return np.ascontiguousarray(table[:, 0]), np.ascontiguousarray(table[:, 1])
    windows = [(law_peak(law)[0], PEAK_WINDOW)]
    for y in heights:
        try:
            windows += [(e, EVENT_WINDOW) for e in law_events(law, y)]
        except InputError:   # the card names the height itself
            pass

    def near(a: int, b: int) -> NDArray[np.bool_]:
        alpha = table[a:b, 0]
        keep = np.zeros(b - a, bool)
        for centre, half in windows:
            keep |= np.abs(alpha - centre) <= half
        return keep

    rows = selected(table, mask_of(table.shape[0], near, table))
    return np.ascontiguousarray(rows[:, 0]), np.ascontiguousarray(rows[:, 1])


def support_area(table: NDArray[np.float64], support: tuple[float, float]) -> float:
    """Trapezoid area [m rad] of the lift over the rows of a table in angle order whose
    alpha lies in ``support`` [rad] (``numpy.trapezoid``, summed a block at a time:
    equal to rounding); 0 with fewer than two such rows."""
    lo, hi = support
    total, count = 0.0, 0
    last: tuple[float, float] | None = None
    for a, b in walk(table.shape[0], table):
        rows = table[a:b]
        m = (rows[:, 0] >= lo) & (rows[:, 0] <= hi)
        x, y = rows[m, 0], rows[m, 1]
        count += x.size
        if last is not None and x.size:
            x, y = np.concatenate(([last[0]], x)), np.concatenate(([last[1]], y))
        if x.size > 1:
            total += float(np.sum(np.diff(x) * (y[1:] + y[:-1]) / 2.0))
        if x.size:
            last = (float(x[-1]), float(y[-1]))
    return total if count > 1 else 0.0
