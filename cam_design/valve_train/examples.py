"""Closed-form lifts used by the dynamics tests and benchmark (docs/lift_laws.md).

These are not lift-law families of the scene (those live in ``cam_design.lift_laws``):
they build the exact test cams of docs/methods.md cases 19, 20 and 22 directly from
their formulas, as piecewise polynomials in alpha.

* ``PiecewisePolynomialLaw``: a LiftLaw from polynomial pieces (numpy Polynomial in
  alpha [rad]).
* ``polydyne_cam``: the §1.5 inversion k h = x0 + F0/c + (1 + c'/c) y_d + eps_c y_d''
  of a prescribed valve motion y_d at the design speed (eps_c = M omega_d^2 / c).
"""
from __future__ import annotations

import math
from typing import Sequence

import numpy as np
from numpy.polynomial import Polynomial
from numpy.typing import NDArray

from cam_design.errors import InputError
from cam_design.lift_laws.base import LiftLaw
from cam_design.valve_train.params import SdofParams, omega_of_rpm

DEG = math.pi / 180.0


class PiecewisePolynomialLaw(LiftLaw):
    """h(alpha) = pieces[i](alpha) on [breaks[i], breaks[i+1]] (alpha in rad)."""

    continuity_order = 0

    def __init__(self, breaks: Sequence[float], pieces: Sequence[Polynomial]) -> None:
        b = np.asarray(breaks, dtype=float)
        if b.ndim != 1 or b.size != len(pieces) + 1 or np.any(np.diff(b) <= 0):
            raise InputError('breaks', b, 'increasing angles, one more than pieces')
        self.breaks = b
        self.pieces = [[p, p.deriv(1), p.deriv(2), p.deriv(3)]
                       for p in pieces]

    @property
    def support(self) -> tuple[float, float]:
        return float(self.breaks[0]), float(self.breaks[-1])

    @property
    def junctions(self) -> tuple[float, ...]:
        return tuple(float(x) for x in self.breaks[1:-1])

    def _evaluate(self, alpha: NDArray[np.float64], nu: int) -> NDArray[np.float64]:
        idx = np.clip(np.searchsorted(self.breaks, alpha, side='right') - 1, 0,
                      len(self.pieces) - 1)
        out = np.empty_like(alpha)
        for i in np.unique(idx):
            sel = idx == i
            out[sel] = self.pieces[i][nu](alpha[sel])
        return out


def smoothstep(a0: float, a1: float, h0: float, h1: float) -> Polynomial:
    """C3 rise from h0 at a0 to h1 at a1 (h', h'', h''' zero at both ends)."""
    s = Polynomial([-a0 / (a1 - a0), 1.0 / (a1 - a0)])
    return h0 + (h1 - h0) * (35 * s ** 4 - 84 * s ** 5 + 70 * s ** 6 - 20 * s ** 7)


def mirror(p: Polynomial) -> Polynomial:
    """p(-alpha)."""
    return p(Polynomial([0.0, -1.0]))


def symmetric_law(rise: Sequence[tuple[float, float, Polynomial]]) -> PiecewisePolynomialLaw:
    """A symmetric lobe from rise-flank pieces (a0, a1, p) with a0 < a1 <= 0 ordered
    from the base circle to the nose; the fall flank is the mirror image."""
    breaks = [rise[0][0]] + [a1 for _, a1, _ in rise]
    pieces = [p for _, _, p in rise]
    fall_b = [-a for a in reversed(breaks[:-1])]
    fall_p = [mirror(p) for p in reversed(pieces)]
    return PiecewisePolynomialLaw(breaks + fall_b, pieces + fall_p)


