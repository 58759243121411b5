"""The ends of a single lobe on a coarse table (steps above 2.25 deg): where a C2 lobe
joins its base circle, h'' is continuous and h''' steps. A smoother penalising third
differences charges h''' itself and rounds such a kink over its bandwidth (the C2 lobe at
2.5 deg, 0.1 um: a 1.6 mm/rad^2 spike of h'' at +-75 deg, 1.27 x scipy's h'' error, no
level better than 1.03). The lobe-end fit smooths the table as a partial spline instead:
a smooth part penalised on fourth differences plus a cubic hinge at each end carrying
the step of h''' (docs/reconstruction.md step 9). Lifts in m, positions in rows (nodes).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from cam_design.lift_table.coarse import (base_circle_sigma, coarse_level, lobe_end_knots,
                                          lobe_end_rows, penalty_eigen)
from cam_design.lift_table.rebound import Fairing

#: the lobe-end fit seeks each kink of h'' from the last base-circle row out to this many
#: rows away from the lobe, in steps of KINK_STEP rows (the C2 lobe at 2.5 deg, 0.5 um:
#: 0.66 x scipy's h'' error at the row, 0.38 with the search)
KINK_REACH = 3.0
KINK_STEP = 0.5


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
        self.e, v = penalty_eigen(n, 4)
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


@dataclass(frozen=True)
class CoarseLobe:
    """How a coarse table without junctions is smoothed: the level ``lam_d``, what to add
    to ``why``, the interpolant's ``knots`` (None: not-a-knot) and the lobe-end fit
    (None: the plain smoother)."""

    lam_d: float
    why: str
    knots: NDArray[np.float64] | None
    plan: LobeEndFit | None


def coarse_lobe(grid: NDArray[np.float64], values: NDArray[np.float64],
                fit: NDArray[np.float64], missing: NDArray[np.bool_], fair: Fairing,
                floor: float, lam_d: float, gamma: float, gcv: bool) -> CoarseLobe:
    """The coarse-table rules for uniform ``values`` [m] on ``grid`` [rad] without
    junctions (``fit`` [m]: their smoothing at ``lam_d``; ``fair``: the rows' fairing;
    ``floor`` [m]: the known noise): the level (``coarse.coarse_level``), the knots
    where the lobe leaves the base circle, and with the GCV criterion (``gcv``) the
    lobe-end fit. h''' may jump there (a C2 lobe's ends): a quintic interpolant without
    a knot, or a third-difference smoother, rounds it."""
    rows = fair.lift[~fair.outlier]
    level = coarse_level(values, fit, ~missing, rows, fair.quantum, floor, lam_d)
    base_sigma = base_circle_sigma(rows, fair.quantum)
    end_sigma = fair.sigma if base_sigma is None else base_sigma
    knots = lobe_end_knots(grid, values, end_sigma)
    ends = lobe_end_rows(values, end_sigma)
    plan = (LobeEndFit(ends, gamma, level.cp_sigma, level.lam_d)
            if knots is not None and ends is not None and gcv else None)
    return CoarseLobe(level.lam_d, level.why, knots, plan)
