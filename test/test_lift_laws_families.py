"""Lift-law families beyond the polynomial: constant acceleration (§1.2), composite
(§1.3), polydyne (§1.5), N-harmonic (§1.6), dual-peak EGR (§1.7); stress cases."""
from __future__ import annotations

import math

import numpy as np
import pytest

from cam_design.errors import InputError
from cam_design.lift_laws import PRESETS, from_spec
from cam_design.lift_laws.composite import constant_acceleration_amplitudes
from cam_design.lift_laws.dual_peak import connection_coefficients

DEG = math.pi / 180
MM = 1e-3
V = 0.015 * MM / DEG
CV_RAMP = {'kind': 'constant_velocity', 'height': 0.3 * MM, 'velocity': V}
S2_RAMP = {'kind': 'constant_acceleration_velocity', 'height': 0.3 * MM, 'velocity': V,
           'angle': 30 * DEG}
TRAIN = {'rocker_ratio': 1.5, 'lash': 0.25 * MM, 'mass': 0.12, 'stiffness': 1.2e7,
         'spring_rate': 3e4, 'spring_preload': 250.0, 'design_cam_speed_rpm': 1500}
Y7 = [[4, 35 * 8 * MM], [5, -84 * 8 * MM], [6, 70 * 8 * MM], [7, -20 * 8 * MM]]


# ------------------------------------------------------------- constant acceleration
def test_constant_acceleration_case_12() -> None:
    """#12: v0 = 0.015 mm/deg, alpha0 = 50 deg, H = 8 mm, phi1 = 15 deg:
    a1 = 0.0200333, a2 = -0.00901429 mm/deg^2 (closed form and the law)."""
    a1, a2 = constant_acceleration_amplitudes(V, 50 * DEG, 8 * MM, 15 * DEG)
    to = DEG ** 2 / MM
    assert a1 * to == pytest.approx(0.0200333, abs=1e-7)
    assert a2 * to == pytest.approx(-0.00901429, abs=1e-7)
    law = from_spec({'family': 'constant_acceleration', 'ramp': CV_RAMP, 'rise': 8 * MM,
                     'half_angle': 50 * DEG, 'positive_width': 15 * DEG}, 'L')
    assert law(-40 * DEG, 2) == pytest.approx(a1, rel=1e-12)
    assert law(-10 * DEG, 2) == pytest.approx(a2, rel=1e-12)
    assert law(0.0) == pytest.approx(8.3 * MM, rel=1e-14)
    assert abs(law(0.0, 1)) < 1e-15
    assert law.continuity_order == 0          # CV ramp; h'' jumps are allowed (order 1)
    assert [j.achieved for j in law.junction_report] == [0, 1, 1, 3, 1, 1, 0]


def test_constant_acceleration_three_segments() -> None:
    """3-segment variant: a3 = r a2 at the nose, h'(nose) = 0, h(nose) = H_r + H."""
    law = from_spec({'family': 'constant_acceleration', 'ramp': CV_RAMP, 'rise': 8 * MM,
                     'half_angle': 50 * DEG, 'positive_width': 15 * DEG,
                     'nose_width': 15 * DEG, 'nose_ratio': 0.5}, 'L')
    a2, a3 = law(-25 * DEG, 2), law(-5 * DEG, 2)
    assert a3 == pytest.approx(0.5 * a2, rel=1e-12)
    assert law(0.0) == pytest.approx(8.3 * MM, rel=1e-13)
    assert law.flank_is_monotone()
    with pytest.raises(InputError, match='L.nose_ratio'):
        from_spec({'family': 'constant_acceleration', 'ramp': CV_RAMP, 'rise': 8 * MM,
                   'half_angle': 50 * DEG, 'positive_width': 15 * DEG,
                   'nose_width': 15 * DEG, 'nose_ratio': 1.5}, 'L')
    with pytest.raises(InputError, match='L.positive_width'):
        from_spec({'family': 'constant_acceleration', 'ramp': CV_RAMP, 'rise': 8 * MM,
                   'half_angle': 50 * DEG, 'positive_width': 55 * DEG}, 'L')


