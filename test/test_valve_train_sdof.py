"""SDOF valve-train model: methods.md §7 cases 18-20, 22, limits, reference, edges."""
from __future__ import annotations

import math

import numpy as np
import pytest

from cam_design.errors import InputError
from cam_design.valve_train import SdofParams, simulate
from cam_design.valve_train.examples import (DEG, PiecewisePolynomialLaw,
                                             acceleration_step_law, ramp_polydyne_law,
                                             smoothstep, smoothstep_polydyne_law,
                                             symmetric_law)
from cam_design.valve_train.reference import reference_solve
from cam_design.valve_train.sdof import CONTACT, SEAT

BASE = dict(mass=0.12, stiffness=1.2e7, damping=60.0, spring_rate=3.0e4,
            spring_preload=250.0, rocker_ratio=1.5, lash=0.25e-3)
MM_DEG = 1e-3 / DEG


def ramp_law(poly_nose: bool = True) -> PiecewisePolynomialLaw:
    """§1.1(b) ramp (H1 = 0.3 mm, v1 = 0.015 mm/deg, alpha1 = 30 deg, methods #8) and
    the §1.4 2-6-10-14 base section (H = 8 mm, alpha0 = 50 deg), built from the
    closed forms of methods.md (independent of cam_design.lift_laws)."""
    h1, v1, a1 = 0.3e-3, 0.015 * MM_DEG, 30 * DEG
    e0 = h1 - v1 * a1
    beta1 = -2 * e0 / v1
    cb = v1 ** 2 / (4 * (v1 * a1 - h1))
    start = -80 * DEG
    from numpy.polynomial import Polynomial as P
    s = P([-start, 1.0])                      # angle from the ramp start
    pieces = [(start, start + beta1, cb * s ** 2),
              (start + beta1, start + a1, e0 + v1 * s)]
    if poly_nose:
        half = 50 * DEG
        x = P([0.0, -1.0 / half])             # 1 at the ramp end, 0 at the nose
        c = {2: -17.001953125e-3, 6: 16.544921875e-3, 10: -9.896484375e-3,
             14: 2.353515625e-3}
        base = h1 + 8e-3 + sum(ci * x ** i for i, ci in c.items())
        pieces.append((start + a1, 0.0, base))
    return symmetric_law(pieces)


@pytest.fixture(scope='module')
def law() -> PiecewisePolynomialLaw:
    return ramp_law()


def test_ramp_law_matches_methods_example(law: PiecewisePolynomialLaw) -> None:
    assert law(0.0) == pytest.approx(8.3e-3, abs=1e-12)
    assert law(-50 * DEG, 1) == pytest.approx(0.015 * MM_DEG, rel=1e-9)
    assert law(0.0, 2) == pytest.approx(-44.6513e-3, rel=1e-5)


def test_case18_opening_angle_hard_seat(law: PiecewisePolynomialLaw) -> None:
    """kh = x0 + F0/c on the ramp: 22.03704 deg after the ramp start (case 18)."""
    p = SdofParams(**{**BASE, 'damping': 0.0}, restitution=0.0)
    res = simulate(law, p, 1500.0, step_deg=0.5)
    opening = math.degrees(res.events.opening) + 80.0
    h_open = (0.25e-3 + 250.0 / 1.2e7) / 1.5
    assert h_open == pytest.approx(0.180556e-3, abs=1e-9)
    assert opening == pytest.approx(22.03704, abs=1e-5)


def test_case18_seating_velocity(law: PiecewisePolynomialLaw) -> None:
    """Rigid seating speed k v_r omega = 0.2025 m/s at 1500 rpm; the dynamic seating
    velocity on the constant-velocity ramp is within the opening transient of it."""
    omega = 1500 * 2 * math.pi / 60
    assert 1.5 * 0.015 * MM_DEG * omega == pytest.approx(0.2025, abs=1e-5)
    p = SdofParams(**BASE, restitution=0.0)
    res = simulate(law, p, 1500.0, step_deg=0.5)
    closing = res.events.closing
    assert 1.5 * law(closing, 1) * -omega == pytest.approx(0.2025, abs=1e-5)
    # transient bound sqrt(eps) * k v_r (methods §4.3) in velocity: omega * that
    eps = 0.12 * omega ** 2 / (1.2e7 + 3e4)
    assert abs(res.events.seating_velocity - 0.2025) < 0.2025 * 2 * math.sqrt(eps) * 10
    assert res.events.separations == []


