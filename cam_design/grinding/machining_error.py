"""Machining errors of a ground cam: exact simulation and first-order sensitivities
(docs/grinding.md).

Machine model. The grinder moves the wheel centre along a table curve W_t(s) in the cam
frame (the nominal table is the wheel path of :class:`WheelPath`). The real machine
puts the wheel centre at

    W(s) = R(index) [W_t(s) + (R_a - R_t) r(s) + dC e(s)] + (x_r, y_r)

with R_a the actual and R_t the table's wheel radius (the operator re-zeroes the wheel
slide on the base circle, so the slide carries R_a - R_t; r = W_t / |W_t| is the slide
direction), dC the centre-distance error (CNC: along the slide, e = r; cradle: the work
axis moved away from the pivot, e = unit vector from O to P), ``index`` the angular
indexing error (a rotation of the cam on the spindle) and (x_r, y_r) the run-out (the
grinding axis off the cam's own axis). The cam is what the wheel discs of radius R_a
leave; the lift of the design follower on it is found exactly (:func:`ground_lift`).

Sensitivities. A small move dW of the wheel centre and dR of its radius move the
profile along its normal n by dn = dW . n - dR; a follower then moves by
dn / cos(mu_f) (mu_f its pressure angle, 0 for a flat face). Each error source is such
a dW (per unit error) at the wheel position that cuts the point the follower touches.
For the master-follower radius error of a cradle machine (roller master) the cradle
angle changes until the bigger roller touches the same master again.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cam_design.errors import InputError, require_finite
from cam_design.follower import Follower, convert_lift
from cam_design.jets import jet_mul, jet_sqrt
from cam_design.grinding.curve import jet_cos_sin, law_jet, param_jet, polar_jets
from cam_design.grinding.master_cam import Cradle, MasterCam
from cam_design.grinding.wheel_path import WheelPath

SOURCES = ('wheel_radius', 'centre_distance', 'index', 'run_out_x', 'run_out_y',
           'master_follower_radius')
UNITS = {'wheel_radius': 'm', 'centre_distance': 'm', 'index': 'rad', 'run_out_x': 'm',
         'run_out_y': 'm', 'master_follower_radius': 'm'}
NEWTON_TOL = 1e-13
NEWTON_MAX_ITER = 60
MAX_STEP = 0.05
Jet = NDArray[np.float64]
TableCurve = Callable[[NDArray[np.float64]], tuple[Jet, Jet]]


@dataclass(frozen=True)
class MachineErrors:
    """Error values of one grinding set-up (m, rad); see the module docstring.

    ``wheel_radius``: actual minus nominal wheel radius; ``master_follower_radius`` is
    only used by the sensitivities (a cradle with a roller master)."""

    wheel_radius: float = 0.0
    centre_distance: float = 0.0
    index: float = 0.0
    run_out_x: float = 0.0
    run_out_y: float = 0.0
    master_follower_radius: float = 0.0

    def __post_init__(self) -> None:
        for f in fields(self):
            require_finite(f'grinding.errors.{f.name}', getattr(self, f.name))


def path_curve(path: WheelPath) -> TableCurve:
    """Table curve of a wheel path: W(s) = D(s) u(s), u = (-sin s, cos s)."""
    d0 = path.base_radius + path.wheel_radius

    def curve(s: NDArray[np.float64]) -> tuple[Jet, Jet]:
        d = law_jet(path.lift, s)
        d[0] += d0
        c, sn = jet_cos_sin(param_jet(s))
        return -jet_mul(d, sn), jet_mul(d, c)
    return curve


class GroundCam:
    """The design follower on a cam ground along a table curve by a real machine.

    ``path``: the nominal WheelPath (design law, follower, base radius); ``curve``: the
    table actually run (default: the nominal path); ``table_radius``: the wheel radius
    the table was computed for (default: the nominal); ``cradle``: for the
    centre-distance error of a cradle machine (else CNC slide); ``probe``: the follower
    whose lift is returned (default: the design follower).
    """

    def __init__(self, path: WheelPath, errors: MachineErrors, *,
                 curve: TableCurve | None = None, table_radius: float | None = None,
                 cradle: Cradle | None = None, probe: Follower | None = None) -> None:
        self.path, self.errors, self.cradle = path, errors, cradle
        self.curve = curve if curve is not None else path_curve(path)
        self.table_radius = path.wheel_radius if table_radius is None else table_radius
        self.wheel = path.wheel_radius + errors.wheel_radius
        self.probe = probe
        f = path.design_follower if probe is None else probe
        self.r = 0.0 if f.kind == 'flat' else f.radius
        self.flat = f.kind == 'flat'
        if not self.flat and not self.r < self.wheel:
            raise InputError('grinding.wheel_radius', self.wheel,
                             f'a wheel larger than the follower roller ({self.r} m)')

    def wheel_centre(self, s: NDArray[np.float64]) -> tuple[Jet, Jet]:
        """Jets of the actual wheel centre at table parameters s."""
        e = self.errors
        x, y = self.curve(s)
        rad, ang = polar_jets(x, y)
        slide = self.wheel - self.table_radius
        if self.cradle is None:
            shift = slide + e.centre_distance
            c, sn = jet_cos_sin(ang)
            x = x + shift * c
            y = y + shift * sn
        else:
            c, sn = jet_cos_sin(ang)
            x = x + slide * c
            y = y + slide * sn
            phi = self.cradle.wheel_jets(rad)['phi']
            ce, se = jet_cos_sin(ang - phi)       # O -> P seen in the cam frame
            x = x + e.centre_distance * ce
            y = y + e.centre_distance * se
        ci, si = math.cos(e.index), math.sin(e.index)
        return ci * x - si * y + e.run_out_x, si * x + ci * y + e.run_out_y

    def _objective(self, s: NDArray[np.float64], alpha: NDArray[np.float64]) -> Jet:
        """Jet in s of the follower distance bound from the wheel disc at s."""
        x, y = self.wheel_centre(s)
        ua = (-np.sin(alpha), np.cos(alpha))
        p = x * ua[0] + y * ua[1]
        if self.flat:
            out = p.copy()
            out[0] -= self.wheel
            return out
        q = -x * ua[1] + y * ua[0]
        rr = (self.wheel - self.r) ** 2
        inner = -jet_mul(q, q)
        inner[0] += rr
        if np.any(~(inner[0] > 0)):
            return np.full_like(p, np.nan)
        return p - jet_sqrt(inner)

    def lift(self, alpha: ArrayLike, s_start: ArrayLike | None = None
             ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(lift [m] of the design follower at ``alpha`` on the ground cam, table
        parameter of the cutting wheel position). Flat: max over s of W.u - R_a;
        roller/knife: min over s of the near intersection of the follower axis with
        the disc of radius R_a - r about W(s). Newton from ``s_start`` (default: the
        nominal contact); InputError if it does not settle (never a silent value)."""
        a = np.asarray(alpha, dtype=float).reshape(-1)
        s = (contact_parameter(self.path, a, self.probe) if s_start is None
             else np.asarray(s_start, dtype=float).reshape(-1).copy())
        sign = 1.0 if self.flat else -1.0           # maximise (flat) or minimise (roller)
        for _ in range(NEWTON_MAX_ITER):
            j = self._objective(s, a)
            g1, g2 = j[1], 2.0 * j[2]
            ok = sign * g2 < 0
            step = np.where(ok, -g1 / np.where(ok, g2, 1.0), sign * np.sign(g1) * MAX_STEP)
            step = np.clip(step, -MAX_STEP, MAX_STEP)
            s = s + step
            if np.all(np.abs(step) < NEWTON_TOL):
                break
        j = self._objective(s, a)
        if not np.all(np.isfinite(j[0])) or np.max(np.abs(j[1])) > 1e-9:
            raise InputError('grinding', 'a ground-cam contact that does not settle',
                             'a smooth, convex enough cam and small machine errors')
        base = self.path.base_radius + (0.0 if self.flat else self.r)
        return j[0] - base, s


