"""Composable lift-law segments with analytic derivatives, and the piecewise law.

Every segment is a function f(u) of an affine variable ``u = (alpha - origin) / scale``
with analytic d^n f / du^n (n = 0..3); its alpha-derivatives are
``f^(n)(u) / scale**n``. A negative ``scale`` mirrors the segment, so the fall flank
of a symmetric lobe is the rise flank with the sign of ``scale`` and ``origin``
flipped (``Segment.mapped``).

Flanks are built in a *flank coordinate* t [rad]: t = 0 where the follower leaves the
base circle, t = T at the nose. ``assemble_lobe`` maps the rise flank to alpha = t - T
(alpha < 0) and the fall flank to alpha = T - t (alpha > 0), as architecture.md
requires (alpha from the lobe centreline, rise flank at alpha < 0).

``PiecewiseLaw`` locates segments with ``np.searchsorted`` and checks every junction
(including the two support edges, where the base circle is the neighbour) with the
analytic derivatives, never with finite differences.
"""
from __future__ import annotations

import dataclasses
import math
from fractions import Fraction
from typing import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cam_design.errors import InputError
from cam_design.lift_laws.base import MAX_ORDER, LiftLaw

#: relative tolerance of the junction check (times the largest |h^(n)| on the support)
JUNCTION_RTOL = 1e-8


@dataclasses.dataclass(frozen=True)
class Segment:
    """Base class: f(u) on alpha in [lo, hi] with u = (alpha - origin) / scale."""

    lo: float
    hi: float
    origin: float
    scale: float

    def du(self, u: NDArray[np.float64], nu: int) -> NDArray[np.float64]:
        """d^nu f / du^nu at ``u`` (subclasses)."""
        raise NotImplementedError

    def __call__(self, alpha: NDArray[np.float64] | float, nu: int = 0) -> NDArray[np.float64]:
        """nu-th alpha-derivative at ``alpha`` [rad] (no range check)."""
        u = (np.asarray(alpha, dtype=float) - self.origin) / self.scale
        return self.du(u, nu) / self.scale ** nu

    def mapped(self, sign: int, shift: float) -> 'Segment':
        """The same function of t re-expressed in alpha, where t = sign * alpha + shift."""
        ends = sorted((sign * (self.lo - shift), sign * (self.hi - shift)))
        return dataclasses.replace(self, lo=ends[0], hi=ends[1],
                                   origin=sign * (self.origin - shift),
                                   scale=sign * self.scale)


@dataclasses.dataclass(frozen=True)
class PowerSegment(Segment):
    """Sparse power sum f(u) = sum_k c_k u^k (integer exponents k >= 0, up to ~60)."""

    coefficients: tuple[tuple[int, float], ...] = ()

    def du(self, u: NDArray[np.float64], nu: int) -> NDArray[np.float64]:
        out = np.zeros_like(u)
        for k, c in self.coefficients:
            if k < nu or c == 0.0:
                continue
            out += c * math.perm(k, nu) * u ** (k - nu)
        return out


@dataclasses.dataclass(frozen=True)
class CosineSegment(Segment):
    """Finite cosine series f(u) = sum_j a_j cos(j pi u)."""

    amplitudes: tuple[float, ...] = ()

    def du(self, u: NDArray[np.float64], nu: int) -> NDArray[np.float64]:
        out = np.zeros_like(u)
        for j, a in enumerate(self.amplitudes):
            if a == 0.0 or (j == 0 and nu > 0):
                continue
            w = j * math.pi
            # d^n cos(w u) = w^n cos(w u + n pi / 2)
            out += a * w ** nu * np.cos(w * u + nu * math.pi / 2)
        return out


