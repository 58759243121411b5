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
refusals are cheap. The fits are ``partial_spline.LevelSystem``s, one per level, which
keep what they have solved (the factor, R y, each junction's windowed column and its
products), so a set of junctions at a level already met costs only its new columns and
a dense system of size 2J; the level is searched on one lattice of half decades per
table (``Levels``), so successive candidates meet the same levels. The scan is one
real FFT of the residual against cached spectra of the hinges (a correlation for
right-opening and a convolution for left-opening junctions) and is reused while
candidates are refused. A candidate is first scored at the present level and
unrefined angle (a pre-test); only one within ``PRETEST_SLACK`` of the bar gets its
angle refined, and only one whose refined angle stays by the scan's gets the level
chosen again; the search stops after ``MAX_REFUSED`` refusals in a row.

Look-ahead. Junctions that are only worth their price together (the four edges of a
dwell: the smoothing level can rise only when all are in) each fail the GCV test alone,
the known weakness of forward selection with jointly useful terms. A candidate refused
by that test alone is held (up to ``MAX_PENDING``; it still counts as a refusal) and a
later candidate that fails alone is tried with the held ones: the set is kept when it
lowers N ln(GCV) by the bar per junction added, the held ones add the bar each to what
the candidate does alone, and the level of the rest rises ``LOOKAHEAD_LEVEL_RISE``
times. Past ``MAX_REFUSED`` refusals in a row the search tries one more candidate per
held one, only to complete a set.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from functools import lru_cache, partial
from typing import Callable

import numpy as np
from numpy.typing import NDArray
from scipy.fft import irfft, next_fast_len, rfft

from cam_design.lift_table.hinges import (hinge_coefficients, hinge_values, horner,
                                          ramp_hinge, side_of, taper_nodes)
from cam_design.lift_table.partial_spline import (LevelSystem, PartialFit, interior_grams,
                                                  partial_fit, residual_operator)

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
#: candidates refused by the GCV test alone that are held and tried again together with
#: the next one (look-ahead): the junctions of a dwell or a circular-arc cam lower the
#: score only together, as the level can rise only when every step of h'' is explained
#: (a rounded dwell table at 0.5 deg: one junction 7, two 17, three 28, all four 87)
MAX_PENDING = 3
#: a set taken by the look-ahead must raise the smoothing level of the rest at least
#: this many times (the way such junctions pay together; on the accuracy benchmark's
#: tables at 0.1-2.5 deg the sets of true junctions raised it 2-1e5 times, the four
#: edges of a rounded dwell 70-90 times, the sets with a false member 1.3-5.7 times:
#: spikes, h''' kinks, the fall of the narrow-peak lobe's acceleration peak at 1 deg)
LOOKAHEAD_LEVEL_RISE = 10.0
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


