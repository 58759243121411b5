"""Wheel-centre path of a grinding wheel acting as a roller on the work cam (docs/grinding.md).

The wheel (radius R_w) touches the cam profile like a large roller follower; its centre
runs on the parallel curve of the profile at distance R_w. For a CNC cam grinder the
wheel centre moves on a line through the cam axis, so the table it needs is the
distance D of the wheel centre from the cam axis against the polar angle of the wheel
centre in the cam frame, which is the lift of an in-line roller of radius R_w:
D(alpha) = R0 + R_w + h_w(alpha).

Designs: flat, in-line roller, knife (through ``cam_design.follower.convert_lift``),
offset roller and rocker (their pitch curve, from the same formulas as
``offset_roller_profile`` / ``rocker_profile``, is first turned into the lift of the
equivalent in-line roller of the same radius: the same cam).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cam_design.errors import InputError, require_positive
from cam_design.cam_profile import offset_params, rocker_check, roller_profile, sign_param
from cam_design.follower import Follower, convert_lift, wrap_angle
from cam_design.jets import jet_mul
from cam_design.grinding.curve import PolarCurveLift, jet_cos_sin, law_jet, param_jet
from cam_design.lift_laws.base import LiftLaw

DESIGN_KINDS = ('flat', 'roller', 'knife', 'offset-roller', 'rocker')
#: design angles scanned for hollows the wheel cannot enter (points per turn)
BRIDGE_SCAN = 7200


@dataclass(frozen=True)
class Design:
    """The follower a lift law was written for.

    ``kind`` flat | roller | knife | offset-roller | rocker; ``radius`` r [m] (roller,
    offset-roller, rocker; 0 = knife edge); ``offset`` e [m] (offset-roller);
    ``centre_distance`` a and ``arm_length`` l [m] (rocker: the law is the arc lift of the
    roller centre, swing h / l); ``eta`` +1 clockwise / -1 counter-clockwise cam,
    ``delta`` offset side or swing direction (as ``cam_design.follower``).
    """

    kind: str
    radius: float = 0.0
    offset: float = 0.0
    centre_distance: float = 0.0
    arm_length: float = 0.0
    eta: int = 1
    delta: int = 1

    def __post_init__(self) -> None:
        if self.kind not in DESIGN_KINDS:
            raise InputError('design.kind', self.kind, ' | '.join(DESIGN_KINDS))
        require_positive('design.radius', self.radius, allow_zero=True)
        if self.kind == 'roller' and self.radius == 0:
            raise InputError('design.radius', self.radius, 'a roller radius > 0 (or kind: '
                             'knife)')
        if self.kind == 'knife' and self.radius != 0:
            raise InputError('design.radius', self.radius, '0 for a knife follower')

    @property
    def inline(self) -> bool:
        """True for flat / in-line roller / knife designs."""
        return self.kind in ('flat', 'roller', 'knife')


def equivalent_inline(law: LiftLaw, base_radius: float, design: Design, *,
                      key: str = 'lift') -> tuple[LiftLaw, Follower]:
    """(lift law, follower) of an in-line design that cuts the same cam as ``design``.

    Flat / roller / knife: the law itself. Offset roller and rocker: the radial lift
    |P| - (R0 + r) of their pitch curve P, against the polar angle of P measured from
    the direction the follower centre has at alpha = 0 on the base circle, in the sense
    of alpha (``eta``); a roller (or knife) of the same radius r.
    """
    r0 = require_positive('base_radius', base_radius)
    if design.inline:
        return law, Follower(design.kind, design.radius)
    r = design.radius
    eta = sign_param('design.eta', design.eta, (1, -1))
    if design.kind == 'offset-roller':
        r, e, eta, delta, s0 = offset_params(r0, r, design.offset, eta, design.delta)

        def curve(s: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
            h = law_jet(law, s)
            c, sn = jet_cos_sin(eta * param_jet(s))
            vx = h.copy()
            vx[0] += s0
            return jet_mul(c, vx) - sn * (delta * e), jet_mul(sn, vx) + c * (delta * e)
        base_dir = math.atan2(delta * e, s0)
    else:
        r, dist, arm, psi0 = rocker_check(r0, r, design.centre_distance, design.arm_length)
        delta = sign_param('design.delta', design.delta, (1, -1))

        def curve(s: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
            turn = eta * param_jet(s)
            big = turn - delta * law_jet(law, s) / arm
            big[0] -= delta * psi0
            ct, st = jet_cos_sin(turn)
            cb, sb = jet_cos_sin(big)
            return dist * ct - arm * cb, dist * st - arm * sb
        base_dir = math.atan2(arm * math.sin(delta * psi0), dist - arm * math.cos(psi0))
    # polar angle of P = eta (alpha' + shift) + pi/2 with alpha' = alpha on the base circle
    shift = eta * (base_dir - 0.5 * math.pi)
    lo, hi = law.support
    eq = PolarCurveLift(curve, r0 + r, sense=eta, shift=shift, support=(lo, hi),
                        junctions=tuple(law.junctions), continuity_order=law.continuity_order,
                        key=key)
    return eq, Follower('roller' if r > 0 else 'knife', r)


class WheelPath:
    """Wheel-centre path of a wheel of radius ``wheel_radius`` R_w [m] on the cam of ``law``.

    ``lift`` is the wheel as an in-line roller (a LiftLaw, exact h_w and 3 derivatives);
    :meth:`table` gives the centre distance and the contact point at wheel angles alpha
    [rad] (polar angle of the wheel centre from the lobe centreline, in the sense of
    alpha; for offset / rocker designs from the follower-centre direction at alpha = 0).
    """

    def __init__(self, law: LiftLaw, base_radius: float, design: Design,
                 wheel_radius: float, *, key: str = 'lift') -> None:
        self.base_radius = require_positive('base_radius', base_radius)
        self.wheel_radius = require_positive('wheel_radius', wheel_radius)
        self.design = design
        self.design_law, self.design_follower = equivalent_inline(law, base_radius, design,
                                                                  key=key)
        self.lift = convert_lift(self.design_law, self.base_radius, self.design_follower,
                                 Follower('roller', self.wheel_radius), key=key)
        self.bridged = self._bridged()

    def _bridged(self) -> list[tuple[float, float]]:
        """(alpha_first, alpha_last) [rad] of the design angles where the profile is
        concave with a radius below R_w: the wheel bridges the hollow there and the ground
        cam is NOT the design (empty list: the wheel reproduces the design)."""
        if self.design_follower.kind == 'flat':
            return []           # a realisable flat-tappet profile is convex everywhere
        a = -math.pi + 2 * math.pi * np.arange(BRIDGE_SCAN) / BRIDGE_SCAN
        prof = roller_profile(self.design_law, self.base_radius, self.design_follower.radius,
                              a)
        rho = prof.rho
        bad = (rho < 0) & (-rho < self.wheel_radius)
        edges = np.diff(np.concatenate([[0], bad.astype(int), [0]]))
        first, last = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
        return [(float(a[i]), float(a[j])) for i, j in zip(first, last)]

    def distance(self, alpha: ArrayLike) -> NDArray[np.float64]:
        """(4, n): D, D', D'', D''' [m, m/rad^k] of the wheel-centre distance (any
        angle: wrapped to one turn)."""
        a = np.asarray(alpha, dtype=float).reshape(-1)
        if not np.all(np.isfinite(a)):
            raise InputError('alpha', 'non-finite angles', 'finite angles [rad]')
        out = self.lift.derivatives(wrap_angle(a))
        out[0] += self.base_radius + self.wheel_radius
        return out

    def table(self, alpha: ArrayLike) -> dict[str, NDArray[np.float64]]:
        """Columns at wheel angles ``alpha``: distance, wheel centre and contact point.

        ``wheel_x_m, wheel_y_m``: wheel centre; ``contact_x_m, contact_y_m``: contact point
        (cam frame of follower.py, nose on +Y); ``contact_angle_rad``: polar angle of the
        contact point from the lobe centreline; ``normal_angle_rad``: direction of the
        profile normal there (alpha - mu); ``wheel_pressure_angle_rad`` mu =
        atan(D'/D), the angle between the wheel-centre line and the contact normal.
        """
        a = np.asarray(alpha, dtype=float).reshape(-1)
        d, d1 = self.distance(a)[:2]
        theta = a + 0.5 * math.pi
        ux, uy = np.cos(theta), np.sin(theta)
        norm = np.hypot(d, d1)
        nx, ny = (d * ux + d1 * uy) / norm, (d * uy - d1 * ux) / norm
        wx, wy = d * ux, d * uy
        cx, cy = wx - self.wheel_radius * nx, wy - self.wheel_radius * ny
        mu = np.arctan2(d1, d)
        contact = (np.arctan2(cy, cx) - 0.5 * math.pi + math.pi) % (2 * math.pi) - math.pi
        return {'angle_rad': a, 'wheel_centre_distance_m': d, 'contact_angle_rad': contact,
                'normal_angle_rad': a - mu, 'wheel_pressure_angle_rad': mu,
                'wheel_x_m': wx, 'wheel_y_m': wy, 'contact_x_m': cx, 'contact_y_m': cy}


def wheel_table(law: LiftLaw, base_radius: float, design: Design,
                wheel_radii: ArrayLike, step: float, *, key: str = 'lift',
                paths: list[WheelPath] | None = None) -> dict[str, NDArray[np.float64]]:
    """Long table over the full turn at angle ``step`` [rad] for each wheel radius [m]:
    ``wheel_radius_m`` then the columns of :meth:`WheelPath.table`. ``paths``, if given,
    receives the WheelPath of each radius (for their ``bridged`` report)."""
    radii = np.asarray(wheel_radii, dtype=float).reshape(-1)
    if radii.size == 0:
        raise InputError('wheel_radius', 'an empty list', 'at least one wheel radius [m]')
    if not (math.isfinite(step) and 1e-6 <= step <= math.pi / 18):
        raise InputError('step', step, 'an angle step in [1e-6, pi/18] rad')
    n = int(round(2 * math.pi / step))
    alpha = -math.pi + 2 * math.pi * np.arange(n) / n
    parts: dict[str, list[NDArray[np.float64]]] = {}
    for rw in radii:
        path = WheelPath(law, base_radius, design, float(rw), key=key)
        if paths is not None:
            paths.append(path)
        cols = {'wheel_radius_m': np.full(n, float(rw))}
        cols.update(path.table(alpha))
        for k, v in cols.items():
            parts.setdefault(k, []).append(v)
    return {k: np.concatenate(v) for k, v in parts.items()}