def test_case19_acceleration_step_amplitude() -> None:
    """eps y'' + y = q with q = (D/2)(alpha - a*)^2: y - q = -eps D (1 - cos)."""
    p = SdofParams(**{**BASE, 'damping': 0.0}, restitution=0.0)
    eps = 2.5e-4
    omega = math.sqrt(eps * (p.stiffness + p.spring_rate) / p.mass)
    rpm = omega * 60 / (2 * math.pi)
    law, a_star = acceleration_step_law(p, rpm, accel=0.01)
    res = simulate(law, p, rpm, step_deg=0.1)
    sel = (res.alpha > a_star) & (res.alpha < a_star + 30 * DEG)
    a = res.alpha[sel]
    u = 1.5 * law(a) - p.lash
    q = (p.stiffness * u - p.spring_preload) / (p.stiffness + p.spring_rate)
    dev = res.y[sel] - q
    exact = -eps * 0.01 * (1 - np.cos((a - a_star) / math.sqrt(eps)))
    assert np.max(np.abs(dev - exact)) < 1e-12
    amplitude = (np.max(dev) - np.min(dev)) / 2
    assert amplitude == pytest.approx(2.5e-6, rel=0.01)


def test_case20_polydyne_inversion_exact() -> None:
    p = SdofParams(**{**BASE, 'damping': 0.0}, restitution=0.0)
    law, yd = smoothstep_polydyne_law(p, 1500.0)
    res = simulate(law, p, 1500.0, step_deg=0.25)
    sel = (res.alpha >= -60 * DEG) & (res.alpha <= 0.0)
    err = np.abs(res.y[sel] - yd(res.alpha[sel]))
    assert np.max(err) < 1e-12
    # tangential (quartic) approach of the opening level: the angle is ill-conditioned
    assert math.degrees(res.events.opening) == pytest.approx(-60.0, abs=0.1)


def test_case20_infeasible_at_3000_separates() -> None:
    """At 3000 rpm the same y_d needs c delta < 0: the valve separates."""
    p = SdofParams(**{**BASE, 'damping': 0.0}, restitution=0.0)
    law, _ = smoothstep_polydyne_law(p, 3000.0)
    res = simulate(law, p, 3000.0, step_deg=0.25)
    assert res.events.separations


def test_case22_polydyne_with_ramp_transient() -> None:
    p = SdofParams(**{**BASE, 'damping': 0.0}, restitution=0.0)
    law, yd = ramp_polydyne_law(p, 1500.0)
    res = simulate(law, p, 1500.0, step_deg=0.1)
    sel = (res.alpha >= -50 * DEG) & (res.alpha <= 0.0)
    dev = np.max(np.abs(res.y[sel] - yd(res.alpha[sel])))
    omega = 1500 * 2 * math.pi / 60
    eps_c = p.mass * omega ** 2 / p.stiffness
    predicted = math.sqrt(eps_c) * 1.5 * 0.015 * MM_DEG / (1 + p.spring_rate / p.stiffness)
    assert predicted == pytest.approx(2.02e-5, rel=2e-3)
    assert dev == pytest.approx(2.02e-5, rel=0.02)


def test_quasi_static_limit(law: PiecewisePolynomialLaw) -> None:
    p = SdofParams(**BASE)
    res = simulate(law, p, 5.0, step_deg=0.5)
    h = law(res.alpha)
    yqs = np.maximum(0.0, (p.stiffness * (1.5 * h - p.lash) - p.spring_preload)
                     / (p.stiffness + p.spring_rate))
    assert np.max(np.abs(np.maximum(res.y, 0.0) - yqs)) < 1e-9
    assert res.events.separations == [] and res.events.bounce_count == 0


def test_energy_balance_without_damping(law: PiecewisePolynomialLaw) -> None:
    """With b_t = b_v = b_s = 0, E(end) - E(start) = int F_t du (work of the cam)."""
    p = SdofParams(**{**BASE, 'damping': 0.0}, seat_damping=0.0)
    res = simulate(law, p, 1500.0, step_deg=0.01, max_revolutions=1)
    y, v, u = res.y, res.v, res.u
    delta = u - y
    energy = (0.5 * p.mass * v ** 2 + p.spring_preload * y + 0.5 * p.spring_rate * y ** 2
              + np.where(res.regime & CONTACT, 0.5 * p.stiffness * delta ** 2, 0.0)
              + np.where(res.regime & SEAT, 0.5 * p.seat_stiffness * y ** 2, 0.0))
    du = np.diff(u)
    work = np.sum(0.5 * (res.force[1:] + res.force[:-1]) * du)
    top = 0.5 * p.stiffness * np.max(delta) ** 2
    assert energy[-1] - energy[0] == pytest.approx(work, abs=1e-4 * top)


