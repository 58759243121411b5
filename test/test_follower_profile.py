"""Cam profile coordinates, curvature, pressure angle and undercut (methods §2.1-2.5)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from cam_design.errors import InputError
from cam_design.cam_profile import (flat_profile, offset_pressure_angle, offset_roller_profile,
                                    rocker_polar, rocker_profile, roller_profile)
from cam_design.follower import Follower
from test_follower_convert import E, R0, RC, DiscLift, smooth_bump

ALPHA = np.linspace(-math.pi, math.pi, 2001)
CENTRE = np.array([[0.0], [E]])      # disc centre: nose on +Y (book frame)


def test_disc_flat_profile_rho_equals_disc_radius() -> None:
    prof = flat_profile(DiscLift(Follower('flat')), R0, ALPHA)
    assert np.max(np.abs(prof.rho - RC)) < 1e-15                 # §7 #13 via eq. 2.6
    pts = np.stack([prof.x, prof.y])
    assert np.max(np.abs(np.hypot(*(pts - CENTRE)) - RC)) < 1e-15
    assert not prof.undercut.any()
    assert np.max(np.abs(prof.face_offset)) == pytest.approx(E, abs=1e-9)


@pytest.mark.parametrize('r', [0.008, 0.0])
def test_disc_roller_profile_rho_equals_disc_radius(r: float) -> None:
    follower = Follower('roller', r) if r else Follower('knife')
    law = DiscLift(follower)
    prof = roller_profile(law, R0, r, ALPHA)
    assert np.max(np.abs(prof.rho - RC)) < 1e-12                 # §7 #13 via eq. 2.7
    assert np.max(np.abs(prof.rho_pitch - (RC + r))) < 1e-12
    assert np.max(np.abs(np.hypot(prof.x, prof.y - E) - RC)) < 1e-15
    assert np.max(np.abs(np.hypot(prof.pitch_x, prof.pitch_y - E) - RC - r)) < 1e-15
    # eq. 2.16 written out (independent of the envelope code)
    h, h1 = law(ALPHA), law(ALPHA, 1)
    g, th = R0 + r + h, ALPHA + math.pi / 2
    s = np.hypot(g, h1)
    x = g * np.cos(th) - r * (g * np.cos(th) + h1 * np.sin(th)) / s
    y = g * np.sin(th) - r * (g * np.sin(th) - h1 * np.cos(th)) / s
    assert np.max(np.abs(prof.x - x)) < 1e-15 and np.max(np.abs(prof.y - y)) < 1e-15
    # pressure angle of an in-line roller on a disc: the normal passes the disc centre
    pitch = np.stack([prof.pitch_x, prof.pitch_y])
    normal = (pitch - CENTRE) / np.hypot(*(pitch - CENTRE))
    motion = np.stack([np.cos(th), np.sin(th)])
    want = np.arccos(np.clip(np.abs(np.sum(normal * motion, axis=0)), 0, 1))
    assert np.max(np.abs(prof.pressure_angle - want)) < 1e-7


def _numeric_pitch_normal(pitch_fn, phi: np.ndarray, step: float = 1e-6) -> np.ndarray:
    """Unit normal of a pitch curve from central differences of its points."""
    t = (pitch_fn(phi + step) - pitch_fn(phi - step)) / (2 * step)
    t /= np.hypot(*t)
    return np.stack([-t[1], t[0]])


@pytest.mark.parametrize('eta', [1, -1])
@pytest.mark.parametrize('delta', [1, -1, 0])
def test_offset_roller_pressure_angle_matches_pitch_normal(eta: int, delta: int) -> None:
    law = smooth_bump(0.006, 1.2)
    r0, r, e = 0.02, 0.006, 0.004 if delta else 0.0
    phi = np.linspace(-1.5, 1.5, 301)
    prof = offset_roller_profile(law, r0, r, e, phi, eta=eta, delta=delta)
    s0 = math.sqrt((r0 + r) ** 2 - e * e)

    def pitch_fn(p: np.ndarray) -> np.ndarray:   # the thesis formula, written out
        s = law(p)
        return np.stack([(s0 + s) * np.cos(eta * p) - delta * e * np.sin(eta * p),
                         (s0 + s) * np.sin(eta * p) + delta * e * np.cos(eta * p)])

    assert np.max(np.abs(np.stack([prof.pitch_x, prof.pitch_y]) - pitch_fn(phi))) < 1e-16
    normal = _numeric_pitch_normal(pitch_fn, phi)
    motion = np.stack([np.cos(eta * phi), np.sin(eta * phi)])
    independent = np.arccos(np.clip(np.abs(np.sum(normal * motion, axis=0)), 0, 1))
    closed = offset_pressure_angle(law, r0, r, e, phi, eta=eta, delta=delta)
    assert np.max(np.abs(closed - independent)) < 1e-7
    assert np.max(np.abs(prof.pressure_angle - independent)) < 1e-7
    # the envelope: at distance r from the pitch curve, on the inner side, along the normal
    d = np.stack([prof.pitch_x - prof.x, prof.pitch_y - prof.y])
    assert np.max(np.abs(np.hypot(*d) - r)) < 1e-15
    assert np.max(np.abs(_cross(d, normal))) < 1e-9
    assert np.mean(np.hypot(prof.x, prof.y)) < np.mean(np.hypot(prof.pitch_x, prof.pitch_y))
    base = np.abs(phi) > 1.2
    assert np.allclose(np.hypot(prof.pitch_x, prof.pitch_y)[base], r0 + r, atol=1e-15)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[0] * b[1] - a[1] * b[0]


@pytest.mark.parametrize('eta', [1, -1])
@pytest.mark.parametrize('delta', [1, -1])
def test_rocker_thesis_form_checks(eta: int, delta: int) -> None:
    law = smooth_bump(0.005, 1.1)
    r0, r, a, arm = 0.015, 0.005, 0.045, 0.035
    phi = np.linspace(-math.pi, math.pi, 721)
    prof = rocker_profile(law, r0, r, a, arm, phi, eta=eta, delta=delta)
    pivot = a * np.stack([np.cos(eta * phi), np.sin(eta * phi)])
    pitch = np.stack([prof.pitch_x, prof.pitch_y])
    assert np.max(np.abs(np.hypot(*(pitch - pivot)) - arm)) < 1e-15      # |B - A'| = l
    base = law(phi) == 0
    assert base.any()
    assert np.max(np.abs(np.hypot(*pitch[:, base]) - (r0 + r))) < 1e-15  # |B| = r0
    # pressure angle: pitch normal (numeric) vs the roller centre's velocity (perp. to arm)
    psi0 = math.acos((a * a + arm * arm - (r0 + r) ** 2) / (2 * a * arm))

    def pitch_fn(p: np.ndarray) -> np.ndarray:
        big = eta * p - delta * (psi0 + law(p) / arm)
        return np.stack([a * np.cos(eta * p) - arm * np.cos(big),
                         a * np.sin(eta * p) - arm * np.sin(big)])

    normal = _numeric_pitch_normal(pitch_fn, phi)
    arm_dir = (pitch - pivot) / arm
    independent = np.arccos(np.clip(np.abs(_cross(arm_dir, normal)), 0, 1))
    assert np.max(np.abs(prof.pressure_angle - independent)) < 1e-7


@pytest.mark.parametrize('co', [False, True])
def test_rocker_polar_form_equals_thesis_form(co: bool) -> None:
    law = smooth_bump(0.005, 1.1)
    r0, r, a, arm = 0.015, 0.005, 0.045, 0.035
    phi = np.linspace(-math.pi, math.pi, 361)
    delta = 1 if co else -1
    prof = rocker_profile(law, r0, r, a, arm, phi, eta=1, delta=delta)
    rho, theta = rocker_polar(law, r0, r, a, arm, phi, co_directional=co)
    assert np.max(np.abs(rho - np.hypot(prof.pitch_x, prof.pitch_y))) < 1e-15
    psi0 = math.acos((a * a + arm * arm - (r0 + r) ** 2) / (2 * a * arm))
    beta0 = math.atan2(arm * math.sin(psi0), a - arm * math.cos(psi0))
    ang = np.arctan2(prof.pitch_y, prof.pitch_x) - delta * beta0
    diff = (ang - theta + math.pi) % (2 * math.pi) - math.pi
    assert np.max(np.abs(diff)) < 1e-13


def test_undercut_detected_on_sharp_roller_nose() -> None:
    law = smooth_bump(0.010, 0.5)       # nose pitch radius of curvature ~3 mm < roller 8 mm
    prof = roller_profile(law, 0.015, 0.008, np.linspace(-1, 1, 2001))
    assert prof.undercut.any()
    (lo, hi), = prof.undercut_intervals()
    assert lo < 0 < hi and hi - lo < 0.5
    assert np.all((prof.rho_pitch[prof.undercut] > 0) & (prof.rho_pitch[prof.undercut] < 0.008))
    assert prof.summary()['undercut'] is True
    knife = roller_profile(law, 0.015, 0.0, np.linspace(-1, 1, 2001))
    assert not knife.undercut.any()


def test_undercut_detected_on_sharp_flat_nose() -> None:
    law = smooth_bump(0.015, 0.4)
    prof = flat_profile(law, 0.01, np.linspace(-0.5, 0.5, 1001))
    assert prof.undercut.any() and prof.summary()['rho_min_m'] < 0
    (lo, hi), = prof.undercut_intervals()
    assert lo < 0 < hi


def test_concave_roller_flank_is_not_undercut() -> None:
    law = smooth_bump(0.006, 0.8)     # concave pitch flanks (rho_pitch < 0): fine for a roller
    prof = roller_profile(law, 0.012, 0.002, np.linspace(-1, 1, 2001))
    assert np.any(prof.rho_pitch < 0)
    assert not prof.undercut.any()
    assert np.allclose(prof.rho, prof.rho_pitch - 0.002)


@pytest.mark.parametrize('call,key', [
    (lambda law: roller_profile(law, 0.02, -0.001, [0.0]), 'radius'),
    (lambda law: flat_profile(law, 0.0, [0.0]), 'base_radius'),
    (lambda law: flat_profile(law, 0.02, []), 'alpha'),
    (lambda law: roller_profile(law, 0.02, 0.01, [float('inf')]), 'alpha'),
    (lambda law: offset_roller_profile(law, 0.02, 0.005, 0.03, [0.0]), 'offset'),
    (lambda law: offset_roller_profile(law, 0.02, 0.005, -0.001, [0.0]), 'offset'),
    (lambda law: offset_roller_profile(law, 0.02, 0.005, 0.001, [0.0], eta=2), 'eta'),
    (lambda law: offset_roller_profile(law, 0.02, 0.005, 0.001, [0.0], delta=True), 'delta'),
    (lambda law: offset_roller_profile(law, 0.02, 0.005, 0.001, [0.0], delta=0), 'delta'),
    (lambda law: rocker_profile(law, 0.02, 0.005, 0.2, 0.03, [0.0]), 'centre_distance'),
    (lambda law: rocker_profile(law, 0.02, 0.005, 0.04, 0.0, [0.0]), 'arm_length'),
])
def test_bad_input_names_the_key(call, key: str) -> None:
    with pytest.raises(InputError) as err:
        call(smooth_bump(0.005, 1.0))
    assert err.value.key == key
    assert str(err.value).startswith(f'{key}: got ')


def test_converted_roller_profile_has_the_flat_designs_curvature() -> None:
    # one cam, two descriptions: the roller profile of the converted lift must have, at
    # each contact, the flat design's rho1 = R0 + h + h'' at the contact normal angle
    from cam_design.follower import convert_lift

    law = smooth_bump(0.005, 1.6)
    r0, r = 0.02, 0.007
    seen = convert_lift(law, r0, Follower('flat'), Follower('roller', r))
    alpha = np.linspace(-math.pi, math.pi, 1441)
    prof = roller_profile(seen, r0, r, alpha)
    n = np.stack([prof.pitch_x - prof.x, prof.pitch_y - prof.y]) / r
    psi = (np.arctan2(n[1], n[0]) + math.pi / 2) % (2 * math.pi) - math.pi
    rho1 = r0 + law(psi) + law(psi, 2)
    assert np.max(np.abs(prof.rho - rho1)) < 1e-12
    flat = flat_profile(law, r0, psi)      # and the same contact points
    assert np.max(np.hypot(prof.x - flat.x, prof.y - flat.y)) < 1e-15


@pytest.mark.parametrize('follower,tol', [(Follower('flat'), 1e-12),
                                          (Follower('roller', 0.008), 1e-9),
                                          (Follower('knife'), 1e-13)])
def test_lift_from_profile_points_on_the_disc(follower: Follower, tol: float) -> None:
    from cam_design.cam_profile import lift_from_profile

    s = np.linspace(-math.pi, math.pi, 2000, endpoint=False)
    prof = flat_profile(DiscLift(Follower('flat')), R0, s)
    a = np.linspace(-math.pi, math.pi, 721)
    want = DiscLift(follower)(a)
    assert np.max(np.abs(lift_from_profile(prof.x, prof.y, a, follower, R0) - want)) < tol
    assert np.max(np.abs(lift_from_profile(prof.x, prof.y, a, follower) - want)) < tol


def test_lift_from_profile_agrees_with_convert_lift_on_a_real_lobe() -> None:
    from cam_design.cam_profile import lift_from_profile
    from cam_design.follower import convert_lift
    from cam_design.lift_laws import from_spec

    law = from_spec({'family': 'preset', 'name': 'flat_tappet_intake'}, 'test')
    s = np.linspace(-math.pi, math.pi, 20000, endpoint=False)
    prof = flat_profile(law, 0.0165, s)
    ball = Follower('roller', 0.002)
    a = np.linspace(-math.pi, math.pi, 361)
    ref = lift_from_profile(prof.x, prof.y, a, ball, 0.0165)
    exact = convert_lift(law, 0.0165, Follower('flat'), ball)(a)
    assert np.max(np.abs(ref - exact)) < 1e-9


def test_lift_from_profile_bad_input() -> None:
    from cam_design.cam_profile import lift_from_profile

    with pytest.raises(InputError, match='profile'):
        lift_from_profile([0.0, 1.0], [0.0, 1.0], [0.0], Follower('flat'))
    with pytest.raises(InputError, match='profile'):
        lift_from_profile(np.r_[np.ones(9), np.nan], np.ones(10), [0.0], Follower('flat'))
    with pytest.raises(InputError, match='follower'):
        lift_from_profile(np.ones(10), np.ones(10), [0.0], 'flat')


def test_roller_rho_matches_book_formula_on_a_lobe() -> None:
    # methods §2.2 (eq. 2.7 with erratum 5) written out, on a lobe with concave flanks
    law = smooth_bump(0.006, 0.8)
    r0, r = 0.012, 0.002
    a = np.linspace(-math.pi, math.pi, 3001)
    prof = roller_profile(law, r0, r, a)
    g, g1, g2 = r0 + r + law(a), law(a, 1), law(a, 2)
    rho_pitch = (g * g + g1 * g1) ** 1.5 / (g * g + 2 * g1 * g1 - g * g2)
    assert np.max(np.abs(prof.rho_pitch - rho_pitch) / np.abs(rho_pitch)) < 1e-12
    assert np.max(np.abs(prof.rho - (rho_pitch - r)) / np.abs(rho_pitch)) < 1e-12
    assert np.any(rho_pitch < 0) and not prof.undercut.any()


@pytest.mark.parametrize('target', [Follower('knife'), Follower('roller', 0.001),
                                    Follower('roller', 0.004)])
def test_concave_roller_design_converted_to_smaller_followers(target: Follower) -> None:
    # a roller design with concave flanks: knives and rollers that fit the hollow are
    # converted exactly (checked against the brute-force max over profile points)
    from cam_design.cam_profile import lift_from_profile
    from cam_design.follower import convert_lift

    law = smooth_bump(0.006, 0.8)
    r0, r = 0.012, 0.002
    prof = roller_profile(law, r0, r, np.linspace(-math.pi, math.pi, 40000, endpoint=False))
    assert np.min(prof.rho) < -0.005          # concave radius >= 5 mm somewhere
    a = np.linspace(-math.pi, math.pi, 241)
    conv = convert_lift(law, r0, Follower('roller', r), target)
    ref = lift_from_profile(prof.x, prof.y, a, target, r0)
    assert np.max(np.abs(conv(a) - ref)) < 1e-9


def test_noisy_roller_lift_to_flat_bridges_the_noise() -> None:
    # a ball-probe lift with 0.1 um noise (a tabulated measurement): its profile has many
    # tiny hollows, which a flat face bridges (max over runs) - checked by brute force
    from cam_design.cam_profile import lift_from_profile
    from cam_design.follower import convert_lift
    from cam_design.lift_laws import TabulatedLift

    rng = np.random.default_rng(3)
    a = np.linspace(-1.6, 1.6, 1281)
    bump = np.cos(0.5 * math.pi * a / 1.6) ** 4
    law = TabulatedLift(a, 0.005 * bump + 1e-7 * bump * rng.standard_normal(a.size))
    ball = Follower('roller', 0.002)
    conv = convert_lift(law, 0.02, ball, Follower('flat'))
    assert conv.continuity_order == 0
    prof = roller_profile(law, 0.02, 0.002, np.linspace(-math.pi, math.pi, 40000,
                                                        endpoint=False))
    x = np.linspace(-math.pi, math.pi, 721)
    ref = lift_from_profile(prof.x, prof.y, x, Follower('flat'), 0.02)
    assert np.max(np.abs(conv(x) - ref)) < 1e-9
