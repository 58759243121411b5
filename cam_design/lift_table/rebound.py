"""The rebound method 回弹法 on a lift table: each row's rebound, the fairing of the rows
it flags, and the rounding step of the rows (docs/reconstruction.md, steps 1-2).

1. **Rebound** r_i = S_(i)(alpha_i) - h_i of the natural cubic interpolating spline S,
   for every point at once in closed form (no N refits): removing knot i leaves a
   spline whose difference to S is -r_i times the cardinal spline L_i, so
   r_i = -J_i(S) / J_i(L_i) with J_i the jump of the third derivative at alpha_i,
   J(S) = Q gamma and J_i(L_i) = (Q T^-1 Q^T)_ii (Reinsch's Q, T). The band of T^-1
   comes from the LDL^T factors (LAPACK dpttrf) by Takahashi's recurrences,
   evaluated as a vectorised affine scan: O(N) per sweep.
2. **Fairing**: in each sweep, interior points whose |r_i| exceeds ``threshold``
   noise standard deviations times the point's rebound noise factor (1.524 on uniform
   knots, estimated per point on uneven ones), and is the local maximum within +-2
   points, are moved by ``gain * r_i``; a point whose cumulative move would exceed
   ``cap`` noise standard deviations is declared an outlier, replaced by its
   leave-one-out value and given zero weight. On tables coarser than 0.75 deg local
   quintic predictions must confirm each candidate, alone or in a group of up to four
   nearby rows (spikes.py). Sweeps repeat until no point exceeds the tolerance.

Angles in rad, lifts in m. The smoothing that follows is ``spline.reconstruct_spline``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.linalg.lapack import dpttrf, dpttrs

from cam_design.errors import InputError, require_positive
from cam_design.lift_table.noise import EXACT_NOISE_REL, rebound_sigma
from cam_design.lift_table.spikes import confirmed_candidates, local_maxima


def _rebound_noise_factor() -> float:
    """std(r_i)/sigma for white noise on a uniform grid, interior points.

    The rebound operator has the symbol g(w) = (2 - 2 cos w)^2 / (4 + 2 cos w) (up to a
    constant), so var(r)/sigma^2 = mean(g^2) / mean(g)^2.
    """
    w = np.linspace(-np.pi, np.pi, 20001)[:-1]
    g = (2.0 - 2.0 * np.cos(w)) ** 2 / (4.0 + 2.0 * np.cos(w))
    return float(np.sqrt(np.mean(g ** 2)) / np.mean(g))


REBOUND_NOISE_FACTOR = _rebound_noise_factor()


def _backward_affine_scan(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Solve x_k = a_k + b_k x_{k+1} (x_n = 0) for all k by recursive doubling."""
    a = a.copy()
    b = b.copy()
    b[-1] = 0.0
    s = 1
    while s < a.size:
        a[:-s] = a[:-s] + b[:-s] * a[s:]
        b[:-s] = b[:-s] * b[s:]
        s *= 2
    return a


