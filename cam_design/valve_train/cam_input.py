"""The cam input of the valve-train models, piecewise polynomial in the cam angle.

On every step [alpha_i, alpha_i+1] the rigid valve lift u = k h(alpha) - x0 is the
degree-7 Hermite polynomial in sigma = (alpha - alpha_i)/L that matches h, h', h'',
h''' of the lift law at both ends (one-sided at the law's junctions, which are always
step nodes). The interpolation error is O(L^8 h^(8)), far below 1e-12 m for steps
up to a degree on smooth laws, and the models integrate this polynomial exactly.
"""
from __future__ import annotations

from typing import Any, Callable

import bisect
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from cam_design.errors import InputError, require_positive
from cam_design.lift_laws.base import LiftLaw
from cam_design.lift_laws.jet_table import HERMITE_INV
from cam_design.valve_train.params import require_step_deg

_ONE_SIDED = 1e-11   # rad: offset used to evaluate one-sided derivatives at junctions


@dataclass(frozen=True)
class CamInput:
    """Step nodes over one cam revolution and the per-step polynomial of u.

    Attributes:
        nodes: (N+1,) node angles [rad], from ``start`` to ``start + 2 pi``.
        lengths: (N,) step lengths [rad].
        coeffs: (N, 8) monomial coefficients of u(sigma) [m] on each step.
        uniform: (N+1,) True where a node is on the uniform output grid.
        rocker_ratio, lash: k and x0.
        gas: (N, 8) monomial coefficients of an external force on the valve that opposes
            its opening (cylinder gas) [N] on each step, or None (``with_gas``).
    """

    nodes: NDArray[np.float64]
    lengths: NDArray[np.float64]
    coeffs: NDArray[np.float64]
    uniform: NDArray[np.bool_]
    rocker_ratio: float
    lash: float
    gas: NDArray[np.float64] | None = None   # (N, 8) monomials of a force on the valve [N]

    @property
    def start(self) -> float:
        """First node [rad]."""
        return float(self.nodes[0])

    def u(self, k: int, sigma: NDArray[np.float64] | float) -> NDArray[np.float64]:
        """u [m] on step k at local sigma in [0, 1]."""
        return np.polynomial.polynomial.polyval(sigma, self.coeffs[k])


def build_cam_input(law: LiftLaw, rocker_ratio: float, lash: float, step: float,
                    pre: float | None = None, key: str = 'lift') -> CamInput:
    """Nodes every ``step`` rad over one revolution starting at least ``pre`` before
    the lobe, on the grid of multiples of ``step`` (alpha = 0 is a node).

    ``pre`` defaults to two steps (at least 0.5 deg). The window is [start, start +
    2 pi], start = floor((lo - pre)/step) step. The cam is periodic: a lobe wider than
    the window minus ``pre`` (up to a full revolution: eccentrics, long dwells) wraps
    around, u(alpha) = k (h(alpha) + h(alpha - 2 pi) + h(alpha + 2 pi)) - x0. Only a
    support longer than 2 pi is refused (InputError naming ``key``).
    """
    require_step_deg('step [deg]', round(math.degrees(require_positive('step', step)), 12))
    lo, hi = (float(v) for v in law.support)
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi - lo > 2.0 * math.pi + 1e-9:
        raise InputError(key, f'support [{lo:g}, {hi:g}] rad',
                         'a lobe at most one revolution (2 pi rad) wide')
    if pre is None:
        pre = max(2 * step, math.radians(0.5))
    # anchored on alpha = 0: every run with this step shares its grid (the nose is a node)
    start = math.floor((lo - pre) / step + 1e-9) * step
    if hi > start + 2.0 * math.pi - pre:     # a wide lobe: start at (just before) lo
        start = math.floor(lo / step + 1e-9) * step
    end = start + 2.0 * math.pi
    wraps = hi > end - 1e-12 or lo < start + 1e-12
    n = int(math.ceil(2.0 * math.pi / step - 1e-9))
    grid = start + step * np.arange(n + 1)
    grid[-1] = end
    extra = []
    for a in (lo, hi, *law.junctions):
        for shift in (0.0, -2.0 * math.pi, 2.0 * math.pi):
            if start < a + shift < end:
                extra.append(a + shift)
    nodes = np.unique(np.concatenate([grid, np.asarray(extra, dtype=float)]))
    # merge nodes closer than 1e-9 rad (keep the uniform ones)
    uniform = np.isin(nodes, grid)
    keep = np.ones(nodes.size, dtype=bool)
    gaps = np.diff(nodes) < 1e-9
    for i in np.nonzero(gaps)[0]:
        keep[i + 1 if uniform[i] else i] = False
    nodes, uniform = nodes[keep], uniform[keep]
    lengths = np.diff(nodes)
    # the uniform steps differ by rounding only (1e-15 rad): one length, so the solvers
    # share one propagator for all of them (the node angles stay as they are)
    lengths[np.abs(lengths - step) <= 1e-12 * step] = step
    junction = ~uniform.copy()
    jset = np.asarray(extra, dtype=float)
    if jset.size:
        near = np.min(np.abs(nodes[:, None] - jset[None, :]), axis=1) < 1e-9
        junction |= near

    def jets(a: NDArray[np.float64]) -> NDArray[np.float64]:
        out = law.derivatives(a)
        if wraps:           # the periodic copies, strictly inside their support
            for shift in (-2.0 * math.pi, 2.0 * math.pi):
                b = a + shift
                sel = (b > lo) & (b < hi)
                if np.any(sel):
                    out[:, sel] += law.derivatives(b[sel])
        return out

    left = jets(nodes[1:] - np.where(junction[1:], _ONE_SIDED, 0.0))
    right = jets(nodes[:-1] + np.where(junction[:-1], _ONE_SIDED, 0.0))
    if not (np.all(np.isfinite(left)) and np.all(np.isfinite(right))):
        raise InputError(key, 'non-finite h or derivatives', 'a finite lift law')
    scale = np.stack([lengths ** d for d in range(4)])   # (4, N): d/dsigma = L d/dalpha
    ends = np.concatenate([right * scale, left * scale])  # (8, N)
    coeffs = (HERMITE_INV @ ends).T * rocker_ratio
    coeffs[:, 0] -= lash
    return CamInput(nodes=nodes, lengths=lengths, coeffs=coeffs, uniform=uniform,
                    rocker_ratio=float(rocker_ratio), lash=float(lash))


