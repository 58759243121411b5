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
AIC) and (b) a free mix of the step and that ramp (both columns) puts a part of the
change within ``SHARE`` on the ramp (``WidthScores.share``). Beside a true step the
smooth part's local bias makes GCV prefer narrow ramps for their bump alone
(measured on the circular-arc and constant-acceleration cams: gains up to 30 for
ramps of 1-2 rows, whose free mix put 1.5-4.4 times the whole change on the ramp):
hence (b), and no ramp narrower than 3 rows (at 1-2 rows a ramp differs from the step
at one or two rows only, by c w^2 / 24).

Lifts in m, positions and widths in nodes (grid rows).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

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
#: a ramp replaces a step only when it lowers N ln(GCV) by more than this. On the
#: accuracy benchmark's 576 tables at 0.1-2.5 deg, pooled h'' error of the constant-
#: acceleration / circular-arc cams: margin 0 +1.45 / +1.06 %, 1 +0.85 / +0.75 %,
#: 2 +0.79 / +0.48 % (every width of 1-8 rows by GCV alone: +8 / +14 %)
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
    side = side_of(tau, n)
    out = np.zeros((hi - lo, len(widths)))
    for i, w in enumerate(widths):
        # the rows within w/2 + 1 of tau, the others 0 or the constant
        a = min(max(math.ceil(tau - 0.5 * w - 1.0), lo), hi)
        b = max(min(math.floor(tau + 0.5 * w + 1.0) + 1, hi), lo)
        if b > a:
            u = side * (np.arange(a, b, dtype=float) - tau)
            out[a - lo:b - lo, i] = ramp_hinge(u, w) - ramp_hinge(u, 0.0)
        past = slice(b - lo, None) if side > 0 else slice(0, a - lo)
        out[past, i] = w ** 2 / 24.0
    return out


@dataclass(frozen=True)
class _Ramps:
    """Junction ``k``'s ramps less its step, d (one column per ramp width): on rows
    [a, b) about the junction ``near`` ((b - a, R)), beyond them on the side the hinge
    opens to (``side``) the constant ``tail`` (R,), 0 on the other; R d on the window
    [lo, hi) (``rd``, 0 elsewhere) and its running sums down the window (``sums``,
    (hi - lo + 1, R), from 0)."""

    a: int
    b: int
    near: NDArray[np.float64]
    tail: NDArray[np.float64]
    side: int
    lo: int
    hi: int
    rd: NDArray[np.float64]
    sums: NDArray[np.float64]

    def past(self, lo: int, hi: int) -> tuple[int, int]:
        """Rows of [lo, hi) where d is its constant ``tail`` (an empty pair if none)."""
        return (max(self.b, lo), hi) if self.side > 0 else (lo, min(self.a, hi))

    def dot(self, other: _Ramps) -> NDArray[np.float64]:
        """d' R d_other (R, R): over ``other``'s window, from the rows about this
        junction and the running sums of R d_other beyond them."""
        a, b = max(self.a, other.lo), min(self.b, other.hi)
        out = (self.near[a - self.a:b - self.a].T @ other.rd[a - other.lo:b - other.lo]
               if b > a else np.zeros((self.near.shape[1],) * 2))
        lo, hi = self.past(other.lo, other.hi)
        if hi > lo:
            out += np.outer(self.tail, other.sums[hi - other.lo] - other.sums[lo - other.lo])
        return out