@dataclasses.dataclass(frozen=True)
class ShapeSegment(Segment):
    """f(u) = p0 + p1 u + q S2(u) with f'' = q s(u): an acceleration shape s on [0, 1].

    ``shape`` is one of SHAPES; for 'polynomial', ``poly`` holds s(u) = sum poly[k] u^k.
    S1 and S2 are the first and second integrals of s from 0.
    """

    p0: float = 0.0
    p1: float = 0.0
    q: float = 0.0
    shape: str = 'constant'
    poly: tuple[float, ...] = ()

    def du(self, u: NDArray[np.float64], nu: int) -> NDArray[np.float64]:
        if nu == 0:
            return self.p0 + self.p1 * u + self.q * shape_integral(self.shape, self.poly, u, 2)
        if nu == 1:
            return self.p1 + self.q * shape_integral(self.shape, self.poly, u, 1)
        return self.q * shape_integral(self.shape, self.poly, u, 2 - nu)


SHAPES = ('constant', 'half_sine', 'quarter_sine', 'quarter_cosine', 'polynomial')


def shape_integral(shape: str, poly: Sequence[float], u: NDArray[np.float64],
                   order: int) -> NDArray[np.float64]:
    """s(u) integrated ``order`` times from 0 (order 2, 1, 0) or differentiated (-1)."""
    u = np.asarray(u, dtype=float)
    pi = math.pi
    if shape == 'constant':
        return {2: u * u / 2, 1: u, 0: np.ones_like(u), -1: np.zeros_like(u)}[order]
    if shape == 'half_sine':          # s = sin(pi u)
        w = pi
        return {2: (u - np.sin(w * u) / w) / w, 1: (1 - np.cos(w * u)) / w,
                0: np.sin(w * u), -1: w * np.cos(w * u)}[order]
    if shape == 'quarter_sine':       # s = sin(pi u / 2), 0 -> 1
        w = pi / 2
        return {2: (u - np.sin(w * u) / w) / w, 1: (1 - np.cos(w * u)) / w,
                0: np.sin(w * u), -1: w * np.cos(w * u)}[order]
    if shape == 'quarter_cosine':     # s = cos(pi u / 2), 1 -> 0
        w = pi / 2
        return {2: (1 - np.cos(w * u)) / (w * w), 1: np.sin(w * u) / w,
                0: np.cos(w * u), -1: -w * np.sin(w * u)}[order]
    if shape == 'polynomial':
        out = np.zeros_like(u)
        for k, a in enumerate(poly):
            if order >= 0:
                out += a * u ** (k + order) / math.perm(k + order, order)
            elif k >= 1:
                out += a * k * u ** (k - 1)
        return out
    raise InputError('shape', shape, 'one of ' + ', '.join(SHAPES))


@dataclasses.dataclass(frozen=True)
class Junction:
    """A junction between two pieces (or a piece and the base circle)."""

    alpha: float          # rad
    required: int         # order the family guarantees
    achieved: int         # highest order whose jump is within tolerance (-1: h jumps)
    jumps: tuple[float, ...]   # |left - right| for nu = 0..3 (SI units)


