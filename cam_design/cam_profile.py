"""Cam profile geometry: coordinates, radius of curvature, pressure angle and undercut of
the cam for each follower kind, and the lift a follower reads from sampled profile points
(docs/follower.md).

Conventions as in ``cam_design.follower``: alpha [rad] is the cam angle from the lobe
centreline, ``base_radius`` R0 [m] the radius of the cam's base circle; lengths in m.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cam_design.errors import InputError, require_positive
from cam_design.follower import Follower, contact_radius
from cam_design.lift_laws.base import LiftLaw


@dataclass(frozen=True)
class Profile:
    """A sampled cam profile in the cam-fixed frame (all lengths m, angles rad).

    ``alpha``: the cam angle of each sample; ``x, y``: the actual (working) profile;
    ``pitch_x, pitch_y``: the roller-centre (pitch) curve, equal to x, y for a knife and
    for a flat tappet the contact point as well; ``rho``: signed radius of curvature of
    the actual profile (> 0 convex, < 0 concave); ``rho_pitch``: of the pitch curve (flat
    tappet: equal to rho); ``pressure_angle``: angle between the contact normal and the
    follower's direction of motion at the roller centre (0 for a flat face);
    ``undercut``: bool per sample, True where the envelope reverses (cusp, rho in
    (0, radius) of a roller, rho <= 0 of a flat face); ``face_offset``: the contact's
    distance from the tappet axis (flat tappet: h', the face must be wider than its max).
    """

    kind: str
    alpha: NDArray[np.float64]
    x: NDArray[np.float64]
    y: NDArray[np.float64]
    pitch_x: NDArray[np.float64]
    pitch_y: NDArray[np.float64]
    rho: NDArray[np.float64]
    rho_pitch: NDArray[np.float64]
    pressure_angle: NDArray[np.float64]
    undercut: NDArray[np.bool_]
    face_offset: NDArray[np.float64]

    def undercut_intervals(self) -> list[tuple[float, float]]:
        """(alpha_first, alpha_last) [rad] of each run of undercut samples."""
        edges = np.diff(np.concatenate([[0], np.asarray(self.undercut, dtype=int), [0]]))
        first = np.flatnonzero(edges == 1)
        last = np.flatnonzero(edges == -1) - 1
        return [(float(self.alpha[i]), float(self.alpha[j])) for i, j in zip(first, last)]

    def summary(self) -> dict[str, object]:
        """Key numbers for a report: extreme radii, pressure angle, undercut intervals."""
        return {
            'kind': self.kind,
            'points': int(self.alpha.size),
            'rho_min_m': float(np.min(self.rho)),
            'rho_min_alpha_rad': float(self.alpha[int(np.argmin(self.rho))]),
            'rho_pitch_min_m': float(np.min(self.rho_pitch)),
            'pressure_angle_max_deg': float(np.degrees(np.max(np.abs(self.pressure_angle)))),
            'face_offset_max_m': float(np.max(np.abs(self.face_offset))),
            'undercut': bool(np.any(self.undercut)),
            'undercut_intervals_rad': self.undercut_intervals(),
        }

    def columns(self) -> dict[str, NDArray[np.float64]]:
        """The per-sample arrays, in CSV column order (SI units in the names)."""
        return {
            'alpha_rad': self.alpha, 'x_m': self.x, 'y_m': self.y,
            'pitch_x_m': self.pitch_x, 'pitch_y_m': self.pitch_y, 'rho_m': self.rho,
            'rho_pitch_m': self.rho_pitch, 'pressure_angle_rad': self.pressure_angle,
            'undercut': self.undercut.astype(float), 'face_offset_m': self.face_offset,
        }


def _alpha_grid(alpha: ArrayLike) -> NDArray[np.float64]:
    a = np.asarray(alpha, dtype=float).reshape(-1)
    if a.size == 0:
        raise InputError('alpha', 'an empty list', 'at least one angle in rad')
    if not np.all(np.isfinite(a)):
        raise InputError('alpha', 'non-finite entries', 'finite angles in rad')
    return a


def _unit(angle: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.stack([np.cos(angle), np.sin(angle)])


def _perp(v: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotate (2, n) vectors by +90 degrees."""
    return np.stack([-v[1], v[0]])


def _cross(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    return a[0] * b[1] - a[1] * b[0]


def inner_envelope(pitch: NDArray[np.float64], d1: NDArray[np.float64],
                   d2: NDArray[np.float64], radius: float) -> dict[str, NDArray[np.float64]]:
    """Inner envelope of circles of ``radius`` [m] centred on a pitch curve (docs/follower.md).

    ``pitch``, ``d1``, ``d2``: (2, n) arrays of P, dP/dphi, d2P/dphi2 (analytic). The side
    is picked numerically: the offset P + sign r n (n the left normal) with the smaller
    mean distance from the cam centre is the inner one. Returns ``profile`` (2, n),
    ``normal`` (2, n, unit, pointing from the profile to the roller centre),
    ``rho_pitch`` and ``rho`` (signed radii, > 0 where the pitch curve bends towards the
    cam: rho = rho_pitch - r), ``undercut`` (bool: dQ/dphi . dP/dphi <= 0).
    """
    speed = np.hypot(d1[0], d1[1])
    if np.any(speed == 0):
        raise InputError('pitch curve', 'a stationary point', 'a regular pitch curve')
    left = _perp(d1) / speed
    kappa = _cross(d1, d2) / speed ** 3      # signed curvature, + when turning left
    candidates = [pitch + sign * radius * left for sign in (1.0, -1.0)]
    means = [float(np.mean(np.hypot(c[0], c[1]))) for c in candidates]
    sign = 1.0 if means[0] <= means[1] else -1.0
    profile = candidates[0] if sign > 0 else candidates[1]
    # centre of curvature at P + left / kappa; towards the inner side when sign*kappa > 0
    with np.errstate(divide='ignore'):
        rho_pitch = np.where(kappa != 0, sign / np.where(kappa != 0, kappa, 1.0), np.inf)
    # Q' = P' (1 - sign r kappa): reversed where sign * r * kappa >= 1
    factor = 1.0 - sign * radius * kappa
    return {'profile': profile, 'normal': -sign * left, 'rho_pitch': rho_pitch,
            'rho': rho_pitch - radius, 'undercut': factor <= 0}


def flat_profile(law: LiftLaw, base_radius: float, alpha: ArrayLike) -> Profile:
    """Flat-faced translating tappet profile, Shang eq. 2.15 (docs/follower.md).

    Cam frame: origin at the cam centre, nose on +Y; the tappet axis at cam angle alpha is
    at theta = pi/2 + alpha. x = p cos(theta) - h' sin(theta), y = h' cos(theta) +
    p sin(theta), p = R0 + h; rho1 = R0 + h + h'' (eq. 2.6); undercut where rho1 <= 0.
    """
    r0 = require_positive('base_radius', base_radius)
    a = _alpha_grid(alpha)
    h, h1, h2, _ = law.derivatives(a)
    theta = a + 0.5 * math.pi
    p = r0 + h
    c, s = np.cos(theta), np.sin(theta)
    x = p * c - h1 * s
    y = h1 * c + p * s
    rho = r0 + h + h2
    return Profile('flat', a, x, y, x.copy(), y.copy(), rho, rho.copy(), np.zeros_like(a),
                   rho <= 0, h1)


def _pitch_profile(kind: str, a: NDArray[np.float64], pitch: NDArray[np.float64],
                   d1: NDArray[np.float64], d2: NDArray[np.float64], radius: float,
                   motion: NDArray[np.float64]) -> Profile:
    """Shared tail of the roller profiles: envelope, curvature, pressure angle."""
    env = inner_envelope(pitch, d1, d2, radius)
    cos_p = np.abs(np.sum(env['normal'] * motion, axis=0))
    pressure = np.arccos(np.clip(cos_p, 0.0, 1.0))
    prof = env['profile']
    return Profile(kind, a, prof[0], prof[1], pitch[0], pitch[1], env['rho'],
                   env['rho_pitch'], pressure, env['undercut'].astype(bool), np.zeros_like(a))


def roller_profile(law: LiftLaw, base_radius: float, radius: float,
                   alpha: ArrayLike) -> Profile:
    """In-line translating roller (or knife, radius 0) tappet profile, Shang eq. 2.16.

    Same frame as :func:`flat_profile`. g = R0 + r + h is the pitch radius (R0 the base
    radius of the profile, r the roller radius R00); the profile is the inner envelope,
    rho_pitch = (g^2 + g'^2)^1.5 / (g^2 + 2g'^2 - g g''), rho1 = rho_pitch - r
    (erratum 5: subtract the roller radius). Pressure angle atan(|g'| / g).
    """
    r0 = require_positive('base_radius', base_radius)
    r = require_positive('radius', radius, allow_zero=True)
    a = _alpha_grid(alpha)
    h, h1, h2, _ = law.derivatives(a)
    theta = a + 0.5 * math.pi
    u, w = _unit(theta), _perp(_unit(theta))
    g = r0 + r + h
    pitch = g * u
    d1 = h1 * u + g * w
    d2 = (h2 - g) * u + 2.0 * h1 * w
    return _pitch_profile('roller' if r > 0 else 'knife', a, pitch, d1, d2, r, u)


def _rotation_apply(angle: NDArray[np.float64], v: NDArray[np.float64]) -> NDArray[np.float64]:
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([c * v[0] - s * v[1], s * v[0] + c * v[1]])


def sign_param(key: str, value: int, allowed: tuple[int, ...]) -> int:
    """``value`` if it is one of the signs ``allowed`` (a bool is not), else InputError(key)."""
    if isinstance(value, bool) or value not in allowed:
        raise InputError(key, value, ' or '.join(f'{v:+d}' for v in allowed))
    return int(value)


def offset_roller_profile(law: LiftLaw, base_radius: float, radius: float, offset: float,
                          alpha: ArrayLike, *, eta: int = 1, delta: int = 1) -> Profile:
    """Offset translating roller follower, thesis (S3) reverse-method form (docs/follower.md).

    Frame: x-axis along the follower's rise direction. phi = alpha is the cam angle, s =
    h(phi) the lift; ``eta`` = +1 clockwise cam, -1 counter-clockwise; ``delta`` = +1/-1
    for a guide line offset to the +y/-y side by ``offset`` e >= 0 [m]. The pitch base
    radius is r0 = R0 + r (R0 = ``base_radius`` of the profile), s0 = sqrt(r0^2 - e^2):
    x = (s0+s) cos(eta phi) - delta e sin(eta phi), y = (s0+s) sin(eta phi) + delta e cos(eta phi).
    Pressure angle: tan = |s' - eta delta e| / (s0 + s) (equal to the pitch-normal angle).
    """
    r, e, eta, delta, s0 = offset_params(base_radius, radius, offset, eta, delta)
    a = _alpha_grid(alpha)
    h, h1, h2, _ = law.derivatives(a)
    turn = eta * a
    v = np.stack([s0 + h, np.full_like(a, delta * e)])
    pitch = _rotation_apply(turn, v)
    d1 = _rotation_apply(turn, np.stack([h1 - eta * delta * e, eta * (s0 + h)]))
    d2 = _rotation_apply(turn, np.stack([h2 - (s0 + h), 2.0 * eta * h1 - delta * e]))
    kind = 'offset-roller' if r > 0 else 'offset-knife'
    return _pitch_profile(kind, a, pitch, d1, d2, r, _unit(turn))


def offset_pressure_angle(law: LiftLaw, base_radius: float, radius: float, offset: float,
                          alpha: ArrayLike, *, eta: int = 1, delta: int = 1
                          ) -> NDArray[np.float64]:
    """Closed-form pressure angle [rad] (docs/follower.md): atan(|s' - eta delta e| / (s0 + s))."""
    _, e, eta, delta, s0 = offset_params(base_radius, radius, offset, eta, delta)
    a = _alpha_grid(alpha)
    return np.arctan(np.abs(law(a, 1) - eta * delta * e) / (s0 + law(a)))


def offset_params(base_radius: float, radius: float, offset: float, eta: int, delta: int
                  ) -> tuple[float, float, int, int, float]:
    """Validated (r, e, eta, delta, s0) of the offset translating follower."""
    r0 = require_positive('base_radius', base_radius)
    r = require_positive('radius', radius, allow_zero=True)
    e = require_positive('offset', offset, allow_zero=True)
    eta = sign_param('eta', eta, (1, -1))
    delta = sign_param('delta', delta, (1, -1, 0))
    if delta == 0 and e > 0:
        raise InputError('delta', delta, '+1 or -1 for an offset guide line (offset > 0)')
    rp = r0 + r
    if e >= rp:
        raise InputError('offset', e, f'an offset smaller than the pitch base radius {rp} m')
    return r, e, eta, delta, math.sqrt(rp * rp - e * e)


def rocker_check(base_radius: float, radius: float, centre_distance: float,
                 arm_length: float) -> tuple[float, float, float, float]:
    """Validated (r, a, l, psi0) of the rocker roller follower: radius [m], centre distance
    a [m], arm length l [m] and the arm angle psi0 [rad] on the base circle."""
    r0 = require_positive('base_radius', base_radius)
    r = require_positive('radius', radius, allow_zero=True)
    dist = require_positive('centre_distance', centre_distance)
    arm = require_positive('arm_length', arm_length)
    rp = r0 + r
    if not abs(dist - arm) < rp < dist + arm:
        raise InputError('centre_distance', dist, f'|a - l| < r0 < a + l with pitch base '
                         f'radius r0 = {rp} m and arm length l = {arm} m')
    psi0 = math.acos((dist * dist + arm * arm - rp * rp) / (2.0 * dist * arm))
    return r, dist, arm, psi0


def rocker_profile(law: LiftLaw, base_radius: float, radius: float, centre_distance: float,
                   arm_length: float, alpha: ArrayLike, *, eta: int = 1, delta: int = 1
                   ) -> Profile:
    """Oscillating (rocker) roller follower, thesis form (docs/follower.md).

    Frame: x-axis along OA (cam centre O to pivot A, distance a = ``centre_distance``),
    arm length l; the swing is psi = h(phi) / l [rad] (the law gives the roller centre's
    arc lift, m); psi0 = arccos((a^2 + l^2 - r0^2) / (2al)) with r0 = R0 + r;
    ``eta`` = +1 clockwise cam, ``delta`` = +1/-1 the swing direction during the rise:
    x = a cos(eta phi) - l cos(eta phi - delta (psi0 + psi)), y likewise with sin.
    Pressure angle: between the contact normal and the roller centre's velocity
    (perpendicular to the arm).
    """
    r, dist, arm, psi0 = rocker_check(base_radius, radius, centre_distance, arm_length)
    eta = sign_param('eta', eta, (1, -1))
    delta = sign_param('delta', delta, (1, -1))
    a = _alpha_grid(alpha)
    h, h1, h2, _ = law.derivatives(a)
    turn = eta * a
    big = turn - delta * (psi0 + h / arm)
    big1 = eta - delta * h1 / arm
    big2 = -delta * h2 / arm
    pitch = dist * _unit(turn) - arm * _unit(big)
    d1 = dist * eta * _perp(_unit(turn)) - arm * big1 * _perp(_unit(big))
    d2 = -dist * _unit(turn) - arm * big2 * _perp(_unit(big)) + arm * big1 ** 2 * _unit(big)
    kind = 'rocker' if r > 0 else 'rocker-knife'
    return _pitch_profile(kind, a, pitch, d1, d2, r, _perp(_unit(big)))


def rocker_polar(law: LiftLaw, base_radius: float, radius: float, frame_length: float,
                 arm_length: float, alpha: ArrayLike, *, co_directional: bool = False
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Pitch curve of the rocker follower in the CG paper's polar form (S1 eqs 1-6).

    rho = sqrt(L^2 + l^2 - 2 L l cos(psi0 + psi)); theta = phi + (beta0 - beta) for the
    counter-directional type (逆向) and phi - (beta0 - beta) for the co-directional type
    (同向), with beta = atan2(l sin(psi0 + psi), L - l cos(psi0 + psi)). Returns (rho [m],
    theta [rad]). Same curve as :func:`rocker_profile` with eta = +1 and delta = -1
    (counter) or +1 (co), rotated by -delta beta0.
    """
    _, dist, arm, psi0 = rocker_check(base_radius, radius, frame_length, arm_length)
    a = _alpha_grid(alpha)
    big = psi0 + law(a) / arm
    rho = np.sqrt(dist * dist + arm * arm - 2.0 * dist * arm * np.cos(big))
    beta = np.arctan2(arm * np.sin(big), dist - arm * np.cos(big))
    beta0 = math.atan2(arm * math.sin(psi0), dist - arm * math.cos(psi0))
    sign = -1.0 if co_directional else 1.0
    return rho, a + sign * (beta0 - beta)


#: target angles per block in lift_from_profile (memory: block x points doubles).
POINTS_BLOCK = 128


def lift_from_profile(x: ArrayLike, y: ArrayLike, alpha: ArrayLike, follower: Follower,
                      base_radius: float | None = None) -> NDArray[np.float64]:
    """Lift [m] of a translating follower on a cam given by dense profile points (§2.6).

    ``x, y`` [m]: profile points in the cam frame of :func:`flat_profile` (nose on +Y,
    the follower axis at alpha is at theta = pi/2 + alpha), ordered along the closed
    profile and roughly evenly spaced. Flat: h = max_i P_i.u - R0; roller/knife of
    radius r: D = max over |P_i.u_perp| <= r of [P_i.u + sqrt(r^2 - (P_i.u_perp)^2)],
    h = D - (R0 + r). The discrete max is refined by a parabola through the best point
    and its two neighbours (error well below the raw ds^2/(8 rho)). ``base_radius`` R0
    defaults to the smallest support/centre distance found (h >= 0). For exact
    conversions of a design lift use :func:`convert_lift`; this is for measured or
    drawn coordinates (and as an independent reference).
    """
    px = np.asarray(x, dtype=float).reshape(-1)
    py = np.asarray(y, dtype=float).reshape(-1)
    if px.size != py.size or px.size < 8:
        raise InputError('profile', f'{px.size} x and {py.size} y values',
                         'as many x as y values, at least 8 points')
    if not (np.all(np.isfinite(px)) and np.all(np.isfinite(py))):
        raise InputError('profile', 'non-finite coordinates', 'finite x, y in m')
    if not isinstance(follower, Follower):
        raise InputError('follower', follower, 'a cam_design.follower.Follower')
    a = _alpha_grid(alpha)
    r = contact_radius(follower)
    if follower.kind == 'knife':
        out = _radial_function(px, py, a + 0.5 * math.pi)
    else:
        out = _support_max(px, py, a, follower.kind == 'flat', r)
    if base_radius is None:
        base = float(np.min(out)) - r
    else:
        base = require_positive('base_radius', base_radius)
    return out - base - r


def _radial_function(px: NDArray[np.float64], py: NDArray[np.float64],
                     theta: NDArray[np.float64]) -> NDArray[np.float64]:
    """Distance from the centre to a star-shaped closed curve in the directions theta
    (periodic cubic spline of radius against polar angle)."""
    from scipy.interpolate import CubicSpline

    ang = np.arctan2(py, px)
    order = np.argsort(ang)
    ang, rad = ang[order], np.hypot(px, py)[order]
    if np.any(np.diff(ang) <= 0):
        raise InputError('profile', 'repeated polar angles',
                         'a profile seen once from the cam centre (star-shaped)')
    spline = CubicSpline(np.append(ang, ang[0] + 2 * math.pi), np.append(rad, rad[0]),
                         bc_type='periodic')
    return spline(ang[0] + np.mod(theta - ang[0], 2 * math.pi))


def _support_max(px: NDArray[np.float64], py: NDArray[np.float64], a: NDArray[np.float64],
                 flat: bool, r: float) -> NDArray[np.float64]:
    """Refined discrete max of the flat support / roller centre distance (§2.6)."""
    out = np.empty(a.size)
    n = px.size
    for start in range(0, a.size, POINTS_BLOCK):
        theta = a[start:start + POINTS_BLOCK, None] + 0.5 * math.pi
        c, s = np.cos(theta), np.sin(theta)
        along = px * c + py * s
        if flat:
            val = along
        else:
            across = -px * s + py * c
            val = along + np.sqrt(np.clip(r * r - across * across, 0.0, None))
            val = np.where(np.abs(across) <= r, val, -np.inf)
        i = np.argmax(val, axis=1)
        rows = np.arange(val.shape[0])
        f0 = val[rows, (i - 1) % n]
        f1 = val[rows, i]
        f2 = val[rows, (i + 1) % n]
        with np.errstate(divide='ignore', invalid='ignore'):
            curv = f0 - 2.0 * f1 + f2
            ok = np.isfinite(f0) & np.isfinite(f2) & (curv < 0)
            peak = f1 - np.where(ok, (f2 - f0) ** 2 / (8.0 * curv), 0.0)
        out[start:start + POINTS_BLOCK] = peak
    return out
