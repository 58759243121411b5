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
* **A step or spikes?** A junction that passes that test is then compared with one
  row, or two rows one or two apart, within ``ROW_REACH`` rows of it free to move
  (``row_gain``): a step of h'' changes every row after it, a spike one row. It is
  refused when the rows fit better, and they are taken out as outliers.
* **A step or a one-row rise?** Above 4.5 deg (72 rows a turn or fewer) a change of h''
  within about one row (the acceleration peak of a polynomial lobe) passes that test as
  a step, and no criterion on the rows tells the two apart (docs/limits.md lists the
  rules tried). Every kept junction there is fitted as a linear change of h'' over
  ``HEDGE_WIDTH`` rows, placed by GCV: a hedge between a step and a one-row rise
  (docs/methods.md), with the level of the junction fit checked against the
  base-circle noise as below.
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
from typing import Callable

import numpy as np
from numpy.typing import NDArray
from scipy.fft import dct

from cam_design.lift_table.hinges import ramp_hinge
from cam_design.lift_table.junctions import (JunctionFit, choose_level, find_junctions,
                                             lattice_minimum, ramp_columns, ramp_fit, refit)
from cam_design.lift_table.noise import EXACT_NOISE_REL, MAD_TO_SIGMA
from cam_design.lift_table.rebound import VERY_COARSE_RAD

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
#: rows either side of a junction that may explain it instead as spikes, and the gain
#: in N ln(GCV) above which they do (``row_gain``)
ROW_REACH = 2
ROW_MARGIN = 0.0
#: the GCV fit's lobe residuals are structure when their lag-one correlation exceeds this
#: (spikes make it negative: -0.22 to -0.40 on the C2 lobe with 5 spikes; the misfit at
#: the steps of the dwell and circular-arc cams +0.03 to +0.11, of the C2 and ramped
#: lobes +0.2 to +0.56) and their RMS exceeds STRUCTURED_RMS times the base-circle noise
STRUCTURED_LAG_ONE = 0.0
STRUCTURED_RMS = 1.5
#: width [rows] of the linear change of h'' that stands for every junction kept on a
#: table coarser than VERY_COARSE_RAD. A fitted step where h'' in truth rises over one
#: row costs about J^2 / 12 of integrated squared h'' error per row (J the change of
#: h''), a ramp of width w where the truth is a step J^2 w / 12: the width balances the
#: two. On the accuracy families at 5 deg (3 seeds, 8 noise kinds; h'' RMS error /
#: scipy's GCV spline's) widths 0 / 0.5 / 0.65 / 0.75 / 0.8 / 0.85 / 1 row: circular
#: arc at most 0.62 / 0.77 / 0.83 / 0.88 / 0.91 / 0.94 / 1.01; narrow peak without
#: spikes at most 3.9 / 1.38 / 1.07 / 0.98 / 0.95 / 0.92 / 0.88, at 0.1 um 3.9 / 1.32 /
#: 0.99 / 0.82 / 0.75 / 0.69 / 0.60 (0.72 without junctions: from 0.85 on no case that
#: is within 0.9 without junctions is worse with them)
HEDGE_WIDTH = 0.85
#: places [rows] of a ramp's centre tried around the search's angle, and passes over
#: the junctions (each placed with the others held)
RAMP_OFFSETS = tuple(np.linspace(-0.5, 0.5, 11))
RAMP_PASSES = 2
#: the level of a ramp fit is searched this many decades either side of the search's
#: (GCV), and over this range of log10 levels (Mallows' Cp)
RAMP_LEVEL_REACH = 2.0
CP_LOG_LEVELS = (-7.0, 4.0)


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

    return 10.0 ** lattice_minimum(score, np.arange(-6.0, 12.01, 1.0), 22)[0]


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