class ReboundOperator:
    """Leave-one-out rebounds of the natural cubic interpolating spline on fixed knots.

    ``alpha`` [rad] strictly increasing (>= 4 points). ``rebound(y)`` returns r with
    r_i = S_(i)(alpha_i) - y_i for every interior i (0 at the two end points).
    """

    def __init__(self, alpha: ArrayLike) -> None:
        x = np.asarray(alpha, dtype=float)
        if x.size < 4 or np.any(np.diff(x) <= 0):
            raise InputError('rebound.alpha', x.size, '>= 4 strictly increasing angles')
        self.alpha = x
        h = np.diff(x)
        self.h = h
        d = (h[:-1] + h[1:]) / 3.0
        e = h[1:-1] / 6.0
        dd, ee, info = dpttrf(d, e)
        if info != 0:
            raise InputError('rebound.alpha', 'a singular spline system', 'distinct angles')
        self._d, self._e = dd, ee
        self.diag = self._cardinal_jumps(dd, ee, h)

    @staticmethod
    def _cardinal_jumps(dd: NDArray[np.float64], ll: NDArray[np.float64],
                        h: NDArray[np.float64]) -> NDArray[np.float64]:
        """(Q T^-1 Q^T)_ii for every knot i (Takahashi band of T^-1)."""
        m = dd.size
        l2 = np.zeros(m)
        l2[:-1] = ll ** 2
        s0 = _backward_affine_scan(1.0 / dd, l2)                  # Sigma_kk
        s1 = np.zeros(m)
        s1[:-1] = -ll * s0[1:]                                   # Sigma_k,k+1
        s2 = np.zeros(m)
        if m > 2:
            s2[:-2] = ll[:-1] * ll[1:] * s0[2:]                  # Sigma_k,k+2
        n = m + 2
        inv_h = 1.0 / h
        # coefficients of row i of Q on interior knots i-1, i, i+1 (indices i-2, i-1, i)
        ca = np.zeros(n)
        cb = np.zeros(n)
        cc = np.zeros(n)
        ca[2:] = inv_h[1:]                 # knot i-1 -> 1/h[i-1], valid for i >= 2
        cb[1:-1] = -(inv_h[:-1] + inv_h[1:])
        cc[:-2] = inv_h[:-1]               # knot i+1 -> 1/h[i], valid for i <= n-3

        def pad(v: NDArray[np.float64], lo: int) -> NDArray[np.float64]:
            return np.concatenate([np.zeros(lo), v, np.zeros(n - lo - v.size)])
        sa, sb, sc = pad(s0, 2), pad(s0, 1), pad(s0, 0)          # Sigma at (i-2), (i-1), (i)
        sab = pad(s1, 2)                                          # Sigma(i-2, i-1)
        sbc = pad(s1, 1)                                          # Sigma(i-1, i)
        sac = pad(s2, 2)                                          # Sigma(i-2, i)
        return (ca * ca * sa + cb * cb * sb + cc * cc * sc
                + 2.0 * (ca * cb * sab + cb * cc * sbc + ca * cc * sac))

    def second_derivatives(self, y: NDArray[np.float64]) -> NDArray[np.float64]:
        """S'' at every knot (0 at the ends: natural spline); ``y`` (n,) or (n, k)."""
        h = self.h if y.ndim == 1 else self.h[:, None]
        slope = np.diff(y, axis=0) / h
        rhs = slope[1:] - slope[:-1]
        gamma, info = dpttrs(self._d, self._e, rhs)
        pad = [(1, 1)] + [(0, 0)] * (y.ndim - 1)
        return np.pad(gamma, pad)

    def rebound(self, y: ArrayLike) -> NDArray[np.float64]:
        """r_i = S_(i)(alpha_i) - y_i [same unit as y] for all i; ``y`` (n,) or (n, k)."""
        y = np.asarray(y, dtype=float)
        gam = self.second_derivatives(y)
        h = self.h if y.ndim == 1 else self.h[:, None]
        s = np.diff(gam, axis=0) / h
        jump = np.zeros(gam.shape)
        jump[:-1] += s
        jump[1:] -= s
        diag = self.diag if y.ndim == 1 else self.diag[:, None]
        r = -jump / diag
        r[0] = r[-1] = 0.0        # ends: no interior knot to release (extrapolation)
        return r

    def noise_factors(self, half_width: int = 10) -> NDArray[np.float64]:
        """std(r_i) / sigma for white noise, per point (0 at the ends).

        std(r_i)/sigma = |K e_i| / K_ii with K = Q T^-1 Q^T. Uniform knots: the
        constant REBOUND_NOISE_FACTOR (1.524). Uneven knots (the factor then varies
        from 1.1 to 7 for +-0.45 step jitter): K e_i = Q g_i with T g_i = Q^T e_i, solved
        for every i at once on a window of +-``half_width`` interior knots (T^-1 decays
        geometrically: relative error 1e-10 at 10) by a vectorised Thomas algorithm.
        """
        h = self.h
        n = h.size + 1
        out = np.full(n, REBOUND_NOISE_FACTOR)
        if float(np.ptp(h)) > 1e-6 * float(np.median(h)):
            out[1:-1] = np.sqrt(self._row_norms2(half_width)) / self.diag[1:-1]
        out[0] = out[-1] = 0.0
        return out

    def _row_norms2(self, half_width: int) -> NDArray[np.float64]:
        """|K e_i|^2 for the interior knots i = 1..n-2 (see ``noise_factors``)."""
        h = self.h
        n = h.size + 1
        m = n - 2
        d = (h[:-1] + h[1:]) / 3.0
        e = h[1:-1] / 6.0
        hw = min(half_width, m)
        offsets = np.arange(-hw, hw + 1)
        cols = np.arange(m)[:, None] + offsets[None, :]        # interior indices
        inside = (cols >= 0) & (cols < m)
        cc = np.clip(cols, 0, m - 1)
        diag = np.where(inside, d[cc], 1.0)
        lower = np.zeros_like(diag)
        if m > 1:
            lower[:, 1:] = np.where(inside[:, 1:] & inside[:, :-1],
                                    e[np.clip(cc[:, :-1], 0, m - 2)], 0.0)
        upper = np.zeros_like(diag)
        upper[:, :-1] = lower[:, 1:]
        inv_h = 1.0 / h
        knot = np.arange(1, n - 1)
        rhs = np.zeros_like(diag)
        rhs[:, hw] = -(inv_h[knot - 1] + inv_h[knot])           # Q^T e_i at knot i
        if hw >= 1:
            rhs[:, hw - 1] = np.where(knot >= 2, inv_h[knot - 1], 0.0)       # knot i-1
            rhs[:, hw + 1] = np.where(knot <= n - 3, inv_h[np.minimum(knot, n - 2)], 0.0)
        rhs = np.where(inside, rhs, 0.0)
        cp = np.zeros_like(diag)
        dp = np.zeros_like(diag)
        cp[:, 0] = upper[:, 0] / diag[:, 0]
        dp[:, 0] = rhs[:, 0] / diag[:, 0]
        for k in range(1, 2 * hw + 1):
            den = diag[:, k] - lower[:, k] * cp[:, k - 1]
            cp[:, k] = upper[:, k] / den
            dp[:, k] = (rhs[:, k] - lower[:, k] * dp[:, k - 1]) / den
        g = np.zeros_like(diag)
        g[:, -1] = dp[:, -1]
        for k in range(2 * hw - 1, -1, -1):
            g[:, k] = dp[:, k] - cp[:, k] * g[:, k + 1]
        g = np.where(inside, g, 0.0)
        # Q g = jumps of the slopes of g on the full knots (g = 0 outside the window)
        gp = np.pad(g, ((0, 0), (1, 1)))
        kf = np.concatenate([cols[:, :1], cols + 1, cols[:, -1:] + 2], axis=1)
        valid = (kf[:, :-1] >= 0) & (kf[:, 1:] <= n - 1)
        hk = h[np.clip(kf[:, :-1], 0, h.size - 1)]
        slope = np.where(valid, np.diff(gp, axis=1) / hk, 0.0)
        jump = np.concatenate([slope[:, :1], slope[:, 1:] - slope[:, :-1], -slope[:, -1:]],
                              axis=1)
        return np.sum(jump ** 2, axis=1)


