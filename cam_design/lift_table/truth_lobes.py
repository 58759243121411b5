"""Analytic lobes whose acceleration jumps at known angles, for the accuracy tests and
the ``reconstruction_accuracy`` benchmark.

Each family is a closed form with exact h, h', h'', h''' and the list of angles where
h'' jumps (the junctions a reconstruction should find). The lift-law registry supplies
the ramped polynomial and constant-acceleration lobes (their segment tables give the
junctions); the dwell cam and the circular-arc cam are written out here, independently
of the reconstruction code. Angles in rad from the nose, lifts in m.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from numpy.polynomial import Polynomial
from numpy.typing import ArrayLike, NDArray

DEG = math.pi / 180.0
Law = Callable[..., NDArray[np.float64]]


class CircularArcCam:
    """Symmetric circular-arc cam under a flat follower (lengths in m, alpha [rad] from
    the nose): nose arc r_n, flank arcs R_f tangent to the base circle R0 and to the
    nose. h = r_n + d cos(alpha) - R0 on the nose, R_f + e cos(|alpha| + b) - R0 on the
    flank (support functions of the arcs), 0 on the base circle. C1 only: h'' jumps at
    the nose-flank tangent points and where the flanks meet the base circle."""

    def __init__(self, r0: float = 18e-3, lift: float = 8e-3, r_nose: float = 5e-3,
                 r_flank: float = 60e-3) -> None:
        self.r0, self.rn, self.rf = r0, r_nose, r_flank
        self.d = r0 + lift - r_nose                       # nose centre from the axis
        self.e = r_flank - r0                             # flank centre from the axis
        cos_b = (self.e ** 2 + self.d ** 2 - (r_flank - r_nose) ** 2) / (2 * self.e * self.d)
        self.b = math.acos(cos_b)
        self.end = math.pi - self.b                       # base circle beyond
        self.tangent = math.atan2(self.e * math.sin(self.b), self.d - self.e * cos_b)

    @property
    def junctions(self) -> tuple[float, ...]:
        """Angles [rad] where h'' jumps."""
        return (-self.end, -self.tangent, self.tangent, self.end)

    def __call__(self, alpha: ArrayLike, nu: int = 0) -> NDArray[np.float64]:
        """nu-th derivative [m/rad^nu] at ``alpha`` [rad]."""
        a = np.asarray(alpha, dtype=float)
        u = np.abs(a)
        sign = np.sign(a) ** nu if nu % 2 else 1.0
        nose = self.d * np.cos(u + nu * np.pi / 2)
        flank = self.e * np.cos(u + self.b + nu * np.pi / 2)
        if nu == 0:
            nose = nose + self.rn - self.r0
            flank = flank + self.rf - self.r0
        out = np.where(u <= self.tangent, nose, np.where(u < self.end, flank, 0.0))
        return out * sign


@dataclass(frozen=True)
class DwellCam:
    """Rise - dwell - return - dwell with simple-harmonic (cosine) rise and return of
    ``rise`` [m] over ``width`` [rad] each, a top dwell of ``top`` [rad] centred on 0.
    h'' = +-(rise/2)(pi/width)^2 at the four dwell edges, where it jumps from 0."""

    rise: float = 8e-3
    width: float = 70 * DEG
    top: float = 30 * DEG

    @property
    def junctions(self) -> tuple[float, ...]:
        e0, e1 = self.top / 2, self.top / 2 + self.width
        return (-e1, -e0, e0, e1)

    def __call__(self, alpha: ArrayLike, nu: int = 0) -> NDArray[np.float64]:
        a = np.asarray(alpha, dtype=float)
        u = np.abs(a)
        sign = np.sign(a) ** nu if nu % 2 else 1.0
        k = math.pi / self.width
        t = u - self.top / 2                           # 0 at the top dwell's edge
        flank = (t > 0) & (t < self.width)
        # h = rise/2 (1 + cos(k t)) on the flank (rise at t = 0, 0 at t = width)
        val = 0.5 * self.rise * k ** nu * np.cos(k * t + nu * math.pi / 2)
        if nu == 0:
            val = val + 0.5 * self.rise
        top = (self.rise if nu == 0 else 0.0) * np.ones_like(u)
        out = np.where(t <= 0, top, np.where(flank, val, 0.0))
        return out * sign


@dataclass(frozen=True)
class BumpLobe:
    """h = rise (1 - x^2)^3, x = alpha / half_width: C2 (h''' jumps at the ends)."""

    rise: float = 8e-3
    half_width: float = 75 * DEG
    junctions: tuple[float, ...] = ()

    def __call__(self, alpha: ArrayLike, nu: int = 0) -> NDArray[np.float64]:
        a = np.asarray(alpha, dtype=float)
        x = a / self.half_width
        p = (Polynomial([1.0, 0.0, -1.0]) ** 3).deriv(nu)
        return np.where(np.abs(x) < 1.0, self.rise * p(x) / self.half_width ** nu, 0.0)


@dataclass(frozen=True)
class CosineRampLobe:
    """A 4-5-6-7 polynomial rise to the nose of ``rise - ramp`` [m] over ``width`` [rad],
    standing on an S-shaped cosine ramp of ``ramp`` [m] over ``ramp_width`` [rad] at each
    end: h = ramp/2 (1 + cos(pi t / ramp_width)), t from 0 where the main rise starts to
    ``ramp_width`` on the base circle (velocity zero at both ends of the ramp). h'' jumps
    at the four ramp ends (by (ramp/2)(pi/ramp_width)^2) and changes sign inside each
    ramp: six sign changes over the lobe instead of a cam's usual two."""

    rise: float = 9e-3
    ramp: float = 0.25e-3
    width: float = 55 * DEG
    ramp_width: float = 20 * DEG

    @property
    def junctions(self) -> tuple[float, ...]:
        e0, e1 = self.width, self.width + self.ramp_width
        return (-e1, -e0, e0, e1)

    def __call__(self, alpha: ArrayLike, nu: int = 0) -> NDArray[np.float64]:
        a = np.asarray(alpha, dtype=float)
        u = np.abs(a)
        sign = np.sign(a) ** nu if nu % 2 else 1.0
        p = Polynomial([0.0, 0.0, 0.0, 0.0, 35.0, -84.0, 70.0, -20.0]).deriv(nu)
        main = (self.rise - self.ramp) * p(1.0 - u / self.width) * (-1.0 / self.width) ** nu
        k = math.pi / self.ramp_width
        t = u - self.width
        ramp = 0.5 * self.ramp * k ** nu * np.cos(k * t + nu * math.pi / 2)
        if nu == 0:
            main, ramp = main + self.ramp, ramp + 0.5 * self.ramp
        out = np.where(t <= 0, main, np.where(t < self.ramp_width, ramp, 0.0))
        return out * sign


@dataclass(frozen=True)
class Family:
    """A named truth lobe: ``law(alpha, nu)`` and the angles [rad] where h'' jumps."""

    name: str
    law: Law
    junctions: tuple[float, ...] = field(default=())


def _registry_family(name: str, spec: dict) -> Family:
    """A lobe of the lift-law registry, with the junctions where its h'' jumps."""
    from cam_design.lift_laws import PiecewiseLaw, from_spec

    law = from_spec(spec, 'truth')
    assert isinstance(law, PiecewiseLaw)
    scale = float(np.max(np.abs(law(np.linspace(-math.pi, math.pi, 7201), 2))))
    report = law.junction_report
    jumps = tuple(float(j.alpha) for j in report
                  if j.jumps[2] > 1e-6 * scale)
    return Family(name, law, jumps)


def families() -> list[Family]:
    """The accuracy families: ramped C1 (CA+CV ramp and 2-6-10-14, the §1.1 ramp), a C2
    lobe, a dwell cam, a constant-acceleration cam on the same ramp, a circular-arc cam, and
    a narrow-peak lobe (the flat-tappet intake preset: its acceleration peak about two rows
    wide at 5 deg, where a fast smooth change of h'' looks like a step), and a lobe on
    S-shaped cosine ramps (six sign changes of h'', where a cam usually has two)."""
    ramp = {'kind': 'constant_acceleration_velocity', 'height': 3.0e-4,
            'velocity': 0.015e-3 / DEG, 'angle': 30 * DEG}
    arc = CircularArcCam()
    dwell = DwellCam()
    cosine = CosineRampLobe()
    return [
        _registry_family('ramped C1', {'family': 'preset', 'name': 'methods_example'}),
        Family('C2', BumpLobe()),
        Family('dwell', dwell, dwell.junctions),
        _registry_family('constant acceleration', {
            'family': 'constant_acceleration', 'ramp': ramp, 'rise': 8.0e-3,
            'half_angle': 50 * DEG, 'positive_width': 15 * DEG}),
        Family('circular arc', arc, arc.junctions),
        _registry_family('narrow peak', {'family': 'preset', 'name': 'flat_tappet_intake'}),
        Family('cosine ramp', cosine, cosine.junctions),
    ]


def measured_table(law: Law, step: float, *, sigma: float = 0.0, quantum: float = 0.0,
                   outliers: int = 0, seed: int = 0, outlier_size: float = 10e-6
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """A full-revolution table of ``law`` at ``step`` [rad] over (-pi, pi]: Gaussian
    noise ``sigma`` [m], ``outliers`` spikes of +-``outlier_size`` [m] on the lobe's
    rows, then rounding to ``quantum`` [m] (0: none). Returns (alpha, lift)."""
    rng = np.random.default_rng(seed)
    n = int(round(2 * math.pi / step))
    a: NDArray[np.float64] = -math.pi + step * np.arange(1, n + 1, dtype=np.float64)
    h = law(a) + rng.normal(0.0, sigma, a.size)
    if outliers:
        lobe = np.flatnonzero(law(a) > 1e-4)
        lobe = lobe[(lobe > 4) & (lobe < a.size - 5)]
        idx = rng.choice(lobe, min(outliers, lobe.size), replace=False)
        h[idx] += outlier_size * rng.choice([-1.0, 1.0], idx.size)
    if quantum:
        h = np.round(h / quantum) * quantum
    return np.asarray(a, dtype=np.float64), np.asarray(h, dtype=np.float64)