def noise_sigma(rows: NDArray[np.float64], quantum: float, known: float) -> float | None:
    """The noise [m] a coarse table's fit is judged against: that of the base circle of
    ``rows`` [m] (rounded to ``quantum``), at least the ``known`` noise [m] and the
    exact-table bound (a computed table's base circle has no scatter); None without
    base-circle rows."""
    sigma = base_circle_sigma(rows, quantum)
    if sigma is None:
        return None
    return max(sigma, known, EXACT_NOISE_REL * float(np.ptp(rows)))


def structured(values: NDArray[np.float64], fit: NDArray[np.float64], sigma: float
               ) -> tuple[bool, float, float]:
    """(structure, lag-one correlation, RMS / ``sigma``) of the residuals ``values -
    fit`` [m] on the lobe: structure when they exceed STRUCTURED_RMS times the noise
    and are positively correlated row to row (a fit that cannot follow the lobe)."""
    rho, rms = structured_misfit(values, fit, sigma)
    return rho > STRUCTURED_LAG_ONE and rms > STRUCTURED_RMS, rho, rms


def coarse_level(values: NDArray[np.float64], fit: NDArray[np.float64],
                 live: NDArray[np.bool_], rows: NDArray[np.float64], quantum: float,
                 known: float, lam_d: float) -> CoarseLevel:
    """The level of a coarse table without junctions: ``lam_d`` (its smoothed ``fit``
    of the uniform ``values`` [m]; ``live`` the nodes with data) unless that fit leaves
    structured residuals on the lobe far above the noise of the base circle of ``rows``
    [m] (rounded to ``quantum``, at least the ``known`` noise [m]); then Mallows' Cp
    with that noise, if lower."""
    sigma = noise_sigma(rows, quantum, known)
    if sigma is None:
        return CoarseLevel(lam_d)
    misfit, rho, rms = structured(values[live], fit[live], sigma)
    if not misfit:
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


def _step_columns(n: int, taus: list[float], width: float) -> NDArray[np.float64]:
    """(n, K): a unit change of h'' at each node position of ``taus`` (node units),
    opening on its longer side: a step (``width`` 0) or a linear change over ``width``
    rows centred there."""
    t = np.asarray(taus, dtype=float)
    side = np.where(t <= 0.5 * (n - 1), 1.0, -1.0)
    return ramp_hinge(side * (np.arange(n, dtype=float)[:, None] - t), width)


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
    fixed = _step_columns(n, [t for i, t in enumerate(taus) if i != j], 0.0)
    sharp = _step_columns(n, [taus[j] + d for d in SHARP_OFFSETS], 0.0)
    soft = [_step_columns(n, [taus[j] + d for d in SOFT_OFFSETS], w) for w in SOFT_WIDTHS]
    scores = _gcv_scores(values, r, trace_s, fixed, np.column_stack([sharp] + soft), gamma)
    return n * math.log(float(np.min(scores[:len(SHARP_OFFSETS)]))
                        / float(np.min(scores[len(SHARP_OFFSETS):])))


def row_gain(values: NDArray[np.float64], missing: NDArray[np.bool_], taus: list[float],
             j: int, lam_d: float, gamma: float) -> tuple[float, tuple[int, ...]]:
    """N ln(GCV with junction ``j`` / GCV with, instead of it, one row or two rows (one
    or two apart) within ``ROW_REACH`` rows of it free to move: the best of them), the
    others kept as steps; with the rows of the best. > 0 when rows off the lobe (spikes)
    explain the rows better than a step of h'': a step changes h'' for every row after
    it, a spike moves one row. A free row is a column e_k, the same one degree of
    freedom as the step's."""
    n = values.size
    r, trace_s = _residual_matrix(n, float(lam_d))
    fixed = _step_columns(n, [t for i, t in enumerate(taus) if i != j], 0.0)
    sharp = _gcv_scores(values, r, trace_s, fixed,
                        _step_columns(n, [taus[j] + d for d in SHARP_OFFSETS], 0.0), gamma)
    centre = int(round(taus[j]))
    near = [k for k in range(centre - ROW_REACH, centre + ROW_REACH + 1)
            if 0 < k < n - 1 and not missing[k]]
    if not near:
        return -math.inf, ()
    eye = np.eye(n)
    singles = _gcv_scores(values, r, trace_s, fixed, eye[:, near], gamma)
    best: tuple[float, tuple[int, ...]] = (float(np.min(singles)),
                                           (near[int(np.argmin(singles))],))
    for k in near:
        partners = [m for m in near if 0 < m - k <= 2]
        if partners:
            pair = _gcv_scores(values, r, trace_s, np.column_stack([fixed, eye[:, k]]),
                               eye[:, partners], gamma)
            best = min(best, (float(np.min(pair)), (k, partners[int(np.argmin(pair))])))
    return n * math.log(float(np.min(sharp)) / best[0]), best[1]