# ------------------------------------------------------------- composite engine
def test_composite_half_sine_quarter_sine_is_c2() -> None:
    """half-sine (positive) + quarter-sine (negative, max at the nose) on an S2 ramp:
    C2 everywhere inside (h'' = 0 at the ramp end and the inner junction)."""
    law = from_spec({'family': 'composite', 'ramp': S2_RAMP, 'rise': 8 * MM,
                     'segments': [{'shape': 'half_sine', 'width': 15 * DEG},
                                  {'shape': 'quarter_sine', 'width': 35 * DEG}]}, 'L')
    rep = law.junction_report
    assert [j.achieved for j in rep][2:-2] == [2, 2, 3, 2, 2]
    assert law(0.0) == pytest.approx(8.3 * MM, rel=1e-13)
    assert law(-42.5 * DEG, 2) > 0 > law(-10 * DEG, 2)
    assert law.flank_is_monotone()


def test_composite_matches_constant_acceleration() -> None:
    """Two constant shapes with continuity 1 reproduce the §1.2 closed form."""
    law = from_spec({'family': 'composite', 'ramp': CV_RAMP, 'rise': 8 * MM,
                     'continuity': 1,
                     'segments': [{'shape': 'constant', 'width': 15 * DEG},
                                  {'shape': 'constant', 'width': 35 * DEG}]}, 'L')
    a1, a2 = constant_acceleration_amplitudes(V, 50 * DEG, 8 * MM, 15 * DEG)
    assert law(-40 * DEG, 2) == pytest.approx(a1, rel=1e-12)
    assert law(-10 * DEG, 2) == pytest.approx(a2, rel=1e-12)


def test_composite_polynomial_shape_and_modified() -> None:
    """Polynomial shape s(u) = 1 - u^2 after a half-sine; 'modified' (C3) is rejected
    when over-determined, with the key of the segment list."""
    law = from_spec({'family': 'composite', 'ramp': S2_RAMP, 'rise': 8 * MM, 'continuity': 1,
                     'segments': [{'shape': 'half_sine', 'width': 15 * DEG},
                                  {'shape': 'polynomial', 'coefficients': [-1, 0, 1],
                                   'width': 35 * DEG}]}, 'L')
    assert law(0.0) == pytest.approx(8.3 * MM, rel=1e-13)
    with pytest.raises(InputError, match=r'^L\.segments'):
        from_spec({'family': 'composite', 'ramp': S2_RAMP, 'rise': 8 * MM, 'continuity': 3,
                   'segments': [{'shape': 'half_sine', 'width': 15 * DEG},
                                {'shape': 'quarter_cosine', 'width': 35 * DEG}]}, 'L')
    with pytest.raises(InputError, match=r'^L\.segments\[1\]\.shape'):
        from_spec({'family': 'composite', 'ramp': S2_RAMP, 'rise': 8 * MM,
                   'segments': [{'shape': 'half_sine', 'width': 0.2},
                                {'shape': 'FB2', 'width': 0.5}]}, 'L')


# ------------------------------------------------------------- polydyne
def _yd(u: np.ndarray, nu: int) -> np.ndarray:
    """8 mm (35u^4 - 84u^5 + 70u^6 - 20u^7) and its u-derivatives (numpy polynomial)."""
    p = np.polynomial.Polynomial([0, 0, 0, 0, 35, -84, 70, -20]) * 8 * MM
    return p.deriv(nu)(u) if nu else p(u)


def test_polydyne_inversion_identity() -> None:
    """§1.5 / #20 precondition: k h = x0 + F0/c + (1 + c'/c) y_d + eps_c y_d'' exactly.

    Erratum 7: S0 prints eps = M omega^3 / c (units 1/s); the dimensionless
    eps_c = M omega^2 / c (alpha in rad) is used: 2.467401e-4 at 1500 rpm cam."""
    law = from_spec(dict(TRAIN, family='polydyne',
                         valve_motion={'angle': 60 * DEG, 'coefficients': Y7}), 'L')
    w = 2 * math.pi * 1500 / 60
    eps = 0.12 * w * w / 1.2e7
    assert eps == pytest.approx(2.467401e-4, rel=1e-6)
    a = np.linspace(-60 * DEG, 0.0, 2001)[:-1]    # the nose itself belongs to the fall flank
    u = (a + 60 * DEG) / (60 * DEG)
    rhs = 0.25 * MM + 250 / 1.2e7 + (1 + 3e4 / 1.2e7) * _yd(u, 0) \
        + eps * _yd(u, 2) / (60 * DEG) ** 2
    assert np.max(np.abs(1.5 * law(a) - rhs)) < 1e-15
    assert np.allclose(law(-a), law(a), rtol=0, atol=1e-18)
    for nu in (1, 2, 3):   # derivatives of the identity
        rhs_n = ((1 + 3e4 / 1.2e7) * _yd(u, nu) + eps * _yd(u, nu + 2) / (60 * DEG) ** 2) \
            / (60 * DEG) ** nu
        assert np.max(np.abs(1.5 * law(a, nu) - rhs_n)) < 1e-12 * np.max(np.abs(rhs_n))


