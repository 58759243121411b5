"""The joins of a lobe to the base circle: where a smoothed (or mid-lobe) lobe is cut,
the curve is replaced, back to the base circle, by a degree-7 Hermite segment from
h = h' = h'' = h''' = 0 to the curve's four values; ``join_width`` makes it as long as
the lobe's own rise (the least peak |h''| of the joins that rise monotonically) and
``lobe_edge`` finds where it starts. Angles in rad, lifts in m (docs/methods.md, "One
table, one lobe", rule 6).
"""
from __future__ import annotations

import math
from functools import lru_cache
from typing import Any, Callable

import numpy as np
from numpy.typing import NDArray

#: a curve of the lobe frame: (alpha [rad], nu) -> nu-th derivative [m/rad^nu]
Curve = Callable[[Any, int], Any]

#: smallest join [deg]: half a table step, at least this
JOIN_MIN_DEG = 0.25
#: a join ending on a row may be this share of the smallest join (a lift rising as
#: t^n from the base circle needs 2 t/n: n up to 10 at one step from the base row)
ROW_JOIN_SHARE = 0.4
#: the join's width is chosen among n h / h' for n from 2 to this (a lift rising as
#: t^n from the base circle) in JOIN_TRIALS steps, by its peak |h''| at JOIN_SAMPLES points
JOIN_POWER_MAX = 6.0
JOIN_TRIALS = 33
JOIN_SAMPLES = 41
#: widths whose peak |h''| is within this factor of the smallest are as good
JOIN_PEAK_SLACK = 1.02
#: ... and a join whose least peak |h''| exceeds this many times |h''| at the join point
#: is no rise from the base circle: the shortest join (2 h / h') is taken instead
JOIN_FLOOR_FACTOR = 2.0


def join(at: float, width: float, jets: NDArray[np.float64], side: int) -> Any:
    """The degree-7 Hermite join from the base circle (all jets 0) to ``jets`` (4,) at
    ``at`` over ``width`` [rad]; side -1: before the lobe, +1: after it."""
    from scipy.interpolate import BPoly

    zero = [0.0, 0.0, 0.0, 0.0]
    if side < 0:
        return BPoly.from_derivatives([at - width, at], [zero, list(jets)])
    return BPoly.from_derivatives([at, at + width], [list(jets), zero])


@lru_cache(maxsize=2)
def _join_basis(nu: int) -> NDArray[np.float64]:
    """(JOIN_SAMPLES, 4): the ``nu``-th derivatives, on s in [0, 1], of the degree-7
    Hermite basis that is 0 with its first three derivatives at 0 and has d^m/ds^m =
    delta_mk at 1 (k = 0..3), at JOIN_SAMPLES points."""
    rows = [[math.perm(p, m) * at ** (p - m) if p >= m else 0.0 for p in range(8)]
            for m in range(4) for at in (0.0, 1.0)]
    rhs = np.vstack([np.eye(4)[m] if at else np.zeros(4) for m in range(4) for at in (0.0, 1.0)])
    basis = np.linalg.solve(np.array(rows), rhs)                    # (8 powers, 4)
    s = np.linspace(0.0, 1.0, JOIN_SAMPLES)
    powers = np.stack([math.perm(p, nu) * s ** max(p - nu, 0) if p >= nu else 0.0 * s
                       for p in range(8)], axis=1)
    out = powers @ basis
    out.setflags(write=False)
    return out


def join_width(jets: NDArray[np.float64], side: int) -> float:
    """The width [rad] of the join from the base circle to ``jets`` (lift [m] and its
    first three derivatives [m/rad^k] at the join point; side -1 before the lobe, +1
    after it): among n h / |h'| for n in 2..JOIN_POWER_MAX (a lift rising as t^n from
    the base circle is n h / h' from it), the joins that rise monotonically from the
    base circle, and of those the ones with the smallest peak |h''|. A join shorter
    than the lobe's own rise makes an acceleration spike the lobe does not have; a
    longer one than its jets allow dips below the base circle."""
    h, v = float(jets[0]), abs(float(jets[1]))
    widths = np.linspace(2.0, JOIN_POWER_MAX, JOIN_TRIALS) * h / v
    sign = (-float(side)) ** np.arange(4)              # d/ds of the mirrored join
    power = np.arange(4)[None, :]
    coef = sign * jets * widths[:, None] ** power                   # (trials, 4): d^m/ds^m
    rising = np.all(_join_basis(1) @ coef.T >= -1e-12 * np.abs(coef[:, 1]), axis=0)
    acc = _join_basis(2) @ (coef / widths[:, None] ** 2).T          # (samples, trials)
    peak = np.where(rising, np.max(np.abs(acc), axis=0), np.inf)
    least = float(np.min(peak))
    if not least <= JOIN_FLOOR_FACTOR * abs(float(jets[2])):
        # jets no t^n rise from the base circle has (a point inside an earlier join,
        # the rows' noise): the shortest join a rise from the base circle needs
        return 2.0 * h / v
    # the peak cannot fall below |h''| at the join point, and it often sits on that
    # floor over a range of widths: the middle of that range (on the accuracy families
    # the shortest of it cut a C2 lobe's rise short, the longest overshot dwell ends)
    ok = np.flatnonzero(peak <= JOIN_PEAK_SLACK * least)
    return float(widths[int(ok[ok.size // 2])])


def lobe_edge(curve: Curve, x: NDArray[np.float64], y: NDArray[np.float64],
              rows: NDArray[np.float64], top: int, tau: float, side: int,
              min_width: float) -> tuple[float, float, bool]:
    """(join point [rad], join width [rad], mid-lobe) on one side of the lobe: walk out
    from the top to the last grid point above ``tau``; the join ends on the first row
    inside it (so the law passes through every lobe row) when the join it needs there
    (``join_width``) is at least ``ROW_JOIN_SHARE`` of ``min_width``; else further in, on
    the grid, at the first point whose join is at least ``min_width``."""
    idx = np.arange(top, -1, -1) if side < 0 else np.arange(top, x.size)
    below = np.flatnonzero(y[idx] <= tau)
    mid_lobe = below.size == 0
    k = int(idx[-1]) if mid_lobe else int(idx[below[0] - 1])

    def width_at(at: float) -> float:
        jets = np.array([float(curve(at, nu)) for nu in range(4)])
        # lifted, and rising towards the top
        return join_width(jets, side) if jets[0] > 0 and jets[1] * -side > 0 else math.inf

    lo, hi = sorted((float(x[k]), float(x[top])))
    inside = rows[(rows >= lo - 1e-12) & (rows <= hi + 1e-12)]
    if inside.size:
        at = float(inside[0] if side < 0 else inside[-1])
        width = width_at(at)
        if ROW_JOIN_SHARE * min_width <= width < math.inf:   # a lobe row: keep it
            return at, width, mid_lobe
    while True:
        width = width_at(float(x[k]))
        if (min_width <= width < math.inf) or k == top:
            break
        k -= side
    return float(x[k]), width, mid_lobe
