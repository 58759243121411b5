"""Design checks of Shang (1988) §2.1 (docs/lift_laws.md), SI units throughout.

Formulas (S0 numbering): valve flow area (2.1), time-area (2.2), fullness (2.3),
Hertz line-contact stress (2.4, 2.5, 2.11), spring force (2.8), inertia force (2.9),
equivalent mass (2.10, with the valve mass M1 that the printed formula lacks:
erratum 6), oil-film number and minimum film (2.12, with a reversal flag),
valve-piston clearance (2.13) with the crank-slider (2.14 and the exact form), and
the cam/crank angle mapping phi - phi0 = 2 (alpha - alpha0).

Flat-tappet radius of curvature rho1 = R0 + h + h'' (2.6) is here; roller-follower
curvature (2.7) belongs to ``cam_design.follower``.

The Hertz constants are Shang's printed 0.564 (= 1/sqrt(pi) = 0.56419 rounded)
and 0.418 (= 0.564 * sqrt(1 / (2 (1 - 0.3^2))) rounded), so results agree with the
book to its printing; they differ from the unrounded constants by < 0.05 %.
"""
from __future__ import annotations

import dataclasses
import math
from typing import Any, Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cam_design.errors import InputError, require_finite, require_positive

HERTZ_GENERAL = 0.564     # (2.4)
HERTZ_STEEL = 0.418       # (2.5), (2.11), mu = 0.3


def _arr(key: str, value: ArrayLike) -> NDArray[np.float64]:
    a = np.asarray(value, dtype=float)
    if not np.all(np.isfinite(a)):
        raise InputError(key, 'non-finite values', 'finite numbers')
    return a


# ---------------------------------------------------------------- flow (2.1-2.3)
def valve_flow_area(y: ArrayLike, seat_diameter: float, seat_angle: float) -> NDArray:
    """(2.1) F_p = pi d cos(g) y + pi cos^2(g) sin(g) y^2 [m^2].

    ``y`` valve lift [m] (>= 0), ``seat_diameter`` d = inner seat diameter [m],
    ``seat_angle`` gamma [rad] from the valve-head plane. Valid while
    y < w / (sin g cos g) (see ``flow_area_validity``)."""
    d = require_positive('seat_diameter', seat_diameter)
    g = require_finite('seat_angle', seat_angle)
    if not 0 <= g < math.pi / 2:
        raise InputError('seat_angle', seat_angle, 'an angle in [0, pi/2) rad')
    yy = _arr('y', y)
    if np.any(yy < 0):
        raise InputError('y', float(yy.min()), 'valve lifts >= 0 m')
    with np.errstate(over='ignore', invalid='ignore'):
        fp = math.pi * d * math.cos(g) * yy + math.pi * math.cos(g) ** 2 * math.sin(g) * yy ** 2
    if not np.all(np.isfinite(fp)):
        raise InputError('y', 'an overflowing lift', 'valve lifts of physical size')
    return fp


def flow_area_validity(seat_width: float, seat_angle: float) -> float:
    """Largest lift [m] for which (2.1) holds: w / (sin g cos g) (inf for g = 0)."""
    w = require_positive('seat_width', seat_width)
    s = math.sin(seat_angle) * math.cos(seat_angle)
    return math.inf if s == 0 else w / s


def time_area(alpha: ArrayLike, flow_area: ArrayLike) -> NDArray:
    """(2.2) cumulative integral of F_p over alpha [m^2 rad] (trapezoid, same grid).

    Divide by omega [rad/s] for the time-area in m^2 s."""
    from scipy.integrate import cumulative_trapezoid

    a = _arr('alpha', alpha)
    f = _arr('flow_area', flow_area)
    if a.shape != f.shape or a.ndim != 1 or a.size < 2:
        raise InputError('flow_area', f.shape, f'one value per alpha ({a.shape})')
    if np.any(np.diff(a) <= 0):
        raise InputError('alpha', 'not increasing', 'strictly increasing angles')
    return cumulative_trapezoid(f, a, initial=0.0)