def test_against_radau_open_phase(law: PiecewisePolynomialLaw) -> None:
    """Same equations with scipy Radau rtol 1e-12 (contact phase, from our state at
    -50 deg): agreement to 1e-6 of the maximum lift (we get ~1e-12)."""
    p = SdofParams(**BASE)
    res = simulate(law, p, 3000.0, step_deg=0.1)
    i0 = int(np.argmin(np.abs(res.alpha + 50 * DEG)))
    sel = slice(i0, i0 + 601)
    a = res.alpha[sel]
    ref = reference_solve(law, p, 3000.0, a, rtol=1e-12, atol=1e-15,
                          z0=(res.y[i0], res.v[i0]), r0=int(res.regime[i0]))
    err = np.max(np.abs(ref.y - res.y[sel]))
    assert err < 1e-6 * np.max(res.y)
    assert err < 1e-11


def test_against_radau_seating(law: PiecewisePolynomialLaw) -> None:
    """Seating with the stiff penalty seat and bounces, against Radau."""
    p = SdofParams(**BASE)
    res = simulate(law, p, 1500.0, step_deg=0.1)
    i0 = int(np.argmin(np.abs(res.alpha - 55 * DEG)))
    sel = slice(i0, i0 + 51)
    ref = reference_solve(law, p, 1500.0, res.alpha[sel], rtol=1e-10, atol=1e-14,
                          z0=(res.y[i0], res.v[i0]), r0=int(res.regime[i0]))
    assert np.max(np.abs(ref.y - res.y[sel])) < 1e-6 * np.max(res.y)


EDGES = [{'seat_stiffness': 1e11}, {'lash': 0.0}, {'spring_preload': 0.0},
         {'seat_stiffness': 1e11, 'lash': 0.0}, {'stiffness': 1e10}, {'restitution': 0.5}]
UNDAMPED = [{'damping': 0.0, 'seat_damping': 0.0}, {'restitution': 1.0, 'damping': 0.0}]


@pytest.mark.parametrize('changes, rpm', [(c, r) for c in EDGES for r in (50.0, 1500.0, 12000.0)]
                         + [(c, 1500.0) for c in UNDAMPED])
def test_stiff_edges_finite(law: PiecewisePolynomialLaw, changes: dict, rpm: float) -> None:
    """Seat 1e11 N/m, zero lash, zero preload, stiff train, hard seats, 50..12000 rpm:
    finite results, an opening, and no spurious lift at moderate speed."""
    p = SdofParams(**{**BASE, **changes})
    res = simulate(law, p, rpm, step_deg=0.5, max_revolutions=2)
    assert np.all(np.isfinite(res.y)) and np.all(np.isfinite(res.force))
    assert np.all(res.force >= 0)
    if rpm <= 1500:
        # with zero preload (or an elastic seat and no damping) nothing stops the
        # bouncing valve: there is no stable periodic state, the run says so, and its
        # last revolution starts in the air (already open: no opening inside it)
        assert res.events.opening is not None or (
            not res.settled and res.y[0] > 0 and changes in (
                {'spring_preload': 0.0}, {'restitution': 1.0, 'damping': 0.0}))
        assert np.max(res.y) < 1.5 * law(0.0)


@pytest.mark.parametrize('name, value', [
    ('mass', 0.0), ('mass', -1.0), ('stiffness', float('nan')), ('damping', -1.0),
    ('rocker_ratio', 0.0), ('lash', -1e-4), ('spring_rate', -1.0),
    ('seat_stiffness', 0.0), ('restitution', 1.5), ('spring_preload', float('inf')),
])
def test_invalid_parameters_named(name: str, value: float) -> None:
    with pytest.raises(InputError) as info:
        SdofParams(**{**BASE, name: value})
    label = {'seat_stiffness': 'seat.stiffness', 'restitution': 'seat.restitution'}
    assert f'valve_train.{label.get(name, name)}' in str(info.value)


def test_no_restoring_force_rejected() -> None:
    with pytest.raises(InputError, match='valve_train.spring_rate'):
        SdofParams(**{**BASE, 'spring_rate': 0.0, 'spring_preload': 0.0})


def test_bad_speed_and_step(law: PiecewisePolynomialLaw) -> None:
    p = SdofParams(**BASE)
    with pytest.raises(InputError, match='cam_speed_rpm'):
        simulate(law, p, 0.0)
    with pytest.raises(InputError, match='step'):
        simulate(law, p, 1500.0, step_deg=-0.1)


def test_smoothstep_helper() -> None:
    s = smoothstep(0.0, 1.0, 0.0, 2.0)
    assert s(1.0) == pytest.approx(2.0) and s.deriv(3)(1.0) == pytest.approx(0.0, abs=1e-9)