class PiecewiseLaw(LiftLaw):
    """A lift law made of contiguous segments; h = 0 outside them.

    ``required`` gives, for every junction (support lo, interior boundaries in order,
    support hi), the continuity order the family guarantees; construction raises
    InputError (naming ``key``) if the analytic derivatives violate it.
    """

    def __init__(self, segments: Sequence[Segment], required: Sequence[int], *,
                 key: str = 'lift_law', name: str = 'piecewise') -> None:
        segs = sorted(segments, key=lambda s: s.lo)
        if not segs:
            raise InputError(key, 'no segments', 'at least one segment')
        for a, b in zip(segs, segs[1:]):
            if abs(a.hi - b.lo) > 1e-12 * max(1.0, abs(a.hi)):
                raise InputError(key, (a.hi, b.lo), 'contiguous segments')
        if len(required) != len(segs) + 1:
            raise InputError(key, len(required), f'{len(segs) + 1} junction orders')
        for s in segs:
            if not (s.hi > s.lo):
                raise InputError(key, (s.lo, s.hi), 'segments of positive width')
        if segs[0].lo < -math.pi - 1e-12 or segs[-1].hi > math.pi + 1e-12:
            raise InputError(key, f'support {math.degrees(segs[0].lo):.6g} .. '
                             f'{math.degrees(segs[-1].hi):.6g} deg',
                             'a lobe within -180 .. 180 deg (alpha is wrapped to (-pi, pi])')
        self.segments = tuple(segs)
        self.name = name
        self.key = key
        self._los = np.array([s.lo for s in segs])
        self._support = (segs[0].lo, segs[-1].hi)
        self._junctions = self._check(list(required))
        self.continuity_order = min(j.achieved for j in self._junctions)

    @property
    def support(self) -> tuple[float, float]:
        return self._support

    @property
    def junctions(self) -> tuple[float, ...]:
        return tuple(j.alpha for j in self._junctions)

    @property
    def junction_report(self) -> tuple[Junction, ...]:
        """Every junction with its required and achieved order and the jumps."""
        return self._junctions

    def _evaluate(self, alpha: NDArray[np.float64], nu: int) -> NDArray[np.float64]:
        idx = np.clip(np.searchsorted(self._los, alpha, side='right') - 1,
                      0, len(self.segments) - 1)
        out = np.empty_like(alpha)
        for k in np.unique(idx):
            m = idx == k
            out[m] = self.segments[k](alpha[m], nu)
        return out

    def derivatives(self, alpha: ArrayLike) -> NDArray[np.float64]:
        """(4, n): the derivatives 0..3 at the flattened ``alpha`` (segments located once)."""
        a = np.asarray(alpha, dtype=float).reshape(-1)
        out = np.zeros((MAX_ORDER + 1, a.size))
        lo, hi = self._support
        inside = np.nonzero((a >= lo) & (a <= hi))[0]
        if inside.size == 0:
            return out
        ai = a[inside]
        idx = np.clip(np.searchsorted(self._los, ai, side='right') - 1,
                      0, len(self.segments) - 1)
        for k in np.unique(idx):
            m = inside[idx == k]
            seg = self.segments[k]
            for nu in range(MAX_ORDER + 1):
                out[nu, m] = seg(a[m], nu)
        return out

    def _scales(self) -> NDArray[np.float64]:
        lo, hi = self._support
        grid = np.linspace(lo, hi, 2001)
        grid = np.concatenate([grid, [s.lo for s in self.segments], [hi]])
        return np.array([np.max(np.abs(self._evaluate(grid, nu))) for nu in range(4)])

    def _check(self, required: list[int]) -> tuple[Junction, ...]:
        scales = self._scales()
        if not np.all(np.isfinite(scales)):
            raise InputError(self.key, 'non-finite lift or derivatives',
                             'parameters giving a finite law')
        tol = JUNCTION_RTOL * np.maximum(scales, 1e-300)
        out = []
        pieces: list[Segment | None] = [None, *self.segments, None]
        for k, req in enumerate(required):
            left, right = pieces[k], pieces[k + 1]
            if right is not None:
                at = float(right.lo) + 0.0   # no -0.0
            else:                            # the end: the last segment is left of it
                assert left is not None
                at = float(left.hi) + 0.0
            jumps = []
            for nu in range(MAX_ORDER + 1):
                lv = float(left(at, nu)) if left is not None else 0.0
                rv = float(right(at, nu)) if right is not None else 0.0
                jumps.append(abs(lv - rv))
            achieved = -1
            for nu in range(MAX_ORDER + 1):
                if not jumps[nu] <= tol[nu]:      # also catches NaN
                    break
                achieved = nu
            if achieved < req:
                raise InputError(self.key, f'jump {jumps[achieved + 1]:.3g} in derivative '
                                 f'{achieved + 1} at alpha = {math.degrees(at):.6g} deg',
                                 f'continuity to order {req} (parameters give a '
                                 'discontinuous or ill-conditioned law)')
            out.append(Junction(at, req, achieved, tuple(jumps)))
        return tuple(out)

    def flank_is_monotone(self, samples: int = 4001) -> bool:
        """True if h' >= 0 on the rise flank (alpha < 0) and <= 0 on alpha > 0 (to 1e-12)."""
        lo, hi = self._support
        a = np.linspace(lo, hi, samples)
        v = self(a, 1)
        tol = 1e-9 * max(np.max(np.abs(v)), 1e-300)
        return bool(np.all(v[a < 0] >= -tol) and np.all(v[a > 0] <= tol))


