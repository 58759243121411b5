"""Propagation helpers shared by the exact piecewise-linear solvers (``sdof`` and
``mdof_exact``, docs/dynamics.md): the matrix exponential of the augmented system, the
polynomial cam input at sub-nodes, the cubic-Hermite dip screen of the switching
functions and the bracketing of a switch on its Taylor polynomials, and the bookkeeping of a
lift-off from the seat (opening or bounce).

Polynomials on a step are held as monomial coefficients in sigma = t / step in [0, 1]
(``NB`` = degree + 1 of the cam input); ``FACT`` turns them into the basis sigma^j / j!
used by the propagators.
"""
from __future__ import annotations

import math
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import brentq

from cam_design.lift_laws.jet_table import DEGREE

NB = DEGREE + 1
FACT = np.array([math.factorial(j) for j in range(NB)], dtype=float)
BOUNCE_TOL = 1e-9             # m: smallest bounce (height bound) that is counted


def expm(g: NDArray) -> NDArray:
    """Matrix exponential of a small matrix: Taylor (order 18) with scaling and squaring.

    scipy.linalg.expm calls threaded LAPACK and costs milliseconds on 10x10 matrices
    under load; this costs ~30 us and is accurate to rounding for the balanced
    augmented matrices used here (norm scaled below 0.5 before the series).
    """
    norm = float(np.max(np.sum(np.abs(g), axis=0)))
    sq = max(0, int(math.ceil(math.log2(norm / 0.5)))) if norm > 0.5 else 0
    a = g / (2.0 ** sq)
    eye = np.eye(g.shape[0])
    e = eye + a / 18.0
    for n in range(17, 0, -1):
        e = eye + (a @ e) / n
    for _ in range(sq):
        e = e @ e
    return e


class SolverError(RuntimeError):
    """The solver could not finish (e.g. an endless chatter of events)."""


ARANGE = np.arange(64, dtype=float)


GRID9 = np.linspace(0.0, 1.0, 33)


VG9 = GRID9[None, :] ** np.arange(64)[:, None]


_SCREEN: dict[int, tuple[NDArray, NDArray]] = {}


_VANDER: dict[int, tuple[NDArray, NDArray]] = {}


def screen_grid(dense: int) -> tuple[NDArray, NDArray]:
    """(grid, VGD): 32 dense + 1 points on [0, 1] (``GRID9`` for dense = 1) and the
    (64, 2 points) matrix of the monomials t^j and their derivatives j t^(j-1) there."""
    hit = _SCREEN.get(dense)
    if hit is None:
        grid = np.linspace(0.0, 1.0, 32 * dense + 1)
        vg = grid[None, :] ** ARANGE[:, None]
        dvg = np.vstack([np.zeros((1, grid.size)), ARANGE[1:, None] * vg[:-1]])
        hit = (grid, np.hstack([vg, dvg]))
        _SCREEN[dense] = hit
    return hit


def horner2(c: NDArray, t: float) -> tuple[float, float]:
    """(p(t), p'(t)) of monomial coefficients c."""
    val = 0.0
    der = 0.0
    for x in c[::-1].tolist():
        der = der * t + val
        val = val * t + x
    return val, der


def vander(m: int) -> tuple[NDArray, NDArray]:
    """(NB, m) matrices: coeffs @ V gives p(j/m), coeffs @ dV gives p'(j/m), j=1..m."""
    hit = _VANDER.get(m)
    if hit is None:
        sig = np.arange(1, m + 1) / m
        jj = np.arange(NB)[:, None]
        vand = sig[None, :] ** jj
        dvand = np.zeros_like(vand)
        dvand[1:] = jj[1:] * sig[None, :] ** (jj[1:] - 1)
        hit = (vand, dvand)
        if len(_VANDER) < 256:
            _VANDER[m] = hit
    return hit


def vander0(m: int) -> tuple[NDArray, NDArray, NDArray]:
    """(NB, m+1) matrices giving p, p', p'' (sigma derivatives) at sigma = j/m, j=0..m."""
    sig = np.arange(m + 1) / m
    jj = np.arange(NB)[:, None]
    v0 = sig[None, :] ** jj
    v1 = np.zeros_like(v0)
    v1[1:] = jj[1:] * sig[None, :] ** (jj[1:] - 1)
    v2 = np.zeros_like(v0)
    v2[2:] = jj[2:] * (jj[2:] - 1) * sig[None, :] ** (jj[2:] - 2)
    return v0, v1, v2