def fullness(alpha: ArrayLike, y: ArrayLike) -> float:
    """(2.3) xi = int_a^{alpha_a} y dalpha / (y_max (alpha_a - a)).

    a and alpha_a are the first and last angles with y > 0 (linearly interpolated to
    the zero crossings); integration by the trapezoid rule on the given grid."""
    a = _arr('alpha', alpha)
    yy = _arr('y', y)
    if a.shape != yy.shape or a.ndim != 1:
        raise InputError('y', yy.shape, f'one value per alpha ({a.shape})')
    pos = np.nonzero(yy > 0)[0]
    if pos.size == 0:
        raise InputError('y', 'no positive lift', 'a valve lift that opens the valve')
    i0, i1 = int(pos[0]), int(pos[-1])
    lo = a[i0] if i0 == 0 else a[i0 - 1] + (a[i0] - a[i0 - 1]) * (-yy[i0 - 1]) / (
        yy[i0] - yy[i0 - 1])
    hi = a[i1] if i1 == a.size - 1 else a[i1] + (a[i1 + 1] - a[i1]) * yy[i1] / (
        yy[i1] - yy[i1 + 1])
    seg_a = np.concatenate([[lo], a[i0:i1 + 1], [hi]])
    seg_y = np.concatenate([[0.0], yy[i0:i1 + 1], [0.0]])
    integral = float(np.sum((seg_y[1:] + seg_y[:-1]) * np.diff(seg_a)) / 2)
    return integral / (float(yy.max()) * (hi - lo))


def rigid_valve_lift(h: ArrayLike, rocker_ratio: float, lash: float) -> NDArray:
    """y = max(k h - x0, 0) [m] (docs/contract.md; Shang prints it wrongly twice)."""
    k = require_positive('rocker_ratio', rocker_ratio)
    x0 = require_positive('lash', lash, allow_zero=True)
    return np.maximum(k * _arr('h', h) - x0, 0.0)


# ---------------------------------------------------------------- curvature and stress
def flat_tappet_curvature(h: ArrayLike, h2: ArrayLike, base_radius: float) -> NDArray:
    """(2.6) rho1 = R0 + h + h'' [m] (h'' in m/rad^2)."""
    r0 = require_positive('base_radius', base_radius)
    return r0 + _arr('h', h) + _arr('h2', h2)


def _finite_stress(sigma: NDArray) -> NDArray:
    """The stress, or InputError if the inputs overflowed it."""
    with np.errstate(invalid='ignore'):
        if not np.all(np.isfinite(sigma)):
            raise InputError('force', 'a non-finite stress',
                             'force, width, radii and moduli of physical size')
    return sigma


def _curvature_sum(rho1: ArrayLike, rho2: ArrayLike) -> NDArray:
    """1/|rho1| + 1/rho2 (rho2 signed: inf = flat, < 0 = concave), clipped at 0."""
    r1 = np.abs(_arr('rho1', rho1))
    if np.any(r1 == 0):
        raise InputError('rho1', 0.0, 'a non-zero radius of curvature')
    r2 = np.asarray(rho2, dtype=float)
    if np.any(np.isnan(r2)) or np.any(r2 == 0):
        raise InputError('rho2', 'nan or 0', 'a non-zero radius of curvature (inf: flat)')
    with np.errstate(divide='ignore'):
        inv2 = np.where(np.isinf(r2), 0.0, 1.0 / r2)
    return np.maximum(1.0 / r1 + inv2, 0.0)


def hertz_stress(force: ArrayLike, width: float, rho1: ArrayLike, rho2: ArrayLike = math.inf,
                 e1: float = 2.06e11, e2: float | None = None, mu1: float = 0.3,
                 mu2: float | None = None) -> NDArray:
    """(2.4) sigma = 0.564 sqrt(F (1/rho1 + 1/rho2) / [((1-mu1^2)/E1 + (1-mu2^2)/E2) W]).

    ``force`` [N], ``width`` W [m], radii [m] (|rho| used; rho2 = inf for a flat face;
    a concave follower can pass a negative rho2, giving 1/|rho1| - 1/|rho2|), moduli [Pa].
    Force <= 0 (separation) gives stress 0."""
    w = require_positive('width', width)
    e1 = require_positive('e1', e1)
    e2 = e1 if e2 is None else require_positive('e2', e2)
    mu2 = mu1 if mu2 is None else mu2
    f = np.maximum(_arr('force', force), 0.0)
    curv = _curvature_sum(rho1, rho2)
    comp = (1 - mu1 ** 2) / e1 + (1 - mu2 ** 2) / e2
    with np.errstate(over='ignore', invalid='ignore', divide='ignore'):
        sigma = HERTZ_GENERAL * np.sqrt(f * curv / (comp * w))
    return _finite_stress(sigma)


