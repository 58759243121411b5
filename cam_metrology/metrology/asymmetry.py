"""Top point and false asymmetry (docs/metrology.md, a reconstruction [RECON]).

If the zero of a measured lift table is off the true nose by delta, a symmetric cam
looks asymmetric: S(delta + a) != S(delta - a). Near the top h' ~ 0, so the maximum
is a poorly conditioned top point. The symmetry axis d instead minimises

    A(d) = sum_a w_a [S(d + a) - S(d - a)]^2,  w_a = |S'(d + a)| + |S'(d - a)|,

solved by Gauss-Newton d <- d - sum w r J / sum w J^2 (r_a = S(d+a) - S(d-a),
J_a = S'(d+a) + S'(d-a), the derivative of r with respect to d). The flank variant
finds, for lift levels L, the angles alpha-(L) and alpha+(L) on the two flanks; the
top is the mean of their midpoints and the scatter of the midpoints measures the
real asymmetry. After re-zeroing at d, what is left of S(d+a) - S(d-a) is real
asymmetry (reported as RMS and maximum, in m).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Iterable, Iterator

import numpy as np
from numpy.typing import NDArray
from scipy.interpolate import BSpline, make_interp_spline, make_lsq_spline
from scipy.linalg import cholesky_banded
from scipy.optimize import brentq

from cam_design.errors import InputError


@dataclass(frozen=True)
class TopPoint:
    """Symmetry axis ``d`` [rad] of a lift table (same frame as its angles), the
    flank-level top ``d_flank`` [rad] and the scatter of its midpoints [rad], the
    residual asymmetry after re-zeroing (RMS and max |S(d+a)-S(d-a)| [m]) and the
    apparent asymmetry RMS [m] at the frame's zero before re-zeroing."""

    d: float
    d_flank: float
    flank_scatter: float
    residual_rms: float
    residual_max: float
    apparent_rms: float
    iterations: int


#: angles [rad] closer than this are one encoder position (several revolutions over
#: the same encoder counts differ only by rounding, ~1e-15 rad; the lift moves by
#: < 1e-11 m over 1e-9 rad)
SAME_ANGLE = 1e-9
#: positions closer than knot_spacing / POSITION_BINS count once when the knot
#: spacing is chosen (encoder noise spreads a repeated position by arc-seconds)
POSITION_BINS = 8
#: largest accepted pivot ratio (max/min diagonal of the Cholesky factor of the
#: regression's normal matrix, squared: a lower bound of its condition number); well
#: posed fits are ~10-400, rank-deficient ones infinite
MAX_PIVOT_RATIO = 1e6


def merge_repeated(alpha: NDArray[np.float64], lift: NDArray[np.float64],
                   tol: float = SAME_ANGLE,
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]]:
    """Sorted distinct angles [rad], the mean lift [m] at each and the sample count.

    Angles within ``tol`` [rad] of their neighbour (chained) are one position; its
    angle and lift are the means. A least-squares fit of the means weighted by
    sqrt(count) is the fit of all samples (the within-position scatter only adds a
    constant to the sum of squares).
    """
    if alpha.size > 1 and not bool(np.all(alpha[1:] >= alpha[:-1])):
        order = np.argsort(alpha, kind='stable')
        a, h = alpha[order], lift[order]
        del order
    else:   # in angle order already (a lift table): no copies
        a, h = alpha, lift
    start = np.concatenate(([True], np.diff(a) > tol))
    group = np.cumsum(start) - 1
    count = np.bincount(group)
    return (np.bincount(group, a) / count, np.bincount(group, h) / count,
            count.astype(np.int64))


def merge_repeated_blocks(blocks: Iterable[tuple[NDArray[np.float64], NDArray[np.float64]]],
                          tol: float = SAME_ANGLE,
                          ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]]:
    """``merge_repeated`` of samples already in angle order, handed out as blocks
    ``(alpha, lift)`` (a long lift table read a block of rows at a time): the same
    numbers (``long_columns.run_means``)."""
    from cam_metrology.metrology.long_columns import run_means

    last: list[float] = []   # the previous block's last angle

    def runs() -> Iterator[tuple[NDArray[np.bool_], NDArray[np.float64],
                                 NDArray[np.float64]]]:
        for alpha, lift in blocks:
            if alpha.size:
                first = not last or alpha[0] - last[0] > tol
                yield np.concatenate(([first], np.diff(alpha) > tol)), alpha, lift
                last[:] = [float(alpha[-1])]

    return run_means(runs())


