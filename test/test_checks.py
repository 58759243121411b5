"""Design checks of the book §2.1 (methods.md §3, §7 #10, #14-#17)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from cam_design import checks as C
from cam_design.errors import InputError
from cam_design.lift_laws import PRESETS, from_spec

D = math.pi / 180
MM = 1e-3


def test_flow_area_case_15() -> None:
    """#15: d = 40 mm, gamma = 45 deg, y = 8 mm -> 7.819474e-4 m^2 (= curtain form)."""
    fp = C.valve_flow_area(8 * MM, 40 * MM, 45 * D)
    assert float(fp) == pytest.approx(7.819474e-4, abs=1e-9)
    g, y, d = 45 * D, 8 * MM, 40 * MM
    want = math.pi * y * math.cos(g) * (d + y * math.sin(g) * math.cos(g))
    assert float(fp) == pytest.approx(want, rel=1e-14)
    assert C.flow_area_validity(1.5 * MM, g) == pytest.approx(3 * MM)


def test_hertz_case_14() -> None:
    """#14: F = 1000 N, W = 12 mm, rho1 = 6 mm, E = 206 GPa: (2.11) 7.0704e8 Pa,
    (2.4) 7.0715e8 Pa (both with the book's rounded constants)."""
    steel = float(C.hertz_stress_steel(1000, 12 * MM, 6 * MM))
    assert steel == pytest.approx(7.0704e8, rel=1e-3)
    assert float(C.hertz_stress(1000, 12 * MM, 6 * MM)) == pytest.approx(7.0715e8, rel=1e-3)
    # (2.5) with two equal steel cylinders equals (2.4) with mu = 0.3 up to the rounding
    s4 = C.hertz_stress(1000, 12 * MM, 6 * MM, 9 * MM)
    s5 = C.hertz_stress_steel(1000, 12 * MM, 6 * MM, 9 * MM)
    assert float(s4) == pytest.approx(float(s5), rel=5e-4)
    assert float(C.hertz_stress_steel(-5.0, 12 * MM, 6 * MM)) == 0.0


def test_piston_case_16() -> None:
    """#16: r = 50, l = 180 mm, phi = 90 deg: 56.9444 mm (2.14), exact 57.0838 mm."""
    s = C.piston_displacement(90 * D, 50 * MM, 180 * MM)
    e = C.piston_displacement(90 * D, 50 * MM, 180 * MM, exact=True)
    assert float(s) / MM == pytest.approx(56.9444, abs=1e-4)
    assert float(e) / MM == pytest.approx(57.0838, abs=1e-4)
    phi = np.linspace(0, 2 * math.pi, 73)
    assert np.all(np.abs(C.piston_displacement(phi, 50 * MM, 180 * MM)
                         - C.piston_displacement(phi, 50 * MM, 180 * MM, exact=True)) < 0.5 * MM)


def test_angle_mapping_case_17() -> None:
    """#17: intake phi0 = -18 deg, alpha0 = 28 deg, alpha = 37 deg -> phi = 0 (TDC);
    exhaust phi0 = 130 deg, alpha0 = 30 deg."""
    assert float(C.crank_angle(37 * D, -18 * D, 28 * D)) == pytest.approx(0.0, abs=1e-15)
    assert float(C.crank_angle(30 * D, 130 * D, 30 * D)) == pytest.approx(130 * D)
    a = np.linspace(-1, 1, 9)
    assert np.allclose(C.cam_angle(C.crank_angle(a, 0.3, 0.1), 0.3, 0.1), a, atol=1e-15)


def test_flat_tappet_curvature_case_10() -> None:
    """#10: rho1 at the nose with R0 = 40 mm and H1 = 0.3 mm: 3.64870 mm."""
    law = from_spec(PRESETS['methods_example'], 'l')
    rho = C.flat_tappet_curvature(law(0.0), law(0.0, 2), 40 * MM)
    assert float(rho) / MM == pytest.approx(3.64870, abs=1e-5)


