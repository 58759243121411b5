"""Velocity and acceleration error of a measured lobe: the reconstruction's h' and h''
minus the design's (pure numerics; docs/metrology.md "Velocity and acceleration error").

The lobe's lift error measured - design (base-circle referenced, as the verdict uses
it; the design as the probe sees it) is averaged into bins of ``BIN_DEG`` (bounded cost
whatever the sample count) and smoothed by a cubic smoothing spline whose level is
chosen by generalized cross-validation (``scipy.interpolate.make_smoothing_spline``)
over the lobe and ``MARGIN_DEG`` of base circle on each side (the reconstruction's own
spline refuses a pure-noise error: its banded system is not positive definite when the
error has no shape); its first and second derivatives are the velocity and acceleration
errors, reported where the design lift is above 0 (the lobe, ramps included: an error at
the start of a stroke shows where it is, ``at_deg``). Smoothing the error, not the lift,
keeps the design's own acceleration steps (ramp ends) out of it: a spline cannot follow a
step of h'' and would report half of it as an error.

Angle zones (``tolerances.derivative_error_zones``, cam deg from the lobe centreline):
the same curves' statistics over the bins inside each zone (the base-circle margin
included), and, per quantity, over the lobe outside the zones that set a limit for it
(where the lobe's own maximum applies, as the lift-error zones do).
"""
from __future__ import annotations

import math
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from cam_metrology.metrology.lift_error import referenced_rows
from cam_metrology.metrology.long_columns import run_means
from cam_metrology.metrology.spill import walk

#: bin width [deg] of the table before the spline (7200 bins a revolution at most)
BIN_DEG = 0.05
#: base circle kept on each side of the lobe [deg]
MARGIN_DEG = 5.0
MM = 1e3


def _binned(alpha: Any, lift: Any) -> tuple[Any, Any]:
    """Means of ``lift`` in bins of ``BIN_DEG`` of ``alpha`` [rad] (empty bins dropped)."""
    width = math.radians(BIN_DEG)
    k = np.floor(alpha / width).astype(np.int64)
    keys, inverse, count = np.unique(k, return_inverse=True, return_counts=True)
    a = np.bincount(inverse, alpha) / count
    h = np.bincount(inverse, lift) / count
    return a, h


def _long_binned(rows: Any, margin: float) -> tuple[Any, Any] | None:
    """``_binned`` of the rows within ``margin`` [rad] of the lobe (design > 0) of a long
    referenced table in angle order, read a block at a time (the bins are runs of
    rows: ``long_columns.run_means``, the same sums); None with fewer than 10 lobe rows."""
    n = rows.shape[0]
    first = last = -1
    count = 0
    for a, b in walk(n, rows):
        on = np.flatnonzero(rows[a:b, 2] > 0)
        count += on.size
        if on.size:
            first = a + int(on[0]) if first < 0 else first
            last = a + int(on[-1])
    if count < 10:
        return None
    lo, hi = rows[first, 0] - margin, rows[last, 0] + margin
    width = math.radians(BIN_DEG)
    prev: list[int] = []   # the previous block's last bin

    def runs() -> Any:
        for a, b in walk(n, rows):
            part = rows[a:b]
            m = (part[:, 0] >= lo) & (part[:, 0] <= hi)
            alpha, err = part[m, 0], part[m, 1] - part[m, 2]
            if alpha.size:
                k = np.floor(alpha / width).astype(np.int64)
                first_new = not prev or int(k[0]) != prev[0]
                yield np.concatenate(([first_new], k[1:] != k[:-1])), alpha, err
                prev[:] = [int(k[-1])]

    a_mean, e_mean, _ = run_means(runs())
    return a_mean, e_mean


def _stats(grid: Any, err: Any, scale: float) -> dict[str, float] | None:
    """Largest |err| (times ``scale``), its cam angle [deg], and the RMS; None for no
    points."""
    if grid.size == 0:
        return None
    k = int(np.argmax(np.abs(err)))
    return {'max_abs': float(abs(err[k]) * scale), 'at_deg': float(np.degrees(grid[k])),
            'rms': float(np.sqrt(np.mean(err ** 2)) * scale)}


VELOCITY, ACCELERATION = 'velocity_error_mm_per_rad', 'acceleration_error_mm_per_rad2'
#: report field -> the limit's attribute on a zone (scene.model.DerivativeZone)
ZONE_LIMITS = {VELOCITY: 'velocity_max_mm_per_rad', ACCELERATION: 'acceleration_max_mm_per_rad2'}


def _zone_stats(a: Any, curves: Mapping[str, Any], on: Any, zones: Sequence[Any]
                ) -> dict[str, Any]:
    """``derivative_error_zones`` (each zone's statistics of both curves over the bins
    ``a`` [rad] inside it; None where it has none) and ``derivative_error_outside_zones``
    (per quantity over the lobe bins ``on`` outside the zones that limit it)."""
    deg = np.degrees(a)
    rows, outside = [], {}
    for z in zones:
        sel = (deg >= z.from_deg) & (deg <= z.to_deg)
        rows.append({'from_deg': z.from_deg, 'to_deg': z.to_deg,
                     **{q: _stats(a[sel], c[sel], MM) for q, c in curves.items()}})
    for q, c in curves.items():
        limited = [z for z in zones if getattr(z, ZONE_LIMITS[q]) is not None]
        if limited:
            sel = on.copy()
            for z in limited:
                sel &= (deg < z.from_deg) | (deg > z.to_deg)
            outside[q] = _stats(a[sel], c[sel], MM)
    return {'derivative_error_zones': rows, 'derivative_error_outside_zones': outside}


def derivative_errors(table: Any, values: Mapping[str, Any],
                      design: Callable[..., Any], zones: Sequence[Any] = ()) -> dict[str, Any]:
    """``velocity_error_mm_per_rad`` and ``acceleration_error_mm_per_rad2``
    ({max_abs, at_deg, rms}) of a lobe's (alpha, measured, design) table against the
    ``design`` law (as seen by the probe), and with ``zones`` (DerivativeZone) their
    statistics by zone (module doc); ``derivative_error`` (the reason) when the
    reconstruction fails."""
    from scipy.interpolate import make_smoothing_spline

    rows = referenced_rows(table, values)
    margin = math.radians(MARGIN_DEG)
    if isinstance(rows, np.memmap):   # a long table: binned a block of rows at a time
        binned = _long_binned(rows, margin)
        if binned is None:
            return {'derivative_error': 'fewer than 10 samples on the lobe'}
        a, e = binned
    else:
        alpha, nominal = rows[:, 0], rows[:, 2]
        error = rows[:, 1] - nominal
        on = np.flatnonzero(nominal > 0)
        if on.size < 10:
            return {'derivative_error': 'fewer than 10 samples on the lobe'}
        sel = (alpha >= alpha[on[0]] - margin) & (alpha <= alpha[on[-1]] + margin)
        a, e = _binned(alpha[sel], error[sel])
    try:
        spline = make_smoothing_spline(a, e)
    except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
        return {'derivative_error': f'smoothing of the lift error failed: {exc}'}
    lobe = np.asarray(design(a, 0)) > 0
    if np.count_nonzero(lobe) < 3:
        return {'derivative_error': 'fewer than 3 bins on the lobe'}
    curves = {VELOCITY: spline(a, 1), ACCELERATION: spline(a, 2)}
    out: dict[str, Any] = {q: _stats(a[lobe], c[lobe], MM) for q, c in curves.items()}
    if zones:
        out.update(_zone_stats(a, curves, lobe, zones))
    return out