def test_polydyne_infeasible_at_3000_rpm() -> None:
    """§1.5: at 3000 rpm cam the same y_d needs c*delta < 0 on the deceleration:
    flagged before any profile is produced, naming the design speed."""
    with pytest.raises(InputError) as info:
        from_spec(dict(TRAIN, family='polydyne', design_cam_speed_rpm=3000,
                       valve_motion={'angle': 60 * DEG, 'coefficients': Y7}), 'L')
    assert info.value.key == 'L.design_cam_speed_rpm'
    assert 'infeasible' in str(info.value)
    # the magnitudes quoted in methods §1.5: F0/c = 2.1e-5 m against eps y_d'' = -5.4e-5 m
    w = 2 * math.pi * 3000 / 60
    u = np.linspace(0, 1, 100001)
    worst = 0.12 * w * w / 1.2e7 * np.min(_yd(u, 2)) / (60 * DEG) ** 2
    assert 250 / 1.2e7 == pytest.approx(2.1e-5, rel=0.01)
    assert worst == pytest.approx(-5.4e-5, rel=0.02)


def test_polydyne_practical_ramp_junction() -> None:
    """Practical form: CV ramp of height (x0 + F0/c)/k = 0.180556 mm (12.03704 deg at
    0.015 mm/deg), C2 at the ramp end, min c*delta/c = F0/c = 2.083e-5 m."""
    from cam_design.lift_laws.polydyne import contact_margin

    law = from_spec(dict(TRAIN, family='polydyne', valve_lift=8 * MM, half_angle=50 * DEG,
                         ramp_velocity=V), 'L')
    ramp_deg = math.degrees(law.support[1]) - 50
    assert ramp_deg == pytest.approx(12.03704, abs=1e-5)
    assert law(law.support[0] + (12.03704 * DEG)) == pytest.approx(0.180556 * MM, rel=1e-5)
    rep = law.junction_report
    assert [j.achieved for j in rep] == [0, 2, 3, 2, 0]
    seg = law.valve_motion[0]
    a = np.linspace(seg.lo, seg.hi, 20001)
    assert contact_margin(seg, law.train, a).min() == pytest.approx(2.0833e-5, rel=1e-4)
    assert law.flank_is_monotone()
    y = seg(a)
    assert y[0] == pytest.approx(0.0, abs=1e-17) and y[-1] == pytest.approx(8 * MM)
    assert seg(a[0], 1) == pytest.approx(1.5 * V / (1 + 3e4 / 1.2e7), rel=1e-12)


# ------------------------------------------------------------- harmonic
@pytest.mark.parametrize('order,end_order', [(3, 2), (6, 2), (10, 4), (40, 4)])
def test_harmonic_constraints(order: int, end_order: int) -> None:
    """h(+-Phi) = h'' = 0 (and h'''' with end_order 4), h(0) = max_lift, C3."""
    law = from_spec({'family': 'harmonic', 'order': order, 'half_angle': 80 * DEG,
                     'max_lift': 8.3 * MM, 'end_order': end_order}, 'L')
    a = law.amplitudes
    j = np.arange(order + 1)
    assert law(0.0) == pytest.approx(8.3 * MM, rel=1e-13)
    for m in ((0, 2, 4) if end_order == 4 else (0, 2)):
        terms = a * (-1.0) ** j * j ** m
        assert abs(np.sum(terms)) < 1e-13 * np.sum(np.abs(terms))
    assert law.continuity_order == 3


def test_harmonic_least_squares_target() -> None:
    """Fit of the free coefficients to the §1.4 cam (§5.2 option B): N = 15 gets within
    0.005 mm with the end and nose constraints."""
    law = from_spec({'family': 'harmonic', 'order': 15, 'half_angle': 80 * DEG,
                     'max_lift': 8.3 * MM, 'target': PRESETS['methods_example']}, 'L')
    tgt = from_spec(PRESETS['methods_example'], 't')
    a = np.linspace(-80 * DEG, 80 * DEG, 1001)
    assert np.max(np.abs(law(a) - tgt(a))) < 5e-3 * MM


