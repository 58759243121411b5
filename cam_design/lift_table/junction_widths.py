"""A step or a ramp of h'' at each junction the search keeps.

The junction search (``junctions.find_junctions``) fits every junction as a step of
h''. A lobe whose h'' rises fast but smoothly (the flat-tappet intake preset: h''
0 -> 57 mm/rad^2 between -65 and -58 deg) lowers the search's score there as much as
a step does, and the step it keeps at 1 deg is wrong by about half the rise over two
degrees either side. Here each kept junction may instead be a linear change of h''
over ``w`` rows centred on its angle (``hinges.ramp_hinge``; the step is w -> 0), w
among ``WIDTHS``, chosen by the criterion the search already uses (GCV of the whole
partial spline at the search's level, the other junctions held at their present
widths, at most ``PASSES`` passes). A ramp is taken where (a) it lowers N ln(GCV) by
more than ``RAMP_MARGIN`` against the step (the charge for one chosen parameter, as in
AIC) and (b) a free mix of the step and that ramp (both columns, the mix's share of
the change on the ramp, ``WidthScores.share``) puts between ``SHARE`` of the change on
the ramp. Beside a true step the smooth part's local bias makes GCV prefer narrow
ramps for their bump alone (measured on the circular-arc and constant-acceleration
cams: gains up to 30 for ramps of 1-2 rows, whose free mix put 1.5-4.4 times the
whole change on the ramp): hence (b), and no ramp narrower than 3 rows (at 1-2 rows a
ramp differs from the step at one or two rows only, by c w^2 / 24).

Lifts in m, positions and widths in nodes (grid rows).
"""
from __future__ import annotations

import math
import numpy as np
from numpy.typing import NDArray

from cam_design.lift_table.hinges import ramp_hinge, side_of
from cam_design.lift_table.junctions import JunctionFit, fit_result
from cam_design.lift_table.partial_spline import (LevelSystem, PartialFit, residual_operator,
                                                  window_margin)

#: widths [rows] a junction's change of h'' may take (0: a step; see the module's
#: docstring for why none of 1-2 rows)
WIDTHS = (0.0, 3.0, 4.0, 6.0, 8.0)
#: coordinate passes over the junctions (each chosen with the others held)
PASSES = 2
#: a ramp replaces a step only when it lowers N ln(GCV) by more than this (on the
#: accuracy benchmark's 576 tables at 0.1-1 deg: 0 let ramps in beside true steps,
#: circular-arc h'' error +14 %; 2 kept every family within +1 %)
RAMP_MARGIN = 2.0
#: ... and only when a free mix of the step and that ramp puts this part of the change
#: on the ramp (at the flat-tappet rise 0.55-1.3 at the chosen width; beside true steps
#: 1.5-4.4 at 1-2 rows)
SHARE = (0.5, 1.25)


def ramp_less_step(n: int, tau: float, widths: tuple[float, ...], lo: int, hi: int
                   ) -> NDArray[np.float64]:
    """(hi - lo, len(widths)) on rows [lo, hi): each ramp of h'' over ``widths`` nodes at
    node ``tau`` less the step there (``ramp_hinge``, opening on the longer side of n
    rows): 0 before the ramp, the constant w^2 / 24 past it."""
    u = side_of(tau, n) * (np.arange(lo, hi, dtype=float) - tau)
    out = np.zeros((hi - lo, len(widths)))
    for i, w in enumerate(widths):
        near = np.abs(u) < 0.5 * w + 1.0
        out[near, i] = ramp_hinge(u[near], w) - ramp_hinge(u[near], 0.0)
        out[(u > 0.0) & ~near, i] = w ** 2 / 24.0
    return out


