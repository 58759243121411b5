"""Master cam of a rocking-cradle (copy) cam grinder (docs/grinding.md, figure there).

Geometry (all in the plane of the cam, lengths m, angles rad):

* P: cradle pivot, fixed in the machine. The cradle carries the work spindle (axis O,
  |PO| = ``pivot_to_work`` a) and the master spindle (axis O_m, |PO_m| =
  ``pivot_to_master`` a_m); both spindles turn together (1:1, same sense).
* W: grinding-wheel centre, fixed in the machine, |PW| = ``pivot_to_wheel`` b.
* M: master-follower centre (roller) or a point of its face (flat), fixed in the
  machine, |PM| = ``pivot_to_master_follower`` c; the angle from the line PW to the line
  PM, less the angle from PO to PO_m, is ``master_angle`` (0 when the two triangles
  open alike).
* ``side`` (+1 / -1): on which side of the line PO the wheel centre lies.

The wheel-centre distance D = |OW| fixes the cradle angle gamma (angle OPW) by the law
of cosines, D^2 = a^2 + b^2 - 2 a b cos gamma; the master-follower distance follows from
the second triangle, D_m^2 = a_m^2 + c^2 - 2 a_m c cos(gamma + master_angle) (for
``side`` +1). When the cradle swings, the line from O to the wheel turns relative to the
cradle, so the spindle angle theta differs from the wheel angle alpha_w:
theta = alpha_w - (phi - phi_base), phi the angle at O between OP and OW.

A geometrically similar cradle (a_m = k a, c = k b, master_angle = 0) makes the master
pitch curve exactly k times the wheel-centre path.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cam_design.errors import InputError, require_finite, require_mapping, require_positive
from cam_design.cam_profile import Profile, inner_envelope
from cam_design.follower import wrap_angle
from cam_design.jets import jet_inverse_compose, jet_mul, jet_sqrt
from cam_design.grinding.curve import jet_cos_sin, law_jet, param_jet, polar_jets
from cam_design.grinding.wheel_path import WheelPath

MASTER_KINDS = ('roller', 'flat')
NEWTON_TOL = 1e-14
NEWTON_MAX_ITER = 50


@dataclass(frozen=True)
class Cradle:
    """Rocking-cradle dimensions [m, rad] (module docstring and docs/grinding.md)."""

    pivot_to_work: float
    pivot_to_wheel: float
    pivot_to_master: float
    pivot_to_master_follower: float
    master_angle: float = 0.0
    side: int = 1

    def __post_init__(self) -> None:
        for name in ('pivot_to_work', 'pivot_to_wheel', 'pivot_to_master',
                     'pivot_to_master_follower'):
            require_positive(f'grinding.cradle.{name}', getattr(self, name))
        require_finite('grinding.cradle.master_angle', self.master_angle)
        if isinstance(self.side, bool) or self.side not in (1, -1):
            raise InputError('grinding.cradle.side', self.side, '+1 or -1')

    def wheel_jets(self, d: NDArray[np.float64]) -> dict[str, NDArray[np.float64]]:
        """Jets of the cradle state for the jet ``d`` of the wheel-centre distance D.

        Work-cradle frame: O at the origin, P at (a, 0). Returns ``wx, wy`` (wheel
        centre), ``vx, vy`` (unit vector P -> W), ``phi`` (polar angle of W), ``gamma``
        (cradle angle OPW, value only meaningful), ``mx, my`` (master follower point in
        the master-cradle frame: O_m at the origin, P at (a_m, 0)), ``dm`` = |O_m M|,
        ``phim`` (polar angle of M).
        """
        a, b = self.pivot_to_work, self.pivot_to_wheel
        am, c = self.pivot_to_master, self.pivot_to_master_follower
        dd = jet_mul(d, d)
        wx = dd / (2.0 * a)
        wx[0] += (a * a - b * b) / (2.0 * a)
        rad = dd - jet_mul(wx, wx)
        if np.any(~(rad[0] > 0)):
            i = int(np.argmax(~(rad[0] > 0)))
            raise InputError('grinding.cradle', f'wheel-centre distance {d[0][i]:.6g} m',
                             f'a cradle whose triangle closes: |a - b| < D < a + b with '
                             f'a = pivot_to_work = {a} m, b = pivot_to_wheel = {b} m')
        wy = self.side * jet_sqrt(rad)
        vx, vy = wx / b, wy / b
        vx[0] -= a / b
        cd, sd = math.cos(self.master_angle), math.sin(self.master_angle)
        mx = c * (cd * vx - self.side * sd * vy)
        my = c * (self.side * sd * vx + cd * vy)
        mx[0] += am
        _, phi = polar_jets(wx, wy)
        dm, phim = polar_jets(mx, my)
        if np.any(~(dm[0] > 0)):
            raise InputError('grinding.cradle', 'the master follower on the master axis',
                             'pivot_to_master different from pivot_to_master_follower')
        gamma = np.arctan2(np.abs(wy[0]), a - wx[0])
        return {'wx': wx, 'wy': wy, 'vx': vx, 'vy': vy, 'phi': phi, 'gamma': gamma,
                'mx': mx, 'my': my, 'dm': dm, 'phim': phim}


class MasterCam:
    """Master cam for the wheel path ``path`` on ``cradle`` with a master follower
    ``kind`` roller (radius ``radius`` [m]) or flat (face perpendicular to the master
    radius at rest, fixed in the machine).

    Curve parameter: the wheel angle alpha_w [rad] of ``path``. Exact quantities come as
    jets in alpha_w; :meth:`follower_lift` re-parametrises by the spindle angle.
    """

    def __init__(self, path: WheelPath, cradle: Cradle, kind: str = 'roller',
                 radius: float = 0.0) -> None:
        if kind not in MASTER_KINDS:
            raise InputError('grinding.master_follower.kind', kind, ' | '.join(MASTER_KINDS))
        self.kind = kind
        self.radius = require_positive('grinding.master_follower.radius', radius,
                                       allow_zero=kind == 'flat')
        self.path, self.cradle = path, cradle
        self.d0 = path.base_radius + path.wheel_radius
        base = cradle.wheel_jets(self._d_param(np.array([self.d0])))
        self._base = {k: float(np.asarray(v)[0]) if np.ndim(v) == 1 else float(v[0][0])
                      for k, v in base.items()}
        self._v0 = (self._base['vx'], self._base['vy'])
        m0 = math.hypot(self._base['mx'], self._base['my'])
        self._n0 = (self._base['mx'] / m0, self._base['my'] / m0)
        self.magnification = float(self._lift_jet(base)[1][0])
        self._h0 = float(self._lift_jet(base)[0][0])
        self.base_value = self._h0
        if kind == 'roller' and not self.radius < self._h0:
            raise InputError('grinding.master_follower.radius', radius,
                             f'a roller smaller than the master pitch base radius '
                             f'{self._h0:.6g} m')
        # check the whole turn once: triangle closes, spindle angle advances
        s = np.linspace(-math.pi, math.pi, 2049)
        th = self.jets(s)['theta']
        if np.any(~(th[1] > 0)):
            i = int(np.argmax(~(th[1] > 0)))
            raise InputError('grinding.cradle', f'the spindle angle turns back at wheel '
                                                f'angle {s[i]:.4g} rad',
                             'a cradle whose swing is small against the cam (pivot far '
                             'from the work)')
        self._s_tab, self._th_tab = s, th[0]

    @staticmethod
    def _d_param(d: NDArray[np.float64]) -> NDArray[np.float64]:
        """Jet of D as its own parameter (for dD_m/dD)."""
        out = np.zeros((4, d.size))
        out[0], out[1] = d, 1.0
        return out

    def _lift_jet(self, st: dict[str, NDArray[np.float64]]) -> NDArray[np.float64]:
        """Jet of the master follower's distance: D_m (roller) or the face support H."""
        if self.kind == 'roller':
            return st['dm']
        v0x, v0y = self._v0
        cos_d = v0x * st['vx'] + v0y * st['vy']          # rotation of the cradle since rest
        sin_d = v0x * st['vy'] - v0y * st['vx']
        n0x, n0y = self._n0
        nx = cos_d * n0x - sin_d * n0y
        ny = sin_d * n0x + cos_d * n0y
        st['nx'], st['ny'] = nx, ny
        return jet_mul(st['mx'], nx) + jet_mul(st['my'], ny)

    def jets(self, s: ArrayLike) -> dict[str, NDArray[np.float64]]:
        """Jets in the wheel angle s: ``theta`` (spindle angle), ``value`` (D_m or H),
        ``angle`` (alpha_m of M for a roller, normal angle psi of the face for a flat),
        plus the cradle state."""
        s = np.asarray(s, dtype=float).reshape(-1)
        d = law_jet(self.path.lift, s)
        d[0] += self.d0
        st = self.cradle.wheel_jets(d)
        value = self._lift_jet(st)
        theta = param_jet(s) - st['phi']
        theta[0] += self._base['phi']
        if self.kind == 'roller':
            angle = theta + st['phim']
            angle[0] -= self._base['phim']
        else:
            _, nu = polar_jets(st['nx'], st['ny'])
            angle = theta + nu
            angle[0] -= math.atan2(self._n0[1], self._n0[0])
        st.update(theta=theta, value=value, angle=angle, d=d)
        return st

    def wheel_angle(self, theta: ArrayLike) -> NDArray[np.float64]:
        """Wheel angle alpha_w [rad] at spindle angles ``theta`` (Newton, bracketed)."""
        t = np.asarray(theta, dtype=float).reshape(-1)
        t0 = self._th_tab[0]
        tt = t0 + np.mod(t - t0, 2 * math.pi)        # into the table's turn
        i = np.clip(np.searchsorted(self._th_tab, tt) - 1, 0, self._s_tab.size - 2)
        lo, hi = self._s_tab[i].copy(), self._s_tab[i + 1].copy()
        frac = (tt - self._th_tab[i]) / (self._th_tab[i + 1] - self._th_tab[i])
        s = lo + np.clip(frac, 0.0, 1.0) * (hi - lo)
        t = tt
        for _ in range(NEWTON_MAX_ITER):
            th = self.jets(s)['theta']
            f = th[0] - t
            if np.max(np.abs(f), initial=0.0) < NEWTON_TOL:
                return s
            hi = np.where(f > 0, s, hi)
            lo = np.where(f <= 0, s, lo)
            step = s - f / th[1]
            s = np.where((step > lo) & (step < hi), step, 0.5 * (lo + hi))
        raise InputError('grinding.cradle', 'no convergence of the spindle angle',
                         'a smooth wheel path (report this case)')

    def follower_lift(self, theta: ArrayLike) -> NDArray[np.float64]:
        """(4, n): exact master-follower lift [m] and its derivatives against the
        spindle angle theta [rad] (0 on the base circle)."""
        s = self.wheel_angle(theta)
        st = self.jets(s)
        value = st['value'].copy()
        value[0] -= self._h0
        out = jet_inverse_compose(st['theta'], value)
        return out

    def approximate_lift(self, theta: ArrayLike) -> NDArray[np.float64]:
        """Small-swing magnified copy: k h_w(theta), k = dD_m/dD (or dH/dD) at rest."""
        return self.magnification * self.path.lift(np.asarray(theta, dtype=float))

    def profile(self, points: int = 3600) -> Profile:
        """The master profile over one turn at ``points`` wheel angles: envelope of the
        master follower, with signed radius of curvature and undercut flags
        (cam_design.follower.Profile; ``alpha`` is the master angle of each sample)."""
        if not 36 <= points <= 10 ** 6:
            raise InputError('points', points, 'an integer in [36, 1e6]')
        s = -math.pi + 2 * math.pi * np.arange(points) / points
        st = self.jets(s)
        value, angle = st['value'], st['angle']
        if self.kind == 'roller':
            c, sn = jet_cos_sin(angle)
            # polar angle pi/2 + alpha: (cos, sin)(pi/2 + x) = (-sin x, cos x)
            px, py = -jet_mul(value, sn), jet_mul(value, c)
            pitch = np.stack([px[0], py[0]])
            d1 = np.stack([px[1], py[1]])
            d2 = 2.0 * np.stack([px[2], py[2]])
            env = inner_envelope(pitch, d1, d2, self.radius)
            u = np.stack([-np.sin(angle[0]), np.cos(angle[0])])
            cos_p = np.abs(np.sum(env['normal'] * u, axis=0))
            pressure = np.arccos(np.clip(cos_p, 0.0, 1.0))
            prof = env['profile']
            undercut = env['undercut'] | (angle[1] <= 0)
            return Profile('master-roller', wrap_angle(angle[0]), prof[0], prof[1], pitch[0],
                           pitch[1], env['rho'], env['rho_pitch'], pressure, undercut,
                           np.zeros(points))
        der = jet_inverse_compose(angle, value)      # H, dH/dpsi, d2H/dpsi2
        h, h1, h2 = der[0], der[1], der[2]
        psi = angle[0]
        ux, uy = -np.sin(psi), np.cos(psi)
        x = h * ux - h1 * uy
        y = h * uy + h1 * ux
        rho = h + h2
        undercut = ~(rho > 0) | ~(angle[1] > 0)
        return Profile('master-flat', wrap_angle(psi), x, y, x.copy(), y.copy(), rho, rho.copy(),
                       np.zeros(points), undercut, h1)

    def lift_table(self, theta: ArrayLike) -> dict[str, NDArray[np.float64]]:
        """Columns at spindle angles ``theta``: exact and approximate master lift, the
        approximation error, wheel angle, wheel-centre distance and cradle angle."""
        t = np.asarray(theta, dtype=float).reshape(-1)
        s = self.wheel_angle(t)
        st = self.jets(s)
        exact = st['value'][0] - self._h0
        approx = self.approximate_lift(t)
        return {'spindle_angle_rad': t, 'master_lift_m': exact,
                'master_lift_approx_m': approx, 'approx_error_m': approx - exact,
                'wheel_angle_rad': s, 'wheel_centre_distance_m': st['d'][0],
                'cradle_angle_rad': st['gamma'],
                'master_angle_rad': wrap_angle(st['angle'][0])}


