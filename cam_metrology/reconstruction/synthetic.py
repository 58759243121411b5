"""Analytic test lobes with exact derivatives, and simulated measurements of them.

Used by the tests and the benchmark as independent truth (they do not depend on the
lift-law module). ``PolynomialLobe`` is the docs/lift_laws.md test cam: §1.1(b) ramps
(H1 = 0.3 mm, v1 = 0.015 mm/deg, alpha1 = 30 deg) around a 2-6-10-14 base section
(H = 8 mm, alpha2 = 100 deg), C2 everywhere, h''' jumps at the ramp junctions.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

DEG = np.pi / 180.0


@dataclass(frozen=True)
class PolynomialLobe:
    """Symmetric ramp + polynomial lobe (docs/lift_laws.md); mm and deg parameters."""

    rise_mm: float = 8.0
    ramp_height_mm: float = 0.3
    ramp_velocity_mm_per_deg: float = 0.015
    ramp_angle_deg: float = 30.0
    base_half_angle_deg: float = 50.0
    exponents: tuple[int, int, int, int] = (2, 6, 10, 14)

    def coefficients(self) -> dict[int, float]:
        """c_i [mm] of the closed form of §1.4 (book variables)."""
        v, a0, big_h = self.ramp_velocity_mm_per_deg, self.base_half_angle_deg, self.rise_mm
        out = {}
        for i in self.exponents:
            others = [j for j in self.exponents if j != i]
            e1 = sum(others)
            e2 = others[0] * others[1] + others[0] * others[2] + others[1] * others[2]
            e3 = others[0] * others[1] * others[2]
            den = float(np.prod([j - i for j in others]))
            out[i] = (v * a0 * (1 - e1 + e2) - big_h * e3) / den
        return out

    @property
    def half_angle(self) -> float:
        """Working half-angle Phi [rad] (ramps included)."""
        return (self.base_half_angle_deg + self.ramp_angle_deg) * DEG

    def __call__(self, alpha: ArrayLike, nu: int = 0) -> NDArray[np.float64]:
        """nu-th derivative [m/rad^nu] at ``alpha`` [rad]."""
        a = np.abs(np.asarray(alpha, dtype=float)) / DEG          # |alpha| in deg
        sign = np.sign(np.asarray(alpha, dtype=float)) ** nu if nu % 2 else 1.0
        a0 = self.base_half_angle_deg
        out = np.zeros_like(a)
        base = a <= a0
        x = a[base] / a0
        c = self.coefficients()
        if nu == 0:
            val = self.ramp_height_mm + self.rise_mm + sum(ci * x ** i for i, ci in c.items())
        else:
            val = sum(ci * _falling(i, nu) * x ** (i - nu) for i, ci in c.items()
                      if i >= nu) / a0 ** nu
        out[base] = val
        v1, h1, al1 = self.ramp_velocity_mm_per_deg, self.ramp_height_mm, self.ramp_angle_deg
        e0 = h1 - v1 * al1
        beta1 = -2.0 * e0 / v1
        cb = v1 ** 2 / (4.0 * (v1 * al1 - h1))
        ramp = (a > a0) & (a < a0 + al1)
        u = a0 + al1 - a[ramp]                                    # 0 at the base circle
        quad = u <= beta1
        s = (-1.0) ** nu                                          # d/d|alpha| = -d/du
        if nu == 0:
            val = np.where(quad, cb * u ** 2, e0 + v1 * u)
        elif nu == 1:
            val = s * np.where(quad, 2 * cb * u, v1)
        elif nu == 2:
            val = s * np.where(quad, 2 * cb, 0.0)
        else:
            val = np.zeros_like(u)
        out[ramp] = val
        return out * 1e-3 / DEG ** nu * sign


def _falling(i: int, nu: int) -> float:
    out = 1.0
    for k in range(nu):
        out *= i - k
    return out


@dataclass(frozen=True)
class EccentricLobe:
    """Eccentric disc under a flat follower: h = e (1 + cos alpha) [m], alpha from the
    nose; a single harmonic, C-infinity and periodic."""

    eccentricity: float = 4.0e-3

    def __call__(self, alpha: ArrayLike, nu: int = 0) -> NDArray[np.float64]:
        a = np.asarray(alpha, dtype=float)
        e = self.eccentricity
        return [e * (1 + np.cos(a)), -e * np.sin(a), -e * np.cos(a), e * np.sin(a)][nu]


def simulate(law, n_per_rev: int, sigma: float, *, seed: int = 0,
             span: tuple[float, float] = (-np.pi, np.pi), outliers: int = 0,
             outlier_size: float = 10e-6, gap_deg: float = 0.0,
             jitter: float = 0.0) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Simulated measurement of ``law``: alpha [rad] at ``n_per_rev`` points per
    revolution over ``span``, Gaussian noise ``sigma`` [m], ``outliers`` spikes of
    +-``outlier_size`` [m], a gap of ``gap_deg`` on the rise flank, uniform jitter of
    ``jitter`` steps. Returns (alpha, lift)."""
    rng = np.random.default_rng(seed)
    step = 2 * np.pi / n_per_rev
    k0 = int(np.ceil(span[0] / step))
    k1 = int(np.floor(span[1] / step))
    a = np.arange(k0, k1 + 1, dtype=np.float64) * step
    a = a[(a > -np.pi) & (a <= np.pi)]
    if jitter:
        a = np.sort(a + rng.uniform(-jitter, jitter, a.size) * step)
    if gap_deg:
        centre = -45 * DEG
        a = a[np.abs(a - centre) > 0.5 * gap_deg * DEG]
    h = np.asarray(law(a) + rng.normal(0.0, sigma, a.size), dtype=np.float64)
    if outliers:
        idx = rng.choice(np.arange(5, a.size - 5), outliers, replace=False)
        h[idx] += outlier_size * rng.choice([-1.0, 1.0], outliers)
    return a, h
