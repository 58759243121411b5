"""Lift error of a measured lobe referenced to its base circle (SI, m and rad).

The metrology fit takes the lift offset (and the run-out harmonic) from every sample, so
a smooth form error of the lobe (a lift a little too high everywhere) leaks into them and
the fit residual understates it. The lift error a gauge reports, and the one tolerances
are judged on, is measured - design with the offset (and run-out) taken from the base
circle alone: ``base_referenced``. ``local_deviation`` (residual minus its running
median) separates noise and spikes from smooth form errors.
"""
from __future__ import annotations

from typing import Any, Mapping

import numpy as np
from numpy.typing import NDArray
from scipy.ndimage import median_filter

#: gap between the lobe (design lift > 0) and the base-circle samples used [rad]
BASE_MARGIN = float(np.radians(2.0))
#: a sample this close to the margin's edge [rad] counts as outside the gap: on an
#: encoder grid a sample often lies exactly BASE_MARGIN from the lobe's first sample, and
#: which side its last bit falls on differs between CPUs (it moved the base fit by 8 nm)
EDGE_EPS = 1e-9
UM = 1e6


def local_deviation(x: NDArray[np.float64], r: NDArray[np.float64]) -> NDArray[np.float64]:
    """Residuals [m] minus their running median (9 samples in angle order): the noise
    part of the residuals; isolated spikes stand out, a smooth real form error (or a
    biased first fit) does not."""
    order = np.argsort(x, kind='stable')
    dev = np.empty_like(r)
    dev[order] = r[order] - median_filter(r[order], size=9, mode='nearest')
    return dev


def base_referenced(table: Any, harmonic: bool) -> tuple[Any, Any]:
    """The lift table with the measured lift referenced to the base circle alone, and
    the mask of samples kept (isolated spikes dropped).

    The metrology fit takes its lift offset (and the run-out harmonic) from every sample,
    so a smooth form error of the lobe leaks into them (docs/tolerances.md). Here the
    deviation measured - design on the base circle (design lift 0, ``BASE_MARGIN`` away
    from the lobe) is fitted by ``c`` (+ ``a cos alpha + b sin alpha`` when ``harmonic``:
    a once-per-revolution run-out is a first harmonic in alpha too) and subtracted from
    the whole table. Spikes: deviation from the running median of 9 samples above 5 x
    1.4826 x its median absolute value (floored at 0.1 um), unless more than 5 % are."""
    a, m, d = (np.asarray(table[:, k], dtype=float) for k in range(3))
    err = m - d
    dev = np.abs(local_deviation(a, err))
    bad = dev > 5.0 * max(1.4826 * float(np.median(dev)), 1e-7)
    if np.mean(bad) > 0.05:
        bad[:] = False
    lobe = np.nonzero(d > 0)[0]
    if lobe.size:
        lo, hi = a[lobe[0]], a[lobe[-1]]
        gap = BASE_MARGIN - EDGE_EPS
        base = ((a < lo - gap) | (a > hi + gap)) & ~bad
    else:
        base = ~bad
    if np.count_nonzero(base) < 10:
        return table, ~bad
    if harmonic:
        cols = np.column_stack([np.ones(a.size), np.cos(a), np.sin(a)])
        coef = np.linalg.lstsq(cols[base], err[base], rcond=None)[0]
        model = cols @ coef
    else:
        model = np.full(a.size, float(np.median(err[base])))
    return np.column_stack([a, m - model, d]), ~bad


def feature_referenced(table: Any, feature: Mapping[str, Any]) -> tuple[Any, Any]:
    """``base_referenced`` of a lobe's (alpha, measured, design) table with the run-out
    harmonic exactly when its report entry ``feature`` says the run-out was fitted (the
    rule the report, the verdict, the cards and the plots share)."""
    return base_referenced(table, bool(feature.get('runout_fitted')))


def lift_error_stats(table: Any, good: NDArray[np.bool_]) -> dict[str, float] | None:
    """max_plus, max_minus, rms [um] of measured - design over the lobe (design > 0) of a
    (alpha, measured, design) table, samples ``good``; None without lobe samples."""
    err = table[:, 1] - table[:, 2]
    lobe = (table[:, 2] > 0) & good
    if not np.any(lobe):
        return None
    return {'max_plus': float(np.max(err[lobe])) * UM, 'max_minus': float(np.min(err[lobe])) * UM,
            'rms': float(np.sqrt(np.mean(err[lobe] ** 2))) * UM}
