"""The angle frame of a lobe table (no rclpy): where a table's seam goes and which turn
its lobe is told in, the one rule of every route that reads a lift table
(``lobe_table.lobe_law`` applies it; docs/methods.md "One table, one lobe", step 4).

* ``part_turn_centre``: a table over part of the turn keeps its angles contiguous
  around their middle;
* ``seam_frame``: a whole-turn table whose lobe crosses +-180 deg is turned so that
  the seam lies in the middle of its longest base-circle run; one without a base-circle
  run (an eccentric) is periodic, its lowest row at the seam;
* ``lobe_middle`` / ``lobe_turn``: the law's angles are the table's, continuous across
  the lobe, whole turns added so that the lobe's middle lies in the turn of the
  table's first row, [first row, first row + 360 deg) (a nose on the seam row of a
  closed table at the first row).
"""
from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cam_design.lift_table.noise import BASE_SHARE
from cam_design.lift_table.samples import wrap_pi

TWO_PI = 2.0 * math.pi
#: a run of base-circle rows shorter than this [deg] is the bottom of an eccentric
BASE_MIN_DEG = 20.0
#: fewest degrees of such rows for a base level
BASE_LEVEL_DEG = 60.0
#: a base circle this far from 0 [m] (and above the noise) is taken off the lifts
BASE_OFFSET_M = 10e-6
#: a lobe whose middle lies less than this share of a row step before the end of the
#: turn of the table's first row is placed at the first row (a nose on the seam row of
#: a closed table, 0/360 or -180/180 deg, which the fit of rounded or measured rows
#: puts a little to either side)
SEAM_TOL_STEPS = 0.25


def _runs(mask: NDArray[np.bool_]) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """(first index, index after the last) of each run of True in ``mask``."""
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)


def part_turn_centre(alpha: ArrayLike) -> float:
    """The middle [rad] of the rows' angles ``alpha`` [rad] when they cover part of the
    turn (their span is shorter than the turn less 1.5 row steps), else 0. Such a table
    keeps its angles contiguous around that middle (0..300 deg is not cut at 180 deg,
    118..242 deg not wrapped into two pieces); a whole turn is wrapped to (-180, 180]."""
    a = np.asarray(alpha, dtype=float).reshape(-1)
    a = a[np.isfinite(a)]
    if a.size < 2:
        return 0.0
    lo, hi = float(np.min(a)), float(np.max(a))
    gaps = np.diff(np.unique(a))
    row_step = float(np.median(gaps)) if gaps.size else 0.0
    return 0.5 * (lo + hi) if hi - lo < TWO_PI - 1.5 * row_step else 0.0


def seam_frame(a: NDArray[np.float64], h: NDArray[np.float64], step: float,
               level: float) -> tuple[float, bool]:
    """(offset [rad], periodic) of the rows (sorted, in (-pi, pi]): offset 0 unless the
    table covers the whole turn and its lobe crosses the seam. Base circle: the rows
    within ``level`` [m] of the lowest (a few noise sigmas); a run of them shorter than
    ``BASE_MIN_DEG`` is the bottom of an eccentric, not a base circle (the law is then
    periodic)."""
    if a[-1] - a[0] < TWO_PI - 1.5 * step:           # part of the turn: keep its frame
        return 0.0, False
    base = h <= float(np.min(h)) + level
    n = a.size
    if base.all():
        return 0.0, False
    # the cyclic runs of base rows (walked from a lobe row, so none wraps); the longest
    # one's middle goes to the seam
    start = int(np.flatnonzero(~base)[0])
    first, last = _runs(np.roll(base, -start))
    best, best_len = None, -1.0
    if first.size:
        first, last = (first + start) % n, (last - 1 + start) % n
        spans = (a[last] - a[first]) % TWO_PI
        k = int(np.argmax(spans))
        best, best_len = (int(first[k]), int(last[k])), float(spans[k])
    if best is None or best_len < math.radians(BASE_MIN_DEG):
        return float(wrap_pi(a[int(np.argmin(h))] + math.pi)), True   # an eccentric
    if base[0] and base[-1]:
        return 0.0, False
    mid = a[best[0]] + 0.5 * ((a[best[1]] - a[best[0]]) % TWO_PI)
    return float(wrap_pi(mid - math.pi)), False


def base_level(h: NDArray[np.float64], step: float) -> tuple[float, int] | None:
    """(lift [m], rows) the rows give the base circle: the median of the rows within
    ``noise.BASE_SHARE`` of the lift range of their lower quartile (80 um on an 8 mm
    lobe: noise and run-out, not the ramps; the band of the base-circle noise test),
    when those cover at least ``BASE_LEVEL_DEG`` at ``step`` [rad]; None otherwise (an
    eccentric, a table of the lobe alone). For a table over the whole turn (part of one
    may hold only the lobe and its ramps, whose quartile is a ramp). The lower quartile,
    not the lowest row: a few rows below the base circle (a valve trace reading under
    zero near firing TDC) do not move it, and a band wide enough for a base circle's
    run-out keeps its median at the middle of it."""
    y = np.asarray(h, dtype=float)
    near = np.abs(y - float(np.quantile(y, 0.25))) <= BASE_SHARE * float(np.ptp(y))
    if np.count_nonzero(near) * step < math.radians(BASE_LEVEL_DEG):
        return None
    return float(np.median(y[near])), int(np.count_nonzero(near))


def lobe_middle(alpha: NDArray[np.float64], lift: NDArray[np.float64]) -> float:
    """The middle [rad] of the lobe of a curve sampled at ascending ``alpha`` [rad]
    (``lift`` [m]): halfway between where it passes half its max lift on either side
    of its highest sample (linear between samples; the highest sample when the curve
    does not come down to half its lift within ``alpha``). A dwell's flat top or a
    nose between samples moves it little, unlike the highest sample itself."""
    top = int(np.argmax(lift))
    half = 0.5 * float(lift[top])
    below = np.flatnonzero(lift[:top] < half)
    above = np.flatnonzero(lift[top:] < half)
    if not below.size or not above.size:
        return float(alpha[top])
    i, k = int(below[-1]), top + int(above[0]) - 1

    def cross(j: int) -> float:   # where the chord from sample j to j + 1 passes half
        return float(alpha[j] + (half - lift[j]) * (alpha[j + 1] - alpha[j])
                     / (lift[j + 1] - lift[j]))
    return 0.5 * (cross(i) + cross(k))


def lobe_turn(middle: float, first: float, step: float) -> float:
    """The whole turns [rad] to add to a lobe whose middle is at ``middle`` [rad] so that
    it lies in the turn of the table's first row ``first`` [rad]: [first - tol, first +
    2 pi - tol), tol = ``SEAM_TOL_STEPS`` x the row step ``step`` [rad] (the one frame
    rule of every route)."""
    tol = SEAM_TOL_STEPS * step
    return -TWO_PI * math.floor((middle - first + tol) / TWO_PI)