def hertz_stress_steel(force: ArrayLike, width: float, rho1: ArrayLike,
                       rho2: ArrayLike = math.inf, e1: float = 2.06e11,
                       e2: float | None = None) -> NDArray:
    """(2.5) sigma = 0.418 sqrt(E_m F (1/rho1 + 1/rho2) / W), E_m = 2 E1 E2/(E1+E2),
    mu = 0.3; with rho2 = inf this is the flat-tappet form (2.11)."""
    w = require_positive('width', width)
    e1 = require_positive('e1', e1)
    e2 = e1 if e2 is None else require_positive('e2', e2)
    em = 2 * e1 * e2 / (e1 + e2)
    f = np.maximum(_arr('force', force), 0.0)
    curv = _curvature_sum(rho1, rho2)
    with np.errstate(over='ignore', invalid='ignore', divide='ignore'):
        sigma = HERTZ_STEEL * np.sqrt(em * f * curv / w)
    return _finite_stress(sigma)


# ---------------------------------------------------------------- forces (2.8-2.10)
def equivalent_mass(*, valve: float, spring: float, retainer: float, rocker_ratio: float,
                    rocker_inertia: float = 0.0, rocker_arm: float | None = None,
                    tappet: float = 0.0, push_rod: float = 0.0) -> float:
    """(2.10) with erratum 6: M = (M1 + M2/3 + M3) k^2 + I0/l0^2 + m2 + m3 [kg], tappet side.

    valve M1, spring M2, retainer + keepers M3, tappet m2, push rod m3 [kg]; rocker
    inertia I0 [kg m^2] about its pivot, tappet-side arm l0 [m]."""
    vals = {k: require_positive(k, v, allow_zero=True) for k, v in
            (('valve', valve), ('spring', spring), ('retainer', retainer),
             ('rocker_inertia', rocker_inertia), ('tappet', tappet), ('push_rod', push_rod))}
    k = require_positive('rocker_ratio', rocker_ratio)
    rot = 0.0
    if vals['rocker_inertia'] > 0:
        if rocker_arm is None:
            raise InputError('rocker_arm', None, 'the tappet-side arm length l0 [m]')
        rot = vals['rocker_inertia'] / require_positive('rocker_arm', rocker_arm) ** 2
    return ((vals['valve'] + vals['spring'] / 3 + vals['retainer']) * k * k + rot
            + vals['tappet'] + vals['push_rod'])


def spring_force(h: ArrayLike, rocker_ratio: float, lash: float, preload: float,
                 rate: float) -> NDArray:
    """(2.8) F_c = k [F0 + c' x] at the tappet [N], x = max(k h - x0, 0)."""
    f0 = require_positive('preload', preload, allow_zero=True)
    c = require_positive('rate', rate, allow_zero=True)
    return rocker_ratio * (f0 + c * rigid_valve_lift(h, rocker_ratio, lash))


def inertia_force(h2: ArrayLike, mass: float, omega: float) -> NDArray:
    """(2.9) F_N = M omega^2 h'' [N] (h'' in m/rad^2, omega [rad/s], M tappet side)."""
    m = require_positive('mass', mass)
    w = require_finite('omega', omega)
    return m * w * w * _arr('h2', h2)


def rpm_to_omega(rpm: float, key: str = 'cam_speed_rpm') -> float:
    """Camshaft speed [rpm] -> omega [rad/s] (at most 1e5 rpm)."""
    value = require_positive(key, rpm)
    if value > 1e5:
        raise InputError(key, rpm, 'a camshaft speed <= 1e5 rpm')
    return value * 2 * math.pi / 60


@dataclasses.dataclass(frozen=True)
class SeparationCheck:
    """Kinematic no-separation test F = F_c + F_N > 0 where the valve is open."""

    min_force: float       # N
    alpha_at_min: float    # rad
    ok: bool


