"""Keyway (a slot in the shaft) measured by a radial ball probe, as a datum.

Shaft frame: the slot of width ``width`` (w) is centred on the x axis, its flanks are
the planes y = +-w/2, its flat bottom (when the ball reaches it) is at x = R - depth;
the shaft is a cylinder of radius ``shaft_radius`` (R). A ball of radius
``probe_radius`` (r) moves along the radial line at angle alpha from the slot centre
and rests where it first touches the part. Its centre distance from the axis L(alpha)
is the largest of:

* the shaft surface, L = R + r, for |alpha| >= beta = arcsin(w / 2R) (the slot's
  edges are at +-beta);
* an edge (a sharp corner at angle +-beta on the circle R): a point touched by the
  ball, L = R cos(u) + sqrt(r^2 - R^2 sin^2 u) with u = alpha -+ beta, for |u| <=
  arcsin(r / R) (``cam_design.dowel_pin.centre_distance`` with rho = r);
* the bottom, L = (R - depth + r) / cos(alpha), while the ball is clear of both flanks
  (|L sin alpha| <= w/2 - r).

The lift is h = L - (R + r): 0 on the shaft, negative over the slot. When the ball is
wider than the slot (r > w/2) it rests on both edges and never reaches the bottom: the
profile is a V of two edge arcs meeting at alpha = 0. When it is narrower, it rolls
over an edge and drops to the bottom (``depth`` is then needed). Either way the slot
centre is where the two edge arcs are mirror images: alpha = 0.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cam_design.dowel_pin import centre_distance
from cam_design.errors import InputError, require_positive

SHAFT, EDGE_PLUS, EDGE_MINUS, BOTTOM = 0, 1, 2, 3


@dataclass(frozen=True)
class KeywayGeometry:
    """Slot width, shaft radius, probe ball radius and (optional) slot depth [m]."""

    width: float
    shaft_radius: float
    probe_radius: float
    depth: float | None = None

    def __post_init__(self) -> None:
        require_positive('keyway.width', self.width)
        require_positive('keyway.shaft_radius', self.shaft_radius)
        require_positive('keyway.probe_radius', self.probe_radius)
        if self.width >= 2.0 * self.shaft_radius:
            raise InputError('keyway.width', self.width,
                             f'less than the shaft diameter 2 x shaft_radius = '
                             f'{2 * self.shaft_radius:g} m')
        if self.probe_radius >= self.shaft_radius:
            raise InputError('keyway.probe_radius', self.probe_radius,
                             f'less than shaft_radius {self.shaft_radius:g} m')
        if self.depth is None:
            if self.ball_enters:
                raise InputError('keyway.depth', None,
                                 f'the slot depth in m: the ball (radius '
                                 f'{self.probe_radius:g} m) fits the slot (width '
                                 f'{self.width:g} m) and reaches its bottom')
            return
        require_positive('keyway.depth', self.depth)
        edge_x = np.sqrt(self.shaft_radius ** 2 - 0.25 * self.width ** 2)
        if not self.depth > self.shaft_radius - edge_x or self.depth >= self.shaft_radius:
            raise InputError('keyway.depth', self.depth,
                             f'a depth between {self.shaft_radius - edge_x:g} m (the edges) '
                             f'and shaft_radius {self.shaft_radius:g} m')

    @property
    def ball_enters(self) -> bool:
        """True if the ball is narrower than the slot (it drops to the bottom)."""
        return self.probe_radius < 0.5 * self.width

    @property
    def edge_angle(self) -> float:
        """beta [rad]: the slot's edges are at +-beta from its centre."""
        return float(np.arcsin(0.5 * self.width / self.shaft_radius))

    @property
    def tangent_angle(self) -> float:
        """[rad] from an edge where the ball leaves it (its slope becomes infinite)."""
        return float(np.arcsin(self.probe_radius / self.shaft_radius))

    def _candidates(self, a: NDArray[np.float64], nu: int) -> NDArray[np.float64]:
        """(4, n) candidate centre distances (or derivatives) per branch; -inf where a
        branch does not apply."""
        r, big = self.probe_radius, self.shaft_radius
        beta = self.edge_angle
        out = np.full((4,) + a.shape, -np.inf)
        shaft = np.abs(a) >= beta
        out[SHAFT] = np.where(shaft, big + r if nu == 0 else 0.0, -np.inf)
        inside = ~shaft
        for k, corner in ((EDGE_PLUS, beta), (EDGE_MINUS, -beta)):
            u = a - corner
            with np.errstate(invalid='ignore', divide='ignore'):
                val = centre_distance(np.where(inside, u, 0.0), nu, big, r)
            ok = inside & (np.abs(u) <= self.tangent_angle) & np.isfinite(val)
            out[k] = np.where(ok, val, -np.inf)
        if self.depth is not None and self.ball_enters:
            height = big - self.depth + r     # m: ball centre above the slot bottom
            cos_a = np.cos(np.where(inside, a, 0.0))
            sec, tan = 1.0 / cos_a, np.tan(np.where(inside, a, 0.0))
            lval = height * sec
            ok = inside & (np.abs(lval * np.sin(np.where(inside, a, 0.0)))
                           <= 0.5 * self.width - r)
            deriv = (lval, height * sec * tan, height * sec * (tan**2 + sec**2),
                     height * sec * tan * (tan**2 + 5 * sec**2))[nu]
            out[BOTTOM] = np.where(ok, deriv, -np.inf)
        return out

    def branch(self, alpha: ArrayLike) -> NDArray[np.int64]:
        """Which surface the ball touches at ``alpha`` [rad]: SHAFT, EDGE_PLUS, EDGE_MINUS,
        BOTTOM (-1: nowhere, the ball in free fall)."""
        a = np.asarray(alpha, dtype=float)
        cand = self._candidates(a, 0)
        best = np.argmax(cand, axis=0)
        return np.where(np.isfinite(np.max(cand, axis=0)), best, -1)

    def lift(self, alpha: ArrayLike, nu: int = 0) -> NDArray[np.float64]:
        """nu-th derivative (0..3) of h = L - (R + r) at ``alpha`` [rad] (wrapped to
        (-pi, pi]); m, m/rad^nu. 0 on the shaft, negative over the slot."""
        if nu not in (0, 1, 2, 3):
            raise InputError('nu', nu, 'a derivative order 0..3')
        a = np.asarray(alpha, dtype=float)
        a = np.pi - np.mod(np.pi - a, 2 * np.pi)
        which = self.branch(a)
        cand = self._candidates(a, nu)
        pick = np.take_along_axis(cand, np.maximum(which, 0)[None], axis=0)[0]
        pick = np.where(which >= 0, pick, np.nan)
        if nu == 0:
            pick = pick - (self.shaft_radius + self.probe_radius)
        return np.asarray(pick, dtype=float)

    def edge_span(self) -> float:
        """u_end [rad]: how far from its edge (towards the centre) the ball rides an
        edge arc before it meets the other arc (alpha = 0), the bottom, or leaves the
        edge at the tangent angle."""
        beta = self.edge_angle
        if not self.ball_enters:
            return beta
        u = np.linspace(0.0, min(self.tangent_angle, beta), 20001)
        on_edge = self.branch(beta - u) == EDGE_PLUS
        off = np.flatnonzero(~on_edge)
        return float(u[off[0] - 1]) if off.size else float(u[-1])

    @property
    def depth_seen(self) -> float:
        """Lowest lift [m] (negative): at the slot centre."""
        return float(np.nanmin(self.lift(np.linspace(-self.edge_angle, self.edge_angle, 4001))))
