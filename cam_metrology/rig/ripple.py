"""The valve's response to the camshaft's speed ripple (docs/methods.md "Rig").

The valve train feels the cam only through the rigid lift u(t) = k h(alpha(t)) - x0.
With a speed ripple the lobe angle is alpha(t) = phi(t) + eps(phi(t)), phi the
uniform phase of the mean speed and eps the ripple's angle (periodic in the
revolution: its orders are harmonics of the mean speed). So the rippled valve is the
steady-speed valve of the *equivalent law* h_eq(phi) = h(phi + eps(phi)) at the mean
speed, read at each sample's uniform phase: the dynamics' own solver gives the response
to the ripple with no other change (exact for a ripple periodic in the revolution; a
slow drift of the mean speed is not in it).

eps comes from the encoder's angle model (``encoder.Speed``: the harmonic orders it
kept, as a function of time); ``sample_phase`` gives each sample's uniform lobe phase
and ``RippleLaw`` the equivalent law.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cam_design.lift_laws.base import LiftLaw

TWO_PI = 2.0 * math.pi


class RippleLaw(LiftLaw):
    """h_eq(phi) = h(phi + eps(phi)), eps(phi) = g sum_k [a_k cos(k g phi + c_k) +
    b_k sin(k g phi + c_k)] [rad]; derivatives by the chain rule (orders 0..3)."""

    def __init__(self, law: Any, g: int, orders: NDArray[np.int64], a: NDArray[np.float64],
                 b: NDArray[np.float64], c: NDArray[np.float64]) -> None:
        self.law, self.g = law, int(g)
        self.w = np.asarray(orders, dtype=float) * self.g
        self.a, self.b, self.c = (np.asarray(v, dtype=float) for v in (a, b, c))
        self.continuity_order = getattr(law, 'continuity_order', 0)
        amp = float(np.sum(np.hypot(self.a, self.b)))
        lo, hi = law.support
        self._support = (float(lo) - amp - 1e-9, float(hi) + amp + 1e-9)
        self._junctions = tuple(self._inverse(x) for x in (lo, hi, *law.junctions))

    def eps(self, phi: NDArray[np.float64], nu: int = 0) -> NDArray[np.float64]:
        """The ripple angle [rad] (``nu``-th derivative) at uniform phases ``phi``."""
        arg = np.outer(phi, self.w) + self.c
        cos, sin = np.cos(arg), np.sin(arg)
        w = self.w ** nu
        if nu % 2 == 0:
            val = (self.a * cos + self.b * sin) * (-1) ** (nu // 2)
        else:
            val = (-self.a * sin + self.b * cos) * (-1) ** (nu // 2)
        return np.asarray(self.g * (val * w).sum(axis=1), dtype=np.float64)

    def _inverse(self, x: float) -> float:
        """The phase phi with phi + eps(phi) = x (fixed point: |eps'| << 1)."""
        phi = float(x)
        for _ in range(50):
            nxt = float(x - self.eps(np.array([phi]))[0])
            if abs(nxt - phi) < 1e-15:
                return nxt
            phi = nxt
        return phi

    @property
    def support(self) -> tuple[float, float]:
        return self._support

    @property
    def junctions(self) -> tuple[float, ...]:
        return self._junctions

    def _evaluate(self, alpha: NDArray[np.float64], nu: int) -> NDArray[np.float64]:
        x = alpha + self.eps(alpha)
        if nu == 0:
            return np.asarray(self.law(x), dtype=np.float64)
        d1 = 1.0 + self.eps(alpha, 1)
        if nu == 1:
            return np.asarray(self.law(x, 1) * d1, dtype=np.float64)
        e2 = self.eps(alpha, 2)
        if nu == 2:
            return np.asarray(self.law(x, 2) * d1 ** 2 + self.law(x, 1) * e2,
                              dtype=np.float64)
        e3 = self.eps(alpha, 3)
        return np.asarray(self.law(x, 3) * d1 ** 3 + 3.0 * self.law(x, 2) * d1 * e2
                          + self.law(x, 1) * e3, dtype=np.float64)


def has_ripple(speed: Any) -> bool:
    """Whether the encoder's angle model kept any ripple order."""
    return bool(len(speed.orders))


def ripple_law(law: Any, speed: Any, nose: float, direction: int) -> RippleLaw:
    """The equivalent law of a run (``speed``: its ``encoder.Speed``) for the nose at
    encoder angle ``nose`` [rad]: eps(phi) = direction * sign * H(t(phi)), H the
    harmonic part of the angle model, t(phi) from the uniform encoder angle
    psi = direction * phi + nose, omega (t - t0) = sign (psi - psi0)."""
    g = int(direction) * int(speed.sign)
    k = np.asarray(speed.orders, dtype=np.int64)
    c = k * speed.sign * (nose - speed.psi0)
    return RippleLaw(law, g, k, speed.ripple_cos, speed.ripple_sin, c)


def sample_phase(data: Any, nose: float, direction: int) -> NDArray[np.float64]:
    """Uniform lobe phase [rad] in (-pi, pi] of every sample of a run (``RunData``):
    the lobe angle of the encoder angle without the ripple."""
    sp = data.speed
    enc = data.cycles.enc
    if has_ripple(sp):
        enc = enc - sp.sign * sp.ripple_at(data.run.time)
    a = direction * (enc - nose)
    return np.asarray(np.pi - np.mod(np.pi - a, TWO_PI), dtype=np.float64)


def run_bins(pred: Any, data: Any, nose: float, direction: int) -> NDArray[np.float64]:
    """``model.predicted_bins`` of a run, read at its samples' uniform phases (the
    prediction ``pred`` is of the run's equivalent law when it has a ripple)."""
    from cam_metrology.rig.model import predicted_bins

    return predicted_bins(pred, data.cycles, nose, direction,
                          sample_phase(data, nose, direction))