def no_separation(alpha: ArrayLike, h: ArrayLike, h2: ArrayLike, *, rocker_ratio: float,
                  lash: float, preload: float, rate: float, mass: float,
                  omega: float) -> SeparationCheck:
    """Minimum of F_c + F_N over the angles where the follower is lifted (h > 0)."""
    a = _arr('alpha', alpha)
    hh, acc = _arr('h', h), _arr('h2', h2)
    f = spring_force(hh, rocker_ratio, lash, preload, rate) + inertia_force(acc, mass, omega)
    m = hh > 0
    if not np.any(m):
        raise InputError('h', 'no lift', 'a lift law with h > 0 somewhere')
    i = int(np.argmin(np.where(m, f, np.inf)))
    return SeparationCheck(float(f[i]), float(a[i]), bool(f[i] > 0))


# ---------------------------------------------------------------- lubrication (2.12)
@dataclasses.dataclass(frozen=True)
class OilFilm:
    """Oil-film number gamma_L = rho/(R0 + h) and h_min = K (R0+h) sqrt|2 g^2 - g|."""

    gamma: NDArray[np.float64]
    h_min: NDArray[np.float64]         # m (K in m/m; speed and oil dependent)
    reversal: NDArray[np.bool_]        # 0 < gamma < 0.5: entrainment reverses
    dwell_near_half: float             # rad spent with |gamma - 0.5| <= band
    nose_gamma: float                  # gamma at the largest lift (S0: 0.15-0.25 advised)


def oil_film(alpha: ArrayLike, h: ArrayLike, rho: ArrayLike, base_radius: float,
             k_film: float, band: float = 0.05) -> OilFilm:
    """(2.12) with the sign handling of docs/lift_laws.md (radicand negative for 0 < g < 0.5)."""
    a = _arr('alpha', alpha)
    hh, rr = _arr('h', h), _arr('rho', rho)
    r0 = require_positive('base_radius', base_radius)
    k = require_positive('k_film', k_film)
    g = rr / (r0 + hh)
    hmin = k * (r0 + hh) * np.sqrt(np.abs(2 * g * g - g))
    near = np.abs(g - 0.5) <= band
    da = np.gradient(a) if a.size > 1 else np.zeros_like(a)
    return OilFilm(g, hmin, (g > 0) & (g < 0.5), float(np.sum(da[near])),
                   float(g[int(np.argmax(hh))]))


# ---------------------------------------------------------------- piston (2.13, 2.14)
def piston_displacement(phi: ArrayLike, crank_radius: float, rod_length: float, *,
                        exact: bool = False) -> NDArray:
    """(2.14) s = r[(1 - cos phi) + (r/4l)(1 - cos 2 phi)] [m], phi crank angle from TDC
    [rad]; ``exact``: s = r (1 - cos phi) + l (1 - sqrt(1 - lam^2 sin^2 phi))."""
    r = require_positive('crank_radius', crank_radius)
    ln = require_positive('rod_length', rod_length)
    if r >= ln:
        raise InputError('rod_length', rod_length, f'a rod longer than the crank ({r})')
    p = _arr('phi', phi)
    if exact:
        lam = r / ln
        return r * (1 - np.cos(p)) + ln * (1 - np.sqrt(1 - (lam * np.sin(p)) ** 2))
    return r * ((1 - np.cos(p)) + r / (4 * ln) * (1 - np.cos(2 * p)))


def crank_angle(alpha: ArrayLike, phi0: float, alpha0: float) -> NDArray:
    """phi = phi0 + 2 (alpha - alpha0) [rad]: camshaft at half crank speed."""
    return require_finite('phi0', phi0) + 2 * (_arr('alpha', alpha)
                                               - require_finite('alpha0', alpha0))


def cam_angle(phi: ArrayLike, phi0: float, alpha0: float) -> NDArray:
    """Inverse of ``crank_angle``: alpha = alpha0 + (phi - phi0)/2 [rad]."""
    return require_finite('alpha0', alpha0) + (_arr('phi', phi)
                                               - require_finite('phi0', phi0)) / 2


def valve_piston_clearance(piston: ArrayLike, valve: ArrayLike, clearance: float) -> NDArray:
    """(2.13) D_s = s + y0 - y [m]; D_s <= 0 is a collision."""
    return (_arr('piston', piston) + require_finite('clearance', clearance)
            - _arr('valve', valve))


# ---------------------------------------------------------------- flank shape (§1.4)
@dataclasses.dataclass(frozen=True)
class FlankShape:
    """Shape checks of docs/lift_laws.md for one flank."""

    monotone: bool                  # h' of one sign (to 1e-9 of max |h'|)
    acceleration_sign_changes: int  # sign changes of h'' (zeros skipped); 1 expected
    positive_width: float           # rad: longest run with h'' > 0 (the main pulse)