def lattice_minimum(fun: Callable[[float], float], lattice: NDArray[np.float64],
                    iterations: int) -> tuple[float, int]:
    """(minimiser, index of the best lattice point) of ``fun`` over the span of
    ``lattice``: the best of the lattice, then golden section between its neighbours."""
    i = int(np.argmin([fun(v) for v in lattice]))
    a, b = lattice[max(i - 1, 0)], lattice[min(i + 1, lattice.size - 1)]
    return golden_minimum(fun, a, b, iterations), i


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

    def on_lattice(self, lam_d: float) -> float:
        """The lattice level nearest to ``lam_d`` (``lam_d`` itself before the lattice is
        anchored)."""
        if self.anchor is None:
            return lam_d
        h = LEVEL_STEP      # the level as choose_level forms it at its start (k = 0)
        steps = round((math.log10(max(lam_d, 1e-6)) - self.anchor) / h)
        return 10.0 ** (self.anchor + h * steps)

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

    # downhill (GCV is unimodal in the level near its minimum): a lower score one step
    # up already says which way, the step down is then not scored
    d = 1 if score(1) < score(0) or score(-1) >= score(1) else -1
    best = 0
    while abs(best) < LEVEL_REACH and score(best + d) < score(best):
        best += d
    a, b, c = score(best - 1), score(best), score(best + 1)
    curve = a - 2.0 * b + c
    shift = 0.5 * (a - c) / curve if curve > 0.0 else 0.0
    return 10.0 ** (c0 + (best + shift) * h)


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
    k = len(SCAN_OFFSETS)
    # the products with the hinges' spectra, one batch of inverse FFTs: rows [0, k)
    # correlate (right-opening junctions), rows [k, 2k) convolve (left-opening)
    prod = np.empty((2 * k, spectra.shape[-1]), dtype=complex)
    var = np.empty(k)
    for col, off in enumerate(SCAN_OFFSETS):
        m, v = interior_grams(float(lam_d), length, 1, off)
        # efficient score of the step of h'' with a step of h''' free: w'b, w = (1, -k)
        w = np.array([1.0, -m[0, 1] / m[1, 1]])
        var[col] = max(float(w @ v @ w) * sigma ** 2, 1e-300)
        kern = spectra[col, 1] * w[1]      # + spectra[col, 0] * w[0], w[0] = 1
        kern += spectra[col, 0]
        np.multiply(e, kern, out=prod[k + col])
        np.multiply(e, np.conjugate(kern, out=kern), out=prod[col])
    # right: b(j) = sum_i g(i - off) e_{j+i}; left (the table reversed):
    # b(j) = sum_i g(i - off) e_{n-1-j-i}
    b = irfft(prod, nfft, axis=-1)
    pos_r, pos_l = _scan_positions(n)
    mid = 0.5 * (n - 1)
    r0 = int(np.searchsorted(pos_r, margin, side='left'))
    r1 = int(np.searchsorted(pos_r, mid, side='right'))
    l0 = int(np.searchsorted(pos_l, mid, side='right'))
    l1 = int(np.searchsorted(pos_l, n - 1 - margin, side='right'))
    return (np.concatenate([pos_r[r0:r1], pos_l[l0:l1]]),
            np.concatenate([_statistic(b[:k, :n], var, r0, r1),
                            _statistic(b[k:, n - 1::-1], var, k * n - l1, k * n - l0)[::-1]]))


def _statistic(b: NDArray[np.float64], var: NDArray[np.float64], p0: int, p1: int
               ) -> NDArray[np.float64]:
    """Entries [p0, p1) of (b^2 / var).T.ravel() (b: offsets x nodes; the scan's
    positions node by node, offset by offset), formed on the nodes they need only."""
    k = b.shape[0]
    j0, j1 = p0 // k, -(-p1 // k)
    return (b[:, j0:j1] ** 2 / var[:, None]).T.ravel()[p0 - k * j0:p1 - k * j0]


@dataclass(frozen=True)
class JunctionFit:
    """The partial-spline fit with its junctions: ``angles`` [rad], acceleration
    ``jumps`` [m/rad^2] (h''(t+) - h''(t-)), the discrete level ``lam_d``, the smooth
    part ``smooth`` [m] on the grid, ``edf``, the search statistics ``scores``;
    ``step`` [rad], ``x0`` [rad], ``nodes`` and ``coef`` (node units) for the hinges;
    ``fitted_on``: the grid values [m] of the fit, where they are kept; ``widths``
    [nodes] per junction, where h'' changes linearly over that width centred on the
    angle instead of stepping (``ramp_hinge``; empty: every one a step); ``system``:
    the search's level system at ``lam_d`` (its junctions' columns solved), where
    kept."""

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
    widths: tuple[float, ...] = ()
    system: LevelSystem | None = field(default=None, repr=False, compare=False)

    def width(self, k: int) -> float:
        """Width [nodes] of junction ``k``'s change of h'' (0: a step)."""
        return self.widths[k] if self.widths else 0.0

    def hinge_part(self, x: NDArray[np.float64], nu: int = 0) -> NDArray[np.float64]:
        """Sum of the hinges' nu-th derivative [m/rad^nu] at ``x`` [rad]."""
        x = np.asarray(x, dtype=float)
        u = ((x - self.x0) / self.step).ravel()
        out = np.zeros(u.size)
        length = taper_nodes(self.nodes)
        cubic = hinge_coefficients(float(length), nu)[1]
        # ascending points (a grid): each hinge's points are a slice, found by bisection
        ascending = u.size > 1 and bool(np.all(u[1:] >= u[:-1]))
        for k, t in enumerate(self.angles):
            tau = (t - self.x0) / self.step
            side = side_of(tau, self.nodes)
            c2, c3 = self.coef[2 * k:2 * k + 2] * float(side) ** nu
            width = self.width(k)
            # formed on the points the hinge opens to only (beyond them it adds 0): a
            # slice of ``out`` (a view) on ascending points, else its indices
            on: slice | NDArray[np.intp]
            if ascending:
                on = (slice(int(np.searchsorted(u, tau, side='right')), u.size) if side > 0
                      else slice(0, int(np.searchsorted(u, tau, side='left'))))
            else:
                on = np.flatnonzero(side * u > side * tau)
            v = side * (u[on] - tau)
            if width > 0.0:     # a ramp of h'' in place of the quadratic hinge
                out += c2 * ramp_hinge(side * (u - tau), width, nu)
            # the quadratic hinge: v^2/2, v, 1, 0 on v > 0 (Horner's values)
            elif nu == 0:
                out[on] += c2 * ((0.5 * v) * v)
            elif nu == 1:
                out[on] += c2 * v
            elif nu == 2:
                out[on] += c2
            near = v < length
            taper = c3 * horner(v[near], cubic)
            if ascending:
                out[on][near] += taper
            else:
                out[np.asarray(on)[near]] += taper      # the indices themselves
        return out.reshape(x.shape) / self.step ** nu