def polydyne_cam(yd: Polynomial, params: SdofParams, rpm_design: float) -> Polynomial:
    """k h = x0 + F0/c + (1 + c'/c) y_d + eps_c y_d'' (alpha derivatives), as h(alpha)."""
    p = params
    omega = omega_of_rpm(rpm_design, 'rpm_design')
    eps_c = p.mass * omega ** 2 / p.stiffness
    kh = (p.lash + p.spring_preload / p.stiffness + (1 + p.spring_rate / p.stiffness) * yd
          + eps_c * yd.deriv(2))
    return kh / p.rocker_ratio


def smoothstep_polydyne_law(params: SdofParams, rpm_design: float, *,
                            y_max: float = 8e-3, half: float = 60 * DEG,
                            lead: float = 20 * DEG) -> tuple[PiecewisePolynomialLaw,
                                                             Polynomial]:
    """Case 20: y_d = y_max (35u^4 - 84u^5 + 70u^6 - 20u^7), u = (alpha + half)/half on
    the rise, its mirror on the fall, a C3 lead-in from h = 0 to the opening level.
    Returns (law, y_d on the rise flank)."""
    u = Polynomial([1.0, 1.0 / half])          # u = 0 at -half, 1 at the nose
    yd = y_max * (35 * u ** 4 - 84 * u ** 5 + 70 * u ** 6 - 20 * u ** 7)
    h = polydyne_cam(yd, params, rpm_design)
    h_open = float(h(-half))
    law = symmetric_law([(-half - lead, -half, smoothstep(-half - lead, -half, 0.0, h_open)),
                         (-half, 0.0, h)])
    return law, yd


def ramp_polydyne_yd(params: SdofParams, *, y_max: float = 8e-3, half: float = 50 * DEG,
                     ramp_velocity: float = 0.015e-3 / DEG,
                     exponents: Sequence[int] = (2, 6, 10, 14, 18)) -> Polynomial:
    """Case 22 valve motion: even-exponent polynomial in x = -alpha/half (x = 1 at the
    opening, 0 at the nose) with y_d = 0, y_d' = k v_r/(1 + c'/c), y_d'' = y_d''' =
    y_d'''' = 0 at the opening and y_d = y_max at the nose (docs/lift_laws.md)."""
    p = params
    if len(exponents) != 5:
        raise InputError('exponents', exponents, 'five exponents')
    vel = p.rocker_ratio * ramp_velocity / (1 + p.spring_rate / p.stiffness)
    e = np.asarray(exponents, dtype=float)
    rows = [np.ones(5), e, e * (e - 1), e * (e - 1) * (e - 2), e * (e - 1) * (e - 2) * (e - 3)]
    # dy/dalpha = -(1/half) dy/dx: at x = 1, dy/dx = -half * vel
    rhs = [-y_max, -half * vel, 0.0, 0.0, 0.0]
    coef = np.linalg.solve(np.array(rows), np.array(rhs))
    x = Polynomial([0.0, -1.0 / half])
    yd = Polynomial([y_max])
    for ci, ei in zip(coef, exponents):
        yd = yd + ci * x ** int(ei)
    return yd


def ramp_polydyne_law(params: SdofParams, rpm_design: float, *, y_max: float = 8e-3,
                      half: float = 50 * DEG, ramp_velocity: float = 0.015e-3 / DEG
                      ) -> tuple[PiecewisePolynomialLaw, Polynomial]:
    """Case 22: constant-velocity ramp from h = 0 up to the opening level, then the
    polydyne of ``ramp_polydyne_yd``; symmetric. Returns (law, y_d on the rise)."""
    yd = ramp_polydyne_yd(params, y_max=y_max, half=half, ramp_velocity=ramp_velocity)
    h = polydyne_cam(yd, params, rpm_design)
    h_open = float(h(-half))
    ramp_len = h_open / ramp_velocity
    start = -half - ramp_len
    ramp = Polynomial([-start * ramp_velocity, ramp_velocity])
    law = symmetric_law([(start, -half, ramp), (-half, 0.0, h)])
    return law, yd


