"""Junction-aware smoothing: find where h'' jumps and let the smoothing spline jump there.

A lift law is often pieced together from segments whose accelerations differ at the
seams (ramp ends, the segments of a constant-acceleration cam, dwell edges, the arcs of
a circular-arc cam). A smoothing spline that penalises h''' spreads such a step over
its bandwidth. Here the lift on a uniform grid is modelled as a *partial spline*
(Wahba's semi-parametric smoothing spline)

    y = f + sum_j c_j (x - t_j)_+^2 / 2 + noise,

with f smooth (discrete quintic smoother: penalty on third differences with free ends)
and one hinge per junction t_j carrying the step c_j of h''. With free ends a quadratic
is not penalised at all, so the hinge costs the smooth part nothing away from t_j. For
a fixed smoothing level the c_j are a small least-squares problem (banded solves, O(N)
per level); the generalised cross-validation score of the whole fit (the partial
spline's hat-matrix trace) chooses the level.

Junctions are found greedily. For one more junction at t the drop of the penalised
residual is b^2 / (g'Rg), b = g'e (e the current residual, R = I - S); under noise
alone T = b^2 / (sigma^2 g'R^2 g) is chi-square with one degree of freedom. T is
computed at every quarter step at once (a correlation of the residual with the hinge);
the largest T above 2 ln(4 N / alpha) is added, every junction's angle is refined to a
fraction of a step by minimising the penalised residual, the level is chosen again,
and the search repeats. Angles in rad, lifts in m.

Cost. A large T often marks the smoothing bias of a strongly curved, smooth lobe
rather than a junction, and the GCV test refuses it; the search is built so that
refusals are cheap. One ``LevelSystem`` per level keeps the banded factor, R y and
the hinge columns (g, R g) it has solved for: the hinges are a low-rank addition to
the smoother's system, so a fit with other junctions at the same level costs only the
new columns' solves and a dense system of size 2J. The scan is one real FFT of the
residual against cached spectra of the hinges (a correlation for right-opening and a
convolution for left-opening junctions) and is reused while candidates are refused.
A candidate is first scored at the present level and unrefined angle (a pre-test);
only one within ``PRETEST_SLACK`` of the bar gets its angle refined and the level
chosen again, and the search stops after ``MAX_REFUSED`` refusals in a row.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Callable, TypeVar

import numpy as np
from numpy.polynomial import Polynomial
from numpy.typing import NDArray
from scipy.fft import irfft, next_fast_len, rfft
from scipy.linalg import lapack

#: family-wise false-alarm probability of the junction search on a lobe without one
FALSE_ALARM = 1e-3
#: most junctions searched for (ramps and three acceleration segments per flank: ten)
MAX_JUNCTIONS = 12
#: a junction is kept when it lowers N ln(GCV) of the whole fit by this much (a step
#: that only stands in for the smoothing bias of a smooth lobe raises the score)
GCV_GAIN = 12.0
#: a junction may lower the smoothing level of the rest by at most this factor
MIN_LEVEL_RATIO = 0.5
#: no junction is sought within this fraction of the table from either end
END_MARGIN = 0.02
#: the search ends after this many candidates in a row refused by the GCV test (on the
#: accuracy benchmark's 1544 candidates, 4 of the 431 kept came after 3 refusals in a
#: row, none of them a junction of the law)
MAX_REFUSED = 3
#: a candidate whose gain at the present level, before its angle is refined and the
#: level chosen again, is below GCV_GAIN - PRETEST_SLACK is refused without either (on
#: the benchmark: 1 of the 431 kept had a pre-test gain below -30, 448 of 1113 refused)
PRETEST_SLACK = 42.0
#: positions tried per grid step by the scan
SCAN_OFFSETS = (0.0, 0.25, 0.5, 0.75)
#: the level search: steps [decades] downhill from the start, at most this many
LEVEL_STEP = 0.5
LEVEL_REACH = 4
#: golden-section iterations refining a junction's angle over +-1 row (to 0.07 row)
REFINE_ITERATIONS = 7
#: a refined junction more than this many rows from the scan's angle is refused
MAX_MOVE = 0.9
#: fits a level's system remembers (by junction set): with their vectors, and scores
FITS_KEPT = 4
SCORES_KEPT = 64
STACKS_KEPT = 8
#: a hinge's column is solved this many smoother bandwidths either side (window_margin)
WINDOW_BANDWIDTHS = 48.0


def third_difference_gram(m: int) -> NDArray[np.float64]:
    """D3^T D3 (free ends) for m >= 4 unknowns in upper banded storage (4 x m)."""
    c = np.array([-1.0, 3.0, -3.0, 1.0])
    ab = np.zeros((4, m))
    for o in range(4):
        diag = np.convolve(np.ones(m - 3), c[:4 - o] * c[o:])     # length m - o
        ab[3 - o, o:] = diag[:m - o]
    return ab


@lru_cache(maxsize=16)
def _penalty(m: int) -> NDArray[np.float64]:
    ab = third_difference_gram(m)
    ab.setflags(write=False)
    return ab


def _lower_band(upper: NDArray[np.float64], lam_d: float) -> NDArray[np.float64]:
    """I + lam_d P in lower banded storage (Fortran order) from P in upper storage."""
    m = upper.shape[1]
    low = np.zeros((4, m), order='F')
    for k in range(4):
        low[k, :m - k] = lam_d * upper[3 - k, k:]
    low[0] += 1.0
    return low


def _cholesky(low: NDArray[np.float64]) -> NDArray[np.float64]:
    """Lower banded Cholesky factor (read-only). The lower storage: OpenBLAS's
    factorisation of it takes about 0.4 of the upper one's time at these sizes."""
    c, info = lapack.dpbtrf(low, lower=1, overwrite_ab=1)
    if info != 0:
        raise np.linalg.LinAlgError(f'banded Cholesky failed (info {info})')
    c.setflags(write=False)
    return c


