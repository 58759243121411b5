"""Coarse lift tables (steps above 2.25 deg, ``spline.COARSE_LEVEL_RAD``; 144 rows a turn
or fewer): which steps of h'' to believe, and how much to smooth when there are none.

At 72-144 rows a turn a lobe is barely resolved, and what works on finer tables goes
wrong there (docs/reconstruction.md step 9):

* **False junctions.** A smooth but fast change of h'' (the end of a C2 lobe, where
  h''' jumps; the steep flank of a polynomial lobe) lowers the GCV score of the junction
  search as much as a real step of h'' does. Each junction found is therefore tested
  against a *soft* alternative: the same partial spline with the step replaced by a
  linear change of h'' over 2, 3 or 4 rows (a cubic-spline-like ramp, placed anywhere
  within +-1.5 rows). A real step fits the rows better sharp; a stand-in for a fast
  smooth change fits better soft. A junction is kept unless the best soft alternative
  lowers N ln(GCV) by more than ``SOFT_MARGIN``.
* **Smoothing level without junctions.** GCV reads the part of an under-resolved lobe
  that the smoother cannot follow as noise (edf 37-40 of 72 rows, residuals of tens of
  um on a table with 0.1 um of noise). The noise of a full-turn table can be measured
  where there is no signal: the base-circle rows. When the GCV fit leaves residuals on
  the lobe far above that noise and correlated from row to row (structure, not noise),
  the level is chosen instead by Mallows' Cp (the unbiased risk estimate of the lift,
  Stein's SURE for a linear smoother) with the base-circle noise.
* **The lobe's ends.** Without junctions the quintic interpolant gets a triple knot at
  the last base-circle row each side of the lobe (``lobe_end_knots``), where a C2 lobe's
  h''' jumps.

Dense linear algebra: these tables have at most 160 rows (a few hundred nodes with the
free nodes of a table that ends on a flank). Lifts in m, angles in rad, positions along
the table in rows (nodes).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray
from scipy.fft import dct

from cam_design.lift_table.junctions import (JunctionFit, choose_level, find_junctions,
                                             golden_minimum, refit)
from cam_design.lift_table.noise import EXACT_NOISE_REL, MAD_TO_SIGMA

#: rows within this fraction of the lift range above the lowest row are taken for the
#: base circle (a table's ramps start above it at 5 deg steps)
BASE_FRACTION = 0.01
#: fewest base-circle rows for a noise estimate
MIN_BASE_ROWS = 8
#: widths [rows] of the soft alternative to a step of h''
SOFT_WIDTHS = (2.0, 3.0, 4.0)
#: positions [rows] of the soft alternative around the junction
SOFT_OFFSETS = tuple(np.linspace(-1.5, 1.5, 13))
#: positions [rows] of the step itself around the search's angle (which was refined
#: in the search's own model)
SHARP_OFFSETS = tuple(np.linspace(-0.5, 0.5, 21))
#: a junction is refused when a soft change lowers N ln(GCV) by more than this. On the
#: accuracy families at 5 deg (seeds 1-2, all noise kinds, with and without spikes) the
#: false junctions of the C2 and ramped lobes had -7.3 to -34.6, the steps of the dwell
#: cam -1.8 and above
SOFT_MARGIN = 6.0
#: the GCV fit's lobe residuals are structure when their lag-one correlation exceeds this
#: (spikes make it negative: -0.22 to -0.40 on the C2 lobe with 5 spikes; the misfit at
#: the steps of the dwell and circular-arc cams +0.03 to +0.11, of the C2 and ramped
#: lobes +0.2 to +0.56) and their RMS exceeds STRUCTURED_RMS times the base-circle noise
STRUCTURED_LAG_ONE = 0.0
STRUCTURED_RMS = 1.5
#: the lobe-end fit seeks each kink of h'' from the last base-circle row out to this many
#: rows away from the lobe, in steps of KINK_STEP rows (the C2 lobe at 2.5 deg, 0.5 um:
#: 0.66 x scipy's h'' error at the row, 0.38 with the search)
KINK_REACH = 3.0
KINK_STEP = 0.5


def base_circle_sigma(lift: NDArray[np.float64], quantum: float = 0.0) -> float | None:
    """Noise sigma [m] of a lift table from its base-circle rows (within
    ``BASE_FRACTION`` of the range above the lowest row): the MAD of their second
    differences over sqrt(6), at least the rounding's q/sqrt(12). None when fewer than
    ``MIN_BASE_ROWS`` rows qualify (a table of the open valve only), or when most of
    them are equal and the table is not rounded."""
    y = np.asarray(lift, dtype=float)
    if y.size < 3:
        return None
    span = float(np.ptp(y))
    d2 = y[:-2] - 2.0 * y[1:-1] + y[2:]
    low = y[1:-1] <= float(np.min(y)) + BASE_FRACTION * span
    if np.count_nonzero(low) < MIN_BASE_ROWS:
        return None
    mad = float(np.median(np.abs(d2[low])))
    if mad == 0.0:
        # a base circle written as one value (zeros, or noise added to the lobe only)
        # says nothing of the lobe's noise, beyond the rounding's
        return quantum / math.sqrt(12.0) if quantum > 0.0 else None
    return max(MAD_TO_SIGMA * mad / math.sqrt(6.0), quantum / math.sqrt(12.0))


def cp_level(values: NDArray[np.float64], sigma: float) -> float:
    """Discrete level of the reflective quintic smoother (``smooth_grid``) minimising
    Mallows' Cp, RSS + 2 sigma^2 edf, for uniform ``values`` [m] with noise ``sigma``
    [m]: both in closed form on the DCT-II coefficients."""
    n = values.size
    c2 = dct(values, norm='ortho') ** 2
    m3 = (2.0 - 2.0 * np.cos(np.pi * np.arange(n) / n)) ** 3

    def score(log_lam: float) -> float:
        hk = 1.0 / (1.0 + 10.0 ** log_lam * m3)
        return float(np.dot((1.0 - hk) ** 2, c2)) + 2.0 * sigma ** 2 * float(hk.sum())

    grid = np.arange(-6.0, 12.01, 1.0)
    i = int(np.argmin([score(v) for v in grid]))
    a, b = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
    return 10.0 ** golden_minimum(score, a, b, 22)


def structured_misfit(lift: NDArray[np.float64], fit: NDArray[np.float64],
                      sigma: float) -> tuple[float, float]:
    """(lag-one correlation, RMS / sigma) of the residuals ``lift - fit`` [m] on the
    lobe's rows (more than 5 sigma off the median row)."""
    resid = lift - fit
    lobe = np.abs(lift - float(np.median(lift))) > 5.0 * sigma
    r = resid[lobe]
    if r.size < 8 or sigma <= 0.0:
        return 0.0, 0.0
    r = r - float(np.mean(r))
    ss = float(r @ r)
    rho = float(r[1:] @ r[:-1]) / ss if ss > 0.0 else 0.0
    return rho, math.sqrt(float(np.mean(resid[lobe] ** 2))) / sigma


