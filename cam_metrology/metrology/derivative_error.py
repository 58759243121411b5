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
"""
from __future__ import annotations

import math
from typing import Any, Callable, Mapping

import numpy as np

from cam_metrology.metrology.lift_error import referenced_rows

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


def _stats(grid: Any, err: Any, scale: float) -> dict[str, float]:
    """Largest |err| (times ``scale``), its cam angle [deg], and the RMS."""
    k = int(np.argmax(np.abs(err)))
    return {'max_abs': float(abs(err[k]) * scale), 'at_deg': float(np.degrees(grid[k])),
            'rms': float(np.sqrt(np.mean(err ** 2)) * scale)}


def derivative_errors(table: Any, values: Mapping[str, Any],
                      design: Callable[..., Any]) -> dict[str, Any]:
    """``velocity_error_mm_per_rad`` and ``acceleration_error_mm_per_rad2``
    ({max_abs, at_deg, rms}) of a lobe's (alpha, measured, design) table against the
    ``design`` law (as seen by the probe); ``derivative_error`` (the reason) when the
    reconstruction fails."""
    from scipy.interpolate import make_smoothing_spline

    rows = referenced_rows(table, values)
    alpha, nominal = rows[:, 0], rows[:, 2]
    error = rows[:, 1] - nominal
    on = np.flatnonzero(nominal > 0)
    if on.size < 10:
        return {'derivative_error': 'fewer than 10 samples on the lobe'}
    margin = math.radians(MARGIN_DEG)
    sel = (alpha >= alpha[on[0]] - margin) & (alpha <= alpha[on[-1]] + margin)
    a, e = _binned(alpha[sel], error[sel])
    try:
        spline = make_smoothing_spline(a, e)
    except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
        return {'derivative_error': f'smoothing of the lift error failed: {exc}'}
    grid = a[np.asarray(design(a, 0)) > 0]
    if grid.size < 3:
        return {'derivative_error': 'fewer than 3 bins on the lobe'}
    vel, acc = spline(grid, 1), spline(grid, 2)
    return {'velocity_error_mm_per_rad': _stats(grid, vel, MM),
            'acceleration_error_mm_per_rad2': _stats(grid, acc, MM)}