@lru_cache(maxsize=32)
def _factor(n: int, lam_d: float) -> NDArray[np.float64]:
    """Banded Cholesky factor of I + lam_d D3'D3 (free ends, n nodes; cached: the
    search asks for the same level many times)."""
    return _cholesky(_lower_band(_penalty(n), lam_d))


@lru_cache(maxsize=32)
def _interior_factor(m: int, lam_d: float) -> NDArray[np.float64]:
    """Banded Cholesky factor of the m x m block of I + lam_d D3'D3 away from both
    ends (every row the full stencil 20, -15, 6, -1; Toeplitz)."""
    stencil = np.array([-1.0, 6.0, -15.0, 20.0])
    return _cholesky(_lower_band(np.repeat(stencil[:, None], m, axis=1), lam_d))


def _solve(factor: NDArray[np.float64], rhs: NDArray[np.float64]) -> NDArray[np.float64]:
    """(L L')^-1 rhs for a lower banded factor whose first rhs.shape[0] columns are
    used (the leading block's factor is the leading part of the whole one)."""
    m = rhs.shape[0]
    x, info = lapack.dpbtrs(factor[:, :m], rhs, lower=1)
    if info != 0:
        raise np.linalg.LinAlgError(f'banded solve failed (info {info})')
    return np.asarray(x, dtype=np.float64)


def _smooth(rhs: NDArray[np.float64], lam_d: float) -> NDArray[np.float64]:
    """(I + lam_d D3'D3)^-1 rhs (rhs (n,) or (n, k))."""
    return _solve(_factor(rhs.shape[0], float(lam_d)), rhs)


@lru_cache(maxsize=16)
def _cubed_spectrum(n: int) -> NDArray[np.float64]:
    """mu_k^3 of the reflective second difference, modes 1 .. n - 3 (read-only)."""
    mu = 2.0 - 2.0 * np.cos(np.pi * np.arange(1, n - 2) / n)
    m3 = mu ** 3
    m3.setflags(write=False)
    return m3


def _trace_smoother(n: int, lam_d: float) -> float:
    """tr (I + lam_d D3'D3)^-1: the three unpenalised quadratics plus the reflective
    spectrum mu_k^3 of the other modes (boundary terms of order one left out)."""
    return 3.0 + float(np.sum(1.0 / (1.0 + lam_d * _cubed_spectrum(n))))


def _smoothstep() -> Polynomial:
    """S(v) = v^6 sum_k C(5 + k, k) (1 - v)^k: 0 at 0, 1 at 1, flat to 5th order."""
    v = Polynomial([0.0, 1.0])
    return v ** 6 * sum(math.comb(5 + k, k) * Polynomial([1.0, -1.0]) ** k
                        for k in range(6))


def side_of(tau: float, n: int) -> int:
    """+1: the junction at node ``tau`` opens to the right (its longer side), else -1."""
    return 1 if tau <= 0.5 * (n - 1) else -1