def flank_shape(alpha: ArrayLike, h1: ArrayLike, h2: ArrayLike, rise: bool) -> FlankShape:
    """Monotonicity, h'' sign pattern and positive-acceleration width of the rise
    (``rise``: h' >= 0 expected) or fall flank sampled on ``alpha`` (increasing)."""
    a, v, acc = _arr('alpha', alpha), _arr('h1', h1), _arr('h2', h2)
    if not rise:       # look at the fall flank from the base circle towards the nose
        a, v, acc = -a[::-1], -v[::-1], acc[::-1]
    vt = 1e-9 * max(float(np.max(np.abs(v))), 1e-300)
    at = 1e-9 * max(float(np.max(np.abs(acc))), 1e-300)
    signs = np.sign(acc[np.abs(acc) > at])
    changes = int(np.count_nonzero(np.diff(signs)))
    best = run = 0.0
    for i in range(1, a.size):
        run = run + (a[i] - a[i - 1]) if (acc[i] > at and acc[i - 1] > at) else 0.0
        best = max(best, run)
    return FlankShape(bool(np.all(v >= -vt)), changes, best)


# ---------------------------------------------------------------- ramp (§1.1c)
@dataclasses.dataclass(frozen=True)
class RampEvents:
    """Quasi-static valve opening and seating on the ramps (docs/lift_laws.md)."""

    opening_alpha: float       # rad, first k h = x0 + F0/c on the rise flank
    closing_alpha: float       # rad, last one on the fall flank
    opening_velocity: float    # k h' omega at the opening [m/s]
    seating_velocity: float    # k |h'| omega at the closing [m/s]
    on_constant_velocity: bool  # h'' = 0 at both events (opening/seating on the CV part)


def ramp_events(law: Any, rocker_ratio: float, lash: float, preload: float,
                stiffness: float, omega: float) -> RampEvents:
    """Where the train force c (k h - x0) reaches the preload F0 (c, x0 at the valve):
    h = (x0 + F0/c)/k, found by brentq on each flank; velocities k h' omega."""
    from scipy.optimize import brentq

    k = require_positive('rocker_ratio', rocker_ratio)
    level = (require_positive('lash', lash, allow_zero=True)
             + require_positive('preload', preload, allow_zero=True)
             / require_positive('stiffness', stiffness)) / k
    lo, hi = law.support
    grid = np.linspace(lo, hi, 20001)
    above = np.nonzero(law(grid) > level)[0]
    if above.size == 0 or above[0] == 0 or above[-1] == grid.size - 1:
        raise InputError('lash', lash, 'a lift law that rises above the opening level '
                         f'(x0 + F0/c)/k = {level:.4g} m inside its support')
    i, j = int(above[0]), int(above[-1])
    a_open = brentq(lambda x: float(law(x)) - level, grid[i - 1], grid[i], xtol=1e-15)
    a_close = brentq(lambda x: float(law(x)) - level, grid[j], grid[j + 1], xtol=1e-15)
    w = require_finite('omega', omega)
    acc_tol = 1e-9 * float(np.max(np.abs(law(grid, 2))))
    cv = bool(abs(float(law(a_open, 2))) <= acc_tol and abs(float(law(a_close, 2))) <= acc_tol)
    return RampEvents(a_open, a_close, k * float(law(a_open, 1)) * w,
                      k * abs(float(law(a_close, 1))) * w, cv)


# ---------------------------------------------------------------- all checks for a law
#: top-level keys of the check input (docs/lift_laws.md)
CHECK_KEYS = ('base_radius', 'rocker_ratio', 'lash', 'cam_speed_rpm', 'stiffness',
              'follower', 'valve', 'spring', 'masses', 'equivalent_mass', 'contact',
              'lubrication', 'piston')


def _follower(cfg: Mapping[str, Any], key: str) -> tuple[str, float]:
    """(kind, roller radius) from the optional ``follower: {kind, radius}`` (flat)."""
    from cam_design.lift_laws import params as P

    raw = cfg.get('follower')
    if raw is None:
        return 'flat', 0.0
    fk = f'{key}.follower'
    raw = P.mapping(raw, fk)
    P.reject_unknown(raw, fk, ('kind', 'radius'))
    kind = P.choice(raw, fk, 'kind', ('flat', 'roller', 'knife'))
    if kind == 'roller':
        return kind, P.positive(raw, fk, 'radius')
    return kind, 0.0