# ------------------------------------------------------------- dual peak
def test_connection_case_11() -> None:
    """#11: A0..A6 (patent signs A_k = (-1)^k B_k), in mm and degrees."""
    b = connection_coefficients(0.225, -0.015, 0.0, 0.25, 0.0125, 40.0, 20.0, 0.10)
    a = b * (-1.0) ** np.arange(7)
    expected = [0.225, 0.015, 0.0, -6.328125e-5, -3.232421875e-6, -6.884765625e-8,
                -5.37109375e-10]
    for got, want in zip(a, expected):
        assert got == pytest.approx(want, rel=1e-12, abs=1e-15)


def test_connection_conditioning_limit() -> None:
    """In u = s/alpha4 the solve is unit-independent: the same connection in rad/m
    (raw cond ~1e13) and in deg/mm gives the same curve to 1e-12 relative."""
    b_deg = connection_coefficients(0.225, -0.015, 0.0, 0.25, 0.0125, 40.0, 20.0, 0.10)
    b_si = connection_coefficients(0.225 * MM, -0.015 * MM / DEG, 0.0, 0.25 * MM,
                                   0.0125 * MM / DEG, 40 * DEG, 20 * DEG, 0.10 * MM)
    s = np.linspace(0, 40, 101)
    h_deg = np.polynomial.polynomial.polyval(s, b_deg)
    h_si = np.polynomial.polynomial.polyval(s * DEG, b_si) / MM
    assert np.allclose(h_deg, h_si, rtol=1e-12, atol=1e-15)
    # methods §1.7: cond ~1.4e4 in u = s/alpha4 against ~4e9 in raw degrees
    from cam_design.lift_laws.dual_peak import connection_matrix

    assert np.linalg.cond(connection_matrix(40.0, 20.0, 40.0)) == pytest.approx(1.4e4, rel=0.02)
    assert np.linalg.cond(connection_matrix(40.0, 20.0, 1.0)) == pytest.approx(4.1e9, rel=0.03)
    # the scaled matrix does not depend on the units: the same for alpha4 = 0.698 rad
    assert np.allclose(connection_matrix(40 * DEG, 20 * DEG, 40 * DEG),
                       connection_matrix(40.0, 20.0, 40.0), rtol=1e-13, atol=0)
    # a very short connection (alpha4 = 0.5 deg) still satisfies its end conditions
    b = connection_coefficients(0.225, -0.015, 0.0, 0.25, 0.0125, 0.5, 0.25, 0.2)
    p = np.polynomial.Polynomial(b)
    assert p(0.5) == pytest.approx(0.25, rel=1e-9)
    assert p.deriv()(0.5) == pytest.approx(0.0125, rel=1e-6)


DUAL = {'family': 'dual_peak', 'ramp': S2_RAMP, 'rise': 8 * MM, 'half_angle': 50 * DEG,
        'connection': {'start': 5 * DEG, 'angle': 40 * DEG, 'point_angle': 20 * DEG,
                       'point_lift': 0.1 * MM},
        'secondary': {'rise': 1.5 * MM, 'half_angle': 20 * DEG,
                      'ramp': {'height': 0.25 * MM, 'velocity': 0.0125 * MM / DEG,
                               'angle': 30 * DEG}}}


def test_dual_peak_lobe() -> None:
    """The §1.7 example as a whole lobe: min h4 = 0.095519 mm at 16.25 deg into the
    connection, C2 at both connection ends, secondary nose at H6 + H5."""
    law = from_spec(DUAL, 'L')
    assert np.degrees(law.support) == pytest.approx([-80, 165])
    a = np.linspace(55 * DEG, 95 * DEG, 16001)
    h = law(a)
    assert h.min() / MM == pytest.approx(0.095519, abs=1e-6)
    assert math.degrees(a[np.argmin(h)]) - 55 == pytest.approx(16.25, abs=0.01)
    assert law(115 * DEG) == pytest.approx(1.75 * MM, rel=1e-13)
    orders = {round(math.degrees(j.alpha)): j.achieved for j in law.junction_report}
    assert orders[55] >= 2 and orders[95] >= 2 and orders[135] == 3
    assert law(0.0) == pytest.approx(8.3 * MM)