def taper_nodes(n: int) -> float:
    """Length [nodes] of a junction's cubic hinge (long beside the smoother's
    bandwidth, short enough to keep its values, and the rounding of R g, small)."""
    return max(min(0.25 * (n - 1), 60.0 + 0.02 * n), 4.0)


@lru_cache(maxsize=64)
def _hinges_on(length: float) -> tuple[Polynomial, Polynomial]:
    """g2 = u^2/2 on u > 0 (no taper: the free ends do not penalise a quadratic) and
    g3 = u^3/6 w(u) on [0, L], w = 1 - S(u / L), 0 beyond (C5 there, 1 + O(u^6) at
    0): unit steps of the second and third derivatives at 0, in node units."""
    taper = 1.0 - _smoothstep()(Polynomial([0.0, 1.0 / length]))
    return Polynomial([0.0, 0.0, 0.5]), Polynomial([0.0, 0.0, 0.0, 1.0 / 6.0]) * taper


@lru_cache(maxsize=64)
def _hinge_coefficients(length: float, nu: int) -> tuple[NDArray[np.float64], ...]:
    """Power-series coefficients of the nu-th derivatives of g2 and g3."""
    return tuple(np.asarray(p.deriv(nu).coef, dtype=np.float64) for p in _hinges_on(length))


def _horner(x: NDArray[np.float64], coef: NDArray[np.float64]) -> NDArray[np.float64]:
    """sum_k coef[k] x^k by Horner's rule (numpy's polyval without its checks)."""
    acc = np.full(x.shape, coef[-1])
    for c in coef[-2::-1]:
        acc = acc * x + c
    return acc


def hinge_values(u: NDArray[np.float64], length: float, nu: int = 0) -> NDArray[np.float64]:
    """(len(u), 2): nu-th u-derivatives of g2 and g3 (node units), ``u`` nodes from a
    junction that opens to the right."""
    u = np.asarray(u, dtype=float).reshape(-1)
    out = np.zeros((u.size, 2))
    quad, cubic = _hinge_coefficients(float(length), nu)
    pos = u > 0
    out[:, 0] = np.where(pos, _horner(u, quad), 0.0)
    near = np.flatnonzero(pos & (u < length))
    out[near, 1] = _horner(u[near], cubic)
    return out


@lru_cache(maxsize=64)
def _quadratics(n: int) -> NDArray[np.float64]:
    """Orthonormal basis (n, 3) of the quadratics on n nodes (read-only, cached)."""
    x = np.linspace(-1.0, 1.0, n)
    q, _ = np.linalg.qr(np.column_stack([np.ones(n), x, x * x]))
    q.setflags(write=False)
    return q


def _deflate(r: NDArray[np.float64]) -> NDArray[np.float64]:
    """r without its quadratic part. R r is orthogonal to the quadratics (the free
    ends reproduce them); the banded solve's rounding, amplified by the condition
    number, is not, and a long hinge would sum it up."""
    q = _quadratics(r.shape[0])
    return r - q @ (q.T @ r)


#: the stencil of the third difference
_THIRD_DIFFERENCE = np.array([-1.0, 3.0, -3.0, 1.0])


def _penalised(g: NDArray[np.float64], lam_d: float) -> NDArray[np.float64]:
    """lam_d P g = lam_d D3'D3 g (free ends of ``g``'s own rows)."""
    d3 = np.diff(g, 3, axis=0)
    if g.ndim == 1:
        return lam_d * np.convolve(d3, _THIRD_DIFFERENCE)
    return lam_d * np.column_stack([np.convolve(d3[:, k], _THIRD_DIFFERENCE)
                                    for k in range(g.shape[1])])


def _residual_operator(g: NDArray[np.float64], lam_d: float) -> NDArray[np.float64]:
    """R g = (I + lam_d P)^-1 lam_d P g, P = D3'D3: the same as g - S g, but formed from
    third differences, so that the long quadratic tail of a hinge (S reproduces it)
    adds no rounding."""
    return _deflate(_smooth(_penalised(g, lam_d), lam_d))


def window_margin(lam_d: float) -> int:
    """Nodes [>= 10] a hinge's column R g is solved for beyond the reach of P g: R g
    decays like exp(-k / (2 bw)), bw = lam_d^(1/6) nodes, so at ``WINDOW_BANDWIDTHS``
    bandwidths what is left out is below 1e-10 of its peak (the rounding of a
    whole-table solve at the search's levels is 1e-12 .. 1e-9 of it)."""
    reach = WINDOW_BANDWIDTHS * max(lam_d, 1.0) ** (1.0 / 6.0) + 10.0
    return int(min(reach, 1e9))


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