def test_eccentric_disc_curvature_is_constant() -> None:
    """Exact: eccentric disc R_c = 20, e = 5 mm: h = e(1 - cos a), R0 = 15 -> rho1 = 20."""
    a = np.linspace(-math.pi, math.pi, 101)
    e = 5 * MM
    rho = C.flat_tappet_curvature(e * (1 - np.cos(a)), e * np.cos(a), 15 * MM)
    assert np.allclose(rho, 20 * MM, rtol=0, atol=1e-15)


def test_fullness_of_the_base_section() -> None:
    """(2.3) numerically equals the closed form 0.4941829 when the valve opens exactly
    at the ramp end (y = h - H_r on the base section)."""
    law = from_spec(PRESETS['methods_example'], 'l')
    a = np.linspace(-50 * D, 50 * D, 200001)
    xi = C.fullness(a, law(a) - 0.3 * MM)
    assert xi == pytest.approx(0.4941829, abs=1e-6)
    tri = C.fullness(np.linspace(-1, 1, 2001), 1 - np.abs(np.linspace(-1, 1, 2001)))
    assert tri == pytest.approx(0.5, abs=1e-9)


def test_time_area_is_integral() -> None:
    """(2.2): constant area over 2 rad integrates to 2 F."""
    a = np.linspace(0, 2, 11)
    assert C.time_area(a, np.full(11, 3e-4))[-1] == pytest.approx(6e-4)


def test_equivalent_mass_with_valve_mass() -> None:
    """(2.10) with erratum 6: S0 prints M = (M2/3 + M3) k^2 + I0/l0^2 + m2 + m3 without
    the valve mass M1; the standard form has (M1 + M2/3 + M3) k^2."""
    m = C.equivalent_mass(valve=0.05, spring=0.03, retainer=0.01, rocker_ratio=1.5,
                          rocker_inertia=2e-5, rocker_arm=0.04, tappet=0.04, push_rod=0.06)
    assert m == pytest.approx((0.05 + 0.01 + 0.01) * 2.25 + 2e-5 / 0.04 ** 2 + 0.1)
    with pytest.raises(InputError, match='rocker_arm'):
        C.equivalent_mass(valve=0.05, spring=0.03, retainer=0.01, rocker_ratio=1.5,
                          rocker_inertia=2e-5)


def test_forces_and_separation() -> None:
    """(2.8) + (2.9): at low speed no separation; very high speed separates on the
    negative acceleration, at the angle of most negative F."""
    law = from_spec(PRESETS['flat_tappet_intake'], 'l')
    a = np.linspace(*law.support, 3601)
    h, h2 = law(a), law(a, 2)
    kw = dict(rocker_ratio=1.0, lash=0.2 * MM, preload=250.0, rate=3e4, mass=0.12)
    ok = C.no_separation(a, h, h2, omega=C.rpm_to_omega(1500), **kw)
    bad = C.no_separation(a, h, h2, omega=C.rpm_to_omega(20000), **kw)
    assert ok.ok and not bad.ok
    assert h2[np.argmin(np.abs(a - bad.alpha_at_min))] < 0
    fc = C.spring_force(np.array([0.0, 1 * MM]), 1.5, 0.25 * MM, 250.0, 3e4)
    assert fc.tolist() == pytest.approx([375.0, 1.5 * (250 + 3e4 * 1.25e-3)])


def test_oil_film_reversal_and_zero() -> None:
    """(2.12): h_min = 0 at gamma = 0 and 0.5; reversal flagged for 0 < gamma < 0.5."""
    r0 = 10 * MM
    rho = np.array([0.0, 2.5, 5.0, 7.5, 10.0]) * MM
    f = C.oil_film(np.arange(5.0), np.zeros(5), rho, r0, 1e-4)
    assert f.gamma.tolist() == pytest.approx([0, 0.25, 0.5, 0.75, 1.0])
    assert f.h_min[[0, 2]].tolist() == [0.0, 0.0]
    assert f.reversal.tolist() == [False, True, False, False, False]
    assert f.h_min[4] == pytest.approx(1e-4 * r0 * 1.0)