@dataclass(frozen=True)
class CoarseLevel:
    """The level ``lam_d`` of a coarse table without junctions, what to add to
    ``why``, and the noise [m] it was chosen by Mallows' Cp with (None: by GCV)."""

    lam_d: float
    why: str = ''
    cp_sigma: float | None = None


def coarse_level(values: NDArray[np.float64], fit: NDArray[np.float64],
                 live: NDArray[np.bool_], rows: NDArray[np.float64], quantum: float,
                 known: float, lam_d: float) -> CoarseLevel:
    """The level of a coarse table without junctions: ``lam_d`` (its smoothed ``fit``
    of the uniform ``values`` [m]; ``live`` the nodes with data) unless that fit leaves
    structured residuals on the lobe far above the noise of the base circle of ``rows``
    [m] (rounded to ``quantum``, at least the ``known`` noise [m]); then Mallows' Cp
    with that noise, if lower."""
    sigma = base_circle_sigma(rows, quantum)
    if sigma is None:
        return CoarseLevel(lam_d)
    # a base circle without scatter (a computed table): the known noise, else the
    # exact-table bound
    sigma = max(sigma, known, EXACT_NOISE_REL * float(np.ptp(rows)))
    rho, rms = structured_misfit(values[live], fit[live], sigma)
    if rho <= STRUCTURED_LAG_ONE or rms <= STRUCTURED_RMS:
        return CoarseLevel(lam_d)
    lam_cp = cp_level(values, sigma)
    if lam_cp >= lam_d:
        return CoarseLevel(lam_d)
    return CoarseLevel(lam_cp, f'; coarse table: that fit left residuals {rms:.3g} x the '
                       f'base-circle noise ({sigma:.3g} m), correlated row to row '
                       f'({rho:.2f}): level by Mallows\' Cp with that noise, '
                       f'lam_d = {lam_cp:.4g}', sigma)