def _windowed_residual(g: NDArray[np.float64], lam_d: float, lo: int, hi: int
                       ) -> NDArray[np.float64]:
    """R g on rows [lo, hi) of the n = g.shape[0] rows, zero outside (the rows of
    I + lam_d P there: a leading block, a trailing one (the matrix reads the same
    backwards) or the Toeplitz interior)."""
    n = g.shape[0]
    rhs = _penalised(g[lo:hi], lam_d)
    if lo == 0:
        x = _solve(_factor(n, lam_d), rhs)
    elif hi == n:
        x = _solve(_factor(n, lam_d), rhs[::-1])[::-1]
    else:
        x = _solve(_interior_factor(hi - lo, lam_d), rhs)
    return _deflate(x)


@lru_cache(maxsize=256)
def _hinge_pair(n: int, tau: float) -> NDArray[np.float64]:
    """(n, 2): g2 and g3 of one junction at node position ``tau``, opening on its
    longer side (node units; read-only, cached: the level search asks for the same
    junctions at every level)."""
    g = hinge_values(side_of(tau, n) * (np.arange(n, dtype=float) - tau), taper_nodes(n))
    g.setflags(write=False)
    return g


def _hinge_columns(n: int, taus: list[float]) -> NDArray[np.float64]:
    """(n, 2J): g2 and g3 of each junction, opening on its longer side (node units)."""
    cols = [_hinge_pair(n, float(t)) for t in taus]
    return np.concatenate(cols, axis=1) if cols else np.zeros((n, 0))


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
        self.ry = _deflate(values - _smooth(values, self.lam_d))
        self.yry = float(values @ self.ry)
        self.ryry = float(self.ry @ self.ry)
        self.trace = _trace_smoother(self.n, self.lam_d)
        self._cols: dict[float, _Column] = {}
        self._stacks: dict[tuple[float, ...], Stack] = {}
        self._fits: dict[tuple[float, ...], PartialFit] = {}
        self._scores: dict[tuple[float, ...], FitScore] = {}
        self._grams: dict[tuple[float, ...], Gram] = {}

    def _column(self, tau: float) -> _Column:
        col = self._cols.get(tau)
        if col is None:
            g = _hinge_pair(self.n, tau)
            lo, hi = _window(self.n, tau, self.lam_d)
            rg = _windowed_residual(g, self.lam_d, lo, hi)
            col = self._cols[tau] = _Column(lo, hi, g, rg, rg.T @ self.values[lo:hi],
                                            rg.T @ self.ry[lo:hi], g[lo:hi].T @ rg,
                                            rg.T @ rg)
        return col

    def columns(self, taus: list[float]) -> Stack:
        """(G, R G), (n, 2J), of junctions at node positions ``taus`` (R G zero outside
        each junction's window; the last few sets kept)."""
        key = tuple(float(t) for t in taus)
        done = _recall(self._stacks, key)
        if done is None:
            g = np.zeros((self.n, 2 * len(key)))
            rg = np.zeros((self.n, 2 * len(key)))
            for k, t in enumerate(key):
                col = self._column(t)
                g[:, 2 * k:2 * k + 2] = col.g
                rg[col.lo:col.hi, 2 * k:2 * k + 2] = col.rg
            done = _remember(self._stacks, key, (g, rg), STACKS_KEPT)
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
            g, rg = self.columns(list(taus[:-1]))
            k = 2 * len(taus)
            m = np.empty((k, k))
            v = np.empty((k, k))
            m[:-2, :-2], v[:-2, :-2] = pm, pv
            m[-2:, -2:], v[-2:, -2:] = col.m, col.v
            m[:-2, -2:] = g[col.lo:col.hi].T @ col.rg
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
            ridge = m + 1e-13 * np.trace(m) * np.eye(m.shape[0])
            # G'R y formed as (R G)'y: g'(R y) multiplies the rounding of R y by the
            # hinge's long quadratic tail (a 1e-15 change of the level moved the step
            # of h'' by 0.3 % and flipped the search's decisions); R G is formed from
            # third differences and y is data, so the product keeps its digits
            sol = np.linalg.solve(ridge, np.column_stack([gy, v]))
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
            done = self._fit(taus)
            if len(self._fits) >= FITS_KEPT:
                self._fits.pop(next(iter(self._fits)))
            self._fits[key] = done
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

    def gcv(self, taus: list[float], gamma: float) -> float:
        """GCV score of the fit with these junctions (``gamma`` weights the trace)."""
        s = self.score(taus)
        return self.n * s.rss / max(self.n - gamma * s.edf, 1e-9) ** 2