def lobe_spline_of_table(alpha: NDArray[np.float64], measured: NDArray[np.float64],
                         good: NDArray[np.bool_], lo: float, hi: float, knots: float,
                         ) -> tuple[Any, float, float]:
    """``lift_spline`` (knots every ``knots`` [rad]) of the ``good`` rows with
    lo < alpha < hi [rad] of a long lift table in angle order, read a block of rows at a
    time (repeated angles merged as they come: ``merge_repeated_blocks``), and the
    smallest and largest of those angles [rad]."""
    from cam_metrology.metrology.spill import walk

    span = [np.inf, -np.inf]

    def blocks() -> Iterator[tuple[NDArray[np.float64], NDArray[np.float64]]]:
        for i, j in walk(alpha.size, alpha, measured):
            m = good[i:j] & (alpha[i:j] > lo) & (alpha[i:j] < hi)
            a, h = alpha[i:j][m], measured[i:j][m]
            bad = int(np.count_nonzero(~(np.isfinite(a) & np.isfinite(h))))
            if bad:
                raise InputError('asymmetry.samples', f'{bad} non-finite angle(s) or '
                                 'lift(s)', 'finite numbers')
            if a.size:
                span[0], span[1] = min(span[0], float(a[0])), max(span[1], float(a[-1]))
            yield a, h

    merged = merge_repeated_blocks(blocks())
    return spline_of_positions(*merged, knot_spacing=knots), span[0], span[1]


def distinct_positions(alpha: NDArray[np.float64], resolution: float) -> int:
    """Number of cells of width ``resolution`` [rad] holding at least one angle."""
    return int(np.unique(np.floor((alpha - alpha.min()) / resolution)).size)


def lift_spline(alpha: NDArray[np.float64], lift: NDArray[np.float64], *,
                knot_spacing: float | None = None) -> Any:
    """Quintic spline S(alpha) [m] of a lift table (alpha [rad]).

    Repeated angles (several revolutions over the same encoder counts) are merged
    into their mean first. Without ``knot_spacing`` it interpolates the table (exact
    data); with it, it is a least-squares regression spline with knots every
    ``knot_spacing`` [rad] (noisy data, any number of samples; linear cost), widened
    where needed to keep at least two distinct positions per knot interval on average
    (coarse sampling). A regression that is rank deficient or ill-conditioned raises
    InputError instead of returning a meaningless spline.
    """
    alpha, lift = np.asarray(alpha, dtype=float), np.asarray(lift, dtype=float)
    bad = int(np.count_nonzero(~(np.isfinite(alpha) & np.isfinite(lift))))
    if bad:
        raise InputError('asymmetry.samples', f'{bad} non-finite angle(s) or lift(s)',
                         'finite numbers')
    return spline_of_positions(*merge_repeated(alpha, lift), knot_spacing=knot_spacing)


