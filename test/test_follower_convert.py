"""convert_lift: exact eccentric-disc cases, a flat with a velocity step, round trips,
undercut/concave rejection and bad input (methods.md §2.1, §2.2, §2.6, §5.5)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from cam_design.errors import InputError
from cam_design.follower import ConvertedLift, Follower, convert_lift
from cam_design.lift_laws.base import LiftLaw, TabulatedLift

RC, E = 0.020, 0.005          # methods §7 #13: disc radius 20 mm, eccentricity 5 mm
R0 = RC - E


class DiscLift(LiftLaw):
    """Exact lift of an eccentric disc (nose at alpha = 0) for a follower of radius r
    (flat: h = e(1 + cos a); roller/knife: D = e cos a + sqrt((Rc + r)^2 - e^2 sin^2 a));
    derivatives by complex-step-free closed forms of D through q = sqrt(...)."""

    continuity_order = 3

    def __init__(self, follower: Follower) -> None:
        self.follower = follower

    @property
    def support(self) -> tuple[float, float]:
        return -math.pi, math.pi

    def _evaluate(self, a: np.ndarray, nu: int) -> np.ndarray:
        c, s = np.cos(a), np.sin(a)
        if self.follower.kind == 'flat':
            return [E * (1 + c), -E * s, -E * c, E * s][nu]
        r = self.follower.radius if self.follower.kind == 'roller' else 0.0
        big = (RC + r) ** 2
        q = np.sqrt(big - E * E * s * s)
        # u = sin^2 a: u' = sin 2a, u'' = 2 cos 2a, u''' = -4 sin 2a; q = sqrt(big - e^2 u)
        u1, u2, u3 = np.sin(2 * a), 2 * np.cos(2 * a), -4 * np.sin(2 * a)
        k = E * E
        q1 = -k * u1 / (2 * q)
        q2 = -k * u2 / (2 * q) - q1 * q1 / q
        q3 = -k * u3 / (2 * q) - 3 * q1 * q2 / q
        return [E * c + q - (R0 + r), -E * s + q1, -E * c + q2, E * s + q3][nu]


FLAT, KNIFE = Follower('flat'), Follower('knife')
ROLLER = Follower('roller', 0.008)
ALPHA = np.linspace(-math.pi, math.pi, 3601)
PAIRS = [(FLAT, ROLLER), (FLAT, KNIFE), (ROLLER, FLAT), (ROLLER, KNIFE), (KNIFE, ROLLER),
         (KNIFE, FLAT), (ROLLER, Follower('roller', 0.0025)), (Follower('roller', 0.03), FLAT)]


@pytest.mark.parametrize('source,target', PAIRS, ids=lambda f: f'{f.kind}{f.radius}')
def test_eccentric_disc_conversion_is_exact(source: Follower, target: Follower) -> None:
    law = convert_lift(DiscLift(source), R0, source, target)
    got = law.derivatives(ALPHA)
    want = DiscLift(target).derivatives(ALPHA)
    assert np.max(np.abs(got[0] - want[0])) < 1e-12            # m (spec: < 1e-9)
    for nu in (1, 2, 3):                                         # m/rad^nu
        assert np.max(np.abs(got[nu] - want[nu])) < 1e-11
        assert np.allclose(law(ALPHA, nu), got[nu], rtol=0, atol=1e-15)


def test_identity_returns_the_law() -> None:
    law = DiscLift(FLAT)
    assert convert_lift(law, R0, FLAT, FLAT) is law
    assert convert_lift(law, R0, Follower('flat', 0.01), FLAT) is law
    assert convert_lift(law, R0, ROLLER, Follower('roller', 0.008)) is law


def test_wrapped_and_shaped_input() -> None:
    law = convert_lift(DiscLift(FLAT), R0, FLAT, ROLLER)
    a = np.array([[0.3, -2.0], [1.0, 3.0]])
    want = DiscLift(ROLLER)(a, 1)
    assert law(a, 1).shape == (2, 2)
    assert np.allclose(law(a, 1), want, atol=1e-14)
    assert np.allclose(law.solve(a.ravel() + 2 * math.pi)[1], want.ravel(), atol=1e-14)


class RampLobe(LiftLaw):
    """Flat-tappet lobe with constant-velocity ramps (h' steps from 0 to v at the support
    ends) of width w outside |a| <= m, and a main event H_r + H (1 + cos(pi x / m)) / 2 +
    v (m^2 - x^2) / (2m) on x = |a| <= m (h, h' continuous at the junctions)."""

    continuity_order = 0

    def __init__(self, v: float = 0.0005, m: float = 1.4, lift: float = 0.006,
                 vm: float | None = None) -> None:
        self.v, self.m, self.lift = v, m, lift
        self.vm = v if vm is None else vm      # main-event velocity at the junction
        self.w = 0.15

    @property
    def support(self) -> tuple[float, float]:
        return -(self.m + self.w), self.m + self.w

    @property
    def junctions(self) -> tuple[float, ...]:
        return (-self.m, self.m)

    def _evaluate(self, a: np.ndarray, nu: int) -> np.ndarray:
        x = np.abs(a)
        sgn = np.where(a < 0, -1.0, 1.0) ** nu
        hr = self.v * self.w
        k = math.pi / self.m
        ramp = [hr - self.v * (x - self.m), -self.v + 0 * x, 0 * x, 0 * x][nu]
        cx, sx = np.cos(k * x), np.sin(k * x)
        half = self.lift / 2
        q = self.vm / (2 * self.m)     # + vm (m^2 - x^2) / (2m): velocity -vm at x = m
        main = [hr + half * (1 + cx) + q * (self.m ** 2 - x * x), -half * k * sx - 2 * q * x,
                -half * k * k * cx - 2 * q, half * k ** 3 * sx][nu]
        return sgn * np.where(x > self.m, ramp, main)


def brute_roller_lift(law: LiftLaw, r0: float, r: float, alpha: np.ndarray) -> np.ndarray:
    """Independent reference (methods §2.6): dense flat-design profile points, including
    the straight flats at velocity steps, then D = max [P.u + sqrt(r^2 - (P.u_perp)^2)]."""
    s = np.linspace(-math.pi, math.pi, 400001)
    p = r0 + law(s)
    dp = law(s, 1)
    pts = [np.stack([p * np.cos(s) - dp * np.sin(s), p * np.sin(s) + dp * np.cos(s)])]
    lo, hi = law.support
    for b in (lo, hi, *law.junctions):
        h_b = r0 + float(law(np.array([b]))[0])
        t_l, t_r = law(np.array([b - 1e-12, b + 1e-12]), 1)
        t = np.linspace(min(t_l, t_r), max(t_l, t_r), 2001)
        pts.append(np.stack([h_b * math.cos(b) - t * math.sin(b),
                             h_b * math.sin(b) + t * math.cos(b)]))
    x, y = np.concatenate(pts, axis=1)
    out = []
    for a in alpha:
        along = x * math.cos(a) + y * math.sin(a)
        across = -x * math.sin(a) + y * math.cos(a)
        ok = np.abs(across) <= r
        out.append(np.max(along[ok] + np.sqrt(r * r - across[ok] ** 2)) - (r0 + r))
    return np.array(out)


@pytest.mark.parametrize('vm,marks', [(None, 6), (0.0015, 8)])
def test_flat_with_velocity_steps_to_roller_matches_brute_force(vm: float | None,
                                                                marks: int) -> None:
    lobe = RampLobe(vm=vm)      # steps of h' at the support ends (and at the junctions)
    conv = convert_lift(lobe, 0.018, FLAT, Follower('roller', 0.01))
    assert isinstance(conv, ConvertedLift)
    # junctions: both ends of every flat, and the image of a plain h'' step: h'' steps there
    j = np.array(conv.junctions)
    assert j.size == marks
    assert np.all(np.abs(conv(j - 1e-9, 2) - conv(j + 1e-9, 2)) > 5e-3)
    alpha = np.concatenate([np.linspace(-1.6, 1.6, 41), [-1.55 + 0.004, 1.55 - 0.004]])
    ref = brute_roller_lift(lobe, 0.018, 0.01, alpha)
    got = conv(alpha)
    assert np.max(np.abs(got - ref)) < 2e-9
    assert np.all(got[np.abs(alpha) > 1.55] == 0.0)


def test_flat_face_start_closed_form() -> None:
    # on the ramp flat, the roller centre runs on a straight line: D = (R0 + r)/cos(a - lo)
    lobe = RampLobe()
    r = 0.004
    conv = convert_lift(lobe, 0.018, FLAT, Follower('roller', r))
    lo = lobe.support[0]
    a = lo + np.array([1e-4, 5e-3, 1e-2])
    d = (0.018 + r) / np.cos(a - lo)
    assert np.allclose(conv(a), d - (0.018 + r), rtol=0, atol=1e-15)
    assert np.allclose(conv(a, 1), d * np.tan(a - lo), rtol=0, atol=1e-15)


def smooth_bump(lift: float, half_width: float) -> TabulatedLift:
    """A C4-ish smooth bump (cos^4 shape) tabulated on 401 points."""
    a = np.linspace(-half_width, half_width, 401)
    return TabulatedLift(a, lift * np.cos(0.5 * math.pi * a / half_width) ** 4)


@settings(max_examples=25, deadline=None)
@given(lift=st.floats(0.002, 0.006), half=st.floats(1.4, 2.6), r=st.floats(0.002, 0.03))
def test_round_trip_flat_roller_flat(lift: float, half: float, r: float) -> None:
    r0 = 0.03     # rho1 >= r0 + lift - lift pi^2 / half^2 > 5 mm: convex
    law = smooth_bump(lift, half)
    roller = Follower('roller', r)
    there = convert_lift(law, r0, FLAT, roller)
    back = convert_lift(there, r0, roller, FLAT)
    a = np.linspace(-math.pi, math.pi, 1001)
    err = np.max(np.abs(back.derivatives(a) - law.derivatives(a)), axis=1)
    assert np.all(err < [1e-14, 1e-14, 1e-13, 1e-11])     # spec: 1e-9 m


def test_undercut_flat_design_rejected() -> None:
    law = smooth_bump(0.015, 0.4)      # rho1 = R0 + h + h'' < 0 near the nose
    with pytest.raises(InputError, match='undercut') as err:
        convert_lift(law, 0.01, FLAT, ROLLER, key='lobes[0].lift')
    assert err.value.key == 'lobes[0].lift'


@pytest.mark.parametrize('target', [FLAT, Follower('roller', 0.03)])
def test_concave_roller_design_bridged_by_flat_and_large_roller(target: Follower) -> None:
    # a roller design with concave flanks: a flat face (or a roller larger than the
    # hollow) bridges them; the lift is the max over the convex runs (methods §2.6)
    from cam_design.cam_profile import lift_from_profile, roller_profile

    law = smooth_bump(0.006, 0.8)
    r0, r = 0.012, 0.002
    conv = convert_lift(law, r0, Follower('roller', r), target)
    assert conv.continuity_order == 0           # h' steps where the contact jumps ...
    j = np.array(conv.junctions)                # ... and those angles are junctions
    jumps = np.abs(conv(j - 1e-9, 1) - conv(j + 1e-9, 1))
    assert np.sum(jumps > 1e-3) == 2 and np.allclose(j, -j[::-1], atol=1e-12)
    prof = roller_profile(law, r0, r, np.linspace(-math.pi, math.pi, 40000, endpoint=False))
    a = np.linspace(-math.pi, math.pi, 361)
    ref = lift_from_profile(prof.x, prof.y, a, target, r0)
    assert np.max(np.abs(conv(a) - ref)) < 1e-9


@pytest.mark.parametrize('args,key', [
    ((-0.01, FLAT, ROLLER), 'base_radius'),
    ((float('nan'), FLAT, ROLLER), 'base_radius'),
    ((0.01, 'flat', ROLLER), 'source'),
])
def test_bad_input(args: tuple, key: str) -> None:
    with pytest.raises(InputError) as err:
        convert_lift(DiscLift(FLAT), *args)
    assert err.value.key == key


def test_bad_follower_rejected() -> None:
    with pytest.raises(InputError, match='follower.kind'):
        Follower('mushroom')
    with pytest.raises(InputError, match='follower.radius'):
        Follower('roller', -0.001)
    with pytest.raises(InputError, match='follower.radius'):
        Follower('roller', 0.0)


def test_step_in_lift_rejected() -> None:
    law = TabulatedLift(np.linspace(-1, 1, 11), 0.001 + 0.0 * np.linspace(-1, 1, 11))
    with pytest.raises(InputError, match='step'):
        convert_lift(law, 0.02, FLAT, ROLLER)


def test_huge_and_empty_queries() -> None:
    law = convert_lift(DiscLift(FLAT), R0, FLAT, KNIFE)
    assert law(np.array([])).shape == (0,)
    a = np.linspace(-50, 50, 200001)     # solve() wraps; law() is 0 outside the support
    assert np.max(np.abs(law.solve(a)[0] - DiscLift(KNIFE)(_wrap(a)))) < 1e-12
    with pytest.raises(InputError, match='alpha'):
        law.solve([0.1, float('nan')])


def _wrap(a: np.ndarray) -> np.ndarray:
    return (a + math.pi) % (2 * math.pi) - math.pi


@pytest.mark.parametrize('follower', [FLAT, KNIFE, ROLLER])
def test_library_disc_reference_matches_independent_closed_form(follower: Follower) -> None:
    from cam_design.follower import EccentricDiscLift

    lib = EccentricDiscLift(RC, E, follower).derivatives(ALPHA)
    assert np.max(np.abs(lib - DiscLift(follower).derivatives(ALPHA))) < 1e-15
    with pytest.raises(InputError, match='eccentricity'):
        EccentricDiscLift(RC, RC, follower)


def test_block_solve_matches_single_block() -> None:
    law = convert_lift(DiscLift(FLAT), R0, FLAT, ROLLER)
    a = np.linspace(-3, 3, 5000)                  # > SOLVE_BLOCK: several blocks
    assert np.max(np.abs(law.solve(a) - DiscLift(ROLLER).derivatives(a))) < 1e-11


def brute_flat_lift_of_ground_cam(centre: np.ndarray, theta: np.ndarray, wheel: float,
                                  r0: float, alpha: np.ndarray) -> np.ndarray:
    """Flat-tappet lift of the cam ground by circles of radius ``wheel`` centred at
    centre(theta) (a convex pitch region): support of the pitch region minus the radius."""
    x, y = centre * np.cos(theta), centre * np.sin(theta)
    out = []
    for a in alpha:
        proj = x * math.cos(a) + y * math.sin(a)
        i = int(np.argmax(proj))
        # parabolic refinement of the max over the dense theta grid
        j = np.clip([i - 1, i, i + 1], 0, theta.size - 1)
        p = np.polyfit(theta[j] - theta[i], proj[j], 2)
        out.append(p[2] - p[1] ** 2 / (4 * p[0]) - wheel - r0)
    return np.array(out)


@pytest.mark.parametrize('d_r', [0.0, 0.002, -0.003])
def test_ground_lift_with_wheel_radius_error(d_r: float) -> None:
    from cam_design.follower import ground_lift, wheel_centre_lift

    wheel = 0.2
    law = DiscLift(FLAT)
    path = wheel_centre_lift(law, R0, FLAT, wheel)
    a = np.linspace(-math.pi, math.pi, 721)
    want_d = E * np.cos(a) + np.sqrt((RC + wheel) ** 2 - (E * np.sin(a)) ** 2)   # §5.5 check
    assert np.max(np.abs(path(a) + R0 + wheel - want_d)) < 1e-12
    ground = ground_lift(law, R0, FLAT, wheel, d_r)
    theta = np.linspace(-math.pi, math.pi, 200001)
    centre = E * np.cos(theta) + np.sqrt((RC + wheel) ** 2 - (E * np.sin(theta)) ** 2) + d_r
    alpha = np.linspace(-3.1, 3.1, 63)
    ref = brute_flat_lift_of_ground_cam(centre, theta, wheel + d_r, R0, alpha)
    assert np.max(np.abs(ground(alpha) - ref)) < 1e-11
    err = ground(alpha) - law(alpha)
    if d_r == 0.0:
        assert np.max(np.abs(err)) < 1e-12
    else:   # the error grows with |h'| (zero at the nose and on the base circle)
        assert abs(err[31]) < 1e-12 and np.max(np.abs(err)) > 1e-7
    with pytest.raises(InputError, match='wheel_error'):
        ground_lift(law, R0, FLAT, wheel, -wheel)


@pytest.mark.parametrize('vm', [None, 0.0015])
def test_round_trip_through_straight_flanks(vm: float | None) -> None:
    # flat design with flats -> roller (straight pitch segments) -> flat: the velocity
    # steps come back (plateau of the normal angle under the flat target)
    lobe = RampLobe(vm=vm)
    roller = Follower('roller', 0.01)
    back = convert_lift(convert_lift(lobe, 0.018, FLAT, roller), 0.018, roller, FLAT)
    a = np.linspace(-math.pi, math.pi, 7201)
    err = np.max(np.abs(back.derivatives(a) - lobe.derivatives(a)), axis=1)
    assert np.all(err < [1e-15, 1e-15, 1e-15, 1e-14])
    # exactly on a step: the one-sided limit from above, finite
    edge = back.derivatives(np.array([-1.4, 1.4]))
    assert np.all(np.isfinite(edge))
    assert edge[1] == pytest.approx([0.0015 if vm else 0.0005, -0.0005], abs=1e-12)


def test_stress_tiny_and_huge_geometry() -> None:
    from cam_design.follower import EccentricDiscLift

    a = np.linspace(math.pi, -math.pi, 3001)          # reversed order is fine
    for e, r in ((1e-9, 0.008), (0.005, 1.0), (0.005, 1e-9)):
        src = EccentricDiscLift(RC, e, FLAT)
        tgt = Follower('roller', r)
        got = convert_lift(src, RC - e, FLAT, tgt).derivatives(a)
        want = EccentricDiscLift(RC, e, tgt).derivatives(a)
        assert np.max(np.abs(got - want)) < 1e-14, (e, r)


def test_noisy_table_round_trip() -> None:
    rng = np.random.default_rng(7)
    a = np.linspace(-1.6, 1.6, 641)
    bump = np.cos(0.5 * math.pi * a / 1.6) ** 4
    h = 0.005 * bump + 1e-8 * bump * rng.standard_normal(a.size)   # 10 nm noise, tapered
    law = TabulatedLift(a, h)
    roller = Follower('roller', 0.004)
    back = convert_lift(convert_lift(law, 0.03, FLAT, roller), 0.03, roller, FLAT)
    x = np.linspace(-math.pi, math.pi, 2001)
    assert np.max(np.abs(back(x) - law(x))) < 1e-12


def test_continuity_order_reports_steps() -> None:
    lobe = RampLobe()                       # h' steps: continuity 0
    roller = Follower('roller', 0.01)
    there = convert_lift(lobe, 0.018, FLAT, roller)
    assert there.continuity_order == 1      # the roller's h' is continuous, h'' steps
    assert convert_lift(there, 0.018, roller, FLAT).continuity_order == 0
    assert convert_lift(smooth_bump(0.004, 1.5), 0.03, FLAT, roller).continuity_order == 3


@settings(max_examples=20, deadline=None)
@given(lift=st.floats(0.002, 0.006), half=st.floats(1.4, 2.6), r1=st.floats(0.0, 0.03),
       r2=st.floats(0.0, 0.03))
def test_conversions_compose(lift: float, half: float, r1: float, r2: float) -> None:
    # flat -> follower 1 -> follower 2 equals flat -> follower 2 (one cam, any path)
    def follower(r: float) -> Follower:
        return Follower('roller', r) if r > 0 else Follower('knife')

    r0 = 0.03
    law = smooth_bump(lift, half)
    f1, f2 = follower(r1), follower(r2)
    via = convert_lift(convert_lift(law, r0, FLAT, f1), r0, f1, f2)
    direct = convert_lift(law, r0, FLAT, f2)
    a = np.linspace(-math.pi, math.pi, 721)
    err = np.max(np.abs(via.derivatives(a) - direct.derivatives(a)), axis=1)
    assert np.all(err < [1e-15, 1e-15, 1e-14, 1e-12])      # m, m/rad, m/rad^2, m/rad^3


def roller_design_profile_points(law: LiftLaw, r0: float, r1: float) -> np.ndarray:
    """Profile of a roller design, independent of the library: inner offset of the pitch
    curve g u(s) by r1 (eq. 2.16), plus the concave arcs of radius r1 that the roller
    cuts around each pitch-curve corner (h' steps up at the support ends/junctions)."""
    s = np.linspace(-math.pi, math.pi, 40001)
    g, g1 = r0 + r1 + law(s), law(s, 1)
    w = np.hypot(g, g1)
    th = s + math.pi / 2
    pts = [np.stack([g * np.cos(th) - r1 * (g * np.cos(th) + g1 * np.sin(th)) / w,
                     g * np.sin(th) - r1 * (g * np.sin(th) - g1 * np.cos(th)) / w])]
    lo, hi = law.support
    for b in (lo, hi, *law.junctions):
        gb = r0 + r1 + float(law(np.array([b]))[0])
        t_l, t_r = law(np.array([b - 1e-12, b + 1e-12]), 1)
        psi = b + math.pi / 2 - np.linspace(np.arctan(t_l / gb), np.arctan(t_r / gb), 201)
        centre = gb * np.array([[math.cos(b + math.pi / 2)], [math.sin(b + math.pi / 2)]])
        pts.append(centre - r1 * np.stack([np.cos(psi), np.sin(psi)]))
    out = np.concatenate(pts, axis=1)
    return out[:, np.argsort(np.arctan2(out[1], out[0]))]   # ordered along the profile


@pytest.mark.parametrize('target', [Follower('knife'), Follower('roller', 0.004),
                                    Follower('roller', 0.01 - 1e-6)])
def test_roller_design_with_velocity_steps(target: Follower) -> None:
    from cam_design.cam_profile import lift_from_profile

    lobe = RampLobe(vm=0.0015)          # used as a roller design: h' steps up 4 times
    r0, r1 = 0.018, 0.01
    conv = convert_lift(lobe, r0, Follower('roller', r1), target)
    x, y = roller_design_profile_points(lobe, r0, r1)
    alpha = np.concatenate([np.linspace(-1.6, 1.6, 81), np.array(conv.junctions) + 1e-4])
    ref = lift_from_profile(x, y, alpha, target, r0)
    assert np.max(np.abs(conv(alpha) - ref)) < 1e-9
    assert conv.continuity_order == 1 and len(conv.junctions) == 8


@pytest.mark.parametrize('target', [FLAT, Follower('roller', 0.012)])
def test_roller_design_steps_bridged(target: Follower) -> None:
    # a flat face or a larger roller bridges the concave arcs at the h' steps
    from cam_design.cam_profile import lift_from_profile

    lobe = RampLobe(vm=0.0015)
    r0, r1 = 0.018, 0.01
    conv = convert_lift(lobe, r0, Follower('roller', r1), target)
    x, y = roller_design_profile_points(lobe, r0, r1)
    alpha = np.linspace(-1.6, 1.6, 161)
    assert np.max(np.abs(conv(alpha) - lift_from_profile(x, y, alpha, target, r0))) < 1e-9