def acceleration_step_law(params: SdofParams, rpm: float, *, accel: float = 0.01,
                          lead: float = 30 * DEG, span: float = 40 * DEG
                          ) -> tuple[PiecewisePolynomialLaw, float]:
    """Case 19: the quasi-static lift q = (c u - F0)/(c + c') is 0 until alpha* and
    (D/2)(alpha - alpha*)^2 after (D = ``accel`` m/rad^2), reached by a C3 lead-in.
    Returns (law, alpha*). Use a hard seat and zero damping for the exact check."""
    p = params
    a_star = -span
    h_star = (p.lash + p.spring_preload / p.stiffness) / p.rocker_ratio
    csum = p.stiffness + p.spring_rate
    s = Polynomial([-a_star, 1.0])
    para = h_star + csum / (p.stiffness * p.rocker_ratio) * (accel / 2) * s ** 2
    # fall back to zero with a C3 smoothstep well after the window of interest
    top = float(para(0.0))
    law = PiecewisePolynomialLaw(
        [a_star - lead, a_star, 0.0, span + lead],
        [smoothstep(a_star - lead, a_star, 0.0, h_star), para,
         smoothstep(0.0, span + lead, top, 0.0)])
    del rpm
    return law, a_star


class EccentricFlatLaw(LiftLaw):
    """Eccentric disc (eccentricity e) under a flat follower: h = e (1 + cos alpha) on
    [-pi, pi] (nose at alpha = 0, base point at +-pi). A lobe over the whole revolution."""

    continuity_order = 3

    def __init__(self, eccentricity: float) -> None:
        self.e = float(eccentricity)

    @property
    def support(self) -> tuple[float, float]:
        return -math.pi, math.pi

    def _evaluate(self, alpha: NDArray[np.float64], nu: int) -> NDArray[np.float64]:
        e = self.e
        return [e * (1 + np.cos(alpha)), -e * np.sin(alpha), -e * np.cos(alpha),
                e * np.sin(alpha)][nu]


class CircularArcKnifeLaw(LiftLaw):
    """Three-arc cam (base circle R0, flank arcs R1 tangent to it, nose arc rn at
    distance d from the centre on the nose axis) under an in-line knife-edge follower.

    h(alpha) = s(alpha) - R0, s = distance from the cam centre to the profile along the
    ray at angle alpha; on an arc of centre (dc, psi) and radius rho
    s = dc cos(x) + sqrt(rho^2 - dc^2 sin^2 x), x = alpha - psi. Only C1: h'' jumps at
    the four arc junctions (reported as ``junctions``)."""

    continuity_order = 1

    def __init__(self, r0: float, r1: float, rn: float, d: float) -> None:
        if not (0 < rn < r0 < r1 and d > 0 and d + rn > r0 and d + rn < r1):
            raise InputError('arcs', (r0, r1, rn, d), 'rn < R0 < R1, R0 < d + rn < R1')
        self.r0, self.r1, self.rn, self.d = r0, r1, rn, d
        a = r1 - r0
        cphi = (a * a + d * d - (r1 - rn) ** 2) / (2 * d * a)
        self.phi = math.acos(cphi)             # flank centre (rise flank) at angle +phi
        c1 = np.array([a * math.cos(self.phi), a * math.sin(self.phi)])
        n = np.array([d, 0.0])
        t2 = c1 + r1 * (n - c1) / np.linalg.norm(n - c1)
        self.t_nose = abs(math.atan2(t2[1], t2[0]))       # |angle| of flank/nose tangency
        self.t_base = math.pi - self.phi                  # |angle| of base/flank tangency

    @property
    def support(self) -> tuple[float, float]:
        return -self.t_base, self.t_base

    @property
    def junctions(self) -> tuple[float, ...]:
        return (-self.t_nose, self.t_nose)

    def _evaluate(self, alpha: NDArray[np.float64], nu: int) -> NDArray[np.float64]:
        out = np.empty_like(alpha)
        nose = np.abs(alpha) <= self.t_nose
        a = self.r1 - self.r0
        for sel, dc, psi, rho in ((nose, self.d, np.zeros_like(alpha), self.rn),
                                  (~nose, a, -np.sign(alpha) * self.phi, self.r1)):
            if not np.any(sel):
                continue
            x = alpha[sel] - (psi[sel] if np.ndim(psi) else psi)
            # Taylor coefficients in t of s(x + t): cos part and sqrt(g) part
            kk = np.arange(nu + 1)
            fact = np.array([math.factorial(k) for k in kk], dtype=float)
            cosc = np.cos(x[None, :] + kk[:, None] * math.pi / 2) / fact[:, None]
            g = (dc * dc / 2) * (2.0 ** kk[:, None]) * np.cos(
                2 * x[None, :] + kk[:, None] * math.pi / 2) / fact[:, None]
            g[0] += rho * rho - dc * dc / 2
            r = np.zeros_like(g)
            r[0] = np.sqrt(g[0])
            for n in range(1, nu + 1):
                acc = g[n] - sum(r[j] * r[n - j] for j in range(1, n))
                r[n] = acc / (2 * r[0])
            s = fact[nu] * (dc * cosc[nu] + r[nu])
            out[sel] = s - (self.r0 if nu == 0 else 0.0)
        return out