def fit_result(grid: NDArray[np.float64], taus: list[float], lam_d: float,
               fit: PartialFit, scores: list[float],
               fitted_on: NDArray[np.float64] | None = None,
               widths: tuple[float, ...] = ()) -> JunctionFit:
    """The JunctionFit of the partial-spline ``fit`` with junctions at node positions
    ``taus`` on ``grid`` [rad] (each a change of h'' over ``widths`` nodes, 0 or none:
    steps), ordered by angle."""
    step = float(grid[1] - grid[0])
    n = grid.size
    order = np.argsort(taus)
    coef = np.concatenate([fit.coef[2 * i:2 * i + 2] for i in order])
    jumps = tuple(side_of(taus[i], n) * float(fit.coef[2 * i]) / step ** 2 for i in order)
    return JunctionFit(tuple(float(grid[0] + taus[i] * step) for i in order), jumps,
                       lam_d, fit.smooth, fit.edf, tuple(scores[i] for i in order), step,
                       float(grid[0]), n, coef, fitted_on,
                       tuple(widths[i] for i in order) if widths else ())


def find_junctions(grid: NDArray[np.float64], values: NDArray[np.float64], lam0: float,
                   *, gamma: float = 1.0, sigma_floor: float = 0.0,
                   false_alarm: float = FALSE_ALARM,
                   lookahead: bool = True) -> JunctionFit | None:
    """Greedy junction search and partial-spline fit of uniform ``values`` [m] on
    ``grid`` [rad], starting from the plain smoother's level ``lam0``. None when no
    junction is significant (the plain smoothing spline stands). ``lookahead``: hold
    candidates refused by the GCV test alone and try them as a set (else each
    candidate is judged alone)."""
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
    pending: list[float] = []       # refused by the GCV test alone, tried again together
    pending_scores: list[float] = []
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
        # past MAX_REFUSED refusals in a row the search only goes on to complete the
        # held candidates: a candidate alone is not taken there (none of the law's
        # junctions came that late, see MAX_REFUSED)
        completing = in_a_row >= MAX_REFUSED
        alone = None if completing else _attempt(system, levels, taus, [], at, lam, base,
                                                 gamma)
        taken = alone if alone is not None and alone.passes() else None
        if taken is None and pending and (alone is None or alone.placed):
            # the held candidates with this one: kept when the set pays the bar per
            # junction, raises the level of the rest, and the held ones add the bar
            # each to what this one does alone
            joint = _attempt(system, levels, taus, pending, at, lam, base, gamma)
            if joint.passes() and joint.lam_d >= LOOKAHEAD_LEVEL_RISE * lam:
                alone = alone or _attempt(system, levels, taus, [], at, lam, base, gamma)
                if joint.gain - alone.gain >= GCV_GAIN * len(pending):
                    taken = joint
        if taken is None:
            vetoed.append(at)
            in_a_row += 1
            if (not completing and alone is not None and alone.refused_by_gcv_only()
                    and len(pending) < (MAX_PENDING if lookahead else 0)):
                pending.append(alone.trial[-1])
                pending_scores.append(float(stat[i]))
            if in_a_row >= MAX_REFUSED + len(pending):
                break
            continue
        in_a_row = 0
        if taken is not alone:
            scores += pending_scores
            pending, pending_scores = [], []
        taus = taken.trial
        scores.append(float(stat[i]))
        lam, system, fresh = taken.lam_d, levels.at(taken.lam_d), True
    if not taus:
        return None
    return replace(fit_result(grid, taus, lam, system.fit(taus), scores, values.copy()),
                   system=system)