def _rebound_l1_factor() -> float:
    """max_j sum_i |d r_j / d y_i| on uniform knots, interior: the largest rebound that
    errors bounded by 1 can cause (rebound operator row sum, ~2.9)."""
    n = 121
    op = ReboundOperator(np.arange(n, dtype=float))
    rows = op.rebound(np.eye(n))
    return float(np.sum(np.abs(rows[n // 2])))


REBOUND_L1_FACTOR = _rebound_l1_factor()


#: table step [rad] above which no row is taken for an outlier (only reported)
VERY_COARSE_RAD = math.radians(4.5)


@dataclass(frozen=True)
class Fairing:
    """Outcome of the rebound fairing: ``lift`` [m] faired values (outliers replaced by
    their leave-one-out value), ``outlier`` mask, cumulative ``correction`` [m] of kept
    points, initial rebounds ``rebound0`` [m], noise ``sigma`` [m], ``sweeps``."""

    lift: NDArray[np.float64]
    outlier: NDArray[np.bool_]
    correction: NDArray[np.float64]
    rebound0: NDArray[np.float64]
    sigma: float
    tolerance: float
    sweeps: int
    quantum: float = 0.0


def rebound_fairing(alpha: ArrayLike, lift: ArrayLike, *, threshold: float = 4.5,
                    gain: float = 1.0, cap: float = 3.0, max_sweeps: int = 60,
                    sigma: float | None = None, min_tolerance_rel: float = 2e-5) -> Fairing:
    """Rebound method on strictly increasing ``alpha`` [rad], ``lift`` [m].

    ``threshold``: tolerance on |r| in robust standard deviations of r; ``gain`` the
    fraction lambda (<= 1) of r_i applied per move; ``cap``: largest cumulative move
    of a kept point in noise standard deviations; ``sigma`` [m]: instrument noise
    (estimated from the rebounds when None). The tolerance never goes below
    ``min_tolerance_rel`` x the lift range (so exact tables are left alone).
    """
    require_positive('threshold', threshold)
    if not 0.0 < gain <= 1.0:
        raise InputError('gain', gain, 'a fraction in (0, 1]')
    require_positive('cap', cap)
    op = ReboundOperator(alpha)
    x_arr = op.alpha
    coarse = float(np.median(op.h)) > math.radians(0.75)
    y = np.asarray(lift, dtype=float).copy()
    n = y.size
    r = op.rebound(y)
    factor = op.noise_factors()
    interior = np.zeros(n, dtype=bool)
    interior[1:-1] = True
    span = float(np.ptp(y)) if n else 0.0
    quantum = quantisation_step(y)
    floor = max(min_tolerance_rel * span, 1e-300)
    if sigma is None:
        sigma, exact = _estimated_noise(r, factor, y, span, quantum)
    else:
        sigma = require_positive('sigma', sigma, allow_zero=True)
        exact = sigma < EXACT_NOISE_REL * span
    # rounding errors are bounded (|e| <= q/2): their rebound never exceeds q/2 times
    # the rebound operator's row sum; no rounded point is an outlier
    floor = max(floor, 1.05 * 0.5 * quantum * REBOUND_L1_FACTOR)
    tol_i = np.maximum(threshold * sigma * factor, floor * factor / REBOUND_NOISE_FACTOR)
    tol = max(threshold * sigma * REBOUND_NOISE_FACTOR, floor)
    cap_m = max(cap * sigma, floor)
    outlier = np.zeros(n, dtype=bool)
    corr = np.zeros(n)
    r0 = r.copy()
    sweeps = 0
    # an exact (computed, noise-free) table is data, not a measurement: none of its
    # points is moved or dropped (where a local fit misses one, the table has a junction
    # the fit cannot follow, e.g. an acceleration step on a coarse grid)
    # nor on a table coarser than VERY_COARSE_RAD, where a single row off the fit cannot
    # be told from the lobe's own shape (a junction of the law between two rows)
    keep_all = exact or float(np.median(op.h)) > VERY_COARSE_RAD
    seen: dict[bytes, dict[int, float]] = {}
    for sweeps in range(1, 0 if keep_all else max_sweeps + 1):
        a = np.divide(np.abs(r), tol_i, out=np.zeros(n), where=interior & ~outlier)
        big = a > 1.0
        if not np.any(big):
            sweeps -= 1
            break
        # candidates: local maxima of |r|/tol. On coarse tables (steps > 0.75 deg) the
        # cubic spline's own interpolation error on the flanks exceeds the noise, so
        # the rows near each candidate are confirmed by local quintic predictions
        # (which follow the lift), in groups of up to four (spikes one or two rows apart
        # hide each other): a group of one is moved by its rebound as below, the rows
        # of a larger group are outliers at once, set to their local prediction; a
        # rejected maximum is vetoed and the next tried (spikes.py).
        grouped = 0
        if coarse:
            confirmed = confirmed_candidates(x_arr, y, a, big, outlier, threshold * sigma,
                                             floor, seen)
            cand = confirmed.single
            outlier[confirmed.grouped] = True
            y[confirmed.grouped] = confirmed.fill
            grouped = confirmed.grouped.size
        else:
            cand = np.flatnonzero(big & local_maxima(a))
        if cand.size == 0:
            if grouped:
                r = op.rebound(y)
                continue
            sweeps -= 1
            break
        step = gain * r[cand]
        too_far = np.abs(corr[cand] + step) > cap_m
        drop = cand[too_far]
        keep = cand[~too_far]
        outlier[drop] = True
        y[drop] += r[drop]                  # to the leave-one-out value
        y[keep] += step[~too_far]
        corr[keep] += step[~too_far]
        r = op.rebound(y)
    return Fairing(y, outlier, corr, r0, float(sigma), float(tol), sweeps, quantum)


def _estimated_noise(r: NDArray[np.float64], factor: NDArray[np.float64],
                     y: NDArray[np.float64], span: float, quantum: float
                     ) -> tuple[float, bool]:
    """(sigma [m], exact) of rows ``y`` from their rebounds ``r`` and noise factors:
    judged from the rows' scatter, rows sitting on a flat run left out when the rest
    looks like noise (noise.py), so digits do not make a table exact; rounding to a
    step ``quantum`` is noise of std q / sqrt(12) on the lobe, where the MAD of a table
    whose base circle rounds to exact zeros does not see it."""
    u = r[1:-1] / factor[1:-1]                      # rebounds in noise units
    sigma = rebound_sigma(u, y)
    exact = sigma < EXACT_NOISE_REL * span
    if quantum:     # (with no rounding the same estimate)
        sigma = rebound_sigma(u, y, quantum)
    return sigma, exact


def rebound_noise(alpha: ArrayLike, lift: ArrayLike) -> float:
    """The noise sigma [m] that ``rebound_fairing`` estimates for these rows (``alpha``
    [rad] strictly increasing, ``lift`` [m]), without fairing them."""
    op = ReboundOperator(alpha)
    y = np.asarray(lift, dtype=float)
    span = float(np.ptp(y)) if y.size else 0.0
    return _estimated_noise(op.rebound(y), op.noise_factors(), y, span,
                            quantisation_step(y))[0]


#: rows that ``quantisation_step`` tries a step on before all of them
QUANTUM_HEAD = 64


def quantisation_step(y: ArrayLike) -> float:
    """The rounding step q [same unit as y] of a table whose values are all whole
    multiples of q (1, 2 or 5 times a power of ten, from 1e-12 to 1e-2 of the largest
    value, at least 20 levels over the range); 0 when the values are not rounded."""
    v = np.asarray(y, dtype=float)
    v = v[np.isfinite(v)]
    if v.size < 8:
        return 0.0
    top = float(np.max(np.abs(v)))
    span = float(np.ptp(v))
    if not (top > 0 and span > 0):
        return 0.0
    start = math.floor(math.log10(span / 20.0))
    steps = [q for q in (m * 10.0 ** k for k in range(start, int(math.floor(math.log10(top)))
                                                      - 13, -1) for m in (5.0, 2.0, 1.0))
             if q <= span / 20.0]
    if not steps:
        return 0.0
    # a step the first rows already refuse is refused by all of them (the same answer:
    # the largest misfit of all rows is at least that of the first); the first rows are
    # tried on every step at once
    ratio = v[None, :QUANTUM_HEAD] / np.asarray(steps)[:, None]
    head_ok = np.max(np.abs(ratio - np.rint(ratio)), axis=1) <= 1e-6
    for q in (q for q, ok in zip(steps, head_ok) if ok):
        if _whole_multiples(v, q):
            return q
    return 0.0


def _whole_multiples(v: NDArray[np.float64], q: float) -> bool:
    """Every value of ``v`` within 1e-6 q of a whole multiple of ``q``."""
    ratio = v / q
    return float(np.max(np.abs(ratio - np.rint(ratio)))) <= 1e-6