def master_from_section(path: WheelPath, section: dict) -> MasterCam:
    """MasterCam from the ``cradle:`` and ``master_follower:`` of a grinding section."""
    from cam_design.grinding import spec as gs

    if 'cradle' not in section:
        raise InputError('grinding.cradle', None, 'a mapping with ' + ', '.join(gs.CRADLE_KEYS))
    cr = require_mapping(section['cradle'], 'grinding.cradle', gs.CRADLE_KEYS)
    vals = gs.floats(cr, 'grinding.cradle', gs.CRADLE_KEYS[:5], gs.CRADLE_KEYS[:4])
    for name in gs.CRADLE_KEYS[:4]:
        if name not in vals:
            raise InputError(f'grinding.cradle.{name}', None, 'a length > 0 [m]')
    cradle = Cradle(side=cr.get('side', 1), **vals)
    mf = require_mapping(section.get('master_follower', {'kind': 'roller'}),
                         'grinding.master_follower', gs.MASTER_KEYS)
    kind = mf.get('kind', 'roller')
    radius = mf.get('radius', 0.0)
    if kind == 'roller' and 'radius' not in mf:
        raise InputError('grinding.master_follower.radius', None, 'a roller radius > 0 [m]')
    return MasterCam(path, cradle, kind, radius)