def test_valve_piston_clearance_collision() -> None:
    """(2.13): D_s = s + y0 - y <= 0 is a collision."""
    ds = C.valve_piston_clearance(np.array([0.0, 1.0]) * MM, np.array([2.0, 1.0]) * MM,
                                  1 * MM)
    assert ds.tolist() == pytest.approx([-1 * MM, 1 * MM])


@pytest.mark.parametrize('call,key', [
    (lambda: C.valve_flow_area(1e-3, -1, 0.5), 'seat_diameter'),
    (lambda: C.valve_flow_area(1e-3, 0.03, 2.0), 'seat_angle'),
    (lambda: C.valve_flow_area(-1e-3, 0.03, 0.5), 'y'),
    (lambda: C.piston_displacement(0.0, 0.2, 0.1), 'rod_length'),
    (lambda: C.hertz_stress(1.0, 0.0, 1.0), 'width'),
    (lambda: C.fullness([0.0, 1.0], [0.0, 0.0]), 'y'),
    (lambda: C.time_area([0.0, 1.0, 0.5], [1, 1, 1]), 'alpha'),
    (lambda: C.rigid_valve_lift([float('nan')], 1.0, 0.0), 'h'),
])
def test_invalid_inputs(call, key: str) -> None:
    """Bad input -> InputError naming the parameter."""
    with pytest.raises(InputError) as info:
        call()
    assert info.value.key == key


def test_run_checks_all_sections() -> None:
    """run_checks on the default preset reports every section with sane numbers."""
    law = from_spec(PRESETS['flat_tappet_intake'], 'l')
    cfg = {'base_radius': 16.5 * MM, 'rocker_ratio': 1.0, 'lash': 0.2 * MM,
           'cam_speed_rpm': 3000,
           'valve': {'seat_diameter': 0.03, 'seat_angle': 45 * D, 'seat_width': 1.5 * MM},
           'spring': {'preload': 250.0, 'rate': 3e4},
           'masses': {'valve': 0.045, 'spring': 0.04, 'retainer': 0.012, 'tappet': 0.05},
           'contact': {'width': 0.012},
           'lubrication': {'k_film': 1e-4},
           'piston': {'crank_radius': 0.04, 'rod_length': 0.14, 'clearance': 1.2 * MM,
                      'opening_crank_angle': -18 * D}}
    out = C.run_checks(law, cfg)
    assert out['max_lift_mm'] == pytest.approx(8.5)
    assert out['min_rho1_mm'] == pytest.approx(4.322, abs=2e-3)
    assert out['no_separation'] and not out['undercut']
    assert 0.4 < out['fullness'] < 0.6
    assert out['equivalent_mass_kg'] == pytest.approx(0.045 + 0.04 / 3 + 0.012 + 0.05)
    assert out['min_valve_piston_clearance_mm'] > 0
    with pytest.raises(InputError, match='check.valve.seat_diameter'):
        C.run_checks(law, dict(cfg, valve={'seat_angle': 0.5}))
    with pytest.raises(InputError, match='check.valve.seat_diametre'):
        C.run_checks(law, dict(cfg, valve={'seat_diametre': 0.03, 'seat_angle': 0.5}))
    with pytest.raises(InputError, match=r'^check\.cam_speed:'):
        C.run_checks(law, dict(cfg, cam_speed=3000))