def dips(f: NDArray, d: NDArray) -> NDArray:
    """True on each interval where the cubic Hermite interpolant of values f and slopes
    d (per unit of the interval), shape (..., m+1), goes below 0 -> (..., m).

    Cheap bound first: the cubic departs from the chord by at most
    (4/27)(|m0 - D| + |m1 - D|), D = p1 - p0; the exact minimum is computed only where
    that bound does not settle the question."""
    p0, p1 = f[..., :-1], f[..., 1:]
    m0, m1 = d[..., :-1], d[..., 1:]
    lo = np.minimum(p0, p1)
    chord = p1 - p0
    dev = (4.0 / 27.0) * (np.abs(m0 - chord) + np.abs(m1 - chord))
    out = lo < 0
    unsure = ~out & (lo - dev < 0)
    if not np.any(unsure):
        return out
    q0, q1, n0, n1 = p0[unsure], p1[unsure], m0[unsure], m1[unsure]
    a3 = 2 * q0 + n0 - 2 * q1 + n1
    a2 = -3 * q0 - 2 * n0 + 3 * q1 - n1
    a1 = n0
    qa, qb, qc = 3 * a3, 2 * a2, a1
    disc = qb * qb - 4 * qa * qc
    low = np.minimum(q0, q1)
    with np.errstate(divide='ignore', invalid='ignore'):
        sq = np.sqrt(np.maximum(disc, 0.0))
        small = np.abs(qa) < 1e-300
        r1 = np.where(small, -qc / np.where(qb == 0, np.inf, qb), (-qb - sq) / (2 * qa))
        r2 = np.where(small, r1, (-qb + sq) / (2 * qa))
        for r in (r1, r2):
            ok = (disc >= 0) & np.isfinite(r) & (r > 0) & (r < 1)
            val = ((a3 * r + a2) * r + a1) * r + q0
            low = np.where(ok, np.minimum(low, val), low)
    out[unsure] = low < 0
    return out


_VANDER0: dict[int, tuple[NDArray, NDArray, NDArray]] = {}


def sub_node_jets(ucoef: NDArray, m: int, omega: float, la: NDArray
                  ) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """Cam input at the m + 1 sub-nodes j/m of each step: u [m], du/dt [m/s],
    d2u/dt2 [m/s^2] from its (q, NB) monomials ``ucoef`` over step angles ``la`` [rad] at
    ``omega`` [rad/s], and the value matrix (for other polynomials on the same nodes)."""
    mats = _VANDER0.get(m)
    if mats is None:
        mats = vander0(m)
        if len(_VANDER0) < 256:
            _VANDER0[m] = mats
    v0, v1, v2 = mats
    rate = (omega / la)[:, None]
    return ucoef @ v0, (ucoef @ v1) * rate, (ucoef @ v2) * rate * rate, v0


_BINOM = np.array([[math.comb(j, n) for j in range(NB)] for n in range(NB)], dtype=float)


_POW = np.array([[j - n if j >= n else 0 for j in range(NB)] for n in range(NB)])


_SHIFT: dict[tuple[float, float], NDArray] = {}


def shift(c: NDArray, a: float, w: float) -> NDArray:
    """Monomial coefficients of p(a + w t) from those of p(sigma) (last axis)."""
    if a == 0.0 and w == 1.0:
        return c
    mat = _SHIFT.get((a, w))
    if mat is None:
        mat = (_BINOM * np.power(a, _POW) * (w ** np.arange(NB))[:, None]).T
        if len(_SHIFT) < 4096:      # sub-step starts j/m and widths 1/m repeat
            _SHIFT[(a, w)] = mat
    return c @ mat


def eval_min(comp: tuple[float, list[list[float]]], t: float) -> tuple[float, float]:
    """sign * min_i P_i(t) and the derivative of the active P_i (Horner)."""
    sign, polys = comp
    best = math.inf
    dbest = 0.0
    for c in polys:
        val = der = 0.0
        for x in c:
            der = der * t + val
            val = val * t + x
        if val < best:
            best, dbest = val, der
    return sign * best, sign * dbest


