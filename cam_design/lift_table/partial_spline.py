"""The partial spline of a uniform lift table at one smoothing level: the smooth part
plus hinges that let h'' (and h''') step at given junctions.

    y = f + sum_j [c_j g2(x - t_j) + d_j g3(x - t_j)] + noise,

f the discrete quintic smoother (penalty lam_d |D3 f|^2, free ends: a quadratic costs
it nothing), g2 = u_+^2 / 2 a unit step of h'' and g3 a unit step of h''' tapered to
zero (Wahba, Spline Models for Observational Data, 1990, ch. 6). For a fixed level the
hinge coefficients solve (G'R G) c = (R G)'y with R = I - S, S = (I + lam_d P)^-1 the
smoother, P = D3'D3. Lengths in m, positions in nodes (grid rows).

Cost. One ``LevelSystem`` per level keeps the smoother's banded Cholesky factor (lower
band storage), R y, and per junction its column R g, solved on a window of
``WINDOW_BANDWIDTHS`` smoother bandwidths (R g decays geometrically away from the
hinge: the Toeplitz interior block of I + lam_d P, or a block reaching one end of the
table, whose factor is the leading part of the whole one), with its inner products
with y, R y and the other junctions' columns. A set of junctions is then scored
(residual sum of squares, hat-matrix trace, penalised residual) from a dense system of
size 2J without forming a vector of the table's length; the fit's vectors are formed
only when asked for. ``junctions`` searches where the hinges go.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import TypeVar

import numpy as np
from numpy.typing import NDArray

from cam_design.lift_table.hinges import (hinge_block, hinge_coefficients, horner, side_of,
                                          taper_nodes)
from cam_design.lift_table.smoother_band import (apply_smoother, banded_solve, deflate,
                                                 interior_factor, penalty_of,
                                                 trace_smoother, whole_factor)

#: fits a level's system remembers (by junction set): with their vectors, and scores
FITS_KEPT = 4
SCORES_KEPT = 64
STACKS_KEPT = 8
#: Chebyshev nodes in a junction's place between two rows at which a level's interior
#: hinge Grams G'R G and G'R^2 G are solved once (``interior_grams``: the scan and
#: ``moved_objective``): smooth functions of that place (they move by 1e-4 relative
#: over a row), and 7 nodes reach the rounding of the solves themselves (1e-9 .. 7e-8
#: relative at levels 1e2.5 .. 1e8)
GRAM_NODES = 7
#: a hinge's column is solved this many smoother bandwidths either side (window_margin)
WINDOW_BANDWIDTHS = 48.0
#: ... and at most this many rows (the interior block's length does not depend on N; a
#: level that asks for more, above 1e15, is past what the factorisation can hold anyway)
MAX_MARGIN = 20_000


@lru_cache(maxsize=512)
def _hinge_penalty(n: int, tau: float, a: int, b: int) -> NDArray[np.float64]:
    """P g on rows [a, b) of the hinges g of the junction at node ``tau`` on n nodes
    (read-only, kept: asked for at every level, which only scales it)."""
    out = penalty_of(_hinge_pair(n, tau)[a:b])
    out.setflags(write=False)
    return out


def residual_operator(g: NDArray[np.float64], lam_d: float) -> NDArray[np.float64]:
    """R g = (I + lam_d P)^-1 lam_d P g, P = D3'D3: the same as g - S g, but formed from
    third differences, so that the long quadratic tail of a hinge (S reproduces it)
    adds no rounding."""
    return deflate(apply_smoother(lam_d * penalty_of(g), lam_d))


def window_margin(lam_d: float) -> int:
    """Nodes [>= 10] a hinge's column R g is solved for beyond the reach of P g: R g
    decays like exp(-k / (2 bw)), bw = lam_d^(1/6) nodes, so at ``WINDOW_BANDWIDTHS``
    bandwidths what is left out is below 1e-10 of its peak (the rounding of a
    whole-table solve at the search's levels is 1e-12 .. 1e-9 of it). At most
    ``MAX_MARGIN``."""
    reach = WINDOW_BANDWIDTHS * max(lam_d, 1.0) ** (1.0 / 6.0) + 10.0
    return int(min(reach, MAX_MARGIN))


@lru_cache(maxsize=1024)
def _window(n: int, tau: float, lam_d: float) -> tuple[int, int]:
    """Rows [lo, hi) on which the column R g of the junction at node ``tau`` is solved:
    P g (the hinge's third differences: its node and its taper) and a margin either
    side; the whole table, or a part reaching one end, where the margin reaches an
    end (the ends' stencil differs), else a part of fixed length away from both."""
    reach = int(math.ceil(taper_nodes(n))) + 12 + 2 * window_margin(lam_d)
    node = int(math.floor(tau))
    lo = node - reach + window_margin(lam_d) + 6 if side_of(tau, n) < 0 else \
        node - window_margin(lam_d) - 5
    hi = lo + reach
    if lo < 3:
        lo = 0
    if hi > n - 3:
        hi = n
    return lo, hi


def _hinge_support(n: int, tau: float, lo: int, hi: int) -> tuple[int, int]:
    """Rows [a, b) within [lo, hi) holding P g of the junction at node ``tau``: its node
    and its taper, with 3 rows to spare either side."""
    node = int(math.floor(tau))
    taper = int(math.ceil(taper_nodes(n)))
    if side_of(tau, n) > 0:
        a, b = node - 6, node + taper + 8
    else:
        a, b = node - taper - 7, node + 7
    return max(a, lo), min(b, hi)


def _windowed_rhs(n: int, lam_d: float, lo: int, hi: int, tau: float,
                  out: NDArray[np.float64]) -> None:
    """lam_d P g of the hinges g of the junction at node ``tau``, rows [lo, hi) of n
    rows, written into the zeros ``out`` (hi - lo, 2). P g from the hinge's own rows
    only: beyond them its third differences are those of a quadratic or of zero (0 but
    for the rounding of the quadratic's values)."""
    a, b = _hinge_support(n, tau, lo, hi)
    out[a - lo:b - lo] = lam_d * _hinge_penalty(n, float(tau), a, b)


def windowed_residuals(n: int, lam_d: float, places: list[tuple[int, int, float]]
                       ) -> list[NDArray[np.float64]]:
    """R g, (hi - lo, 2), of the hinges g of the junction at node tau on rows [lo, hi)
    of n rows (zero outside), for each (lo, hi, tau) in ``places``: the rows of
    I + lam_d P there are a leading block, a trailing one (the matrix reads the same
    backwards) or the Toeplitz interior. The columns on the interior block of one
    length are solved in one banded solve (LAPACK's solve and the deflation treat each
    right-hand side alone: the same numbers as one solve per junction)."""
    out: list[NDArray[np.float64] | None] = [None] * len(places)
    interior: dict[int, list[int]] = {}
    for k, (lo, hi, tau) in enumerate(places):
        if lo > 0 and hi < n:
            interior.setdefault(hi - lo, []).append(k)
            continue
        rhs = np.zeros((hi - lo, 2))
        _windowed_rhs(n, lam_d, lo, hi, tau, rhs)
        x = (banded_solve(whole_factor(n, lam_d), rhs) if lo == 0
             else banded_solve(whole_factor(n, lam_d), rhs[::-1])[::-1])
        out[k] = deflate(x)
    for m, ks in interior.items():
        rhs = np.zeros((m, 2 * len(ks)))
        for j, k in enumerate(ks):
            lo, hi, tau = places[k]
            _windowed_rhs(n, lam_d, lo, hi, tau, rhs[:, 2 * j:2 * j + 2])
        x = deflate(banded_solve(interior_factor(m, lam_d), rhs))
        for j, k in enumerate(ks):
            out[k] = np.ascontiguousarray(x[:, 2 * j:2 * j + 2])   # as one solve gives it
    return [x for x in out if x is not None]


@lru_cache(maxsize=256)
def _hinge_pair(n: int, tau: float) -> NDArray[np.float64]:
    """(n, 2): g2 and g3 of one junction at node position ``tau``, opening on its
    longer side (node units; read-only, cached: the level search asks for the same
    junctions at every level). The values of ``hinge_values``, formed on the rows
    where the hinge is not zero only."""
    length = taper_nodes(n)
    quad, cubic = hinge_coefficients(length, 0)
    g = np.zeros((n, 2))
    if side_of(tau, n) > 0:                  # rows after tau, u = row - tau rising
        first = int(math.floor(tau)) + 1
        u = np.arange(first, n, dtype=float) - tau
        rows = g[first:]
    else:                                    # rows before tau, backwards: u = tau - row
        last = int(math.ceil(tau)) - 1
        u = -(np.arange(last, -1, -1, dtype=float) - tau)
        rows = g[last::-1]
    rows[:, 0] = horner(u, quad)
    near = int(np.searchsorted(u, length, side='left'))
    rows[:near, 1] = horner(u[:near], cubic)
    g.setflags(write=False)
    return g


@lru_cache(maxsize=STACKS_KEPT)
def _hinge_stack(n: int, taus: tuple[float, ...]) -> NDArray[np.float64]:
    """G, (n, 2J): the hinges of the junctions at node positions ``taus`` side by side
    (read-only, cached: the level search asks for the same set at several levels)."""
    g = np.hstack([_hinge_pair(n, t) for t in taus]) if taus else np.zeros((n, 0))
    g.setflags(write=False)
    return g


@dataclass(frozen=True)
class PartialFit:
    """A partial-spline fit at one level: smooth part ``smooth`` [m] on the grid, hinge
    coefficients ``coef`` [m per node^2], residual sum of squares ``rss`` [m^2], trace
    of the hat matrix ``edf``, penalised residual ``objective`` [m^2], ``resid``."""

    smooth: NDArray[np.float64]
    coef: NDArray[np.float64]
    rss: float
    edf: float
    objective: float
    resid: NDArray[np.float64]


@dataclass(frozen=True)
class FitScore:
    """The scalars of a partial-spline fit (``PartialFit`` without its vectors):
    hinge coefficients ``coef``, ``rss`` [m^2], ``edf``, ``objective`` [m^2]."""

    coef: NDArray[np.float64]
    rss: float
    edf: float
    objective: float


#: (G, R G), (n, 2J), of a set of junctions
Stack = tuple[NDArray[np.float64], NDArray[np.float64]]
#: (G'R G, (R G)'(R G), (R G)'y, (R G)'R y) of a set of junctions
Gram = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64],
             NDArray[np.float64]]


@dataclass(frozen=True)
class _Column:
    """One junction's hinge at one level: rows [lo, hi) of R g (zero elsewhere), the
    hinge g on all rows, and (R g)'y, (R g)'(R y), g'R g, (R g)'(R g) over the rows."""

    lo: int
    hi: int
    g: NDArray[np.float64]
    rg: NDArray[np.float64]
    gy: NDArray[np.float64]
    gry: NDArray[np.float64]
    m: NDArray[np.float64]
    v: NDArray[np.float64]


def _ridged(m: NDArray[np.float64]) -> NDArray[np.float64]:
    """``m`` with 1e-13 of its trace added to its diagonal (the hinge Gram's ridge)."""
    out = m.copy()
    out.flat[::m.shape[0] + 1] += 1e-13 * np.trace(m)
    return out


K = TypeVar('K')
V = TypeVar('V')


def _recall(kept: dict[K, V], key: K) -> V | None:
    """``kept[key]`` (then the most recently used), or None."""
    done = kept.pop(key, None)
    if done is not None:
        kept[key] = done
    return done


def _remember(kept: dict[K, V], key: K, value: V, size: int) -> V:
    """``value`` kept under ``key``; the least recently used dropped beyond ``size``."""
    if len(kept) >= size:
        kept.pop(next(iter(kept)))
    kept[key] = value
    return value


class LevelSystem:
    """The partial-spline system of uniform ``values`` [m] at one discrete level
    ``lam_d``: the smoother's banded factor (cached by level), R y, and the hinge
    columns of every junction asked for so far. The hinges are a low-rank addition to
    the smoother's system. A hinge's column R g is solved on a window about it (it
    decays within a few dozen bandwidths; ``window_margin``) and its inner products
    with y, R y and the other hinges are kept, so a fit with another set of junctions
    at the same level costs only the new junctions' windowed solves and a small dense
    system; its vectors are formed only when asked for (``fit``)."""

    def __init__(self, values: NDArray[np.float64], lam_d: float) -> None:
        self.values = values
        self.n = int(values.size)
        self.lam_d = float(lam_d)
        self.ry = deflate(values - apply_smoother(values, self.lam_d))
        self.yry = float(values @ self.ry)
        self.ryry = float(self.ry @ self.ry)
        self.trace = trace_smoother(self.n, self.lam_d)
        self._cols: dict[float, _Column] = {}
        self._stacks: dict[tuple[float, ...], NDArray[np.float64]] = {}
        self._fits: dict[tuple[float, ...], PartialFit] = {}
        self._scores: dict[tuple[float, ...], FitScore] = {}
        self._grams: dict[tuple[float, ...], Gram] = {}
        #: per set of fixed junctions: smooth part, objective, columns, (X'R X)^-1
        self._moving: dict[tuple[float, ...], tuple] = {}

    def _column(self, tau: float) -> _Column:
        col = self._cols.get(tau)
        if col is None:
            self._solve_columns((tau,))
            col = self._cols[tau]
        return col

    def _solve_columns(self, taus: tuple[float, ...]) -> None:
        """The columns of the junctions ``taus`` not yet solved at this level, their
        windowed solves batched (``windowed_residuals``)."""
        new = [t for t in dict.fromkeys(taus) if t not in self._cols]
        if not new:
            return
        places = [(*_window(self.n, t, self.lam_d), t) for t in new]
        for (lo, hi, t), rg in zip(places, windowed_residuals(self.n, self.lam_d, places)):
            g = _hinge_pair(self.n, t)
            self._cols[t] = _Column(lo, hi, g, rg, rg.T @ self.values[lo:hi],
                                    rg.T @ self.ry[lo:hi], g[lo:hi].T @ rg, rg.T @ rg)

    def columns(self, taus: list[float]) -> Stack:
        """(G, R G), (n, 2J), of junctions at node positions ``taus``."""
        key = tuple(float(t) for t in taus)
        self._solve_columns(key)
        return _hinge_stack(self.n, key), self._residual_stack(key)

    def _residual_stack(self, key: tuple[float, ...]) -> NDArray[np.float64]:
        """R G, (n, 2J), of the junctions ``key``, zero outside each junction's window
        (the last few sets kept)."""
        done = _recall(self._stacks, key)
        if done is None:
            rg = np.zeros((self.n, 2 * len(key)))
            for k, t in enumerate(key):
                col = self._column(t)
                rg[col.lo:col.hi, 2 * k:2 * k + 2] = col.rg
            done = _remember(self._stacks, key, rg, STACKS_KEPT)
        return done

    def _gram(self, taus: tuple[float, ...]) -> Gram:
        """(G'R G, (R G)'(R G), (R G)'y, (R G)'R y) of the hinges ``taus``: one more
        row and column of blocks for a set one junction longer than a kept one (the
        search adds one junction at a time), else from all columns at once."""
        done = _recall(self._grams, taus)
        if done is not None:
            return done
        col = self._column(taus[-1])
        if len(taus) == 1:
            done = (col.m, col.v, col.gy, col.gry)
        elif taus[:-1] in self._grams:
            pm, pv, pgy, pgry = self._gram(taus[:-1])
            rg = self._residual_stack(taus[:-1])
            k = 2 * len(taus)
            m = np.empty((k, k))
            v = np.empty((k, k))
            m[:-2, :-2], v[:-2, :-2] = pm, pv
            m[-2:, -2:], v[-2:, -2:] = col.m, col.v
            # the rows of the window of the earlier hinges G, as rows of their (n, 2J - 2)
            # stack would be (the same product)
            g = np.concatenate([self._column(t).g[col.lo:col.hi] for t in taus[:-1]], axis=1)
            m[:-2, -2:] = g.T @ col.rg
            m[-2:, :-2] = col.g.T @ rg
            v[:-2, -2:] = rg[col.lo:col.hi].T @ col.rg
            v[-2:, :-2] = v[:-2, -2:].T
            done = (m, v, np.concatenate([pgy, col.gy]), np.concatenate([pgry, col.gry]))
        else:
            g, rg = self.columns(list(taus))
            cols = [self._column(t) for t in taus]
            done = (g.T @ rg, rg.T @ rg, np.concatenate([c.gy for c in cols]),
                    np.concatenate([c.gry for c in cols]))
        return _remember(self._grams, taus, done, SCORES_KEPT)

    def score(self, taus: list[float]) -> FitScore:
        """The fit's scalars with hinges at node positions ``taus``, from the kept
        inner products (no vector of the table's length is formed)."""
        key = tuple(float(t) for t in taus)
        done = _recall(self._scores, key)
        if done is not None:
            return done
        if not key:
            done = FitScore(np.zeros(0), self.ryry, self.trace, self.yry)
        else:
            m, v, gy, gry = self._gram(key)
            ridge = _ridged(m)
            # G'R y formed as (R G)'y: g'(R y) multiplies the rounding of R y by the
            # hinge's long quadratic tail (a 1e-15 change of the level moved the step
            # of h'' by 0.3 % and flipped the search's decisions); R G is formed from
            # third differences and y is data, so the product keeps its digits
            sol = np.asarray(np.linalg.solve(ridge, np.column_stack([gy, v])), dtype=np.float64)
            coef = sol[:, 0]
            extra = float(np.trace(sol[:, 1:]))
            rss = self.ryry - 2.0 * float(coef @ gry) + float(coef @ v @ coef)
            objective = self.yry - 2.0 * float(coef @ gy) + float(coef @ m @ coef)
            done = FitScore(coef, max(rss, 0.0), self.trace + extra, objective)
        return _remember(self._scores, key, done, SCORES_KEPT)

    def fit(self, taus: list[float]) -> PartialFit:
        """The partial spline with hinges at node positions ``taus`` (the last few
        kept: the search asks for the same fit again, e.g. its score after its scan)."""
        key = tuple(taus)
        done = self._fits.get(key)
        if done is None:
            done = _remember(self._fits, key, self._fit(taus), FITS_KEPT)
        return done

    def _fit(self, taus: list[float]) -> PartialFit:
        s = self.score(taus)
        resid = self.ry.copy()
        z = self.values.copy()
        for k, t in enumerate(taus):
            col = self._column(float(t))
            c = s.coef[2 * k:2 * k + 2]
            resid[col.lo:col.hi] -= col.rg @ c
            z -= col.g @ c
        smooth = z - resid                       # S (y - G c)
        return PartialFit(smooth, s.coef, float(resid @ resid), s.edf, float(z @ resid),
                          resid)

    def window(self, tau: float) -> tuple[int, int]:
        """Rows [lo, hi) on which the column of a junction at node ``tau`` is solved."""
        return _window(self.n, tau, self.lam_d)

    def interior(self, tau: float) -> bool:
        """The column of a junction at node ``tau`` is solved on the interior block (its
        window reaches neither end of the table)."""
        lo, hi = _window(self.n, tau, self.lam_d)
        return lo > 0 and hi < self.n

    def moved_objective(self, fixed: list[float], tau: float) -> float:
        """``score(fixed + [tau]).objective`` [m^2] (to the solves' rounding) for an
        ``interior`` junction at node ``tau``, without solving its column: one junction
        added lowers the objective by d'S^-1 d, d = g'R z (g its hinges, z the values
        less the fixed junctions' hinges X), S = g'R g - g'R X (X'R X)^-1 X'R g; g'R g
        from its place between two rows (``interior_grams``)."""
        key = tuple(float(t) for t in fixed)
        kept = _recall(self._moving, key)
        if kept is None:
            inverse = None
            if key:
                m = self._gram(key)[0]
                inverse = np.linalg.inv(_ridged(m))
            kept = _remember(self._moving, key, (self.fit(list(key)).smooth,
                                                 self.score(list(key)).objective,
                                                 [self._column(t) for t in key], inverse),
                             FITS_KEPT)
        smooth, objective, cols, inverse = kept
        side = side_of(tau, self.n)
        length = taper_nodes(self.n)
        s00, s01, s10, s11 = interior_grams(self.lam_d, length, side,
                                            tau - math.floor(tau))[0].reshape(4)
        # d = g'R z = (lam P g)'S z on the hinge's own rows (R = lam P S; g'e would
        # multiply the rounding of e by the hinge's long quadratic tail)
        g = _hinge_pair(self.n, tau)
        a, b = _hinge_support(self.n, tau, *_window(self.n, tau, self.lam_d))
        d0, d1 = (self.lam_d * _hinge_penalty(self.n, float(tau), a, b)).T @ smooth[a:b]
        if inverse is not None:
            cross = np.concatenate([g[c.lo:c.hi].T @ c.rg for c in cols], axis=1)
            (c00, c01), (c10, c11) = cross @ inverse @ cross.T
            s00, s01, s10, s11 = s00 - c00, s01 - c01, s10 - c10, s11 - c11
        det = s00 * s11 - s01 * s10
        if not det > 0.0:   # on a fixed junction: S is singular, the exact score is not
            return self.score(list(key) + [tau]).objective
        # d'S^-1 d of the 2 x 2 S
        return objective - float((d0 * (s11 * d0 - s01 * d1) + d1 * (s00 * d1 - s10 * d0))
                                 / det)

    def gcv(self, taus: list[float], gamma: float) -> float:
        """GCV score of the fit with these junctions (``gamma`` weights the trace)."""
        s = self.score(taus)
        return self.n * s.rss / max(self.n - gamma * s.edf, 1e-9) ** 2


def partial_fit(values: NDArray[np.float64], taus: list[float], lam_d: float
                ) -> PartialFit:
    """Partial spline of uniform ``values`` [m] with hinges at node positions ``taus``."""
    return LevelSystem(values, lam_d).fit(taus)


@lru_cache(maxsize=16)
def interior_hinge_grams(lam_d: float, length: float, offsets: tuple[float, ...]
                         ) -> tuple[tuple[NDArray[np.float64], NDArray[np.float64]], ...]:
    """(G'RG, G'R^2G), 2 x 2 in node units, of one right-opening junction far from the
    ends at each of ``offsets`` [nodes] (cached by level): its column solved on its
    window (``window_margin``) as in the fit, all offsets in one solve."""
    margin = window_margin(lam_d)
    size = int(math.ceil(length)) + 12 + 2 * margin
    g = hinge_block(np.arange(size, dtype=float)[:, None]
                    - (margin + 5.0 + np.asarray(offsets, dtype=float))[None, :], length)
    rg = deflate(banded_solve(interior_factor(size, lam_d), lam_d * penalty_of(g)))
    return tuple((g[:, 2 * k:2 * k + 2].T @ rg[:, 2 * k:2 * k + 2],
                  rg[:, 2 * k:2 * k + 2].T @ rg[:, 2 * k:2 * k + 2])
                 for k in range(len(offsets)))


def interior_grams(lam_d: float, length: float, side: int, frac: float
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(G'R G, G'R^2 G), 2 x 2 in node units, of an interior junction ``frac`` of a row
    past its node, opening to the right (``side`` +1) or to the left (-1), at level
    ``lam_d``: from the level's Chebyshev fit in the place (``_interior_gram_fit``).
    Far from the ends the matrix reads the same backwards, so a left-opening junction
    ``frac`` past its node is the mirror image of a right-opening one 1 - ``frac`` past
    its node (the same Grams, but for the windows' truncation, 1e-10 of them)."""
    x = 2.0 * frac - 1.0 if side > 0 else 1.0 - 2.0 * frac
    basis = [1.0, x]
    while len(basis) < GRAM_NODES:
        basis.append(2.0 * x * basis[-1] - basis[-2])
    out = np.array(basis) @ _interior_gram_fit(float(lam_d), float(length))
    return out[:4].reshape(2, 2), out[4:].reshape(2, 2)


@lru_cache(maxsize=16)
def _interior_gram_fit(lam_d: float, length: float) -> NDArray[np.float64]:
    """Chebyshev coefficients (GRAM_NODES, 8) in 2 f - 1 of G'R G and G'R^2 G (2 x 2
    each, flattened) of an interior right-opening junction at the fraction f of a row
    past a node, at level ``lam_d`` (read-only, cached: one solve per level)."""
    k = np.arange(GRAM_NODES)
    frac = 0.5 - 0.5 * np.cos(np.pi * (k + 0.5) / GRAM_NODES)
    grams = interior_hinge_grams(float(lam_d), float(length), tuple(float(f) for f in frac))
    values = np.array([np.concatenate([m.reshape(4), v.reshape(4)]) for m, v in grams])
    coef = _chebyshev_interpolation() @ values
    coef.setflags(write=False)
    return coef


@lru_cache(maxsize=1)
def _chebyshev_interpolation() -> NDArray[np.float64]:
    """(GRAM_NODES, GRAM_NODES): the Chebyshev coefficients of the polynomial through
    values at the Chebyshev points of ``_interior_gram_fit``, from the discrete
    orthogonality of T_j there (the interpolant chebfit finds by least squares)."""
    k = np.arange(GRAM_NODES)
    theta = np.pi * (k + 0.5) / GRAM_NODES
    # the places run from -1 up: x_k = 2 f_k - 1 = -cos(theta_k)
    out = 2.0 / GRAM_NODES * np.cos(np.outer(k, np.pi - theta))
    out[0] *= 0.5
    out.setflags(write=False)
    return out
