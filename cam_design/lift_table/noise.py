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
from dataclasses import dataclass

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


#: share of the lift range above the lowest row within which a row is taken for the
#: base circle by ``base_circle_correlation``
BASE_SHARE = 0.01
#: share of the longest base-circle run left out at each of its ends (the ramps)
BASE_TRIM = 0.15
#: the quadratic trend of a base circle's rows (its run-out) spans at most this share
#: of the lift range (40 um on an 8 mm lobe); a run that rises more is a ramp
BASE_FLAT = 0.005
#: fewest base-circle rows for the correlation test
MIN_CORRELATION_ROWS = 32
#: lag-one correlation of the base-circle noise above which (and above 3.5 of its
#: standard errors, 3.5/sqrt(m)) the rows' noise is taken for correlated
CORRELATED_LAG_ONE = 0.2


@dataclass(frozen=True)
class BaseNoise:
    """The noise on a table's base circle: lag-one correlation ``r1``, ``rows`` used,
    standard deviation ``sigma`` [m] (about a quadratic: the run-out taken off)."""

    r1: float
    rows: int
    sigma: float

    @property
    def correlated(self) -> bool:
        """Whether the rows' noise is correlated row to row: r1 above
        ``CORRELATED_LAG_ONE`` and above 3.5 of its standard errors (3.5/sqrt(rows))."""
        return self.r1 > max(CORRELATED_LAG_ONE, 3.5 / math.sqrt(self.rows))

    def warning(self) -> str:
        """What a correlated noise means for the lobe law (one sentence)."""
        return (f'the noise on the base circle is correlated row to row (lag-one '
                f'correlation {self.r1:.2f} over {self.rows} rows, where independent rows '
                f'give 0 +- {1.0 / math.sqrt(self.rows):.2f}; its spread '
                f'{self.sigma * 1e6:.3g} um): a filtered or averaged trace? Smoothed with '
                "that spread as its noise, but smoothing assumes independent rows: h'' and "
                'what follows from it (jump speed, contact force) may still carry noise; '
                'sample the trace at a step where its noise is independent')


def base_circle_noise(lift: NDArray[np.float64], quantum: float = 0.0) -> BaseNoise | None:
    """The noise on a whole-turn table's base circle (``BaseNoise``): the longest run
    of rows (circular: a base circle across the table's seam is one) within
    ``BASE_SHARE`` of the lift range above the rows' lower quartile, less ``BASE_TRIM``
    of it at each end (where the ramps start), less a quadratic in the row index (a
    base circle's run-out); r1 = sum v_i v_(i+1) / sum v_i^2. Independent rows give r1
    about -1/m +- 1/sqrt(m); a signal low-pass filtered before it was sampled (a DAQ's
    anti-alias filter, a cycle-averaged trace) 0.4 to 0.99, which no noise estimate
    from neighbouring rows sees. None when the lower quartile lies more than twice
    that share above the lowest row (no flat base circle, as on an eccentric), when the
    quadratic spans more than ``BASE_FLAT`` of the lift range (a ramp), when
    fewer than ``MIN_CORRELATION_ROWS`` rows remain, or when their spread is the
    rounding's (``quantum`` [m]) or nothing."""
    y = np.asarray(lift, dtype=float)
    n = y.size
    if n < MIN_CORRELATION_ROWS:
        return None
    base, span = float(np.quantile(y, 0.25)), float(np.ptp(y))
    if base - float(np.min(y)) > 2.0 * BASE_SHARE * span:
        return None
    low = y <= base + BASE_SHARE * span
    if bool(np.all(low)):
        return None
    # the longest circular run of base rows: start the turn just after a lobe row
    shift = int(np.flatnonzero(~low)[-1]) + 1
    ring = np.roll(low, -shift)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], ring.astype(np.int8), [0]])))
    starts, stops = edges[::2], edges[1::2]
    k = int(np.argmax(stops - starts))
    cut = int(BASE_TRIM * (stops[k] - starts[k]))
    idx = (np.arange(starts[k] + cut, stops[k] - cut) + shift) % n
    m = idx.size
    v = y[idx]
    if m < MIN_CORRELATION_ROWS or float(np.ptp(v)) <= 2.0 * quantum:
        return None
    t = np.linspace(-1.0, 1.0, m)
    trend = np.polyval(np.polyfit(t, v, 2), t)
    if float(np.ptp(trend)) > BASE_FLAT * span:
        return None      # the run rises (a ramp, the rows of a lobe alone): not flat
    v = v - trend
    power = float(np.dot(v, v))
    if not power > 0.0:
        return None
    return BaseNoise(float(np.dot(v[:-1], v[1:])) / power, m, math.sqrt(power / (m - 3)))