def test_hard_seat_against_radau(law: PiecewisePolynomialLaw) -> None:
    """Hard seat with restitution 0.5: impacts, rebounds and the held valve against the
    reference (Radau with the same impact law) over the closing."""
    p = SdofParams(**BASE, restitution=0.5)
    res = simulate(law, p, 2000.0, step_deg=0.1)
    i0 = int(np.argmin(np.abs(res.alpha - 50 * DEG)))
    sel = slice(i0, i0 + 151)
    ref = reference_solve(law, p, 2000.0, res.alpha[sel], rtol=1e-10, atol=1e-14,
                          z0=(res.y[i0], res.v[i0]), r0=int(res.regime[i0]))
    assert len(res.events.impacts) >= 2
    assert np.max(np.abs(ref.y - res.y[sel])) < 1e-6 * np.max(res.y)


def test_case22_with_lift_law_polydyne() -> None:
    """The lift-law registry's polydyne (from_spec) is the same cam as ours (1e-15 m)
    and gives the case-22 transient through the solver."""
    from cam_design.lift_laws.registry import from_spec

    p = SdofParams(**{**BASE, 'damping': 0.0}, restitution=0.0)
    spec = {'family': 'polydyne', 'rocker_ratio': 1.5, 'lash': 0.25e-3, 'mass': 0.12,
            'stiffness': 1.2e7, 'spring_rate': 3e4, 'spring_preload': 250.0,
            'design_cam_speed_rpm': 1500.0, 'valve_lift': 8e-3, 'half_angle': 50 * DEG,
            'ramp_velocity': 0.015 * MM_DEG}
    try:
        law = from_spec(spec, 'lift_law')
    except InputError as exc:
        pytest.skip(f'polydyne family not available: {exc}')
    mine, yd = ramp_polydyne_law(p, 1500.0)
    a = np.linspace(-60 * DEG, 60 * DEG, 1201)
    assert np.max(np.abs(law(a) - mine(a))) < 1e-15
    res = simulate(law, p, 1500.0, step_deg=0.1)
    sel = (res.alpha >= -50 * DEG) & (res.alpha <= 0.0)
    assert np.max(np.abs(res.y[sel] - yd(res.alpha[sel]))) == pytest.approx(2.02e-5, rel=0.02)


def test_case18_with_lift_law_preset() -> None:
    """Case 18 on the registry's methods_example lobe (the §1.1 ramp of #8)."""
    from cam_design.lift_laws.registry import from_spec

    try:
        law = from_spec({'family': 'preset', 'name': 'methods_example'}, 'lift_law')
    except InputError as exc:
        pytest.skip(f'preset not available: {exc}')
    p = SdofParams(**{**BASE, 'damping': 0.0}, restitution=0.0)
    res = simulate(law, p, 1500.0, step_deg=0.5)
    assert math.degrees(res.events.opening - law.support[0]) == pytest.approx(22.03704,
                                                                              abs=1e-5)


def test_jet_table_edges() -> None:
    """Tables of h..h''': exact at nodes, reversed / NaN / flat tables rejected, a
    noisy table still gives a finite motion."""
    from cam_design.lift_laws.jet_table import JetTableLift

    law = ramp_law()
    a = np.linspace(-math.pi, math.pi, 3601)
    jets = law.derivatives(a)
    tab = JetTableLift(a, jets)
    lo, hi = tab.support
    inner = (a > lo) & (a < hi)
    assert np.max(np.abs(tab(a[inner]) - jets[0, inner])) < 1e-15
    assert np.max(jets[0, ~inner]) <= 1e-3 * np.max(jets[0])      # trimmed base circle
    with pytest.raises(InputError, match='alpha_rad'):
        JetTableLift(a[::-1], jets[:, ::-1])
    bad = jets.copy()
    bad[2, 50] = np.nan
    with pytest.raises(InputError, match='non-finite'):
        JetTableLift(a, bad)
    with pytest.raises(InputError, match='lift_m'):
        JetTableLift(a, np.zeros_like(jets))
    rng = np.random.default_rng(1)
    noisy = jets + rng.normal(0, 1e-7, jets.shape) * np.array([[1], [10], [100], [1000]])
    res = simulate(JetTableLift(a, noisy), SdofParams(**BASE), 1500.0, step_deg=0.5)
    assert np.all(np.isfinite(res.y)) and res.events.opening is not None


def test_lobe_wider_than_revolution_rejected() -> None:
    from numpy.polynomial import Polynomial as P
    wide = PiecewisePolynomialLaw([-3.2, 3.2], [P([1e-3])])
    with pytest.raises(InputError, match=r'^lift: .*at most one revolution'):
        simulate(wide, SdofParams(**BASE), 1500.0)