def test_dual_peak_rejections() -> None:
    """v5 != v6, a negative connection, and a start off the ramp are rejected."""
    bad = dict(DUAL, secondary=dict(DUAL['secondary'], velocity=0.013 * MM / DEG))
    with pytest.raises(InputError, match=r'^L\.secondary\.velocity'):
        from_spec(bad, 'L')
    bad = dict(DUAL, connection=dict(DUAL['connection'], point_lift=0.001 * MM))
    with pytest.raises(InputError, match=r'^L\.connection\.point_lift'):
        from_spec(bad, 'L')
    bad = dict(DUAL, connection=dict(DUAL['connection'], start=31 * DEG))
    with pytest.raises(InputError, match=r'^L\.connection\.start'):
        from_spec(bad, 'L')


# ------------------------------------------------------------- invalid parameters
@pytest.mark.parametrize('spec,key', [
    (dict(TRAIN, family='polydyne', valve_lift=8e-3, half_angle=0.9, mass=-1), 'L.mass'),
    (dict(TRAIN, family='polydyne', valve_lift=8e-3, half_angle=0.9,
          exponents=[2, 6, 10, 14]), 'L.exponents'),
    (dict(TRAIN, family='polydyne', half_angle=0.9), 'L.valve_lift'),
    ({'family': 'harmonic', 'order': 1, 'half_angle': 1.0, 'max_lift': 8e-3}, 'L.order'),
    ({'family': 'harmonic', 'order': 5, 'half_angle': 4.0, 'max_lift': 8e-3},
     'L.half_angle'),
    ({'family': 'harmonic', 'order': 5, 'half_angle': 1.0, 'max_lift': 8e-3,
      'end_order': 3}, 'L.end_order'),
    ({'family': 'constant_acceleration', 'ramp': CV_RAMP, 'rise': 8e-3,
      'positive_width': 0.2}, 'L.half_angle'),
    ({'family': 'composite', 'ramp': CV_RAMP, 'rise': 8e-3, 'segments': 'x'},
     'L.segments'),
    ({'family': 'dual_peak', 'ramp': S2_RAMP, 'rise': 8e-3, 'half_angle': 0.9},
     'L.connection'),
])
def test_invalid_family_parameters(spec: dict, key: str) -> None:
    """Each bad parameter raises InputError with its dotted key."""
    with pytest.raises(InputError) as info:
        from_spec(spec, 'L')
    assert info.value.key == key, str(info.value)


@pytest.mark.parametrize('spec,key', [
    ({'family': 'polynomial', 'ramp': dict(S2_RAMP, velocity=float('nan')), 'rise': 8e-3,
      'half_angle': 0.9}, 'L.ramp.velocity'),
    ({'family': 'polynomial', 'ramp': S2_RAMP, 'max_lift': float('inf'),
      'half_angle': 0.9}, 'L.max_lift'),
    ({'family': 'constant_acceleration', 'ramp': CV_RAMP, 'rise': 8e-3, 'half_angle': 0.9,
      'positive_width': float('nan')}, 'L.positive_width'),
    ({'family': 'composite', 'ramp': CV_RAMP, 'rise': 8e-3,
      'segments': [{'shape': 'half_sine', 'width': float('inf')}]}, 'L.segments[0].width'),
    ({'family': 'composite', 'ramp': CV_RAMP, 'rise': 8e-3,
      'segments': [{'shape': 'polynomial', 'width': 0.5, 'coefficients': [1, 'x']}]},
     'L.segments[0].coefficients[1]'),
    (dict(TRAIN, family='polydyne', valve_lift=8e-3, half_angle=0.9,
          design_cam_speed_rpm=float('nan')), 'L.design_cam_speed_rpm'),
    ({'family': 'harmonic', 'order': 5, 'half_angle': 1.0, 'max_lift': float('nan')},
     'L.max_lift'),
    ({'family': 'harmonic', 'order': 2.5, 'half_angle': 1.0, 'max_lift': 8e-3}, 'L.order'),
    (dict(DUAL, rise=float('nan')), 'L.rise'),
    ({'family': 'polynomial', 'ramp': S2_RAMP, 'rise': 8e-3, 'half_angle': 0.9,
      'fall': {'half_angle': -1.0}}, 'L.fall.half_angle'),
    ({'family': 'polynomial', 'ramp': S2_RAMP, 'rise': 8e-3, 'half_angle': 0.9,
      'fall': {'ramp': dict(S2_RAMP, height=0.02)}}, 'L.fall.ramp.velocity'),
    ({'family': 'table', 'alpha': [0, 1, 2], 'h': [0, 1, 0]}, 'L.alpha'),
])
def test_non_finite_and_nested_parameters(spec: dict, key: str) -> None:
    """NaN/inf and nested bad values are rejected with the full dotted key (no NaN out)."""
    with pytest.raises(InputError) as info:
        from_spec(spec, 'L')
    assert info.value.key == key, str(info.value)


