"""Plane curves as exact Taylor jets, and their polar (radial-follower) form (docs/grinding.md).

A jet is a (4, n) array of the Taylor coefficients c0..c3 of a quantity in a curve
parameter s (the arithmetic of ``cam_design.follower``). A curve function maps s [rad]
to the jets (x, y) [m] of a point; :class:`PolarCurveLift` turns such a curve (a pitch
curve, a wheel-centre path) into the lift law of an in-line radial follower centre:
h(alpha) = |P| - base at the polar angle pi/2 + alpha (nose on +Y, as follower.py).
"""
from __future__ import annotations

import math
from typing import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cam_design.errors import InputError
from cam_design.follower import wrap_angle
from cam_design.jets import (JET_ORDER, jet_atan2, jet_const, jet_inverse_compose, jet_mul,
                             jet_sqrt)
from cam_design.lift_laws.base import LiftLaw, SolvedLift

Jet = NDArray[np.float64]
#: s [rad] -> jets (x, y) [m] of a curve point
CurveJets = Callable[[NDArray[np.float64]], tuple[Jet, Jet]]

#: table density used to bracket the polar-angle inversion (points per turn)
TABLE_POINTS = 4096
NEWTON_TOL = 1e-14
NEWTON_MAX_ITER = 50


def param_jet(s: ArrayLike) -> Jet:
    """The jet of the parameter itself: s + e."""
    s = np.asarray(s, dtype=float).reshape(-1)
    out = jet_const(s, s.size)
    out[1] = 1.0
    return out


def law_jet(law: LiftLaw, s: NDArray[np.float64]) -> Jet:
    """Jet of h(s) (s wrapped into [-pi, pi)): h^(k) / k!."""
    d = law.derivatives(wrap_angle(np.asarray(s, dtype=float)))
    return np.stack([d[k] / math.factorial(k) for k in range(JET_ORDER + 1)])


def jet_cos_sin(x: Jet) -> tuple[Jet, Jet]:
    """Jets of cos x and sin x (d = x - x0 starts at order 1: d^4 is dropped)."""
    d = x.copy()
    d[0] = 0.0
    d2 = jet_mul(d, d)
    d3 = jet_mul(d2, d)
    cd = -0.5 * d2
    cd[0] += 1.0
    sd = d - d3 / 6.0
    c0, s0 = np.cos(x[0]), np.sin(x[0])
    return c0 * cd - s0 * sd, s0 * cd + c0 * sd


def polar_jets(x: Jet, y: Jet) -> tuple[Jet, Jet]:
    """Jets of the radius sqrt(x^2 + y^2) and of the polar angle atan2(y, x)."""
    return jet_sqrt(jet_mul(x, x) + jet_mul(y, y)), jet_atan2(y, x)


def derivs_of(jet: Jet) -> NDArray[np.float64]:
    """(4, n) derivatives d^k/ds^k from a jet."""
    return np.stack([jet[k] * math.factorial(k) for k in range(JET_ORDER + 1)])


