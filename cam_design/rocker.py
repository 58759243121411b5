"""CG rocker optimum dimension synthesis (Song et al., docs/lift_laws.md, erratum 1 applied).

One cam drives an intake rocker counter-directionally and an exhaust rocker
co-directionally; their theoretical profiles differ by 2 delta(psi). The frame length
L = |O1 O| (cam centre to rocker pivot) is chosen so that max |delta| over the stroke is
minimal, which happens when the deviation at the tangency point K equals minus the
deviation at the stroke end: f(eta) = alpha1 + pi/2 - 2 gamma - eta = 0.

Frame: rocker tip at its lowest position A1 = origin, pivot O = (l, 0), tip arc
K(eta) = (l (1 - cos eta), l sin eta); cam centres lie on x^2 + y^2 = R_b^2. The
tangent to the arc at K meets that circle at O1 (left root). S1 eq (10) drops y_K^2 in
the constant term c; the corrected c = y_K^2 - 2 x_K y_K / tan(eta) + x_K^2 / tan^2(eta)
- R_b^2 is the only one that reproduces the paper's CG125 result.

All lengths in the same unit (the CLI uses m), angles in rad.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from cam_design.errors import InputError, require_positive


@dataclasses.dataclass(frozen=True)
class RockerGeometry:
    """The tangent construction for one eta [rad]."""

    eta: float
    x_o1: float            # cam centre O1
    y_o1: float
    gamma: float           # line angle of O1 A1 (plain arctan of the ratio) [rad]
    alpha1: float          # line angle of O1 A1' (tip at the stroke end) [rad]
    delta_tangent: float   # delta2 = pi/2 - (gamma + eta): deviation at K [rad]
    delta_end: float       # delta1 = alpha1 - gamma: deviation at the stroke end [rad]
    frame_length: float    # L = |O1 O|


@dataclasses.dataclass(frozen=True)
class RockerSynthesis:
    """Result of the optimum synthesis."""

    arm_length: float
    base_radius: float
    max_swing: float              # rad
    geometry: RockerGeometry      # at the optimum eta*
    eccentricity: float | None
    projected_frame_length: float | None   # L_o = sqrt(L^2 - e^2)

    @property
    def eta(self) -> float:
        """Optimum tangency angle eta* [rad]."""
        return self.geometry.eta

    @property
    def delta(self) -> float:
        """Optimum deviation magnitude |delta| [rad] (the deviations are +-delta)."""
        return abs(self.geometry.delta_tangent)

    @property
    def frame_length(self) -> float:
        """L [length unit of the inputs]."""
        return self.geometry.frame_length


def tangent_geometry(eta: float, arm_length: float, base_radius: float,
                     max_swing: float) -> RockerGeometry:
    """The construction of §6 for a given eta in (0, max_swing] (rad)."""
    l, rb = arm_length, base_radius
    t = math.tan(eta)
    xk, yk = l * (1 - math.cos(eta)), l * math.sin(eta)
    a = 1 + 1 / t ** 2
    b = (2 / t) * (yk - xk / t)
    c = yk ** 2 - 2 * xk * yk / t + xk ** 2 / t ** 2 - rb ** 2
    disc = b * b - 4 * a * c
    if disc <= 0:
        raise InputError('base_radius', rb, 'a base circle that the tip tangent intersects '
                         f'(discriminant {disc:.3g} at eta = {math.degrees(eta):.6g} deg)')
    x = (-b - math.sqrt(disc)) / (2 * a)
    y = yk + (x - xk) / t
    gamma = math.atan(y / x)
    xa, ya = l * (1 - math.cos(max_swing)), l * math.sin(max_swing)
    alpha1 = math.atan((ya - y) / (xa - x))
    return RockerGeometry(eta, x, y, gamma, alpha1, math.pi / 2 - (gamma + eta),
                          alpha1 - gamma, math.hypot(x - l, y))


def optimality(eta: float, arm_length: float, base_radius: float, max_swing: float) -> float:
    """f(eta) = alpha1 + pi/2 - 2 gamma - eta [rad] (zero at the optimum)."""
    g = tangent_geometry(eta, arm_length, base_radius, max_swing)
    return g.alpha1 + math.pi / 2 - 2 * g.gamma - eta


def synthesize(arm_length: float, base_radius: float, max_swing: float,
               eccentricity: float | None = None) -> RockerSynthesis:
    """Optimum frame length: brentq on f(eta) over [1e-6, max_swing] (xtol 1e-15).

    ``max_swing`` [rad]; with ``eccentricity`` e also L_o = sqrt(L^2 - e^2).
    """
    from scipy.optimize import brentq

    l = require_positive('arm_length', arm_length)  # noqa: E741 (the paper's l)
    rb = require_positive('base_radius', base_radius)
    psi = require_positive('max_swing', max_swing)
    if psi >= math.pi / 4:
        raise InputError('max_swing', max_swing, 'a swing angle below 45 deg (in rad)')
    if rb >= l * 10:
        raise InputError('base_radius', rb, f'a base radius below 10 x the arm length '
                                            f'({10 * l:.6g})')
    # The construction is scale-invariant: solve it on lengths in units of the arm
    # length (no overflow/underflow for any unit, e.g. 1e300 or 1e-300), scale back.
    rb1 = rb / l
    lo = 1e-6
    try:
        f_lo = optimality(lo, 1.0, rb1, psi)
        f_hi = optimality(psi, 1.0, rb1, psi)
    except InputError as exc:
        raise InputError('base_radius', rb, f'a base circle that the tangents to the tip arc '
                                            f'meet (too small for arm length {l:.6g} and '
                                            f'this swing)') from exc
    if not (f_lo < 0 < f_hi):
        raise InputError('max_swing', max_swing,
                         f'data for which f(eta) changes sign on (0, max_swing] (f = '
                         f'{f_lo:.4g} .. {f_hi:.4g} rad)')
    eta = brentq(optimality, lo, psi, args=(1.0, rb1, psi), xtol=1e-15, rtol=8.9e-16,
                 maxiter=200)
    g1 = tangent_geometry(eta, 1.0, rb1, psi)
    geo = dataclasses.replace(g1, x_o1=g1.x_o1 * l, y_o1=g1.y_o1 * l,
                              frame_length=g1.frame_length * l)
    lo_len = None
    e = None
    if eccentricity is not None:
        e = require_positive('eccentricity', eccentricity, allow_zero=True)
        lo_len = projected_frame_length(geo.frame_length, e)
    return RockerSynthesis(l, rb, psi, geo, e, lo_len)


def projected_frame_length(frame_length: float, eccentricity: float) -> float:
    """L_o = sqrt(L^2 - e^2)."""
    if eccentricity >= frame_length:
        raise InputError('eccentricity', eccentricity, f'e < L = {frame_length:.9g}')
    r = eccentricity / frame_length      # scaled: no overflow for any length unit
    return frame_length * math.sqrt((1 - r) * (1 + r))


def eccentricity_for(frame_length: float, projected: float) -> float:
    """e = sqrt(L^2 - L_o^2) (ill-conditioned: de/dL = L/e)."""
    if projected > frame_length:
        raise InputError('projected_frame_length', projected, f'L_o <= L = {frame_length:.9g}')
    return math.sqrt(frame_length ** 2 - projected ** 2)


def frame_length_for(projected: float, eccentricity: float) -> float:
    """L = sqrt(L_o^2 + e^2)."""
    return math.hypot(projected, eccentricity)


def sampled_deviation(result: RockerSynthesis, samples: int = 200001) -> tuple[float, float]:
    """Independent check: (min, max) over the tip arc of the signed angle between
    O1A1 and O1A(psi), psi in [0, max_swing]; equals (delta1, delta2) at the optimum."""
    l, g = result.arm_length, result.geometry
    psi = np.linspace(0.0, result.max_swing, samples)
    ax, ay = l * (1 - np.cos(psi)) - g.x_o1, l * np.sin(psi) - g.y_o1
    bx, by = -g.x_o1, -g.y_o1
    ang = np.arctan2(bx * ay - by * ax, bx * ax + by * ay)
    return float(ang.min()), float(ang.max())