@lru_cache(maxsize=8)
def _residual_matrix(n: int, lam_d: float) -> tuple[NDArray[np.float64], float]:
    """(R, tr S) of the free-ended quintic smoother S = (I + lam_d D3'D3)^-1, R = I - S
    (dense; read-only, cached)."""
    d3 = np.diff(np.eye(n), 3, axis=0)
    s = np.linalg.inv(np.eye(n) + lam_d * (d3.T @ d3))
    r = np.eye(n) - s
    r.setflags(write=False)
    return r, float(np.trace(s))


def _step_column(n: int, tau: float, width: float) -> NDArray[np.float64]:
    """A unit change of h'' at node ``tau`` (node units), opening on its longer side:
    a step (``width`` 0) or a linear change over ``width`` rows centred on ``tau``."""
    side = 1.0 if tau <= 0.5 * (n - 1) else -1.0
    u = side * (np.arange(n, dtype=float) - tau)
    if width <= 0.0:
        return np.asarray(0.5 * np.maximum(u, 0.0) ** 2, dtype=np.float64)
    ramp = np.maximum(u + 0.5 * width, 0.0) ** 3 - np.maximum(u - 0.5 * width, 0.0) ** 3
    return np.asarray(ramp / (6.0 * width), dtype=np.float64)


def _gcv_scores(values: NDArray[np.float64], r: NDArray[np.float64], trace_s: float,
                fixed: NDArray[np.float64], candidates: NDArray[np.float64],
                gamma: float) -> NDArray[np.float64]:
    """GCV scores of the partial splines y = f + G c, G = [``fixed`` (n, J), one column
    of ``candidates`` (n, K)], at the smoother behind ``r``: all K at once (the fixed
    blocks formed once, one batched (J + 1)-square solve)."""
    n, k = candidates.shape
    j = fixed.shape[1]
    rf, rc, ry = r @ fixed, r @ candidates, r @ values
    m = np.empty((k, j + 1, j + 1))
    gram = np.empty((k, j + 1, j + 1))
    m[:, :j, :j] = fixed.T @ rf
    m[:, :j, j] = (fixed.T @ rc).T
    m[:, j, :j] = m[:, :j, j]
    m[:, j, j] = np.einsum('ik,ik->k', candidates, rc)
    gram[:, :j, :j] = rf.T @ rf
    gram[:, :j, j] = (rf.T @ rc).T
    gram[:, j, :j] = gram[:, :j, j]
    gram[:, j, j] = np.einsum('ik,ik->k', rc, rc)
    m += 1e-13 * np.trace(m, axis1=1, axis2=2)[:, None, None] * np.eye(j + 1)
    rhs = np.empty((k, j + 1, 1))
    rhs[:, :j, 0] = rf.T @ values
    rhs[:, j, 0] = rc.T @ values
    coef = np.linalg.solve(m, rhs)[:, :, 0]                   # (K, J + 1)
    resid = ry[:, None] - rf @ coef[:, :j].T - rc * coef[:, j]
    edf = trace_s + np.trace(np.linalg.solve(m, gram), axis1=1, axis2=2)
    rss = np.einsum('ik,ik->k', resid, resid)
    return np.asarray(n * rss / np.maximum(n - gamma * edf, 1e-9) ** 2, dtype=np.float64)


def soft_gain(values: NDArray[np.float64], taus: list[float], j: int, lam_d: float,
              gamma: float) -> float:
    """N ln(GCV sharp / GCV soft) of junction ``j`` (node position ``taus[j]``) with the
    others kept as steps: > 0 when a linear change of h'' over ``SOFT_WIDTHS`` rows
    (best width and position) explains the rows better than the step (best position
    within ``SHARP_OFFSETS``)."""
    n = values.size
    r, trace_s = _residual_matrix(n, float(lam_d))
    others = [_step_column(n, t, 0.0) for i, t in enumerate(taus) if i != j]
    fixed = np.column_stack(others) if others else np.zeros((n, 0))
    sharp = [_step_column(n, taus[j] + d, 0.0) for d in SHARP_OFFSETS]
    soft = [_step_column(n, taus[j] + d, w) for w in SOFT_WIDTHS for d in SOFT_OFFSETS]
    scores = _gcv_scores(values, r, trace_s, fixed, np.column_stack(sharp + soft), gamma)
    return n * math.log(float(np.min(scores[:len(sharp)]))
                        / float(np.min(scores[len(sharp):])))