def _cleared(pos: NDArray[np.float64], stat: NDArray[np.float64], points: list[float],
             reach: float) -> NDArray[np.float64]:
    """``stat`` set to 0 at the (ascending) positions ``pos`` within ``reach`` of any of
    ``points``."""
    out = stat.copy()
    for p in points:
        out[np.searchsorted(pos, p - reach, side='left'):
            np.searchsorted(pos, p + reach, side='right')] = 0.0
    return out


@dataclass(frozen=True)
class _Attempt:
    """One candidate set tried by the search: junctions ``trial`` (node positions, the
    last one the candidate, refined), the level ``lam_d`` chosen with them, the drop
    ``gain`` of N ln(GCV), and whether the candidate stays where the scan put it
    (``placed``) and keeps the level of the rest (``level_kept``)."""

    trial: list[float]
    added: int
    lam_d: float
    gain: float
    placed: bool
    level_kept: bool

    def passes(self) -> bool:
        """Kept: placed, the level kept, and N ln(GCV) lower by the bar for each
        junction added."""
        return self.placed and self.level_kept and self.gain >= GCV_GAIN * self.added

    def refused_by_gcv_only(self) -> bool:
        """A single candidate that lowers GCV, but by less than the bar."""
        return (self.added == 1 and self.placed and self.level_kept
                and 0.0 < self.gain < GCV_GAIN)


def _attempt(system: LevelSystem, levels: Levels, taus: list[float], held: list[float],
             at: float, lam: float, base: float, gamma: float) -> _Attempt:
    """The junctions ``taus`` taken, the candidates ``held`` and one at node ``at``
    (node positions), scored against the GCV score ``base`` of the present fit (level
    ``lam``). A set with held candidates is only of use if it raises the level
    LOOKAHEAD_LEVEL_RISE times: when its GCV score (unimodal in the level) already
    rises from sqrt(LOOKAHEAD_LEVEL_RISE) to LOOKAHEAD_LEVEL_RISE times the present
    level, it is scored at the present level and the scan's angle (neither refined
    nor searched)."""
    n = system.n
    bar = GCV_GAIN * (len(held) + 1)
    held = taus + held
    # pre-test at the present level and the scan's angle: refining the angle and
    # choosing the level again lowers the score by more, but on the accuracy
    # benchmark almost never by PRETEST_SLACK more (constants above), so a junction
    # far below the bar is refused without either
    quick = n * math.log(base / system.gcv(held + [at], gamma))
    if quick >= bar - PRETEST_SLACK and not (len(held) > len(taus) and _climbs(
            levels, held + [at], lam, gamma)):
        trial, lam_trial, gain = _refine(system, held + [at]), lam, quick
        # a junction refused for its place needs no level search
        if not _misplaced(trial, at):
            lam_trial = choose_level(system.values, trial, gamma, lam, levels)
            # kept only if it lowers the GCV score of the whole fit: a step that
            # stands in for the smoothing bias of a smooth, strongly curved lobe
            # raises it
            gain = n * math.log(base / levels.at(lam_trial).gcv(trial, gamma))
    else:
        trial, lam_trial, gain = held + [at], lam, quick
    # nor if the rest of the fit has to get much rougher for it (a step of the lift
    # itself, which a step of h'' only imitates), nor if it is refused for its place
    placed = not _misplaced(trial, at)
    return _Attempt(trial, len(trial) - len(taus), lam_trial, gain, placed,
                    lam_trial >= MIN_LEVEL_RATIO * lam)