def contact_parameter(path: WheelPath, alpha: ArrayLike, probe: Follower | None = None
                      ) -> NDArray[np.float64]:
    """Wheel angle s whose contact normal equals the follower's (design or ``probe``)
    contact normal at ``alpha`` (s - atan(D'/D) = psi_f; Newton)."""
    a = np.asarray(alpha, dtype=float).reshape(-1)
    psi, _ = follower_normal(path, a, probe)
    d = path.distance(psi)
    s = psi + np.arctan2(d[1], d[0])
    for _ in range(NEWTON_MAX_ITER):
        d = path.distance(s)
        big = d[0] ** 2 + d[1] ** 2
        f = s - np.arctan2(d[1], d[0]) - psi
        f = (f + math.pi) % (2 * math.pi) - math.pi
        fp = (d[0] ** 2 + 2 * d[1] ** 2 - d[0] * d[2]) / big
        step = np.clip(-f / np.where(fp > 0, fp, 1.0), -MAX_STEP, MAX_STEP)
        s = s + step
        if np.max(np.abs(step)) < NEWTON_TOL:
            return s
    raise InputError('grinding', 'a wheel contact that does not settle',
                     'a wheel path whose normal turns monotonically (convex)')


def follower_normal(path: WheelPath, alpha: NDArray[np.float64],
                    probe: Follower | None = None
                    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(normal angle psi_f, pressure angle mu_f) of the contact of the design follower
    (or of ``probe``, whose lift is the design lift converted through the profile)."""
    f = path.design_follower if probe is None else probe
    alpha = (alpha + math.pi) % (2 * math.pi) - math.pi
    if f.kind == 'flat':
        return alpha.copy(), np.zeros_like(alpha)
    law = path.design_law if probe is None else convert_lift(
        path.design_law, path.base_radius, path.design_follower, probe, key='probe')
    h = law.derivatives(alpha)
    mu = np.arctan2(h[1], path.base_radius + f.radius + h[0])
    return alpha - mu, mu


def _rot(vx: NDArray[np.float64], vy: NDArray[np.float64], ang: NDArray[np.float64]
         ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    c, s = np.cos(ang), np.sin(ang)
    return c * vx - s * vy, s * vx + c * vy


def sensitivities(path: WheelPath, alpha: ArrayLike, *, cradle: Cradle | None = None,
                  master: MasterCam | None = None, sources: tuple[str, ...] | None = None,
                  probe: Follower | None = None) -> dict[str, NDArray[np.float64]]:
    """First-order lift error of the design follower (or of ``probe``) per unit of each
    error source (m/m or m/rad) at angles ``alpha`` [rad]. ``centre_distance`` uses the cradle
    (pivot-to-work) when ``cradle`` or ``master`` is given, else the CNC slide;
    ``master_follower_radius`` needs ``master`` (a roller master)."""
    a = np.asarray(alpha, dtype=float).reshape(-1)
    if master is not None:
        cradle = master.cradle
    names = sources or tuple(n for n in SOURCES if n != 'master_follower_radius'
                             or (master is not None and master.kind == 'roller'))
    for n in names:
        if n not in SOURCES:
            raise InputError('sources', n, 'one of ' + ', '.join(SOURCES))
    if 'master_follower_radius' in names and (master is None or master.kind != 'roller'):
        raise InputError('sources', 'master_follower_radius', 'a cradle with a roller '
                                                              'master follower')
    s = contact_parameter(path, a, probe)
    _, mu_f = follower_normal(path, a, probe)
    d = path.distance(s)
    norm = np.hypot(d[0], d[1])
    ux, uy = -np.sin(s), np.cos(s)
    nx, ny = (d[0] * ux + d[1] * uy) / norm, (d[0] * uy - d[1] * ux) / norm   # outward
    cos_w = d[0] / norm
    scale = 1.0 / np.cos(mu_f)
    out: dict[str, NDArray[np.float64]] = {}
    state = None
    if cradle is not None:
        dj = law_jet(path.lift, s)
        dj[0] += path.base_radius + path.wheel_radius
        state = cradle.wheel_jets(dj)
    for name in names:
        if name == 'wheel_radius':
            dn = cos_w - 1.0
        elif name == 'centre_distance':
            if state is None:
                dn = cos_w
            else:
                ex, ey = _rot(np.ones_like(s), np.zeros_like(s), 0.5 * math.pi + s
                              - state['phi'][0])
                dn = ex * nx + ey * ny
        elif name == 'index':
            dn = d[0] * (-np.cos(s) * nx - np.sin(s) * ny)
        elif name == 'run_out_x':
            dn = nx
        elif name == 'run_out_y':
            dn = ny
        else:   # master_follower_radius: checked above to come with a roller master
            assert master is not None and state is not None
            dn = _master_radius_dn(master, s, state, nx, ny)
        out[name] = dn * scale
    return out


def _master_radius_dn(master: MasterCam, s: NDArray[np.float64], state: dict,
                      nx: NDArray[np.float64], ny: NDArray[np.float64]
                      ) -> NDArray[np.float64]:
    """Profile normal move per metre of master-roller radius (cradle re-balances)."""
    cr = master.cradle
    st = master.jets(s)
    # wheel normal into the work-cradle frame (cam -> cradle: phi - pi/2 - s)
    ncx, ncy = _rot(nx, ny, state['phi'][0] - 0.5 * math.pi - s)
    vx, vy = state['vx'][0], state['vy'][0]
    # master pitch curve (master frame) and its outward normal, into the master-cradle frame
    val, ang = st['value'], st['angle']
    c, sn = jet_cos_sin(ang)
    px, py = -jet_mul(val, sn), jet_mul(val, c)
    speed = np.hypot(px[1], py[1])
    mnx, mny = py[1] / speed, -px[1] / speed
    mnx, mny = _rot(mnx, mny, st['phim'][0] - 0.5 * math.pi - ang[0])
    cd, sd = math.cos(cr.side * cr.master_angle), math.sin(cr.side * cr.master_angle)
    rvx, rvy = cd * vx - sd * vy, sd * vx + cd * vy
    dm = cr.pivot_to_master_follower * (-rvy * mnx + rvx * mny)
    dw = cr.pivot_to_wheel * (-vy * ncx + vx * ncy)
    return dw / dm