@pytest.mark.parametrize('kind,radius', [('flat', 0.0), ('roller', 8 * MM), ('knife', 0.0)])
def test_run_checks_eccentric_disc_case_13(kind: str, radius: float) -> None:
    """#13 through run_checks: an eccentric disc (R_c = 20, e = 5 mm) has rho1 = 20 mm
    for every follower (roller curvature comes from cam_design.follower, eq. 2.7 with
    erratum 5: the roller radius is subtracted)."""
    from cam_design.follower import EccentricDiscLift, Follower

    law = EccentricDiscLift(20 * MM, 5 * MM, Follower(kind, radius))
    cfg = {'base_radius': 15 * MM, 'follower': {'kind': kind, 'radius': radius}}
    if kind == 'flat':
        cfg.pop('follower')
    out = C.run_checks(law, cfg, samples=721)
    assert out['min_rho1_mm'] == pytest.approx(20.0, abs=1e-6)
    assert out['follower'] == kind and not out['undercut']


def test_run_checks_roller_hertz_and_pressure_angle() -> None:
    """Roller follower: Hertz with 1/rho1 + 1/r on the normal force F/cos(phi); the
    oil-film number (flat-tappet formula) is skipped; knife: no line contact."""
    law = from_spec(PRESETS['flat_tappet_intake'], 'l')
    cfg = {'base_radius': 16.5 * MM, 'cam_speed_rpm': 1000, 'lash': 0.0,
           'spring': {'preload': 250.0, 'rate': 3e4},
           'masses': {'valve': 0.05, 'spring': 0.03, 'retainer': 0.01},
           'contact': {'width': 0.01}, 'lubrication': {'k_film': 1e-4},
           'follower': {'kind': 'roller', 'radius': 12 * MM}}
    out = C.run_checks(law, cfg)
    assert 0 < out['pressure_angle_max_deg'] < 45
    assert 'oil_film_nose_gamma' not in out
    assert out['max_hertz_stress_mpa'] > 0
    knife = C.run_checks(law, dict(cfg, follower={'kind': 'knife'}))
    assert 'max_hertz_stress_mpa' not in knife
    with pytest.raises(InputError, match='check.follower.radius'):
        C.run_checks(law, dict(cfg, follower={'kind': 'roller'}))
    # array rho2 (signed): concave cam against a roller
    s = C.hertz_stress_steel([1000.0, 1000.0], 0.01, [8 * MM, 8 * MM], [-20 * MM, np.inf])
    assert s[0] < s[1]


def test_flank_shape_constant_acceleration() -> None:
    """§1.4 shape checks: the §1.2 cam has one h'' sign change per flank and a positive
    acceleration width of phi1 = 15 deg; the natural period in cam angle is
    omega 2 pi sqrt(M/c)."""
    law = from_spec({'family': 'constant_acceleration',
                     'ramp': {'kind': 'constant_velocity', 'height': 0.3 * MM,
                              'velocity': 0.015 * MM / D},
                     'rise': 8 * MM, 'half_angle': 50 * D, 'positive_width': 15 * D}, 'l')
    a = np.linspace(*law.support, 14001)
    shape = C.flank_shape(a[a < 0], law(a[a < 0], 1), law(a[a < 0], 2), rise=True)
    assert shape.monotone and shape.acceleration_sign_changes == 1
    assert math.degrees(shape.positive_width) == pytest.approx(15.0, abs=0.02)
    cfg = {'base_radius': 40 * MM, 'cam_speed_rpm': 1500, 'stiffness': 1.2e7,
           'spring': {'preload': 250.0, 'rate': 3e4},
           'masses': {'valve': 0.12, 'spring': 0.0, 'retainer': 0.0}}
    out = C.run_checks(law, cfg)
    assert out['acceleration_sign_changes'] == [1, 1]
    # methods §4.3: M = 0.12 kg, c = 1.2e7 N/m, 1500 rpm -> natural period 5.65 deg
    assert out['natural_period_cam_deg'] == pytest.approx(5.65, abs=0.01)
    assert out['positive_width_over_period'] == pytest.approx(15 / 5.652, rel=3e-3)


