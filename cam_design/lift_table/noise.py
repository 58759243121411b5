"""The noise of a lift table judged from its rows, not from its digits.

The rebound r_i of a row (rebound.ReboundOperator) measured in units of its own noise
factor has the noise sigma as its scale. Its median absolute deviation over all rows
is blind when more than half of the rows carry no scatter at all: a sensor trace whose
valve sits for two thirds of the cycle and reads exactly 0 there, or a table whose base
circle was written as 0.000. Rows inside a run of equal values are left out of a second
estimate, and that estimate is taken where the remaining rebounds look like noise:
white noise gives neighbouring rebounds a lag-one correlation of -0.87, the smooth
interpolation error of an exact table one close to +1. Lifts in m.
"""
from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

MAD_TO_SIGMA = 1.482602218505602
#: a table whose noise is below this fraction of its lift range is computed, not
#: measured (8 nm on an 8 mm lobe; gauges resolve 0.1 um at best)
EXACT_NOISE_REL = 1e-6
#: lag-one correlation of neighbouring rebounds below which they are taken for noise
#: (white noise: -0.87; interpolation error of a computed table: near +1)
NOISE_LAG_ONE = -0.7
#: fewest rows off the flat runs for the second estimate
MIN_ROWS = 16


def flat_rows(lift: NDArray[np.float64], reach: int = 2) -> NDArray[np.bool_]:
    """Rows equal to every row within +-``reach`` (a seated valve, a clipped reading, a
    base circle written as zeros)."""
    y = np.asarray(lift, dtype=float)
    n = y.size
    flat = np.ones(n, dtype=bool)
    for k in range(1, reach + 1):
        same = y[k:] == y[:-k]
        flat[k:] &= same
        flat[:-k] &= same
    return flat


def robust_sigma(u: NDArray[np.float64]) -> float:
    """MAD scale of ``u`` (normalised to a standard deviation for Gaussian data)."""
    return MAD_TO_SIGMA * float(np.median(np.abs(u - np.median(u)))) if u.size else 0.0


def rebound_sigma(u: NDArray[np.float64], lift: NDArray[np.float64],
                  quantum: float = 0.0) -> float:
    """Noise sigma [m] from the normalised rebounds ``u`` of the interior rows of
    ``lift`` (u[k] belongs to lift[k + 1]) rounded to ``quantum`` [m]: the MAD of all
    of them with the rounding's q^2/12 added (a base circle rounded to exact zeros
    hides it), or, where larger and the rebounds off the flat runs look like noise,
    the MAD of those (which already holds the rounding)."""
    whole = math.sqrt(robust_sigma(u) ** 2 + quantum ** 2 / 12.0)
    live = ~flat_rows(lift)[1:-1]
    if np.count_nonzero(live) < MIN_ROWS:
        return whole
    pairs = live[1:] & live[:-1]
    a, b = u[:-1][pairs], u[1:][pairs]
    if a.size < MIN_ROWS or float(np.std(a)) == 0.0 or float(np.std(b)) == 0.0:
        return whole
    if float(np.corrcoef(a, b)[0, 1]) > NOISE_LAG_ONE:
        return whole
    return max(whole, robust_sigma(u[live]))