def spline_of_positions(a: NDArray[np.float64], h: NDArray[np.float64],
                        count: NDArray[np.int64], *, knot_spacing: float | None = None) -> Any:
    """``lift_spline`` of merged positions (``merge_repeated``): angles [rad], mean
    lifts [m] and sample counts."""
    if a.size < 8:
        raise InputError('asymmetry.samples', int(a.size), 'at least 8 distinct angles')
    if knot_spacing is None:
        return make_interp_spline(a, h, k=5)
    # at least 2 distinct positions per knot interval on average: a spacing equal to
    # the sample spacing would make the regression an ill-posed interpolation
    # (Schoenberg-Whitney); positions are counted, not samples, so that repeated
    # revolutions do not narrow the knots
    positions = distinct_positions(a, knot_spacing / POSITION_BINS)
    n_int = max(min(int((a[-1] - a[0]) / knot_spacing), positions // 2), 1)
    inner = _knots_with_data(a, np.linspace(a[0], a[-1], n_int + 1)[1:-1])
    knots = np.concatenate((np.full(6, a[0]), inner, np.full(6, a[-1])))
    weights = np.sqrt(count.astype(float))
    _check_conditioning(a, weights, knots, knot_spacing)
    try:
        spline = make_lsq_spline(a, h, knots, k=5, w=weights)
    except (ValueError, np.linalg.LinAlgError):
        raise InputError('asymmetry.samples', 'gaps in the lobe data',
                         f'samples in every {np.degrees(knot_spacing):.2f} deg interval') from None
    if not np.all(np.isfinite(spline.c)):
        raise InputError('asymmetry.fit', 'non-finite spline coefficients',
                         'a well-posed regression spline')
    return spline


def _knots_with_data(a: NDArray[np.float64], inner: NDArray[np.float64],
                     ) -> NDArray[np.float64]:
    """The interior knots [rad] without those that would leave a knot interval empty
    (a gap in the data, e.g. no samples over the nose, is bridged by one wider
    interval instead of an undetermined coefficient). ``a`` sorted."""
    kept: list[float] = []
    prev = a[0]
    for knot in inner:   # a sample strictly inside (previous kept knot, knot)
        if np.searchsorted(a, knot, 'left') > np.searchsorted(a, prev, 'right'):
            kept.append(float(knot))
            prev = knot
    while kept and np.searchsorted(a, a[-1], 'left') <= np.searchsorted(a, kept[-1], 'right'):
        kept.pop()
    return np.asarray(kept, dtype=float)


def _check_conditioning(a: NDArray[np.float64], weights: NDArray[np.float64],
                        knots: NDArray[np.float64], knot_spacing: float, k: int = 5) -> None:
    """Raise InputError if the regression on the knots is rank deficient or
    ill-conditioned (data too clustered to determine every coefficient)."""
    basis = BSpline.design_matrix(a, knots, k).tocsr().multiply(weights[:, None]).tocsr()
    normal = (basis.T @ basis).todia()
    n = normal.shape[0]
    banded = np.zeros((k + 1, n))
    for j in range(k + 1):
        banded[j, :n - j] = normal.diagonal(-j)
    try:
        diag = cholesky_banded(banded, lower=True)[0]
        ratio = float((diag.max() / diag.min()) ** 2)
    except (np.linalg.LinAlgError, ZeroDivisionError, FloatingPointError):
        ratio = np.inf
    if not ratio <= MAX_PIVOT_RATIO:
        raise InputError('asymmetry.fit', f'regression spline ill-conditioned (pivot ratio '
                         f'{ratio:.3g})', f'distinct angles spread over every '
                         f'{np.degrees(knot_spacing):.2f} deg knot interval')


def top_point(spline: Any, lo: float, hi: float, *, d0: float = 0.0, levels: int = 9,
              grid: int = 2001, max_iter: int = 50) -> TopPoint:
    """Symmetry axis of the spline ``S`` known on [lo, hi] [rad] (the lobe region).

    ``d0`` [rad] starting guess (e.g. the design-fit nose); ``levels`` flank levels
    between 20 % and 80 % of the lift range for the flank variant.
    """
    deriv = spline.derivative()

    def terms(d: float) -> tuple[NDArray[np.float64], ...]:
        half = min(d - lo, hi - d)
        if half <= 0:
            raise InputError('asymmetry.nose', float(d), 'a top point inside the data range')
        a = np.linspace(0.0, half, grid)[1:]
        r = spline(d + a) - spline(d - a)
        dp, dm = deriv(d + a), deriv(d - a)
        return r, dp - dm, np.abs(dp) + np.abs(dm)

    d = float(d0)
    it = 0
    for it in range(1, max_iter + 1):
        r, jac, w = terms(d)
        den = float(np.sum(w * jac * jac))
        if den <= 0:
            raise InputError('asymmetry.flanks', 'no slope', 'a lobe with flanks')
        step = -float(np.sum(w * r * jac)) / den
        d += step
        if abs(step) < 1e-14:
            break
    r, _, _ = terms(d)
    r0 = terms(0.0)[0] if lo < 0.0 < hi else r
    d_flank, scatter = _flank_top(spline, lo, hi, d, levels)
    return TopPoint(d, d_flank, scatter, float(np.sqrt(np.mean(r * r))),
                    float(np.max(np.abs(r))), float(np.sqrt(np.mean(r0 * r0))), it)


def _flank_top(spline: Any, lo: float, hi: float, d: float, levels: int,
               ) -> tuple[float, float]:
    """Mean and scatter [rad] of the midpoints of level crossings on the two flanks."""
    top = float(spline(d))
    base = min(float(spline(lo)), float(spline(hi)))
    mids = []
    for frac in np.linspace(0.2, 0.8, levels):
        level = base + frac * (top - base)
        left = _last_crossing(spline, lo, d, level, from_right=True)
        right = _last_crossing(spline, d, hi, level, from_right=False)
        if left is not None and right is not None:
            mids.append(0.5 * (left + right))
    if not mids:
        raise InputError('asymmetry.flanks', 'no level crossings', 'two flanks in the data')
    m = np.asarray(mids)
    return float(m.mean()), float(m.std(ddof=1)) if m.size > 1 else 0.0


def _last_crossing(spline: Any, a: float, b: float, level: float, *,
                   from_right: bool, n: int = 4001) -> float | None:
    """Crossing of ``level`` on [a, b] nearest to the top (b if from_right, else a)."""
    grid = np.linspace(a, b, n)
    f = spline(grid) - level
    idx = np.flatnonzero(np.sign(f[1:]) != np.sign(f[:-1]))
    if idx.size == 0:
        return None
    k = int(idx[-1] if from_right else idx[0])
    return float(brentq(lambda t: float(spline(t)) - level, grid[k], grid[k + 1], xtol=1e-15))