@dataclass(frozen=True)
class CoarseJunctions:
    """The junction fit kept on a coarse table (None: none kept), the angles [rad]
    refused as stand-ins for a fast smooth change of h'', and the level ``lam_d``."""

    found: JunctionFit | None
    refused: tuple[float, ...]
    lam_d: float


def coarse_junctions(grid: NDArray[np.float64], values: NDArray[np.float64],
                     missing: NDArray[np.bool_], lam0: float, *, gamma: float,
                     sigma_floor: float) -> CoarseJunctions:
    """The junction search of ``find_junctions`` on a coarse uniform table, each
    junction then tested against a soft change of h'' (``soft_gain``); the kept ones
    refitted at their GCV level. Without the search's look-ahead: a set taken only
    together is justified by the level it lets the rest have, which a junction-by-
    junction test that drops some of them would take away (a circular-arc table at
    2.5 deg, 0.5 um: a held pair taken with a third at 289 times the level, then the
    soft test dropped a true edge: h'' 2.2 x worse)."""
    found = find_junctions(grid, values, lam0, gamma=gamma, sigma_floor=sigma_floor,
                           lookahead=False)
    if found is None:
        return CoarseJunctions(None, (), lam0)
    step = float(grid[1] - grid[0])
    taus = [(t - float(grid[0])) / step for t in found.angles]
    soft = [soft_gain(values, taus, j, found.lam_d, gamma) > SOFT_MARGIN
            for j in range(len(taus))]
    refused = tuple(t for t, s in zip(found.angles, soft) if s)
    if not refused:
        return CoarseJunctions(found, (), found.lam_d)
    kept = [k for k, s in enumerate(soft) if not s]
    if not kept:
        return CoarseJunctions(None, refused, lam0)
    # chosen again without the refused ones, but never smoother than with them (GCV
    # without a stand-in may read the lobe's fast change as noise, as without any),
    # nor smoother than the plain fit the search started from
    lam = min(choose_level(values, [taus[k] for k in kept], gamma, found.lam_d),
              found.lam_d, lam0)
    pruned = replace(found, angles=tuple(found.angles[k] for k in kept),
                     scores=tuple(found.scores[k] for k in kept))
    return CoarseJunctions(refit(grid, values, missing, pruned, lam), refused, lam)


def lobe_end_rows(values: NDArray[np.float64], sigma: float) -> tuple[int, int] | None:
    """The last base-circle row on each side of the one lobe of uniform ``values`` [m]
    (rows within 5 ``sigma`` [m], the noise, or 1e-5 of the range above the base
    circle's median row). None without a single lobe clear of the table's ends."""
    n = values.size
    span = float(np.ptp(values))
    low = float(np.min(values))
    level = float(np.median(values[values <= low + 1e-3 * span]))    # the base circle
    base = values <= level + max(5.0 * sigma, 1e-5 * span)
    lobe = np.flatnonzero(~base)
    if lobe.size < 4 or np.any(np.diff(lobe) != 1):
        return None
    ends = (int(lobe[0]) - 1, int(lobe[-1]) + 1)
    if ends[0] < 5 or ends[1] > n - 6:
        return None
    return ends


def lobe_end_knots(grid: NDArray[np.float64], values: NDArray[np.float64],
                   sigma: float) -> NDArray[np.float64] | None:
    """Knots of a quintic interpolant of uniform ``values`` [m] on ``grid`` [rad] that
    may kink h'' (jump of h''') where one lobe leaves the base circle: a triple knot at
    the last base-circle row on each side (``lobe_end_rows``), in place of the knots of
    its two neighbours; the not-a-knot knots elsewhere. None without a single lobe
    clear of the table's ends."""
    ends = lobe_end_rows(values, sigma)
    if ends is None:
        return None
    inner = [float(v) for v in grid[3:-3]]
    for i in ends:
        for j in (i - 1, i + 1):
            inner.remove(float(grid[j]))
        inner += [float(grid[i])] * 2
    return np.concatenate([np.full(6, grid[0]), np.sort(inner), np.full(6, grid[-1])])