def partial_fit(values: NDArray[np.float64], taus: list[float], lam_d: float
                ) -> PartialFit:
    """Partial spline of uniform ``values`` [m] with hinges at node positions ``taus``."""
    return LevelSystem(values, lam_d).fit(taus)


def golden_minimum(fun: Callable[[float], float], a: float, b: float, iterations: int,
                   stop: Callable[[float, float], bool] | None = None) -> float:
    """Minimiser of a unimodal ``fun`` on [a, b] (golden section). ``stop(a, b)``: the
    bracket is of no more interest (the midpoint of the present one is returned)."""
    g = (math.sqrt(5.0) - 1.0) / 2.0
    c, d = b - g * (b - a), a + g * (b - a)
    fc, fd = fun(c), fun(d)
    for _ in range(iterations):
        if stop is not None and stop(a, b):
            break
        if fc < fd:
            b, d, fd = d, c, fc
            c = b - g * (b - a)
            fc = fun(c)
        else:
            a, c, fc = c, d, fd
            d = a + g * (b - a)
            fd = fun(d)
    return 0.5 * (a + b)


class Levels:
    """The level systems of one table, by level: a search that comes back to a level
    reuses its factor, R y and the hinge columns already solved there. The level
    search steps on one lattice of ``LEVEL_STEP`` decades, anchored at the first
    level it starts from (``anchor``, log10), so that the searches of successive
    candidates meet the same levels."""

    def __init__(self, values: NDArray[np.float64]) -> None:
        self.values = values
        self.anchor: float | None = None
        self._systems: dict[float, LevelSystem] = {}

    def at(self, lam_d: float) -> LevelSystem:
        """The system at discrete level ``lam_d``."""
        lam_d = float(lam_d)
        system = self._systems.get(lam_d)
        if system is None:
            system = self._systems[lam_d] = LevelSystem(self.values, lam_d)
        return system


def choose_level(values: NDArray[np.float64], taus: list[float], gamma: float,
                 lam0: float, levels: Levels | None = None) -> float:
    """The GCV-minimising discrete level with these hinges, searched around ``lam0``:
    downhill from the lattice level nearest to log10(lam0) in steps of ``LEVEL_STEP``
    decades (at most ``LEVEL_REACH`` either way) to a bracketing triple, then the
    vertex of the parabola through it (GCV is smooth and unimodal in log lam near its
    minimum). ``levels``: the systems already built for ``values``, if any, and the
    lattice's anchor (without them, or on the first call, log10(lam0) itself)."""
    levels = levels if levels is not None else Levels(values)
    h = LEVEL_STEP
    if levels.anchor is None:
        levels.anchor = math.log10(max(lam0, 1e-6))
    c0 = levels.anchor + h * round((math.log10(max(lam0, 1e-6)) - levels.anchor) / h)
    seen: dict[int, float] = {}

    def score(k: int) -> float:         # GCV at c0 + k h, each level computed once
        if k not in seen:
            seen[k] = levels.at(10.0 ** (c0 + k * h)).gcv(taus, gamma)
        return seen[k]

    d = -1 if score(-1) < score(1) else 1
    best = 0
    while abs(best) < LEVEL_REACH and score(best + d) < score(best):
        best += d
    a, b, c = score(best - 1), score(best), score(best + 1)
    curve = a - 2.0 * b + c
    shift = 0.5 * (a - c) / curve if curve > 0.0 else 0.0
    return 10.0 ** (c0 + (best + shift) * h)


@lru_cache(maxsize=16)
def _hinge_grams(lam_d: float, length: float
                 ) -> tuple[tuple[NDArray[np.float64], NDArray[np.float64]], ...]:
    """(G'RG, G'R^2G), 2 x 2 in node units, of one right-opening junction far from the
    ends at each of ``SCAN_OFFSETS`` (cached by level): its column solved on its
    window (``window_margin``) as in the fit, all offsets in one solve."""
    margin = window_margin(lam_d)
    size = int(math.ceil(length)) + 12 + 2 * margin
    nodes = np.arange(size, dtype=float)
    g = np.concatenate([hinge_values(nodes - (margin + 5 + off), length)
                        for off in SCAN_OFFSETS], axis=1)
    rg = _deflate(_solve(_interior_factor(size, lam_d), _penalised(g, lam_d)))
    return tuple((g[:, 2 * k:2 * k + 2].T @ rg[:, 2 * k:2 * k + 2],
                  rg[:, 2 * k:2 * k + 2].T @ rg[:, 2 * k:2 * k + 2])
                 for k in range(len(SCAN_OFFSETS)))