def test_flank_shape_flags_dual_peak() -> None:
    """The dual-peak cam's fall side is not a single +/- pattern (more sign changes)
    and is not monotone: the check reports it rather than failing."""
    law = from_spec({'family': 'dual_peak',
                     'ramp': {'height': 0.3 * MM, 'velocity': 0.015 * MM / D,
                              'angle': 30 * D},
                     'rise': 8 * MM, 'half_angle': 50 * D,
                     'connection': {'start': 5 * D, 'angle': 40 * D, 'point_angle': 20 * D,
                                    'point_lift': 0.1 * MM},
                     'secondary': {'rise': 1.5 * MM, 'half_angle': 20 * D,
                                   'ramp': {'height': 0.25 * MM,
                                            'velocity': 0.0125 * MM / D,
                                            'angle': 30 * D}}}, 'l')
    out = C.run_checks(law, {'base_radius': 40 * MM})
    assert not out['monotone_flanks']
    assert out['acceleration_sign_changes'][0] == 1
    assert out['acceleration_sign_changes'][1] > 1


def test_ramp_events_case_18() -> None:
    """#18 / methods §1.1c, §4.1 (i): x0 = 0.25 mm, F0 = 250 N, c = 1.2e7 N/m, k = 1.5
    on the §1.1 ramp: opening at 22.03704 deg from the ramp start (h = 0.180556 mm),
    rigid seating speed k v_r omega = 0.2025 m/s at 1500 rpm cam, both on the
    constant-velocity part."""
    law = from_spec(PRESETS['methods_example'], 'l')
    ev = C.ramp_events(law, 1.5, 0.25 * MM, 250.0, 1.2e7, C.rpm_to_omega(1500))
    assert math.degrees(ev.opening_alpha - law.support[0]) == pytest.approx(22.03704,
                                                                            abs=1e-5)
    assert ev.closing_alpha == pytest.approx(-ev.opening_alpha, abs=1e-12)
    assert ev.seating_velocity == pytest.approx(0.2025, abs=1e-5)
    assert ev.opening_velocity == pytest.approx(0.2025, abs=1e-5)
    assert ev.on_constant_velocity
    # through run_checks: tappet-side stiffness c k^2 and mass
    out = C.run_checks(law, {'base_radius': 40 * MM, 'rocker_ratio': 1.5,
                             'lash': 0.25 * MM, 'cam_speed_rpm': 1500,
                             'stiffness': 1.2e7 * 2.25, 'equivalent_mass': 0.12 * 2.25,
                             'spring': {'preload': 250.0, 'rate': 3e4}})
    assert out['seating_velocity_m_per_s'] == pytest.approx(0.2025, abs=1e-5)
    assert out['natural_period_cam_deg'] == pytest.approx(5.65, abs=0.01)
    # a ramp too low for the lash: opening on the constant-acceleration part
    low = C.ramp_events(law, 1.5, 0.05 * MM, 250.0, 1.2e7, C.rpm_to_omega(1500))
    assert not low.on_constant_velocity
    with pytest.raises(InputError, match='lash'):
        C.ramp_events(law, 1.5, 20 * MM, 250.0, 1.2e7, 100.0)