class PolarCurveLift(SolvedLift):
    """Radial-follower lift of a closed star-shaped curve: h(alpha) = |P(s)| - ``base``
    where the polar angle of P(s) is pi/2 + ``sense`` (alpha + ``shift``).

    ``curve(s)`` gives the jets of P for s in [-pi, pi) (one turn, the polar angle must
    advance monotonically with s: else InputError naming ``key``). ``support`` and
    ``junctions`` (in s) are mapped to alpha. Values and three derivatives are exact to
    rounding (bracketed Newton on the polar angle, then series reversion).
    """

    def __init__(self, curve: CurveJets, base: float, *, sense: int = 1, shift: float = 0.0,
                 support: tuple[float, float] = (-math.pi, math.pi),
                 junctions: tuple[float, ...] = (), continuity_order: int = 3,
                 key: str = 'curve') -> None:
        self.curve = curve
        self.base = float(base)
        self.sense = 1 if sense >= 0 else -1
        self.shift = float(shift)
        self.key = key
        self.continuity_order = continuity_order
        s = np.linspace(-math.pi, math.pi, TABLE_POINTS + 1)
        a = np.unwrap(self._angle_rad(s)[0][0])
        if not np.all(np.diff(a) > 0) or abs(a[-1] - a[0] - 2 * math.pi) > 1e-6:
            i = int(np.argmax(~(np.diff(a) > 0)))
            raise InputError(key, f'a curve whose polar angle turns back near s = {s[i]:.4g} '
                                  'rad', 'a closed curve seen once from the cam centre '
                                  '(star-shaped)')
        self._s, self._a = s, a
        lo, hi = support
        full = hi - lo >= 2 * math.pi - 1e-12
        if full:
            self._support = (-math.pi, math.pi)
        else:
            ends = wrap_angle(self.to_alpha(np.array([lo, hi])))
            self._support = (float(ends[0]), float(ends[1]))
            if not self._support[0] < self._support[1]:
                raise InputError(key + '.support', support, 'a support that does not wrap')
        self._junctions = tuple(float(j) for j in wrap_angle(self.to_alpha(np.asarray(
            junctions, dtype=float)))) if junctions else ()
        self._cache: tuple[bytes, NDArray[np.float64]] | None = None

    def _angle_rad(self, s: NDArray[np.float64]) -> tuple[Jet, Jet]:
        """Jets of alpha(s) (unwrapped up to 2 pi) and of the radius |P(s)|."""
        x, y = self.curve(s)
        rad, ang = polar_jets(x, y)
        alpha = self.sense * ang
        alpha[0] -= self.sense * 0.5 * math.pi + self.shift
        return alpha, rad

    def to_alpha(self, s: NDArray[np.float64]) -> NDArray[np.float64]:
        """alpha [rad, wrapped] of the curve points at parameters s."""
        return wrap_angle(self._angle_rad(np.asarray(s, dtype=float).reshape(-1))[0][0])

    def parameter(self, alpha: ArrayLike) -> NDArray[np.float64]:
        """Curve parameter s whose point lies at ``alpha`` (Newton on the polar angle)."""
        t = np.asarray(alpha, dtype=float).reshape(-1)
        a0 = self._a[0]
        tt = a0 + np.mod(t - a0, 2 * math.pi)
        i = np.clip(np.searchsorted(self._a, tt) - 1, 0, self._s.size - 2)
        lo, hi = self._s[i].copy(), self._s[i + 1].copy()
        frac = (tt - self._a[i]) / (self._a[i + 1] - self._a[i])
        s = lo + frac * (hi - lo)
        for _ in range(NEWTON_MAX_ITER):
            ang, _ = self._angle_rad(s)
            f = wrap_angle(ang[0] - tt)
            if np.max(np.abs(f), initial=0.0) < NEWTON_TOL:
                break
            hi = np.where(f > 0, s, hi)
            lo = np.where(f <= 0, s, lo)
            step = s - f / ang[1]
            s = np.where((step >= lo) & (step <= hi), step, 0.5 * (lo + hi))
        return s

    def solve(self, alpha: ArrayLike) -> NDArray[np.float64]:
        """(4, n): h, h', h'', h''' at any ``alpha`` (wrapped)."""
        s = self.parameter(alpha)
        t = np.asarray(alpha, dtype=float).reshape(-1)
        ang, rad = self._angle_rad(s)
        rad = rad.copy()
        rad[0] -= self.base
        out = jet_inverse_compose(ang, rad)
        f = wrap_angle(ang[0] - t)
        for k in range(JET_ORDER):
            out[k] -= f * out[k + 1]
        if not np.all(np.isfinite(out)):
            raise InputError(self.key, 'a non-finite radius derivative',
                             'a regular curve (no cusp, no stationary point)')
        return out

    @property
    def support(self) -> tuple[float, float]:
        return self._support

    @property
    def junctions(self) -> tuple[float, ...]:
        return self._junctions