@dataclasses.dataclass(frozen=True)
class Flank:
    """Segments in flank coordinate t in [0, T] (t = 0 on the base circle, T at the nose).

    ``required`` has one order per junction: base circle, interior, and the nose end
    (the nose is used only for asymmetric lobes; a mirrored lobe states it itself).
    """

    segments: tuple[Segment, ...]
    required: tuple[int, ...]
    nose_order: int = 3          # order of the symmetric nose junction (odd derivs vanish)

    @property
    def length(self) -> float:
        """T [rad]."""
        return self.segments[-1].hi

    def nose(self, nu: int) -> float:
        """nu-th t-derivative at the nose (t = T)."""
        return float(self.segments[-1](self.length, nu))


def assemble_lobe(rise: Flank, fall: Flank | None = None, *, key: str = 'lift_law',
                  name: str = 'lobe', nose_required: int | None = None) -> PiecewiseLaw:
    """A lobe from a rise flank and an explicit fall flank (None: the mirrored rise).

    The rise flank occupies alpha in [-T_r, 0] (alpha = t - T_r), the fall flank
    [0, T_f] (alpha = T_f - t). The nose junction must be at least C1 (h' = 0 on both
    sides); an asymmetric lobe's nose h'' generally jumps unless the flanks match.
    """
    fall_flank = fall if fall is not None else rise
    rise_segs = [s.mapped(+1, rise.length) for s in rise.segments]
    fall_segs = [s.mapped(-1, fall_flank.length) for s in fall_flank.segments]
    if nose_required is None:
        nose_required = rise.nose_order if fall is None else 1
    required = (list(rise.required[:-1]) + [nose_required]
                + list(reversed(fall_flank.required[:-1])))
    return PiecewiseLaw(rise_segs + fall_segs, required, key=key, name=name)


def solve_moments(exponents: Sequence[int], rhs: Sequence[float], *,
                  key: str = 'exponents') -> list[float]:
    """Exact solution of sum_i d_i * perm(e_i, m) = rhs[m], m = 0..n-1 (n = len).

    The moment (falling-factorial Vandermonde) system of the polynomial cams: the
    coefficients of sum d_i x^i whose value and first n-1 x-derivatives at x = 1 are
    given. Solved with ``fractions.Fraction`` (exact for the float inputs), then
    rounded once, so large and closely spaced exponents lose nothing to conditioning.
    """
    n = len(exponents)
    exps = [int(e) for e in exponents]
    if len(set(exps)) != n:
        raise InputError(key, list(exponents), 'distinct exponents')
    if len(rhs) != n:
        raise InputError(key, list(exponents), f'{len(rhs)} exponents')
    a = [[Fraction(math.perm(e, m)) for e in exps] + [Fraction(rhs[m])] for m in range(n)]
    for col in range(n):
        piv = next((r for r in range(col, n) if a[r][col] != 0), None)
        if piv is None:
            raise InputError(key, list(exponents),
                             f'exponents >= {n - 1} (otherwise the moment system is singular)')
        a[col], a[piv] = a[piv], a[col]
        for r in range(n):
            if r != col and a[r][col] != 0:
                f = a[r][col] / a[col][col]
                a[r] = [x - f * y for x, y in zip(a[r], a[col])]
    return [float(a[i][n] / a[i][i]) for i in range(n)]