class _FlankLobe(LiftLaw):
    """A lobe of two flanks, rise over ``rise`` rad to ``lift`` at the nose (alpha = 0)
    and fall over ``fall`` rad, each h = H f(s), s the flank fraction from the base
    circle; a subclass gives d^nu f / ds^nu (``_shape``)."""

    def __init__(self, lift: float, rise: float, fall: float) -> None:
        self.lift, self.rise, self.fall = float(lift), float(rise), float(fall)

    @property
    def support(self) -> tuple[float, float]:
        return -self.rise, self.fall

    @property
    def junctions(self) -> tuple[float, ...]:
        return (0.0,)

    def _shape(self, s: NDArray[np.float64], nu: int) -> NDArray[np.float64]:
        raise NotImplementedError

    def _evaluate(self, alpha: NDArray[np.float64], nu: int) -> NDArray[np.float64]:
        a = np.asarray(alpha, dtype=float)
        beta = np.where(a < 0, self.rise, self.fall)
        s = np.where(a < 0, (a + self.rise) / self.rise, (self.fall - a) / self.fall)
        sign = np.where(a < 0, 1.0, -1.0) ** nu       # ds/dalpha = +-1/beta
        out = self.lift * self._shape(s, nu) * sign / beta ** nu
        inside = (a >= -self.rise) & (a <= self.fall)
        return np.where(inside, out, 0.0)


class CycloidalLobe(_FlankLobe):
    """Cycloidal flanks: f(s) = s - sin(2 pi s) / (2 pi) (C2: h''' steps at the ends
    and at the nose)."""

    continuity_order = 2

    def _shape(self, s: NDArray[np.float64], nu: int) -> NDArray[np.float64]:
        w = 2 * math.pi
        if nu == 0:
            return s - np.sin(w * s) / w
        if nu == 1:
            return 1 - np.cos(w * s)
        return w ** (nu - 1) * (np.sin(w * s) if nu == 2 else np.cos(w * s))


class HarmonicLobe(_FlankLobe):
    """Simple-harmonic (cosine) flanks: f(s) = (1 - cos(pi s)) / 2 (C1: h'' steps at
    the base circle, smooth through the nose only when rise = fall)."""

    continuity_order = 1

    def _shape(self, s: NDArray[np.float64], nu: int) -> NDArray[np.float64]:
        phase = [np.cos, np.sin, np.cos, np.sin][nu % 4](math.pi * s)
        lead = [-1.0, 1.0, 1.0, -1.0][nu % 4] if nu else -1.0
        return (0.5 if nu == 0 else 0.0) + lead * 0.5 * math.pi ** nu * phase