@dataclass(frozen=True)
class CoarseJunctions:
    """The junction fit kept on a coarse table (None: none kept), the angles [rad]
    refused as stand-ins for a fast smooth change of h'', the level ``lam_d`` and what
    to add to the fit's ``why``; ``rows``: the rows (nodes) that explain a refused
    junction better as spikes."""

    found: JunctionFit | None
    refused: tuple[float, ...]
    lam_d: float
    why: str = ''
    rows: tuple[int, ...] = ()


def coarse_junctions(grid: NDArray[np.float64], values: NDArray[np.float64],
                     missing: NDArray[np.bool_], lam0: float, *, gamma: float,
                     sigma_floor: float) -> CoarseJunctions:
    """The junction search of ``find_junctions`` on a coarse uniform table, each
    junction then tested against a soft change of h'' (``soft_gain``); the kept ones
    refitted at their GCV level, on a table coarser than VERY_COARSE_RAD as short ramps
    of h'' (``hedged_junctions``). Without the search's look-ahead: a set taken only
    together is justified by the level it lets the rest have, which a junction-by-
    junction test that drops some of them would take away (a circular-arc table at
    2.5 deg, 0.5 um: a held pair taken with a third at 289 times the level, then the
    soft test dropped a true edge: h'' 2.2 x worse).

    No search on a table coarser than VERY_COARSE_RAD whose base circle gives no
    noise (``base_circle_sigma`` None: fewer than MIN_BASE_ROWS base-circle rows, or
    no scatter there and not rounded; the known noise ``sigma_floor`` [m] stands for
    the rounding). Where the base circle is exact the rows are computed, and a few rows
    off them (a spike) only make the table look noisy, so that the search takes the
    lobe's own fast change of h'' for a junction and the fit bends to the spike row (a
    polynomial lobe's exact 5 deg rows with one row 50 um off: a junction kept beside
    it in three of six placements). The hedge's level check needs that noise too."""
    if (float(grid[1] - grid[0]) > VERY_COARSE_RAD
            and base_circle_sigma(values[~missing], math.sqrt(12.0) * sigma_floor) is None):
        return CoarseJunctions(None, (), lam0)
    tested = _tested_junctions(grid, values, missing, lam0, gamma=gamma,
                               sigma_floor=sigma_floor)
    if tested.found is None or float(grid[1] - grid[0]) <= VERY_COARSE_RAD:
        return tested
    fit, why = hedged_junctions(grid, values, missing, tested.found, gamma=gamma,
                                sigma_floor=sigma_floor)
    return CoarseJunctions(fit, tested.refused, fit.lam_d, why, tested.rows)