@lru_cache(maxsize=8)
def _fourth_difference_basis(n: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Eigenvalues (ascending, >= 0) and orthonormal eigenvectors of D4'D4 on ``n``
    nodes, D4 the fourth difference with free ends (read-only, cached)."""
    d4 = np.diff(np.eye(n), 4, axis=0)
    e, v = np.linalg.eigh(d4.T @ d4)
    e = np.maximum(e, 0.0)
    e.setflags(write=False)
    v.setflags(write=False)
    return e, v


def _kink_columns(n: int, ends: tuple[float, float]) -> NDArray[np.float64]:
    """Unit steps of h''' at the lobe's ends (node positions ``ends``), each opening
    into the lobe: (u)_+^3 scaled to a largest value of 1 (n, 2)."""
    nodes = np.arange(n, dtype=float)
    cols = np.column_stack([np.maximum(nodes - ends[0], 0.0) ** 3,
                            np.maximum(ends[1] - nodes, 0.0) ** 3])
    return np.asarray(cols / np.max(cols, axis=0), dtype=np.float64)


@dataclass(frozen=True)
class KinkedLobe:
    """The lobe-end fit of a coarse table: smoothed ``values`` [m] on the grid, the
    discrete level ``lam_d`` of its fourth-difference penalty, ``edf``, and the node
    positions ``ends`` of its kinks."""

    values: NDArray[np.float64]
    lam_d: float
    edf: float
    ends: tuple[float, float]


class _KinkedSmoother:
    """y = f + G c with f penalised by lam |D4 f|^2 (free ends) and G the steps of h'''
    at the lobe ends, in the eigenbasis of D4'D4: each level costs O(n)."""

    def __init__(self, values: NDArray[np.float64], ends: tuple[float, float]) -> None:
        n = values.size
        self.e, v = _fourth_difference_basis(n)
        self.g_hat = v.T @ _kink_columns(n, ends)
        self.v = v
        self.n = n
        self.y_hat = v.T @ values

    def fit(self, lam_d: float) -> tuple[NDArray[np.float64], float, float]:
        """(residual in the eigenbasis, rss [m^2], trace of the hat matrix)."""
        s = 1.0 / (1.0 + lam_d * self.e)
        r = 1.0 - s
        rg = r[:, None] * self.g_hat
        m = self.g_hat.T @ rg
        m += 1e-12 * np.trace(m) * np.eye(2)
        c = np.linalg.solve(m, rg.T @ self.y_hat)
        resid = r * (self.y_hat - self.g_hat @ c)
        trace = float(np.sum(s)) + float(np.trace(np.linalg.solve(m, rg.T @ rg)))
        return resid, float(resid @ resid), trace

    def values(self, lam_d: float) -> NDArray[np.float64]:
        """The fitted values [m] on the grid."""
        resid = self.fit(lam_d)[0]
        return np.asarray(self.v @ (self.y_hat - resid), dtype=np.float64)

    def criterion(self, log_lams: NDArray[np.float64], gamma: float,
                  cp_sigma: float | None) -> NDArray[np.float64]:
        """GCV (``gamma``) or, with ``cp_sigma`` [m], Mallows' Cp at each log10 level
        (all levels at once)."""
        s = 1.0 / (1.0 + 10.0 ** log_lams[:, None] * self.e[None, :])       # (L, n)
        r = 1.0 - s
        g = self.g_hat
        # products of the two hinge columns (g0 g0, g0 g1, g1 g1) and with y, per node
        pairs = np.column_stack([g[:, 0] * g[:, 0], g[:, 0] * g[:, 1], g[:, 1] * g[:, 1]])
        mp, gp = r @ pairs, (r * r) @ pairs                                   # (L, 3)
        m = np.stack([mp[:, [0, 1]], mp[:, [1, 2]]], axis=1)                  # (L, 2, 2)
        gram = np.stack([gp[:, [0, 1]], gp[:, [1, 2]]], axis=1)
        m += 1e-12 * (mp[:, 0] + mp[:, 2])[:, None, None] * np.eye(2)
        c = np.linalg.solve(m, (r @ (g * self.y_hat[:, None]))[:, :, None])[:, :, 0]
        resid = r * (self.y_hat[None, :] - c @ g.T)
        rss = np.sum(resid * resid, axis=1)
        trace = s.sum(axis=1) + np.trace(np.linalg.solve(m, gram), axis1=1, axis2=2)
        if cp_sigma is not None:
            return np.asarray(rss + 2.0 * cp_sigma ** 2 * trace, dtype=np.float64)
        return np.asarray(self.n * rss / np.maximum(self.n - gamma * trace, 1e-9) ** 2,
                          dtype=np.float64)


def _kink_level(smoother: _KinkedSmoother, gamma: float, cp_sigma: float | None,
                lattice_step: float) -> tuple[float, float]:
    """(criterion, log10 level) minimising GCV (``gamma``) or Mallows' Cp with noise
    ``cp_sigma`` [m] for this smoother: the best of a lattice of log levels, moved to
    the vertex of the parabola through it and its neighbours."""
    lattice = np.arange(-8.0, 10.01, lattice_step)
    scores = smoother.criterion(lattice, gamma, cp_sigma)
    i = min(max(int(np.argmin(scores)), 1), lattice.size - 2)
    a, b, c = scores[i - 1:i + 2]
    curve = a - 2.0 * b + c
    best = lattice[i] + (0.5 * (a - c) / curve * lattice_step if curve > 0.0 else 0.0)
    score = float(smoother.criterion(np.array([best]), gamma, cp_sigma)[0])
    if score > b:
        return float(b), float(lattice[i])
    return score, float(best)


def kinked_lobe_fit(values: NDArray[np.float64], missing: NDArray[np.bool_],
                    ends: tuple[int, int], *, gamma: float, cp_sigma: float | None,
                    scale: float = 1.0, fills: int = 3) -> KinkedLobe:
    """Smoothing of a coarse single-lobe table that lets h''' jump at the lobe's ends (a
    C2 lobe joins its base circle with h'' continuous and h''' stepping). A penalty on
    third differences charges h''' itself and rounds such a kink over the smoother's
    bandwidth; here the smooth part is penalised on fourth differences, which a cubic
    costs nothing, and an unpenalised cubic hinge at each end carries the step of h'''
    (a partial spline: Wahba, *Spline Models for Observational Data*, 1990, ch. 6). Each
    hinge is placed by the criterion, from the last base-circle row (``ends``) out to
    ``KINK_REACH`` rows away from the lobe (a C2 lobe rises as (alpha - t)^3 from its
    kink t: its first rows above the noise lie rows inside it). The level minimises
    GCV (``gamma``) or, when ``cp_sigma`` [m] is given (the coarse level rule found
    structure), Mallows' Cp with that noise; then times ``scale``. ``missing`` nodes
    are refilled with the fit ``fills`` times."""
    at = (float(ends[0]), float(ends[1]))
    offsets = np.arange(0.0, KINK_REACH + 1e-9, KINK_STEP)
    for side in (0, 1):
        trials = [(at[0] - d, at[1]) if side == 0 else (at[0], at[1] + d) for d in offsets]
        at = min(trials, key=lambda t: _kink_level(
            _KinkedSmoother(values, t), gamma, cp_sigma, 0.25)[0])
    smoother = _KinkedSmoother(values, at)
    lam = 10.0 ** _kink_level(smoother, gamma, cp_sigma, 0.1)[1] * scale
    fitted = smoother.values(lam)
    if np.any(missing):
        for _ in range(fills):
            fitted = _KinkedSmoother(np.where(missing, fitted, values), at).values(lam)
    return KinkedLobe(fitted, lam, smoother.fit(lam)[2], at)


@dataclass(frozen=True)
class LobeEndFit:
    """The lobe-end fit of one coarse single-lobe table (``kinked_lobe_fit``): the end
    rows, GCV's ``gamma``, the noise [m] for Cp (None: GCV) and the level ``base`` the
    caller's level is measured against (the sign rule raises it). The reconstruction
    uses it with the GCV criterion only; not yet for the risk criterion of the lobe law
    (card, dynamics), where the jump speed's uncertainty from noisy copies of a rounded
    5 deg table grew from 7 % to 15 % (docs/limits.md). It stands only where its h''
    has the lobe's sign pattern: raising its level for the pattern made a rounded 5 deg
    flat-tappet table 1.44 x scipy's h'' error (0.99 with the plain smoother)."""

    ends: tuple[int, int]
    gamma: float
    cp_sigma: float | None
    base: float

    def fit(self, values: NDArray[np.float64], missing: NDArray[np.bool_],
            lam_d: float) -> KinkedLobe:
        """The fit of ``values`` [m] (``missing`` nodes refilled) at its own level times
        ``lam_d`` / ``base``."""
        return kinked_lobe_fit(values, missing, self.ends, gamma=self.gamma,
                               cp_sigma=self.cp_sigma, scale=lam_d / self.base)

    def why(self, grid: NDArray[np.float64], fit: KinkedLobe) -> str:
        """What to add to a reconstruction's ``why`` (``grid`` [rad])."""
        step = float(grid[1] - grid[0])
        at = ', '.join(f'{math.degrees(float(grid[0]) + e * step):.4g}' for e in fit.ends)
        return (f"; h''' free to jump at the lobe's ends ({at} deg): fourth differences "
                f'penalised, lam_d = {fit.lam_d:.4g}, edf = {fit.edf:.1f}')