def lift_of_time(cam: CamInput, a0: float, omega: float, *, periodic: bool = False
                 ) -> Callable[[float], tuple[float, float]]:
    """u [m] and du/dt [m/s] of ``cam`` at the cam angle a0 + omega t [rad] for a time t
    [s] (``periodic``: the angle taken modulo one revolution from a0), by Horner on the
    step's polynomial in sigma: the cam drive of the ODE-integrated trains."""
    nodes = cam.nodes.tolist()
    coefs = [c[::-1].tolist() for c in cam.coeffs]
    lens = cam.lengths.tolist()
    two_pi = 2.0 * math.pi

    def u(t: float) -> tuple[float, float]:
        a = a0 + ((omega * t) % two_pi if periodic else omega * t)
        i = min(max(bisect.bisect_right(nodes, a) - 1, 0), len(lens) - 1)
        sig = (a - nodes[i]) / lens[i]
        val = der = 0.0
        for c in coefs[i]:
            der = der * sig + val
            val = val * sig + c
        return val, der * omega / lens[i]

    return u


#: points per step at which an external force is fitted (Chebyshev nodes)
GAS_POINTS = 6


def with_gas(cam: CamInput, force: Any) -> CamInput:
    """The cam input with an external force on the valve, ``force(alpha)`` [N] of the cam
    angle [rad] (positive: pushes the valve shut, as cylinder gas on an exhaust valve),
    as a quintic per step fitted at ``GAS_POINTS`` Chebyshev nodes. A force that is
    piecewise linear inside a step (a pressure table) is followed to O(step^2 F'')."""
    import dataclasses

    s = 0.5 - 0.5 * np.cos(np.pi * (np.arange(GAS_POINTS) + 0.5) / GAS_POINTS)
    vand = s[:, None] ** np.arange(6)
    pinv = np.linalg.pinv(vand)                           # (6, GAS_POINTS)
    alpha = cam.nodes[:-1, None] + cam.lengths[:, None] * s[None, :]
    values = np.vectorize(lambda a: float(force(float(a))), otypes=[float])(alpha)
    if not np.all(np.isfinite(values)):
        raise InputError('gas', 'non-finite force', 'a finite force at every cam angle')
    coef = np.zeros_like(cam.coeffs)
    coef[:, :6] = values @ pinv.T
    return dataclasses.replace(cam, gas=coef)
