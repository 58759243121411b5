"""A lobe's lift as its valve train sees it on a twisting shaft (docs/camshaft.md).

With the shaft's deviation psi(alpha) [rad] at the lobe (positive: ahead of the rigid,
constant-speed rotation alpha = omega t), the follower meets the cam at its angle
a + psi, so the lift against the nominal angle a is H(a) = h(a + delta(a)),
delta(a) = psi(a - c) (c: the lobe's angle at shaft angle 0). Its derivatives follow by
the chain rule, with delta's derivatives from the shaft's Fourier series on the grid:
    H'   = h' (1 + d')
    H''  = h'' (1 + d')^2 + h' d''
    H''' = h''' (1 + d')^3 + 3 h'' (1 + d') d'' + h' d'''.
The valve-train solvers take H at constant omega: the exact coupled input.
"""
from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cam_design.lift_laws.base import LiftLaw


class PeriodicJets:
    """psi and its first three derivatives [rad, -, 1/rad, 1/rad^2] of a periodic
    function sampled on the N-point grid alpha_k = 2 pi k / N (``grid_jets`` (4, N),
    exact there, e.g. from the shaft's Fourier series): between the nodes each jet is
    the cubic Hermite interpolant of its value and the next jet (the third linear), so
    psi is O(step^4) accurate off the grid."""

    def __init__(self, grid_jets: NDArray[np.float64]) -> None:
        self.N = grid_jets.shape[1]
        self.step = 2.0 * math.pi / self.N
        self.grid = grid_jets                      # (4, N)
        self.amplitude = float(np.max(np.abs(grid_jets[0]))) if grid_jets.size else 0.0

    def __call__(self, alpha: NDArray[np.float64]) -> NDArray[np.float64]:
        """(4, n) jets at ``alpha`` [rad]."""
        a = np.asarray(alpha, dtype=float).reshape(-1)
        pos = a / self.step
        k0 = np.floor(pos)
        t = pos - k0
        on = t < 1e-9
        t = np.where(on, 0.0, t)
        i0 = k0.astype(np.int64) % self.N
        i1 = (i0 + 1) % self.N
        g, h = self.grid, self.step
        h00 = 2 * t ** 3 - 3 * t ** 2 + 1
        h10 = t ** 3 - 2 * t ** 2 + t
        h01 = -2 * t ** 3 + 3 * t ** 2
        h11 = t ** 3 - t ** 2
        out = np.empty((4, a.size))
        for p in range(3):
            out[p] = (h00 * g[p, i0] + h10 * h * g[p + 1, i0] + h01 * g[p, i1]
                      + h11 * h * g[p + 1, i1])
        out[3] = (1 - t) * g[3, i0] + t * g[3, i1]
        return out


class TwistedLift(LiftLaw):
    """H(a) = h(a + psi(a - shift)) of ``base`` on a shaft deviating by ``twist``
    (module docstring); the lobe keeps its own angle axis (``lobe_start`` = the base
    law's start, the anchor of the crank-angle timing of the gas force)."""

    def __init__(self, base: LiftLaw, twist: PeriodicJets, shift: float) -> None:
        self.base = base
        self.twist = twist
        self.shift = float(shift)
        lo, hi = (float(v) for v in base.support)
        margin = twist.amplitude + 1e-9
        if hi - lo + 2 * margin >= 2 * math.pi:      # a lobe over the whole revolution
            self._support = (lo, lo + 2 * math.pi)
        else:
            self._support = (lo - margin, hi + margin)
        self.lobe_start = lo
        self.continuity_order = base.continuity_order

    @property
    def support(self) -> tuple[float, float]:
        return self._support

    @property
    def junctions(self) -> tuple[float, ...]:
        """The base law's junctions j moved to the nominal angles a with a + delta = j."""
        out = []
        for j in self.base.junctions:
            a = float(j)
            for _ in range(4):
                a = float(j) - float(self.twist(np.array([a - self.shift]))[0, 0])
            out.append(a)
        return tuple(out)

    def _jets(self, a: NDArray[np.float64]) -> NDArray[np.float64]:
        d = self.twist(a - self.shift)
        lo = self.lobe_start                  # the lobe repeats every revolution
        h = self.base.derivatives(lo + np.mod(a + d[0] - lo, 2 * math.pi))
        g = 1.0 + d[1]
        return np.stack([h[0], h[1] * g, h[2] * g * g + h[1] * d[2],
                         h[3] * g ** 3 + 3.0 * h[2] * g * d[2] + h[1] * d[3]])

    def _evaluate(self, alpha: NDArray[np.float64], nu: int) -> NDArray[np.float64]:
        return self._jets(alpha)[nu]

    def derivatives(self, alpha: ArrayLike) -> NDArray[np.float64]:
        """(4, n): H, H', H'', H''' at ``alpha`` (zero outside the support)."""
        a = np.asarray(alpha, dtype=float).reshape(-1)
        out = np.zeros((4, a.size))
        lo, hi = self.support
        inside = (a >= lo) & (a <= hi)
        if np.any(inside):
            out[:, inside] = self._jets(a[inside])
        return out