class WidthScores:
    """GCV scores of the partial spline of uniform ``values`` [m] at level ``lam_d``
    with junctions at node positions ``taus``, each a change of h'' over one of
    ``widths`` rows (beside the tapered step of h''' of its hinge pair); ``system``:
    the level system of these values at ``lam_d`` where one is at hand (the search's).

    A ramp differs from the step by d = ramp - step (``ramp_less_step``): 0 before the
    ramp, a constant after it. Its third differences, and so P d, lie on the ramp's own
    rows, and R d = (I + lam_d P)^-1 lam_d P d (the constant costs the smoother nothing)
    decays within ``window_margin`` of them. So R ramp = R step + R d, with R step the
    search's own windowed column (``LevelSystem.columns``) and R d solved on a window
    about the ramp; the inner products of the ramps' columns are the steps' plus those
    of d (a few rows and a constant) and R d (its window), so nothing of the table's
    length is formed per ramp, and each choice costs a dense system of size 2J."""

    def __init__(self, values: NDArray[np.float64], taus: list[float],
                 widths: tuple[float, ...], lam_d: float, gamma: float,
                 system: LevelSystem | None = None) -> None:
        n = values.size
        self.n, self.gamma, self.nw, self.j = n, gamma, len(widths), len(taus)
        self.ramps = widths[1:]
        if system is None or system.lam_d != lam_d or system.values is not values:
            system = LevelSystem(values, lam_d)
        self.values, self.ry = values, system.ry
        self.ryry, self.trace = system.ryry, system.trace
        self.g, self.rg = system.columns(taus)
        half = 0.5 * max(self.ramps) + 1.0
        reach = window_margin(lam_d) + half + 8.0
        self.parts = []
        for tau in taus:
            # a window reaching an end of the table takes that end
            lo, hi = max(int(tau - reach), 0), min(int(tau + reach) + 2, n)
            a, b = max(math.ceil(tau - half), 0), min(math.floor(tau + half) + 1, n)
            d = ramp_less_step(n, tau, self.ramps, lo, hi)
            rd = residual_operator(d, lam_d)
            sums = np.zeros((hi - lo + 1, len(self.ramps)))
            np.cumsum(rd, axis=0, out=sums[1:])
            side = side_of(tau, n)
            self.parts.append(_Ramps(a, b, d[a - lo:b - lo], np.asarray(self.ramps) ** 2 / 24.0,
                                     side, lo, hi, rd, sums))
        self._products()

    def _block(self, k: int) -> slice:
        """Columns of junction ``k``'s ramps."""
        r = len(self.ramps)
        return slice(2 * self.j + k * r, 2 * self.j + (k + 1) * r)

    def _products(self) -> None:
        """m = A'R A, v = (R A)'(R A), (R A)'y and (R A)'R y of all columns A: the hinge
        pairs G, then each junction's ramps (its step's column plus d)."""
        g, rg, two = self.g, self.rg, 2 * self.j
        size = two + self.j * len(self.ramps)
        m, v = np.empty((size, size)), np.empty((size, size))
        gy, gry = np.empty(size), np.empty(size)
        m[:two, :two], v[:two, :two] = g.T @ rg, rg.T @ rg
        gy[:two], gry[:two] = rg.T @ self.values, rg.T @ self.ry
        sums = np.zeros((self.n + 1, two))          # running sums of R G down the table
        np.cumsum(rg, axis=0, out=sums[1:])
        d_rg, g_rd, rg_rd = [], [], []
        for k, p in enumerate(self.parts):
            rows, c = slice(p.lo, p.hi), self._block(k)
            lo, hi = p.past(0, self.n)
            d_rg.append(p.near.T @ rg[p.a:p.b] + np.outer(p.tail, sums[hi] - sums[lo]))
            g_rd.append(g[rows].T @ p.rd)
            rg_rd.append(rg[rows].T @ p.rd)
            m[:two, c] = m[:two, 2 * k, None] + g_rd[k]
            m[c, :two] = m[None, 2 * k, :two] + d_rg[k]
            v[:two, c] = v[:two, 2 * k, None] + rg_rd[k]
            v[c, :two] = v[:two, c].T
            gy[c] = gy[2 * k] + p.rd.T @ self.values[rows]
            gry[c] = gry[2 * k] + p.rd.T @ self.ry[rows]
        for k, p in enumerate(self.parts):
            for i, q in enumerate(self.parts):
                # (g_k + d_k)'(R g_i + R d_i) and (R g_k + R d_k)'(R g_i + R d_i)
                m[self._block(k), self._block(i)] = (
                    m[2 * k, 2 * i] + g_rd[i][None, 2 * k, :] + d_rg[k][:, 2 * i, None]
                    + p.dot(q))
                lo, hi = max(p.lo, q.lo), min(p.hi, q.hi)
                both = (p.rd[lo - p.lo:hi - p.lo].T @ q.rd[lo - q.lo:hi - q.lo] if hi > lo
                        else 0.0)
                v[self._block(k), self._block(i)] = (
                    v[2 * k, 2 * i] + rg_rd[i][None, 2 * k, :] + rg_rd[k][2 * i, :, None]
                    + both)
        self.m, self.v, self.gy, self.gry = m, v, gy, gry

    def column(self, k: int, w: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(a, R a), (n,) each, of junction ``k``'s change of h'' over ``widths[w]``."""
        a, ra = self.g[:, 2 * k].copy(), self.rg[:, 2 * k].copy()
        if w > 0:
            p = self.parts[k]
            a[p.a:p.b] += p.near[:, w - 1]
            lo, hi = p.past(0, self.n)
            a[lo:hi] += p.tail[w - 1]
            ra[p.lo:p.hi] += p.rd[:, w - 1]
        return a, ra

    def _columns(self, choice: list[int]) -> NDArray[np.intp]:
        """Columns of the hinge pairs with junction k's change of h'' over
        ``widths[choice[k]]``."""
        return np.asarray([i for k, w in enumerate(choice)
                           for i in (self._change(k, w), 2 * k + 1)])

    def _change(self, k: int, w: int) -> int:
        """Column of junction ``k``'s change of h'' over ``widths[w]`` (its step: 2k)."""
        return 2 * k if w == 0 else 2 * self.j + k * (self.nw - 1) + w - 1

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
        idx = np.append(self._columns(choice[:k] + [0] + choice[k + 1:]), self._change(k, w))
        coef = self._solved(idx)[0]
        total = coef[2 * k] + coef[-1]
        return float(coef[-1] / total) if total != 0.0 else math.inf

    def fit(self, choice: list[int]) -> PartialFit:
        """The partial spline with junction k's change of h'' over
        ``widths[choice[k]]``."""
        coef, rss, edf = self._solved(self._columns(choice))
        resid, z = self.ry.copy(), self.values.copy()
        for k, w in enumerate(choice):
            a, ra = self.column(k, w)
            resid -= coef[2 * k] * ra + coef[2 * k + 1] * self.rg[:, 2 * k + 1]
            z -= coef[2 * k] * a + coef[2 * k + 1] * self.g[:, 2 * k + 1]
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
    fitted with those widths (``found`` itself, less its level system, when every
    junction stays a step)."""
    step = float(grid[1] - grid[0])
    taus = [(t - float(grid[0])) / step for t in found.angles]
    scores = WidthScores(values, taus, WIDTHS, found.lam_d, gamma, found.system)
    choice = choose_widths(scores)
    if not any(choice):
        return replace(found, system=None)      # the search's caches not kept further
    return fit_result(grid, taus, found.lam_d, scores.fit(choice), list(found.scores),
                      values.copy(), tuple(WIDTHS[w] for w in choice))