def _tested_junctions(grid: NDArray[np.float64], values: NDArray[np.float64],
                      missing: NDArray[np.bool_], lam0: float, *, gamma: float,
                      sigma_floor: float) -> CoarseJunctions:
    """The junctions of the search that pass the soft-change test, as steps."""
    found = find_junctions(grid, values, lam0, gamma=gamma, sigma_floor=sigma_floor,
                           lookahead=False)
    if found is None:
        return CoarseJunctions(None, (), lam0)
    step = float(grid[1] - grid[0])
    taus = [(t - float(grid[0])) / step for t in found.angles]
    soft = [soft_gain(values, taus, j, found.lam_d, gamma) > SOFT_MARGIN
            for j in range(len(taus))]
    # then one row or a pair near a junction (spikes) against the junction itself
    spikes: set[int] = set()
    for j in range(len(taus)):
        if not soft[j]:
            gain, rows = row_gain(values, missing, taus, j, found.lam_d, gamma)
            if gain > ROW_MARGIN:
                soft[j] = True
                spikes.update(rows)
    refused = tuple(t for t, s in zip(found.angles, soft) if s)
    if not refused:
        return CoarseJunctions(found, (), found.lam_d)
    kept = [k for k, s in enumerate(soft) if not s]
    if not kept:
        return CoarseJunctions(None, refused, lam0, rows=tuple(sorted(spikes)))
    # chosen again without the refused ones, but never smoother than with them (GCV
    # without a stand-in may read the lobe's fast change as noise, as without any),
    # nor smoother than the plain fit the search started from
    lam = min(choose_level(values, [taus[k] for k in kept], gamma, found.lam_d),
              found.lam_d, lam0)
    pruned = replace(found, angles=tuple(found.angles[k] for k in kept),
                     scores=tuple(found.scores[k] for k in kept))
    return CoarseJunctions(refit(grid, values, missing, pruned, lam), refused, lam,
                           rows=tuple(sorted(spikes)))


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
def penalty_eigen(n: int, order: int = 3
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Eigenvalues mu (n,) and orthonormal eigenvectors V (n, n) of D'D, D the
    differences of ``order`` (free ends): the smoother (I + lam_d D'D)^-1 is
    V diag(1 / (1 + lam_d mu)) V' at every level (read-only, cached)."""
    d3 = np.diff(np.eye(n), order, axis=0)
    mu, vec = np.linalg.eigh(d3.T @ d3)
    mu = np.maximum(mu, 0.0)
    mu.setflags(write=False)
    vec.setflags(write=False)
    return mu, vec


def ramp_scores(values: NDArray[np.float64], taus: list[float], widths: list[float]
                ) -> Callable[[float], tuple[float, float]]:
    """(RSS [m^2], edf) of the partial spline with the hinges of ``ramp_columns`` at
    node positions ``taus`` (``widths`` [rows]) as a function of log10 of the discrete
    level: the fit of ``ramp_fit`` (its edf with the smoother's exact trace) in the
    eigenbasis of the penalty, O(n J^2) per level."""
    mu, vec = penalty_eigen(values.size)
    gt = vec.T @ ramp_columns(values.size, taus, widths)
    yt = vec.T @ values

    def at(log_lam: float) -> tuple[float, float]:
        lam = 10.0 ** log_lam
        r = lam * mu / (1.0 + lam * mu)              # eigenvalues of R = I - S
        rg = r[:, None] * gt
        m = gt.T @ rg
        m += 1e-13 * np.trace(m) * np.eye(m.shape[0])
        sol = np.linalg.solve(m, np.column_stack([rg.T @ yt, rg.T @ rg]))
        e = r * (yt - gt @ sol[:, 0])
        return float(e @ e), float(np.sum(1.0 - r)) + float(np.trace(sol[:, 1:]))

    return at


def _best_log_level(score: Callable[[float], float], lo: float, hi: float) -> float:
    """log10 of the level minimising ``score(log10 level)`` on [lo, hi]: the best of a
    half-decade lattice, then golden section between its neighbours."""
    return lattice_minimum(score, np.arange(lo, hi + 1e-9, 0.5), 16)[0]


def _place_ramps(values: NDArray[np.float64], taus: list[float], widths: list[float],
                 lam_d: float, gamma: float) -> list[float]:
    """Centres [nodes] of the ramps of h'' (``widths`` [rows]) near ``taus``, each by
    GCV at level ``lam_d`` among ``RAMP_OFFSETS`` with the others held (the step of
    h''' of each junction's hinge pair held at the search's angle)."""
    n = values.size
    r, trace_s = _residual_matrix(n, float(lam_d))
    placed = list(taus)
    built: dict[tuple[float, float], NDArray[np.float64]] = {}

    def pair(tau: float, width: float) -> NDArray[np.float64]:
        """The hinge pair of one junction (each built once)."""
        key = (tau, width)
        if key not in built:
            built[key] = ramp_columns(n, [tau], [width])
        return built[key]

    for _ in range(RAMP_PASSES):
        for j, tau in enumerate(taus):
            fixed = np.column_stack([pair(placed[k], widths[k]) for k in range(len(taus))
                                     if k != j] + [pair(tau, 0.0)[:, 1:]])
            trials = [tau + d for d in RAMP_OFFSETS]
            scores = _gcv_scores(values, r, trace_s, fixed,
                                 _step_columns(n, trials, widths[j]), gamma)
            placed[j] = trials[int(np.argmin(scores))]
    return placed


def hedged_junctions(grid: NDArray[np.float64], values: NDArray[np.float64],
                     missing: NDArray[np.bool_], found: JunctionFit, *, gamma: float,
                     sigma_floor: float) -> tuple[JunctionFit, str]:
    """``found``'s junctions on a table coarser than VERY_COARSE_RAD fitted as linear
    changes of h'' over ``HEDGE_WIDTH`` rows (``ramp_hinge``), each centred by GCV
    within half a row of the search's angle; the level by GCV with them, or by
    Mallows' Cp with the base-circle noise (at least ``sigma_floor`` [m]) when the GCV
    fit leaves structured residuals on the lobe and Cp's level is lower (the rule of
    ``coarse_level``). With what to add to the fit's ``why``."""
    n = values.size
    step = float(grid[1] - grid[0])
    widths = [HEDGE_WIDTH] * len(found.angles)
    taus = _place_ramps(values, [(t - float(grid[0])) / step for t in found.angles],
                        widths, found.lam_d, gamma)

    scores = ramp_scores(values, taus, widths)

    def gcv(log_lam: float) -> float:
        rss, edf = scores(log_lam)
        return n * rss / max(n - gamma * edf, 1e-9) ** 2

    start = math.log10(found.lam_d)
    log_lam = _best_log_level(gcv, start - RAMP_LEVEL_REACH, start + RAMP_LEVEL_REACH)
    live = ~missing
    # the floor is the known noise or the rounding's q / sqrt(12): it stands for both
    # where the base circle is written as one value
    sigma = noise_sigma(values[live], math.sqrt(12.0) * sigma_floor, sigma_floor)
    fit = ramp_fit(values, taus, widths, 10.0 ** log_lam)
    why = (f'; on a table this coarse a step of h\'\' cannot be told from a rise within '
           f'one row: each junction fitted as a linear change of h\'\' over '
           f'{HEDGE_WIDTH:g} row')
    if sigma is not None and structured(values[live], (values - fit.resid)[live], sigma)[0]:
        noise = sigma

        def cp(log_lam: float) -> float:
            rss, edf = scores(log_lam)
            return rss + 2.0 * noise ** 2 * edf

        log_cp = _best_log_level(cp, *CP_LOG_LEVELS)
        if log_cp < log_lam:
            log_lam = log_cp
            why += (f'; that fit left residuals correlated row to row, above the '
                    f'base-circle noise ({noise:.3g} m): level by Mallows\' Cp with that '
                    f'noise')
    ramps = replace(found, angles=tuple(float(grid[0]) + t * step for t in taus),
                    widths=tuple(widths), fitted_on=None)
    return refit(grid, values, missing, ramps, 10.0 ** log_lam), why