class WidthScores:
    """GCV scores of the partial spline of uniform ``values`` [m] at level ``lam_d``
    with junctions at node positions ``taus``, each a change of h'' over one of
    ``widths`` rows (beside the tapered step of h''' of its hinge pair).

    A ramp differs from the step by d = ramp - step (``ramp_less_step``): the third
    differences of d, and so P d, lie on the ramp's own rows, and R d = (I + lam_d
    P)^-1 lam_d P d (the constant beyond costs the smoother nothing). So R ramp =
    R step + R d, R step the search's own windowed column (``LevelSystem.columns``);
    every column is solved once, and each choice costs a dense system of size 2J."""

    def __init__(self, values: NDArray[np.float64], taus: list[float],
                 widths: tuple[float, ...], lam_d: float, gamma: float) -> None:
        n = values.size
        self.n, self.gamma, self.nw, self.j = n, gamma, len(widths), len(taus)
        system = LevelSystem(values, lam_d)
        g, rg = system.columns(taus)
        ramps = widths[1:]
        # the columns: the hinge pairs, then junction k's ramps (its step plus d)
        a = np.empty((n, 2 * self.j + self.j * len(ramps)))
        ra = np.empty_like(a)
        a[:, :2 * self.j], ra[:, :2 * self.j] = g, rg
        a[:, 2 * self.j:] = np.repeat(g[:, 0::2], len(ramps), axis=1)
        ra[:, 2 * self.j:] = np.repeat(rg[:, 0::2], len(ramps), axis=1)
        reach = window_margin(lam_d) + 0.5 * max(ramps) + 8.0
        for k, tau in enumerate(taus):
            cols = slice(2 * self.j + k * len(ramps), 2 * self.j + (k + 1) * len(ramps))
            # d on a window about the ramp (R d decays within window_margin of P d's
            # rows; a window reaching an end of the table takes that end)
            lo, hi = max(int(tau - reach), 0), min(int(tau + reach) + 2, n)
            d = ramp_less_step(n, tau, ramps, lo, hi)
            a[lo:hi, cols] += d
            if side_of(tau, n) > 0:       # past the window: d's constant w^2 / 24
                a[hi:, cols] += d[-1]
            else:
                a[:lo, cols] += d[0]
            ra[lo:hi, cols] += residual_operator(d, lam_d)
        self.values, self.a, self.ra, self.ry = values, a, ra, system.ry
        self.m = a.T @ ra
        self.v = ra.T @ ra
        self.gy = ra.T @ values           # (R G)'y: keeps its digits (partial_spline)
        self.gry = ra.T @ system.ry
        self.ryry, self.trace = system.ryry, system.trace

    def _columns(self, choice: list[int]) -> NDArray[np.intp]:
        """Columns of the hinge pairs with junction k's change of h'' over
        ``widths[choice[k]]``."""
        return np.asarray([i for k, w in enumerate(choice)
                           for i in (2 * k if w == 0 else
                                     2 * self.j + k * (self.nw - 1) + w - 1, 2 * k + 1)])

    def _solved(self, idx: NDArray[np.intp]) -> tuple[NDArray[np.float64], ...]:
        """(coef, rss [m^2], edf) of the column sets ``idx`` (..., 2J), batched."""
        m = self.m[idx[..., :, None], idx[..., None, :]]
        m = m + (1e-13 * np.trace(m, axis1=-2, axis2=-1))[..., None, None] * np.eye(
            idx.shape[-1])
        v = self.v[idx[..., :, None], idx[..., None, :]]
        sol = np.linalg.solve(m, np.concatenate([self.gy[idx][..., None], v], axis=-1))
        coef = sol[..., 0]
        rss = (self.ryry - 2.0 * np.einsum('...i,...i', coef, self.gry[idx])
               + np.einsum('...i,...ij,...j', coef, v, coef))
        edf = self.trace + np.trace(sol[..., 1:], axis1=-2, axis2=-1)
        return coef, np.maximum(rss, 0.0), edf

    def gcv_of_widths(self, choice: list[int], k: int) -> NDArray[np.float64]:
        """GCV scores (one per width) with junction ``k`` over each of ``widths``, the
        others over ``widths[choice[i]]``."""
        idx = np.stack([self._columns(choice[:k] + [w] + choice[k + 1:])
                        for w in range(self.nw)])
        _, rss, edf = self._solved(idx)
        return np.asarray(self.n * rss / np.maximum(self.n - self.gamma * edf, 1e-9) ** 2,
                          dtype=np.float64)

    def share(self, choice: list[int], k: int, w: int) -> float:
        """The part of junction ``k``'s change of h'' that a free mix of its step and
        its ramp over ``widths[w]`` puts on the ramp (the others as ``choice``): near 1
        where the rows rise over the ramp, far from [0, 1] where the ramp's small bump
        only stands in for the smooth part's bias beside a step."""
        idx = self._columns(choice[:k] + [0] + choice[k + 1:])
        idx = np.append(idx, self._columns([0] * k + [w])[-2])
        coef = self._solved(idx)[0]
        total = coef[2 * k] + coef[-1]
        return float(coef[-1] / total) if total != 0.0 else math.inf

    def fit(self, choice: list[int]) -> PartialFit:
        """The partial spline with junction k's change of h'' over
        ``widths[choice[k]]``."""
        idx = self._columns(choice)
        coef, rss, edf = self._solved(idx)
        resid = self.ry - self.ra[:, idx] @ coef
        z = self.values - self.a[:, idx] @ coef
        return PartialFit(z - resid, coef, float(rss), float(edf), float(z @ resid), resid)


def choose_widths(scores: WidthScores) -> list[int]:
    """Index into ``scores``' widths of each junction's change of h'' (0: a step), by
    GCV: coordinate passes (at most ``PASSES``), each junction with the others held;
    a ramp kept only where it lowers N ln(GCV) by more than ``RAMP_MARGIN`` against the
    step."""
    choice = [0] * scores.j
    for _ in range(PASSES):
        before = list(choice)
        for k in range(scores.j):
            trial = scores.gcv_of_widths(choice, k)
            w = 1 + int(np.argmin(trial[1:]))
            choice[k] = w if (scores.n * math.log(trial[0] / trial[w]) > RAMP_MARGIN
                              and SHARE[0] <= scores.share(choice, k, w) <= SHARE[1]) else 0
        if choice == before:
            break
    return choice


def with_widths(grid: NDArray[np.float64], values: NDArray[np.float64],
                found: JunctionFit, gamma: float) -> JunctionFit:
    """``found`` with each junction's width chosen by ``choose_widths`` at its level,
    and its fit (``found`` itself when every junction stays a step)."""
    step = float(grid[1] - grid[0])
    taus = [(t - float(grid[0])) / step for t in found.angles]
    scores = WidthScores(values, taus, WIDTHS, found.lam_d, gamma)
    choice = choose_widths(scores)
    if not any(choice):
        return found
    return fit_result(grid, taus, found.lam_d, scores.fit(choice), list(found.scores),
                      values.copy(), tuple(WIDTHS[w] for w in choice))
