"""Lift error of a measured lobe referenced to its base circle (SI, m and rad).

The metrology fit takes the lift offset (and the run-out harmonic) from every sample, so
a smooth form error of the lobe (a lift a little too high everywhere) leaks into them and
the fit residual understates it. The lift error a gauge reports, and the one tolerances
are judged on, is measured - design with the offset (and run-out) taken from the base
circle alone: ``base_referenced``. ``local_deviation`` (residual minus its running
median) separates noise and spikes from smooth form errors.
"""
from __future__ import annotations

from typing import Any, Callable, Mapping

import numpy as np
from numpy.typing import NDArray
from scipy.ndimage import median_filter

from cam_metrology.metrology import block_lsq

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
    result (one column less in memory for a feature of millions of samples)."""
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


def base_model(table: Any, harmonic: bool,
               ) -> tuple[Callable[[Any], Any] | None, NDArray[np.bool_]]:
    """The base-circle reference of ``base_referenced``: the function of alpha [rad]
    giving the level [m] to subtract from the measured lift (None when fewer than 10
    base-circle samples: nothing is subtracted), and the mask of samples kept."""
    a, err, first, last = _columns(table)
    dev = local_deviation(a, err.copy(), overwrite=True)
    np.abs(dev, out=dev)
    bad = dev > 5.0 * max(1.4826 * float(np.median(dev)), 1e-7)
    del dev
    if np.mean(bad) > 0.05:
        bad[:] = False
    if first >= 0:
        lo, hi = a[first], a[last]
        gap = BASE_MARGIN - EDGE_EPS
        base = ((a < lo - gap) | (a > hi + gap)) & ~bad
    else:
        base = ~bad
    if np.count_nonzero(base) < 10:
        return None, ~bad
    if harmonic:   # c + a cos(alpha) + b sin(alpha), fitted a block at a time
        c, ca, cb = (float(v) for v in block_lsq.harmonic_lstsq(a, err, base))
        return (lambda alpha: block_lsq.first_harmonic(alpha, c, ca, cb)), ~bad
    level = float(np.median(err[base]))
    return (lambda alpha: level), ~bad


def _columns(table: Any) -> tuple[NDArray[np.float64], NDArray[np.float64], int, int]:
    """(alpha, measured - design) of a lift table as two new columns, and the first
    and last row of design lift > 0 (-1, -1 when none), read a block of rows at a time
    (a spilled table gives back its pages as it is read)."""
    from cam_metrology.metrology.spill import walk

    n = table.shape[0]
    a, err = np.empty(n), np.empty(n)
    first = last = -1
    for k, e in walk(n, table, step=block_lsq.BLOCK_ROWS):
        rows = table[k:e]
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
    whole table (a spilled table gives back its pages block by block)."""
    from cam_metrology.metrology.spill import walk

    model, kept = base_model(table, bool(feature.get('runout_fitted')))
    out = np.empty((int(np.count_nonzero(kept)), 3))
    pos = 0
    for a, b in walk(table.shape[0], table, step=block_lsq.BLOCK_ROWS):
        rows = table[a:b][kept[a:b]]
        if model is not None:
            rows[:, 1] = rows[:, 1] - model(rows[:, 0])
        out[pos:pos + rows.shape[0]] = rows
        pos += rows.shape[0]
    return out


def referenced_error_stats(table: Any, harmonic: bool, good: NDArray[np.bool_],
                           ) -> dict[str, float] | None:
    """``lift_error_stats`` of ``base_referenced(table, harmonic)`` over the samples it
    keeps and ``good``, without the referenced table (one column in memory)."""
    model, kept = base_model(table, harmonic)
    kept &= good
    if model is None:
        return lift_error_stats(table, kept)
    err = _referenced_lift(table, model)
    err -= table[:, 2]
    return error_stats(err, table[:, 2], kept)


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
    design lift [m] of every sample."""
    lobe = (design > 0) & good
    if not np.any(lobe):
        return None
    err = err[lobe]
    return {'max_plus': float(np.max(err)) * UM, 'max_minus': float(np.min(err)) * UM,
            'rms': float(np.sqrt(np.mean(err ** 2))) * UM}