def run_checks(law: Any, cfg: Mapping[str, Any], *, samples: int = 7201) -> dict[str, Any]:
    """All §2.1 checks of a lift law; ``cfg`` is the parsed check input (see
    docs/lift_laws.md "design check"). Flat tappet by default; with
    ``follower: {kind: roller|knife, radius}`` the radius of curvature and pressure
    angle come from ``cam_design.follower.roller_profile``, the contact force is divided
    by cos(pressure angle), Hertz uses the roller radius, and the oil-film number (a
    flat-tappet formula) is skipped. Returns a JSON-ready dict."""
    from cam_design.lift_laws import params as P

    key = 'check'
    P.reject_unknown(cfg, key, CHECK_KEYS)
    r0 = P.radius(cfg, key, 'base_radius')
    k = P.positive(cfg, key, 'rocker_ratio', 1.0)
    x0 = P.positive(cfg, key, 'lash', 0.0, allow_zero=True)
    lo, hi = law.support
    a = np.linspace(lo, hi, samples)
    h, h1, h2, _ = law.derivatives(a)
    y = rigid_valve_lift(h, k, x0)
    kind, roller = _follower(cfg, key)
    if kind == 'flat':
        rho = flat_tappet_curvature(h, h2, r0)
        cos_p = np.ones_like(a)
    else:   # roller/knife geometry belongs to cam_design.follower (eq. 2.7, erratum 5)
        from cam_design.cam_profile import roller_profile

        prof = roller_profile(law, r0, roller, a)
        rho, cos_p = prof.rho, np.cos(prof.pressure_angle)
    convex = rho > 0 if kind != 'flat' else np.ones(rho.shape, dtype=bool)
    i_rho = int(np.argmin(np.where(convex, rho, np.inf))) if np.any(convex) else 0
    out: dict[str, Any] = {
        'max_lift_mm': float(h.max()) * 1e3,
        'max_valve_lift_mm': float(y.max()) * 1e3,
        'support_deg': [math.degrees(lo), math.degrees(hi)],
        'continuity_order': int(law.continuity_order),
        'max_velocity_mm_per_rad': float(np.abs(h1).max()) * 1e3,
        'max_acceleration_mm_per_rad2': float(h2.max()) * 1e3,
        'min_acceleration_mm_per_rad2': float(h2.min()) * 1e3,
        'min_rho1_mm': float(rho[i_rho]) * 1e3,
        'min_rho1_alpha_deg': math.degrees(float(a[i_rho])),
        'follower': kind,
        'undercut': bool(rho[i_rho] <= 0) if kind == 'flat' else bool(np.any(prof.undercut)),
    }
    if kind == 'flat':
        out['tappet_face_radius_min_mm'] = float(np.abs(h1).max()) * 1e3
    else:
        out['pressure_angle_max_deg'] = math.degrees(float(np.arccos(cos_p.min())))
        if np.any(~convex):   # concave flank: its radius must exceed the roller radius
            j = int(np.argmax(np.where(convex, -np.inf, rho)))
            out['min_concave_radius_mm'] = float(-rho[j]) * 1e3
            out['min_concave_radius_alpha_deg'] = math.degrees(float(a[j]))
    rise_shape = flank_shape(a[a < 0], h1[a < 0], h2[a < 0], rise=True)
    fall_shape = flank_shape(a[a > 0], h1[a > 0], h2[a > 0], rise=False)
    out['monotone_flanks'] = rise_shape.monotone and fall_shape.monotone
    out['acceleration_sign_changes'] = [rise_shape.acceleration_sign_changes,
                                        fall_shape.acceleration_sign_changes]
    out['positive_acceleration_width_deg'] = [math.degrees(rise_shape.positive_width),
                                              math.degrees(fall_shape.positive_width)]
    if y.max() > 0:
        out['fullness'] = float(fullness(a, y))
        open_ = np.nonzero(y > 0)[0]
        out['valve_open_deg'] = math.degrees(float(a[open_[0]]))
        out['valve_close_deg'] = math.degrees(float(a[open_[-1]]))
    valve = cfg.get('valve')
    if valve is not None:
        vk = f'{key}.valve'
        valve = P.mapping(valve, vk)
        P.reject_unknown(valve, vk, ('seat_diameter', 'seat_angle', 'seat_width'))
        seat_angle = P.positive(valve, vk, 'seat_angle', allow_zero=True)
        fp = valve_flow_area(y, P.positive(valve, vk, 'seat_diameter'), seat_angle)
        ta = time_area(a, fp)
        out['max_flow_area_mm2'] = float(fp.max()) * 1e6
        out['time_area_mm2_deg'] = float(ta[-1]) * 1e6 * 180 / math.pi
        if 'seat_width' in valve:
            lim = flow_area_validity(P.positive(valve, vk, 'seat_width'), seat_angle)
            out['flow_area_formula_valid'] = bool(y.max() < lim)
    rpm = cfg.get('cam_speed_rpm')
    if rpm is not None:   # checked even when no force check uses it: '3000rpm' is an error
        rpm_to_omega(P.positive(cfg, key, 'cam_speed_rpm'), f'{key}.cam_speed_rpm')
    spring, masses = cfg.get('spring'), cfg.get('masses')
    if masses is not None and cfg.get('equivalent_mass') is not None:
        raise InputError(f'{key}.equivalent_mass', cfg['equivalent_mass'],
                         'either masses or equivalent_mass, not both')
    if rpm is not None and spring is not None and cfg.get('equivalent_mass') is not None:
        masses = {}
    if rpm is not None and spring is not None and masses is not None:
        omega = rpm_to_omega(P.positive(cfg, key, 'cam_speed_rpm'), f'{key}.cam_speed_rpm')
        sk, mk = f'{key}.spring', f'{key}.masses'
        spring, masses = P.mapping(spring, sk), P.mapping(masses, mk)
        P.reject_unknown(spring, sk, ('preload', 'rate'))
        P.reject_unknown(masses, mk, ('valve', 'spring', 'retainer', 'rocker_inertia',
                                      'rocker_arm', 'tappet', 'push_rod'))
        m = P.positive(cfg, key, 'equivalent_mass') if not masses else equivalent_mass(
            valve=P.positive(masses, mk, 'valve', allow_zero=True),
            spring=P.positive(masses, mk, 'spring', 0.0, allow_zero=True),
            retainer=P.positive(masses, mk, 'retainer', 0.0, allow_zero=True),
            rocker_ratio=k,
            rocker_inertia=P.positive(masses, mk, 'rocker_inertia', 0.0, allow_zero=True),
            rocker_arm=masses.get('rocker_arm'),
            tappet=P.positive(masses, mk, 'tappet', 0.0, allow_zero=True),
            push_rod=P.positive(masses, mk, 'push_rod', 0.0, allow_zero=True))
        f0 = P.positive(spring, sk, 'preload', allow_zero=True)
        rate = P.positive(spring, sk, 'rate', allow_zero=True)
        sep = no_separation(a, h, h2, rocker_ratio=k, lash=x0, preload=f0, rate=rate,
                            mass=m, omega=omega)
        force = spring_force(h, k, x0, f0, rate) + inertia_force(h2, m, omega)
        out['equivalent_mass_kg'] = m
        if cfg.get('stiffness') is not None:   # train stiffness at the tappet [N/m]
            c_t = P.positive(cfg, key, 'stiffness')
            period = omega * 2 * math.pi * math.sqrt(m / c_t)
            out['natural_period_cam_deg'] = math.degrees(period)
            out['positive_width_over_period'] = float(
                min(rise_shape.positive_width, fall_shape.positive_width) / period)
            ev = ramp_events(law, k, x0, f0, c_t / (k * k), omega)
            out['quasi_static_opening_deg'] = math.degrees(ev.opening_alpha)
            out['quasi_static_closing_deg'] = math.degrees(ev.closing_alpha)
            out['opening_velocity_m_per_s'] = ev.opening_velocity
            out['seating_velocity_m_per_s'] = ev.seating_velocity
            out['opening_and_seating_on_constant_velocity'] = ev.on_constant_velocity
        out['min_contact_force_n'] = sep.min_force
        out['min_contact_force_alpha_deg'] = math.degrees(sep.alpha_at_min)
        out['no_separation'] = sep.ok
        contact = cfg.get('contact')
        if contact is not None and kind != 'knife':   # no line contact for a knife edge
            ck = f'{key}.contact'
            contact = P.mapping(contact, ck)
            P.reject_unknown(contact, ck, ('width', 'youngs_modulus'))
            lifted = h > 0
            normal = np.where(lifted, force / cos_p, 0.0)
            width = P.positive(contact, ck, 'width')
            modulus = P.positive(contact, ck, 'youngs_modulus', 2.06e11)
            if kind == 'flat' and out['undercut']:
                # rho1 <= 0 somewhere: the profile is not realisable and |rho1| -> 0 gives a
                # grid-dependent stress; report none rather than a meaningless number
                out['max_hertz_stress_mpa'] = None
                out['max_hertz_stress_note'] = 'undercut (rho1 <= 0): no Hertz stress'
            else:
                # the cam radius is signed (< 0: concave flank) and goes second, so a
                # roller on a concave flank gets 1/r - 1/|rho|, not 1/r + 1/|rho|
                sig = (hertz_stress_steel(normal, width, rho, math.inf, e1=modulus)
                       if kind == 'flat' else
                       hertz_stress_steel(normal, width, roller, rho, e1=modulus))
                i = int(np.argmax(sig))
                out['max_hertz_stress_mpa'] = float(sig[i]) / 1e6
                out['max_hertz_stress_alpha_deg'] = math.degrees(float(a[i]))
    lub = cfg.get('lubrication')
    if lub is not None and kind == 'flat':
        lk = f'{key}.lubrication'
        lub = P.mapping(lub, lk)
        P.reject_unknown(lub, lk, ('k_film',))
        lifted = h > 0
        film = oil_film(a[lifted], h[lifted], rho[lifted], r0, P.positive(lub, lk, 'k_film'))
        out['oil_film_nose_gamma'] = film.nose_gamma
        out['oil_film_reversal_deg'] = math.degrees(
            float(np.sum(np.gradient(a[lifted])[film.reversal])))
        out['oil_film_dwell_near_half_deg'] = math.degrees(film.dwell_near_half)
        out['min_oil_film_um'] = float(film.h_min.min()) * 1e6
    piston = cfg.get('piston')
    if piston is not None and y.max() > 0:
        ds, phi_at = min_valve_piston_clearance(a, y, piston, f'{key}.piston')
        out['min_valve_piston_clearance_mm'] = ds * 1e3
        out['min_clearance_crank_deg'] = math.degrees(phi_at)
        out['valve_piston_collision'] = bool(ds <= 0)
    return out