def test_garbage_in_every_check_input() -> None:
    """Stress: every parameter of a full check input replaced by None, text, negative,
    zero, 1e300, NaN, a list or a mapping: InputError, or finite results only."""
    from test_lift_laws_properties import with_value

    law = from_spec(PRESETS['flat_tappet_intake'], 'l')
    cfg0 = {'base_radius': 16.5 * MM, 'rocker_ratio': 1.0, 'lash': 0.2 * MM,
            'cam_speed_rpm': 3000, 'stiffness': 5e6, 'follower': {'kind': 'flat'},
            'valve': {'seat_diameter': 0.03, 'seat_angle': 45 * D, 'seat_width': 1.5 * MM},
            'spring': {'preload': 250.0, 'rate': 3e4},
            'masses': {'valve': 0.045, 'spring': 0.04, 'retainer': 0.012, 'tappet': 0.05},
            'contact': {'width': 0.012}, 'lubrication': {'k_film': 1e-4},
            'piston': {'crank_radius': 0.04, 'rod_length': 0.14, 'clearance': 1.2 * MM,
                       'opening_crank_angle': -18 * D}}
    paths = [(k,) for k in cfg0] + [(k, j) for k, v in cfg0.items() if isinstance(v, dict)
                                    for j in v]
    for path in paths:
        for value in (None, 'abc', -1, 0, 1e300, float('nan'), [], {'x': 1}):
            try:
                out = C.run_checks(law, with_value(cfg0, path, value), samples=361)
            except InputError:
                continue
            assert all(math.isfinite(v) for v in out.values() if isinstance(v, float)), path


def test_roller_hertz_on_concave_flank_uses_signed_curvature() -> None:
    """QA: with a roller follower the cam radius is negative on concave flanks; the
    stress used 1/|rho| + 1/r there (613.9 MPa at -57.2 deg here instead of 482.1 MPa
    at -52.4 deg, 27 % high). Independent check: tappet force F = F0 + c' h + M w^2 h''
    (k = 1, no lash; its minimum is checked against min_contact_force_n), sigma = 0.418
    sqrt(E F/cos(p) (1/r + 1/rho) / W) with rho and the pressure angle p from
    cam_design.follower.roller_profile on a fine grid."""
    from cam_design.cam_profile import roller_profile

    law = from_spec(PRESETS['flat_tappet_intake'], 'l')
    r, f0, rate, m, rpm, w, e = 10 * MM, 250.0, 3e4, 0.12, 3000.0, 0.012, 2.06e11
    cfg = {'base_radius': 16.5 * MM, 'rocker_ratio': 1.0, 'lash': 0.0,
           'follower': {'kind': 'roller', 'radius': r}, 'cam_speed_rpm': rpm,
           'spring': {'preload': f0, 'rate': rate}, 'equivalent_mass': m,
           'contact': {'width': w}}
    out = C.run_checks(law, cfg)
    a = np.linspace(*law.support, 200001)
    prof = roller_profile(law, 16.5 * MM, r, a)
    h, _, h2, _ = law.derivatives(a)
    force = f0 + rate * h + m * (rpm * math.pi / 30) ** 2 * h2
    lifted = h > 0
    assert out['min_contact_force_n'] == pytest.approx(force[lifted].min(), rel=1e-6)
    curv = np.maximum(1 / r + 1 / prof.rho, 0.0)
    sig = 0.418 * np.sqrt(e * np.maximum(force, 0) / np.cos(prof.pressure_angle) * curv / w)
    sig[~lifted] = 0.0
    i = int(sig.argmax())
    assert prof.rho[i] < 0                            # the maximum is on a concave flank
    assert out['max_hertz_stress_mpa'] == pytest.approx(sig[i] / 1e6, rel=1e-5)
    assert out['max_hertz_stress_alpha_deg'] == pytest.approx(math.degrees(a[i]), abs=0.05)


def test_flat_tappet_undercut_reports_no_hertz_stress() -> None:
    """QA: on a 2 mm base circle rho1 = R0 + h + h'' < 0 (undercut); the stress was
    computed with |rho1| -> 0 (7386 MPa, grid-dependent). It must be None with a note."""
    law = from_spec(PRESETS['flat_tappet_intake'], 'l')
    cfg = {'base_radius': 2 * MM, 'cam_speed_rpm': 3000, 'equivalent_mass': 0.1,
           'spring': {'preload': 250.0, 'rate': 3e4}, 'contact': {'width': 0.012}}
    out = C.run_checks(law, cfg)
    assert out['undercut'] is True
    assert out['max_hertz_stress_mpa'] is None and 'undercut' in out['max_hertz_stress_note']