def test_asymmetric_constant_acceleration_and_composite() -> None:
    """Explicit fall flanks: nose lift shared, h' = 0 on both sides of the nose,
    different durations; the fall can use its own ramp."""
    ca = from_spec({'family': 'constant_acceleration', 'ramp': CV_RAMP, 'rise': 8 * MM,
                    'half_angle': 50 * DEG, 'positive_width': 15 * DEG,
                    'fall': {'half_angle': 60 * DEG, 'positive_width': 20 * DEG,
                             'ramp': S2_RAMP}}, 'L')
    assert math.degrees(ca.support[0]) == pytest.approx(-70)
    assert math.degrees(ca.support[1]) == pytest.approx(90)
    assert ca(-1e-15) == pytest.approx(ca(1e-15), rel=1e-13)
    assert ca.flank_is_monotone()
    comp = from_spec({'family': 'composite', 'ramp': S2_RAMP, 'rise': 8 * MM,
                      'segments': [{'shape': 'half_sine', 'width': 15 * DEG},
                                   {'shape': 'quarter_sine', 'width': 35 * DEG}],
                      'fall': {'segments': [{'shape': 'half_sine', 'width': 20 * DEG},
                                            {'shape': 'quarter_sine', 'width': 40 * DEG}]}},
                     'L')
    assert math.degrees(comp.support[1]) == pytest.approx(90)
    assert abs(comp(1e-15, 1)) < 1e-15 and abs(comp(-1e-15, 1)) < 1e-15
    nose = [j for j in comp.junction_report if abs(j.alpha) < 1e-12][0]
    assert nose.achieved >= 1


@pytest.mark.parametrize('start_deg,point_mm', [(2.0, 0.12), (5.0, 0.10), (9.0, 0.12),
                                                (12.0, 0.15), (18.0, 0.10)])
def test_dual_peak_connection_start_anywhere_on_the_ramp(start_deg: float,
                                                         point_mm: float) -> None:
    """The connection starts on the constant-velocity part (h3'' = 0) or on the
    constant-acceleration part (h3'' = 2 C_B) of the main descending ramp: C2 either
    way, or a clear rejection of the interior point (never a silent negative lift)."""
    spec = dict(DUAL, connection=dict(DUAL['connection'], start=start_deg * DEG,
                                      point_lift=point_mm * MM))
    try:
        law = from_spec(spec, 'L')
    except InputError as exc:
        assert exc.key == 'L.connection.point_lift'
        return
    cut = (50 + start_deg) * DEG
    j = [j for j in law.junction_report if abs(j.alpha - cut) < 1e-12][0]
    assert j.achieved >= 2
    a = np.linspace(cut, cut + 40 * DEG, 2001)
    assert law(a).min() >= 0


def test_composite_free_widths_recover_known_widths() -> None:
    """Free widths (methods §1.3 step 3): with the amplitude ratio of a known solution
    imposed, least squares on the widths recovers them from a wrong start."""
    a1, a2 = constant_acceleration_amplitudes(V, 50 * DEG, 8 * MM, 15 * DEG)
    law = from_spec({'family': 'composite', 'ramp': CV_RAMP, 'rise': 8 * MM,
                     'continuity': 1, 'free_widths': True, 'half_angle': 50 * DEG,
                     'ratios': [[0, 1, a2 / a1]],
                     'segments': [{'shape': 'constant', 'width': 0.3},
                                  {'shape': 'constant', 'width': 0.5}]}, 'L')
    widths = [math.degrees(s.hi - s.lo) for s in law.segments]
    assert widths[1] == pytest.approx(15.0, abs=1e-8)
    assert widths[2] == pytest.approx(35.0, abs=1e-8)
    fixed = from_spec({'family': 'composite', 'ramp': S2_RAMP, 'rise': 8 * MM,
                       'segments': [{'shape': 'half_sine', 'width': 12 * DEG},
                                    {'shape': 'quarter_sine', 'width': 38 * DEG}]}, 'L')
    r = fixed(-20 * DEG, 2) / fixed(-44 * DEG, 2) / math.sin(math.pi * 0.5 * 18 / 38) \
        * math.sin(math.pi * 6 / 12)
    free = from_spec({'family': 'composite', 'ramp': S2_RAMP, 'rise': 8 * MM,
                      'free_widths': True, 'half_angle': 50 * DEG, 'ratios': [[0, 1, r]],
                      'segments': [{'shape': 'half_sine', 'width': 0.2},
                                   {'shape': 'quarter_sine', 'width': 0.7}]}, 'L')
    assert math.degrees(free.segments[2].hi - free.segments[2].lo) == pytest.approx(12, abs=1e-6)
    with pytest.raises(InputError, match=r'^L\.segments'):
        from_spec({'family': 'composite', 'ramp': S2_RAMP, 'rise': 8 * MM,
                   'free_widths': True, 'half_angle': 50 * DEG, 'ratios': [[0, 1, 1.0]],
                   'segments': [{'shape': 'half_sine', 'width': 0.2},
                                {'shape': 'quarter_sine', 'width': 0.7}]}, 'L')
    with pytest.raises(InputError, match=r'^L\.half_angle'):
        from_spec({'family': 'composite', 'ramp': S2_RAMP, 'rise': 8 * MM,
                   'half_angle': 50 * DEG,
                   'segments': [{'shape': 'half_sine', 'width': 0.2}]}, 'L')