PISTON_KEYS = ('crank_radius', 'rod_length', 'clearance', 'opening_crank_angle', 'exact')


def min_valve_piston_clearance(alpha: ArrayLike, valve_lift: ArrayLike,
                               piston: Mapping[str, Any], key: str = 'piston',
                               open_alpha: float | None = None) -> tuple[float, float]:
    """Smallest valve-piston clearance D_s = s + y0 - y [m] (2.13) over the cam angles
    ``alpha`` [rad] for the valve lift ``valve_lift`` [m] (rigid or dynamic), and the
    crank angle [rad from TDC] where it occurs. ``piston`` holds ``crank_radius``,
    ``rod_length``, ``clearance`` [m], ``opening_crank_angle`` [rad] (crank angle at the
    opening) and ``exact`` (default True); errors name ``key.X``. The opening is the cam
    angle ``open_alpha`` [rad] (the rigid train's, which fixes the valve timing), or else
    the first sample with y > 0."""
    from cam_design.lift_laws import params as P

    a, y = _arr('alpha', alpha), _arr('valve_lift', valve_lift)
    piston = P.mapping(piston, key)
    P.reject_unknown(piston, key, PISTON_KEYS)
    if not np.any(y > 0):
        raise InputError('valve_lift', float(y.max()), 'a valve that opens (lift > 0)')
    if open_alpha is None:
        open_alpha = float(a[np.nonzero(y > 0)[0][0]])
    phi = crank_angle(a, P.finite(piston, key, 'opening_crank_angle'), open_alpha)
    s = piston_displacement(phi, P.positive(piston, key, 'crank_radius'),
                            P.positive(piston, key, 'rod_length'),
                            exact=bool(piston.get('exact', True)))
    ds = valve_piston_clearance(s, y, P.positive(piston, key, 'clearance', allow_zero=True))
    i = int(np.argmin(ds))
    return float(ds[i]), float(phi[i])