def poly_root(c: list[float], a: float, b: float, fa: float) -> float:
    """Root in [a, b] of the polynomial c (Horner order) changing sign there
    (safeguarded Newton from the secant point)."""
    def ev(t: float) -> tuple[float, float]:
        val = der = 0.0
        for x in c:
            der = der * t + val
            val = val * t + x
        return val, der

    fb = ev(b)[0]
    x = a - fa * (b - a) / (fb - fa) if fb != fa else 0.5 * (a + b)
    up = fb > fa
    for _ in range(60):
        if not a <= x <= b:
            x = 0.5 * (a + b)
        f, d = ev(x)
        if f == 0.0:
            return x
        if (f < 0) == up:
            a = x
        else:
            b = x
        xn = x - f / d if d != 0 else 0.5 * (a + b)
        if not a < xn < b:
            xn = 0.5 * (a + b)
        if abs(xn - x) < 1e-15 or b - a < 1e-15:
            return xn
        x = xn
    return 0.5 * (a + b)


def newton_bracket(comp: tuple[float, list[list[float]]], a: float,
                   b: float) -> tuple[float, float]:
    """[a, b] with f(a) >= 0 > f(b), f = sign * min_i P_i, shrunk to ~1e-14.

    The components are smooth: each one's own root is found by Newton, and the switch
    is the first component root (sign +1: a component drops below 0) or the last one
    (sign -1: every component has become positive); bisection on f is the fallback.
    """
    sign, polys = comp
    roots = []
    for c in polys:
        pa = eval_min((1.0, [c]), a)[0]
        pb = eval_min((1.0, [c]), b)[0]
        if sign > 0 and pb < 0 <= pa:
            roots.append(poly_root(c, a, b, pa))
        elif sign < 0 and pa <= 0 < pb:
            roots.append(poly_root(c, a, b, pa))
    if roots:
        x = min(roots) if sign > 0 else max(roots)
        lo, hi = max(a, x - 1e-14), min(b, x + 1e-14)
        if eval_min(comp, hi)[0] < 0 and eval_min(comp, lo)[0] >= 0:
            return lo, hi
    for _ in range(200):           # fallback: bisection on f
        if b - a <= 1e-14:
            break
        m = 0.5 * (a + b)
        if eval_min(comp, m)[0] >= 0:
            a = m
        else:
            b = m
    return a, b


def bracket(fun: Any, a: float, b: float, fa: float, fb: float) -> tuple[float, float]:
    """Shrink [a, b] with fun(a) >= 0 > fun(b) to width ~1e-14 (Brent, then a check
    that the returned upper end is strictly past the switch)."""
    x = brentq(fun, a, b, xtol=1e-15, rtol=1e-15, maxiter=200)
    lo, hi = max(a, x - 1e-14), min(b, x + 1e-14)
    for _ in range(60):
        if fun(hi) < 0 or hi >= b:
            break
        hi = min(b, hi + 2 * (hi - x) + 1e-14)
    if fun(hi) >= 0:
        hi = b
    if fun(lo) < 0:
        lo = a
    return lo, hi


class LiftOffEvents(Protocol):
    """The events a lift-off updates (``sdof_run.Events``, ``mdof_exact.MdofEvents``)."""

    opening: float | None
    bounce_count: int


class LiftOffRun(Protocol):
    """The run state a lift-off updates (``sdof_run.SdofRun``, ``mdof_exact._Run``)."""

    peak: float
    lift_off: float | None
    start_open: bool
    seated_once: bool
    opened: bool
    next_cycle: list[list[float]] | None

    @property
    def ev(self) -> LiftOffEvents: ...


def free_flight_height(mass: float, v_up: float, preload: float) -> float:
    """Upper bound [m] of the height a valve of ``mass`` [kg] leaving the seat at
    ``v_up`` [m/s] reaches against the spring ``preload`` [N]: m v^2 / (2 F0) (inf
    without preload)."""
    return mass * v_up * v_up / (2.0 * preload) if preload > 0 else math.inf


def reopen(run: LiftOffRun, alpha: float, height: float, forced: bool = False) -> None:
    """Lift-off from the seat at the cam angle ``alpha`` [rad]: the opening (the first
    lift-off), or after the first seating a bounce when its free-flight height bound
    ``height`` [m] (:func:`free_flight_height`) reaches ``BOUNCE_TOL`` (reopenings of
    1e-10 m on a penalty seat at crawl speed are not bounces) or the lift-off is
    ``forced`` (a held valve released from a hard seat). A revolution that started
    open begins collecting the next cycle's open phase here."""
    run.peak = 0.0
    run.lift_off = alpha
    if run.start_open and run.seated_once:
        run.next_cycle = []    # an open phase of the next cycle may start here
    if not run.opened:
        run.opened = True
        run.ev.opening = alpha
    elif run.seated_once and (height >= BOUNCE_TOL or forced):
        run.ev.bounce_count += 1