@lru_cache(maxsize=4)
def _kernel_spectra(n: int, length: float, nfft: int) -> NDArray[np.complex128]:
    """Real FFTs (len(SCAN_OFFSETS), 2, nfft // 2 + 1) of the hinges g2, g3 of a
    right-opening junction at each scan offset, on n nodes (read-only, cached)."""
    nodes = np.arange(n, dtype=float)
    out = np.stack([rfft(hinge_values(nodes - off, length).T, nfft, axis=-1)
                    for off in SCAN_OFFSETS])
    out.setflags(write=False)
    return out


@lru_cache(maxsize=4)
def _scan_positions(n: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Node positions of the scan, ascending: node + offset (right-opening, in row
    order) and (n - 1 - node) - offset (left-opening, in reversed row order)."""
    offs = np.asarray(SCAN_OFFSETS)
    nodes = np.arange(n, dtype=float)
    right = (nodes[:, None] + offs[None, :]).ravel()
    left = ((n - 1 - nodes)[:, None] - offs[None, :]).ravel()[::-1].copy()
    right.setflags(write=False)
    left.setflags(write=False)
    return right, left


def scan(resid: NDArray[np.float64], lam_d: float, sigma: float, margin: int = 3
         ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(node positions tau, statistic T) of one more junction at every quarter node,
    ``margin`` nodes from the ends, each opening on its longer side as in the fit. T
    tests a step of h'' with a step of h''' allowed at the same place: chi-square with
    one degree of freedom where the lift has neither (white noise ``sigma`` [m]).

    The hinge's inner products with the residual at every position are one
    correlation (right-opening) and one convolution (left-opening) with the hinge,
    both from one FFT of the residual (and one batch of inverse FFTs)."""
    n = resid.size
    length = taper_nodes(n)
    nfft = next_fast_len(2 * n, real=True)
    spectra = _kernel_spectra(n, length, nfft)
    e = rfft(resid, nfft)
    kern = np.empty((len(SCAN_OFFSETS), spectra.shape[-1]), dtype=complex)
    var = np.empty(len(SCAN_OFFSETS))
    for col, (m, v) in enumerate(_hinge_grams(float(lam_d), length)):
        # efficient score of the step of h'' with a step of h''' free: w'b, w = (1, -k)
        w = np.array([1.0, -m[0, 1] / m[1, 1]])
        var[col] = max(float(w @ v @ w) * sigma ** 2, 1e-300)
        kern[col] = w[0] * spectra[col, 0] + w[1] * spectra[col, 1]
    # right: b(j) = sum_i g(i - off) e_{j+i}; left (the table reversed):
    # b(j) = sum_i g(i - off) e_{n-1-j-i}
    b = irfft(np.concatenate([e * np.conj(kern), e * kern]), nfft, axis=-1)
    k = len(SCAN_OFFSETS)
    right = (b[:k, :n] ** 2 / var[:, None]).T.ravel()
    left = (b[k:, n - 1::-1] ** 2 / var[:, None]).T.ravel()[::-1]
    pos_r, pos_l = _scan_positions(n)
    mid = 0.5 * (n - 1)
    r0, r1 = np.searchsorted(pos_r, margin, side='left'), np.searchsorted(pos_r, mid, 'right')
    l0 = np.searchsorted(pos_l, mid, side='right')
    l1 = np.searchsorted(pos_l, n - 1 - margin, side='right')
    return (np.concatenate([pos_r[r0:r1], pos_l[l0:l1]]),
            np.concatenate([right[r0:r1], left[l0:l1]]))


@dataclass(frozen=True)
class JunctionFit:
    """The partial-spline fit with its junctions: ``angles`` [rad], acceleration
    ``jumps`` [m/rad^2] (h''(t+) - h''(t-)), the discrete level ``lam_d``, the smooth
    part ``smooth`` [m] on the grid, ``edf``, the search statistics ``scores``;
    ``step`` [rad], ``x0`` [rad], ``nodes`` and ``coef`` (node units) for the hinges;
    ``fitted_on``: the grid values [m] of the fit, where they are kept."""

    angles: tuple[float, ...]
    jumps: tuple[float, ...]
    lam_d: float
    smooth: NDArray[np.float64]
    edf: float
    scores: tuple[float, ...]
    step: float
    x0: float
    nodes: int
    coef: NDArray[np.float64]
    fitted_on: NDArray[np.float64] | None = field(default=None, repr=False, compare=False)

    def hinge_part(self, x: NDArray[np.float64], nu: int = 0) -> NDArray[np.float64]:
        """Sum of the hinges' nu-th derivative [m/rad^nu] at ``x`` [rad]."""
        x = np.asarray(x, dtype=float)
        u = ((x - self.x0) / self.step).ravel()
        out = np.zeros(u.size)
        length = taper_nodes(self.nodes)
        cubic = _hinge_coefficients(float(length), nu)[1]
        for k, t in enumerate(self.angles):
            tau = (t - self.x0) / self.step
            side = side_of(tau, self.nodes)
            v = side * (u - tau)
            c2, c3 = self.coef[2 * k:2 * k + 2] * float(side) ** nu
            # the quadratic hinge: v^2/2, v, 1, 0 on v > 0 (Horner's values)
            if nu == 0:
                vp = np.maximum(v, 0.0)
                out += c2 * ((0.5 * vp) * vp)
            elif nu == 1:
                out += c2 * np.maximum(v, 0.0)
            elif nu == 2:
                out += np.where(v > 0, c2, 0.0)
            near = np.flatnonzero((v > 0) & (v < length))
            out[near] += c3 * _horner(v[near], cubic)
        return out.reshape(x.shape) / self.step ** nu


def _fit_result(grid: NDArray[np.float64], taus: list[float], lam_d: float,
                fit: PartialFit, scores: list[float],
                fitted_on: NDArray[np.float64] | None = None) -> JunctionFit:
    step = float(grid[1] - grid[0])
    n = grid.size
    order = np.argsort(taus)
    coef = np.concatenate([fit.coef[2 * i:2 * i + 2] for i in order])
    jumps = tuple(side_of(taus[i], n) * float(fit.coef[2 * i]) / step ** 2 for i in order)
    return JunctionFit(tuple(float(grid[0] + taus[i] * step) for i in order), jumps,
                       lam_d, fit.smooth, fit.edf, tuple(scores[i] for i in order), step,
                       float(grid[0]), n, coef, fitted_on)


def find_junctions(grid: NDArray[np.float64], values: NDArray[np.float64], lam0: float,
                   *, gamma: float = 1.0, sigma_floor: float = 0.0,
                   false_alarm: float = FALSE_ALARM) -> JunctionFit | None:
    """Greedy junction search and partial-spline fit of uniform ``values`` [m] on
    ``grid`` [rad], starting from the plain smoother's level ``lam0``. None when no
    junction is significant (the plain smoothing spline stands)."""
    n = grid.size
    if n < 16:
        return None
    threshold = 2.0 * math.log(4.0 * n / false_alarm)
    # the plain smoother's level (reflective ends) stands for the free-ended one: they
    # differ by a few per cent, which GCV's flat minimum does not notice
    lam = float(lam0)
    levels = Levels(values)
    system = levels.at(lam)
    in_a_row = 0
    taus: list[float] = []
    scores: list[float] = []
    vetoed: list[float] = []
    pos = stat = np.zeros(0)
    fresh = True
    while len(taus) < MAX_JUNCTIONS:
        if fresh:   # the scan changes only when a junction is taken
            fit = system.fit(taus)
            sigma = max(math.sqrt(fit.rss / max(n - fit.edf, 1.0)), sigma_floor, 1e-300)
            # clear of the table's ends by a few bandwidths (the scan's variance is that
            # of the interior), and of the junctions taken or refused by one
            bandwidth = max(lam, 1.0) ** (1.0 / 6.0)
            pos, stat = scan(fit.resid, lam, sigma,
                             margin=int(max(3 + 6 * bandwidth, END_MARGIN * n)))
            base = system.gcv(taus, gamma)
            fresh = False
        if taus or vetoed:
            stat = _cleared(pos, stat, taus + vetoed, max(1.5, bandwidth))
        i = int(np.argmax(stat)) if stat.size else -1
        if i < 0 or stat[i] < threshold:
            break
        at = float(pos[i])
        # pre-test at the present level and the scan's angle: refining the angle and
        # choosing the level again lowers the score by more, but on the accuracy
        # benchmark almost never by PRETEST_SLACK more (constants above), so a junction
        # far below the bar is refused without either
        quick = n * math.log(base / system.gcv(taus + [at], gamma))
        trial, lam_trial, gain = taus + [at], lam, quick
        if quick >= GCV_GAIN - PRETEST_SLACK:
            trial = _refine(system, taus + [at])
            # a junction refused for its place needs no level search
            if not _misplaced(trial, at):
                lam_trial = choose_level(values, trial, gamma, lam, levels)
                trial_system = levels.at(lam_trial)
                # kept only if it lowers the GCV score of the whole fit: a step that
                # stands in for the smoothing bias of a smooth, strongly curved lobe
                # raises it
                gain = n * math.log(base / trial_system.gcv(trial, gamma))
        # nor if the rest of the fit has to get much rougher for it (a step of the
        # lift itself, which a step of h'' only imitates)
        if (_misplaced(trial, at) or gain < GCV_GAIN or lam_trial < MIN_LEVEL_RATIO * lam):
            vetoed.append(at)
            in_a_row += 1
            if in_a_row >= MAX_REFUSED:
                break
            continue
        in_a_row = 0
        taus = trial
        scores.append(float(stat[i]))
        lam, system, fresh = lam_trial, trial_system, True
    if not taus:
        return None
    return _fit_result(grid, taus, lam, system.fit(taus), scores, values.copy())


def _cleared(pos: NDArray[np.float64], stat: NDArray[np.float64], points: list[float],
             reach: float) -> NDArray[np.float64]:
    """``stat`` set to 0 at the (ascending) positions ``pos`` within ``reach`` of any of
    ``points``."""
    out = stat.copy()
    for p in points:
        out[np.searchsorted(pos, p - reach, side='left'):
            np.searchsorted(pos, p + reach, side='right')] = 0.0
    return out


def _refine(system: LevelSystem, taus: list[float]) -> list[float]:
    """The last junction moved (within one node) to the minimum of the penalised
    residual, the others held (the level's system keeps their columns)."""
    last = taus[-1]
    lo, hi = max(last - 1.0, 1.0), min(last + 1.0, system.n - 2.0)
    # a bracket that has left +-MAX_MOVE of the scan's angle ends in a refusal: stop
    best = golden_minimum(lambda t: system.score(taus[:-1] + [t]).objective, lo, hi,
                          REFINE_ITERATIONS,
                          stop=lambda a, b: b < last - MAX_MOVE or a > last + MAX_MOVE)
    return taus[:-1] + [best]


def _misplaced(trial: list[float], at: float) -> bool:
    """The refined junction is refused for its place alone: within a node of another,
    or more than ``MAX_MOVE`` from the scan's angle ``at`` (the residual has no sharp
    step there)."""
    return (min((abs(trial[-1] - t) for t in trial[:-1]), default=math.inf) < 1.0
            or abs(trial[-1] - at) > MAX_MOVE)


class JunctionSpline:
    """The smooth part's interpolant plus the hinges: ``spline(x, nu)`` [m/rad^nu]."""

    def __init__(self, smooth: Callable[[NDArray[np.float64], int], NDArray[np.float64]],
                 junctions: JunctionFit) -> None:
        self.smooth = smooth
        self.junctions = junctions

    def __call__(self, x: NDArray[np.float64], nu: int = 0) -> NDArray[np.float64]:
        x = np.asarray(x, dtype=float)
        return self.smooth(x, nu) + self.junctions.hinge_part(x, nu)


def refit(grid: NDArray[np.float64], values: NDArray[np.float64],
          missing: NDArray[np.bool_], found: JunctionFit, lam_d: float,
          fills: int = 3) -> JunctionFit:
    """The fit with ``found``'s junctions at level ``lam_d``; nodes marked ``missing``
    (outliers, gaps, free end nodes) are refilled with the fit ``fills`` times, so that
    they end up carrying no weight (EM for the missing values)."""
    if (found.fitted_on is not None and lam_d == found.lam_d and not np.any(missing)
            and np.array_equal(found.fitted_on, values)):
        return found                    # the search's own last fit
    step = float(grid[1] - grid[0])
    taus = [(t - float(grid[0])) / step for t in found.angles]
    vals = values.copy()
    for _ in range(fills + 1 if np.any(missing) else 1):
        fit = partial_fit(vals, taus, lam_d)
        vals = np.where(missing, vals - fit.resid, values)
    return _fit_result(grid, taus, lam_d, fit, list(found.scores))