@pytest.mark.parametrize('order,end_order', [(4, 2), (5, 3), (12, 3), (40, 3), (200, 2)])
def test_harmonic_with_explicit_ramps(order: int, end_order: int) -> None:
    """Explicit-ramp form (basis cos(j pi a/(2 Phi)), methods §1.6): h(Phi) = H_r,
    h'(Phi) = -v_r, h''(Phi) = 0 (and h''' with end_order 3): the junction to the S2
    ramp is C2/C3, h(0) = max_lift, flanks monotone, even with the nearly dependent
    basis of large N."""
    law = from_spec({'family': 'harmonic', 'order': order, 'half_angle': 50 * DEG,
                     'max_lift': 8.3 * MM, 'end_order': end_order, 'ramp': S2_RAMP}, 'L')
    assert np.degrees(law.support) == pytest.approx([-80, 80])
    ramp_end = [j for j in law.junction_report if abs(j.alpha + 50 * DEG) < 1e-12][0]
    assert ramp_end.achieved >= end_order
    assert law(0.0) == pytest.approx(8.3 * MM, rel=1e-11)
    assert law.flank_is_monotone()


def test_harmonic_explicit_ramps_fit_target() -> None:
    """Fitted to the §1.4 cam on the same ramp, N = 15 is within 1e-5 mm."""
    law = from_spec({'family': 'harmonic', 'order': 15, 'half_angle': 50 * DEG,
                     'max_lift': 8.3 * MM, 'ramp': S2_RAMP,
                     'target': PRESETS['methods_example']}, 'L')
    tgt = from_spec(PRESETS['methods_example'], 't')
    a = np.linspace(-80 * DEG, 80 * DEG, 2001)
    assert np.max(np.abs(law(a) - tgt(a))) < 1e-5 * MM
    with pytest.raises(InputError, match=r'^L\.max_lift'):
        from_spec({'family': 'harmonic', 'order': 15, 'half_angle': 50 * DEG,
                   'max_lift': 0.2 * MM, 'ramp': S2_RAMP}, 'L')
    with pytest.raises(InputError, match=r'^L\.end_order'):
        from_spec({'family': 'harmonic', 'order': 15, 'half_angle': 50 * DEG,
                   'max_lift': 8.3 * MM, 'ramp': S2_RAMP, 'end_order': 4}, 'L')


def test_polydyne_rejects_non_monotone_valve_motion() -> None:
    """methods §1.5: y_d must rise monotonically. y_d = the §1.5 motion - 2u^2(1-u)^4
    (8 mm units) keeps the first three derivatives zero at the nose but dips below zero
    first: rejected, naming the flank angle parameter."""
    coeffs = [[k, c * 8 * MM] for k, c in ((2, -2), (3, 8), (4, 23), (5, -76), (6, 68),
                                           (7, -20))]
    with pytest.raises(InputError) as info:
        from_spec(dict(TRAIN, family='polydyne', design_cam_speed_rpm=300,
                       valve_motion={'angle': 60 * DEG, 'coefficients': coeffs}), 'L')
    assert info.value.key == 'L.half_angle'
