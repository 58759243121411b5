"""Exact synthetic test data for the metrology numerics (tests and benchmarks).

``PolynomialRampCam`` is the test cam of docs/lift_laws.md with the ramp of §1.1b,
written here in closed form so that tests do not depend on the lift-law module.
``sample_lobe`` and ``sample_pin`` generate encoder/probe samples as a bench would
record them: any start angle, several revolutions, either direction, wrapped or
unwrapped, an arbitrary probe zero and seeded Gaussian noise.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from cam_design.dowel_pin import DowelPinGeometry
from cam_design.keyway import KeywayGeometry
from cam_design.lift_laws.base import LiftLaw

TWO_PI = 2.0 * np.pi


def _elementary(values: list[int]) -> tuple[float, float, float]:
    """Elementary symmetric sums e1, e2, e3 of three numbers."""
    a, b, c = values
    return a + b + c, a * b + a * c + b * c, a * b * c


class PolynomialRampCam(LiftLaw):
    """Symmetric cam: §1.1b ramps (constant acceleration + constant velocity) and the
    §1.4 high-order polynomial working section (closed-form coefficients).

    Args (SI): ``rise`` H [m] of the working section above the ramp, ``ramp_height``
    H_r [m], ``ramp_velocity`` v [m/rad], ``ramp_angle`` alpha1 [rad],
    ``half_angle`` alpha0 [rad] of the working section, ``exponents`` (4 even ints).
    """

    continuity_order = 1

    def __init__(self, rise: float = 8e-3, ramp_height: float = 0.3e-3,
                 ramp_velocity: float = 0.015e-3 * 180 / np.pi,
                 ramp_angle: float = np.radians(30.0), half_angle: float = np.radians(50.0),
                 exponents: tuple[int, ...] = (2, 6, 10, 14)) -> None:
        self.rise, self.ramp_height = rise, ramp_height
        self.v, self.a1, self.a0 = ramp_velocity, ramp_angle, half_angle
        self.exponents = tuple(exponents)
        self.coef = []
        for i in self.exponents:
            others = [j for j in self.exponents if j != i]
            e1, e2, e3 = _elementary(others)
            den = float(np.prod([j - i for j in others]))
            self.coef.append((ramp_velocity * half_angle * (1 - e1 + e2) - rise * e3) / den)
        self.e1 = ramp_velocity
        self.e0 = ramp_height - ramp_velocity * ramp_angle
        self.beta1 = -2.0 * self.e0 / self.e1
        self.cb = ramp_velocity ** 2 / (4.0 * (ramp_velocity * ramp_angle - ramp_height))

    @property
    def support(self) -> tuple[float, float]:
        end = self.a0 + self.a1
        return -end, end

    def _radial(self, b: NDArray[np.float64], nu: int) -> NDArray[np.float64]:
        """nu-th derivative with respect to |alpha| = b."""
        out = np.zeros_like(b)
        work = b <= self.a0
        x = b[work] / self.a0
        val = np.full_like(x, self.rise + self.ramp_height) if nu == 0 else np.zeros_like(x)
        for c, i in zip(self.coef, self.exponents):
            if i >= nu:
                fall = float(np.prod(np.arange(i - nu + 1, i + 1)))
                val = val + c * fall * x ** (i - nu)
        out[work] = val / self.a0 ** nu
        u = self.a0 + self.a1 - b[~work]
        sign = (-1.0) ** nu   # d/db = -d/du
        quad = u <= self.beta1
        ramp = np.where(quad, [self.cb * u * u, 2 * self.cb * u, 2 * self.cb + 0 * u,
                               0 * u][nu],
                        [self.e0 + self.e1 * u, self.e1 + 0 * u, 0 * u, 0 * u][nu])
        out[~work] = sign * ramp
        return out

    def _evaluate(self, alpha: NDArray[np.float64], nu: int) -> NDArray[np.float64]:
        val = self._radial(np.abs(alpha), nu)
        return val * np.sign(alpha) if nu % 2 else val


@dataclass(frozen=True)
class Samples:
    """Synthetic samples: encoder angle [rad], probe reading [m], stamps [ns]."""

    theta: NDArray[np.float64]
    s: NDArray[np.float64]
    stamp_ns: NDArray[np.int64]


def encoder_angles(n_per_rev: int, revolutions: float, start: float, direction_sign: int,
                   wrapped: bool) -> NDArray[np.float64]:
    """Equally spaced encoder angles [rad], increasing (+1) or decreasing (-1)."""
    n = int(round(n_per_rev * revolutions))
    theta = start + direction_sign * TWO_PI * np.arange(n) / n_per_rev
    return np.mod(theta, TWO_PI) if wrapped else theta


def sample_lobe(law: LiftLaw, nose: float, direction: int = 1, *, n_per_rev: int = 3600,
                revolutions: float = 1.0, start: float = 0.3, turn: int = 1,
                wrapped: bool = False, zero: float = 0.0, noise: float = 0.0,
                seed: int = 0, rate_hz: float = 1000.0) -> Samples:
    """Probe readings s = zero + law(alpha) + noise for a lobe whose nose is at ``nose``.

    ``turn`` is the sense in which the encoder angle runs (+1 increasing, -1
    decreasing); ``direction`` is the scene convention alpha = direction*(theta-nose).
    """
    theta = encoder_angles(n_per_rev, revolutions, start, turn, wrapped)
    alpha = np.angle(np.exp(1j * direction * (theta - nose)))
    rng = np.random.default_rng(seed)
    s = zero + law(alpha) + noise * rng.standard_normal(theta.size)
    stamps = (np.arange(theta.size) * (1e9 / rate_hz)).astype(np.int64)
    return Samples(theta, s, stamps)


def sample_pin(pin: DowelPinGeometry, centre: float, *, n_per_rev: int = 3600,
               revolutions: float = 1.0, start: float = 0.3, turn: int = 1,
               wrapped: bool = False, zero: float = 0.0, stop_drop: float = 0.5e-3,
               noise: float = 0.0, seed: int = 0, rate_hz: float = 1000.0) -> Samples:
    """Probe readings on the dowel pin: zero + h(alpha) in contact, else a probe stop
    ``stop_drop`` [m] below the lowest contact lift."""
    theta = encoder_angles(n_per_rev, revolutions, start, turn, wrapped)
    alpha = np.angle(np.exp(1j * (theta - centre)))
    h = pin.lift(alpha)
    h = np.where(np.isfinite(h), h, pin.lift_min - stop_drop)
    rng = np.random.default_rng(seed)
    s = zero + h + noise * rng.standard_normal(theta.size)
    stamps = (np.arange(theta.size) * (1e9 / rate_hz)).astype(np.int64)
    return Samples(theta, s, stamps)


def sample_keyway(keyway: KeywayGeometry, centre: float, direction: int = 1, *,
                  n_per_rev: int = 3600, revolutions: float = 1.0, start: float = 0.3,
                  turn: int = 1, wrapped: bool = False, zero: float = 0.0,
                  runout: float = 0.0, noise: float = 0.0, seed: int = 0,
                  rate_hz: float = 1000.0) -> Samples:
    """Probe readings over a keyway whose centre is at ``centre`` [rad]:
    ``zero + h(alpha) + runout cos(theta) + noise`` with ``alpha = direction (theta -
    centre)``, h of ``KeywayGeometry.lift`` (0 on the shaft, negative over the slot)."""
    theta = encoder_angles(n_per_rev, revolutions, start, turn, wrapped)
    alpha = np.angle(np.exp(1j * direction * (theta - centre)))
    rng = np.random.default_rng(seed)
    s = zero + keyway.lift(alpha) + runout * np.cos(theta) + \
        noise * rng.standard_normal(theta.size)
    stamps = (np.arange(theta.size) * (1e9 / rate_hz)).astype(np.int64)
    return Samples(theta, s, stamps)


def bumped_lobe_table(law: LiftLaw, bump: float, centre: float, width: float, *,
                      n_per_rev: int = 7200, noise: float = 0.0, seed: int = 0
                      ) -> NDArray[np.float64]:
    """A lobe's lift table (alpha, measured, design) [rad, m, m] over one revolution whose
    measured lift carries the local form error ``bump sin^4(pi u)``, u = (alpha -
    centre) / width + 1/2 in [0, 1] (C3: its derivatives vanish at both ends; largest
    |e'| (3 sqrt3 / 4) bump pi / width, largest |e''| 4 bump (pi / width)^2 at
    ``centre``), plus seeded Gaussian noise [m]."""
    alpha = np.linspace(-np.pi, np.pi, n_per_rev, endpoint=False)
    design = law(alpha)
    u = (alpha - centre) / width + 0.5
    error = np.where((u >= 0) & (u <= 1), bump * np.sin(np.pi * u) ** 4, 0.0)
    error += np.random.default_rng(seed).normal(0.0, noise, alpha.size)
    return np.column_stack([alpha, design + error, design])