def _climbs(levels: Levels, taus: list[float], lam: float, gamma: float) -> bool:
    """The GCV score with junctions ``taus`` is higher at LOOKAHEAD_LEVEL_RISE times
    the level ``lam`` than at its square root times: its minimum (GCV is unimodal in
    the level) lies below LOOKAHEAD_LEVEL_RISE x ``lam``. Both levels are taken on the
    search's lattice (``Levels.on_lattice``), where the level searches have already
    built their systems and the columns of the junctions taken."""
    rise = LOOKAHEAD_LEVEL_RISE
    return bool(levels.at(levels.on_lattice(lam * rise)).gcv(taus, gamma)
                >= levels.at(levels.on_lattice(lam * math.sqrt(rise))).gcv(taus, gamma))


def _refine(system: LevelSystem, taus: list[float]) -> list[float]:
    """The last junction moved (within one node) to the minimum of the penalised
    residual, the others held (the level's system keeps their columns)."""
    last = taus[-1]
    lo, hi = max(last - 1.0, 1.0), min(last + 1.0, system.n - 2.0)
    fixed = taus[:-1]
    objective: Callable[[float], float]
    if (system.interior(lo) and system.interior(hi)
            and side_of(lo, system.n) == side_of(hi, system.n)):
        # the same penalised residual without solving each trial angle's column
        objective = partial(system.moved_objective, fixed)
    else:
        objective = partial(_objective, system, fixed)
    # a bracket that has left +-MAX_MOVE of the scan's angle ends in a refusal: stop
    best = golden_minimum(objective, lo, hi,
                          REFINE_ITERATIONS,
                          stop=lambda a, b: b < last - MAX_MOVE or a > last + MAX_MOVE)
    return taus[:-1] + [best]


def _objective(system: LevelSystem, fixed: list[float], tau: float) -> float:
    """Penalised residual [m^2] of the fit with ``fixed`` plus a junction at ``tau``."""
    return system.score(fixed + [tau]).objective


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
    widths = [found.width(k) for k in range(len(taus))]
    vals = values.copy()
    for _ in range(fills + 1 if np.any(missing) else 1):
        fit = (ramp_fit(vals, taus, widths, lam_d) if any(widths)
               else partial_fit(vals, taus, lam_d))
        vals = np.where(missing, vals - fit.resid, values)
    return fit_result(grid, taus, lam_d, fit, list(found.scores), widths=found.widths)


def ramp_columns(n: int, taus: list[float], widths: list[float]) -> NDArray[np.float64]:
    """(n, 2J): per junction at node ``taus[j]`` (opening on its longer side) the change
    of h'' over ``widths[j]`` nodes (``ramp_hinge``) and the tapered step of h''' of the
    partial spline's hinge pair (node units)."""
    rows = np.arange(n, dtype=float)
    length = taper_nodes(n)
    g = np.zeros((n, 2 * len(taus)))
    for j, (tau, width) in enumerate(zip(taus, widths)):
        u = side_of(tau, n) * (rows - tau)
        g[:, 2 * j] = ramp_hinge(u, width)
        g[:, 2 * j + 1] = hinge_values(u, length)[:, 1]
    return g


def ramp_fit(values: NDArray[np.float64], taus: list[float], widths: list[float],
             lam_d: float) -> PartialFit:
    """The partial spline of uniform ``values`` [m] at level ``lam_d`` with the hinges
    of ``ramp_columns`` (a change of h'' over ``widths[j]`` nodes at node ``taus[j]``):
    the fit of ``partial_fit`` (whose hinges are steps, width 0) with the columns
    solved on the whole table (for coarse tables: at most a few hundred rows)."""
    system = LevelSystem(values, lam_d)
    g = ramp_columns(values.size, taus, widths)
    rg = residual_operator(g, lam_d)
    m = g.T @ rg
    m += 1e-13 * np.trace(m) * np.eye(m.shape[0])
    sol = np.linalg.solve(m, np.column_stack([rg.T @ values, rg.T @ rg]))
    coef = np.asarray(sol[:, 0], dtype=np.float64)
    resid = system.ry - rg @ coef
    z = values - g @ coef
    return PartialFit(z - resid, coef, float(resid @ resid),
                      system.trace + float(np.trace(sol[:, 1:])), float(z @ resid), resid)
