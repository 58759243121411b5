"""Lift laws: ramps, polynomial cam, registry (methods.md §1.1, §1.4, §7 #8-#10)."""
from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest

from cam_design.errors import InputError
from cam_design.lift_laws import PRESETS, from_spec
from cam_design.lift_laws.polynomial import (base_section_fullness, polynomial_coefficients,
                                             polynomial_coefficients_exact)
from cam_design.lift_laws.ramps import patent_ramp_coefficients

DEG = math.pi / 180
MM = 1e-3
V1 = 0.015 * MM / DEG          # 0.015 mm/deg in m/rad
RAMP = {'kind': 'constant_acceleration_velocity', 'height': 0.3 * MM, 'velocity': V1,
        'angle': 30 * DEG}


def test_patent_ramp_case_8() -> None:
    """§7 #8: H1 = 0.3 mm, v1 = 0.015 mm/deg, alpha1 = 30 deg (S2 eqs 10-13)."""
    c = patent_ramp_coefficients(0.3 * MM, V1, 30 * DEG)
    assert math.degrees(c.beta1) == pytest.approx(20.0, abs=1e-12)
    assert c.cb * MM ** -1 * DEG ** 2 == pytest.approx(3.75e-4, rel=1e-12)
    assert c.e0 / MM == pytest.approx(-0.15, abs=1e-12)
    assert c.e1 / MM * DEG == pytest.approx(0.015, abs=1e-12)


@pytest.mark.parametrize('velocity,why', [(0.009 * MM / DEG, 'below H1/alpha1'),
                                          (0.0201 * MM / DEG, 'above 2 H1/alpha1'),
                                          (0.3 * MM / (30 * DEG), 'equal to H1/alpha1')])
def test_patent_ramp_existence(velocity: float, why: str) -> None:
    """H1/alpha1 < v1 <= 2 H1/alpha1, else InputError naming the velocity."""
    spec = {'family': 'polynomial', 'ramp': dict(RAMP, velocity=velocity), 'rise': 8 * MM,
            'half_angle': 50 * DEG}
    with pytest.raises(InputError, match=r'lobe\.ramp\.velocity'):
        from_spec(spec, 'lobe')


def test_patent_ramp_upper_limit_is_allowed() -> None:
    """v1 = 2 H1/alpha1 gives beta1 = alpha1: a pure constant-acceleration ramp."""
    v = 2 * 0.3 * MM / (30 * DEG)
    law = from_spec({'family': 'polynomial', 'ramp': dict(RAMP, velocity=v),
                     'rise': 8 * MM, 'half_angle': 50 * DEG}, 'lobe')
    assert law(-80 * DEG) == pytest.approx(0.0, abs=1e-18)
    assert law(-50 * DEG) == pytest.approx(0.3 * MM, rel=1e-12)
    assert law(-50 * DEG, 1) == pytest.approx(v, rel=1e-12)


def test_polynomial_coefficients_case_9() -> None:
    """§7 #9 with erratum 3: S2 eqs (24)-(25) are misprinted; the corrected closed form
    gives c2, c6, c10, c14 = -17.001953125, 16.544921875, -9.896484375, 2.353515625 mm
    (H2 = 8 mm, v2 = 0.015 mm/deg, alpha2 = 100 deg). As printed, (24) has the
    denominator 2(s-q)(r-q)(p-q) and gives c_p = +51.005859375 mm; (25) has the
    numerator term rq for rp and the denominator 2(s-q)(r-q)(q-q) = 0 (undefined)."""
    p, q, r, s = 2, 6, 10, 14
    printed_cp = (-2 * 8 * s * r * q + 0.015 * 100 * (s * r + s * q + r * q - s - r - q + 1)) \
        / (2 * (s - q) * (r - q) * (p - q))
    assert printed_cp == pytest.approx(51.005859375, abs=1e-12)
    c = polynomial_coefficients([2, 6, 10, 14], 8 * MM, V1, 50 * DEG)
    expected = {2: -17.001953125, 6: 16.544921875, 10: -9.896484375, 14: 2.353515625}
    for i, v in expected.items():
        assert c[i] / MM == pytest.approx(v, abs=1e-9)


def test_polynomial_case_10_fullness_nose_rho() -> None:
    """§7 #10: fullness 0.4941829, nose h'' = -44.65130 mm/rad^2, rho1 = 3.64870 mm
    (R0 = 40 mm, ramp H1 = 0.3 mm)."""
    c = polynomial_coefficients([2, 6, 10, 14], 8 * MM, V1, 50 * DEG)
    assert base_section_fullness(c, 8 * MM) == pytest.approx(0.4941829, abs=1e-6)
    law = from_spec(PRESETS['methods_example'], 'lobe')
    assert law(0.0, 2) / MM == pytest.approx(-44.65130, abs=1e-5)
    rho = 40 * MM + law(0.0) + law(0.0, 2)
    assert rho / MM == pytest.approx(3.64870, abs=1e-5)
    assert law(0.0) == pytest.approx(8.3 * MM, rel=1e-14)


def exact_coefficients(exps: list[int], rise: Fraction, va: Fraction) -> dict[int, Fraction]:
    """Independent exact reference: Cramer-free elimination on the 4x4 moment system."""
    rows = [[Fraction(math.perm(e, m)) for e in exps] for m in range(4)]
    rhs = [-rise, -va, Fraction(0), Fraction(0)]
    n = 4
    a = [r + [b] for r, b in zip(rows, rhs)]
    for col in range(n):
        piv = next(r for r in range(col, n) if a[r][col] != 0)
        a[col], a[piv] = a[piv], a[col]
        for r in range(n):
            if r != col:
                f = a[r][col] / a[col][col]
                a[r] = [x - f * y for x, y in zip(a[r], a[col])]
    return {e: a[i][n] / a[i][i] for i, e in enumerate(exps)}


@pytest.mark.parametrize('exps', [[2, 6, 10, 14], [2, 10, 18, 26], [2, 20, 35, 50],
                                  [44, 46, 48, 50], [2, 3, 4, 5], [47, 48, 49, 50],
                                  [2, 48, 49, 50]])
def test_closed_form_against_fractions(exps: list[int]) -> None:
    """Stress: exponents up to 50 and closely spaced ones vs exact rationals."""
    rise, va = Fraction(8, 1000), Fraction(3, 10000)
    ref = exact_coefficients(exps, rise, va)
    closed = polynomial_coefficients(exps, float(rise), float(va), 1.0)
    exact = polynomial_coefficients_exact(exps, float(rise), float(va), 1.0)
    scale = max(abs(float(v)) for v in ref.values())
    for e in exps:
        assert closed[e] == pytest.approx(float(ref[e]), rel=1e-12, abs=1e-15 * scale)
        assert exact[e] == pytest.approx(float(ref[e]), rel=1e-15, abs=1e-18 * scale)


@pytest.mark.parametrize('exps', [[2, 20, 35, 50], [44, 46, 48, 50], [47, 48, 49, 50]])
def test_high_exponent_lobe_junctions(exps: list[int]) -> None:
    """Large/close exponents still give a C3 ramp/base junction (analytic check)."""
    law = from_spec({'family': 'polynomial', 'ramp': RAMP, 'rise': 8 * MM,
                     'half_angle': 50 * DEG, 'exponents': exps}, 'lobe')
    assert law.continuity_order == 1
    orders = [j.achieved for j in law.junction_report]
    assert orders == [1, 1, 3, 3, 3, 1, 1]


def test_symmetry_and_shape() -> None:
    """Mirrored lobe: h even, h' odd; zero outside the support; h'(0) = 0."""
    law = from_spec(PRESETS['flat_tappet_intake'], 'lobe')
    a = np.linspace(0, law.support[1] * 1.1, 777)
    for nu in range(4):
        assert np.allclose(law(-a, nu), (-1) ** nu * law(a, nu), rtol=0, atol=1e-15)
    assert law(np.array([-2.0, 2.0])).tolist() == [0.0, 0.0]
    assert law.max_lift() == pytest.approx(8.5 * MM, rel=1e-9)
    assert law.flank_is_monotone()


def test_preset_flat_tappet_is_realisable() -> None:
    """The default-scene preset: rho1 = R0 + h + h'' > 4 mm with R0 = 16.5 mm."""
    law = from_spec({'family': 'preset', 'name': 'flat_tappet_intake'}, 'lobe')
    a = np.linspace(*law.support, 20001)
    rho = 16.5 * MM + law(a) + law(a, 2)
    assert rho.min() > 4 * MM


def test_asymmetric_polynomial() -> None:
    """An explicit fall flank with its own duration; nose lift and h' = 0 match."""
    spec = dict(PRESETS['methods_example'], fall={'half_angle': 60 * DEG})
    law = from_spec(spec, 'lobe')
    assert law.support[0] == pytest.approx(-80 * DEG)
    assert law.support[1] == pytest.approx(90 * DEG)
    assert law(-1e-12) == pytest.approx(law(1e-12), abs=1e-15)
    assert abs(law(1e-15, 1)) < 1e-16 and abs(law(-1e-15, 1)) < 1e-16
    assert law.flank_is_monotone()


@pytest.mark.parametrize('spec,key', [
    ({'family': 'nope'}, 'L.family'),
    ({'family': 'polynomial', 'ramp': RAMP, 'half_angle': 1.0}, 'L.rise'),
    ({'family': 'polynomial', 'ramp': RAMP, 'rise': -1e-3, 'half_angle': 1.0}, 'L.rise'),
    ({'family': 'polynomial', 'ramp': RAMP, 'rise': 8e-3, 'half_angle': float('nan')},
     'L.half_angle'),
    ({'family': 'polynomial', 'ramp': RAMP, 'rise': 8e-3, 'half_angle': 1.0,
      'exponents': [2, 6, 6, 14]}, 'L.exponents'),
    ({'family': 'polynomial', 'ramp': RAMP, 'rise': 8e-3, 'half_angle': 1.0,
      'exponents': [2, 4, 6, 8, 10, 12, 14, 16, 18]}, 'L.exponents'),
    ({'family': 'polynomial', 'ramp': dict(RAMP, height=0), 'rise': 8e-3,
      'half_angle': 1.0}, 'L.ramp.height'),
    ({'family': 'polynomial', 'ramp': {'kind': 'bogus'}, 'rise': 8e-3,
      'half_angle': 1.0}, 'L.ramp.kind'),
    ({'family': 'polynomial', 'ramp': RAMP, 'rise': 8e-3, 'half_angle': 1.0,
      'typo': 1}, 'L.typo'),
    ({'family': 'preset', 'name': 'nope'}, 'L.name'),
])
def test_invalid_parameters_named(spec: dict, key: str) -> None:
    """Every bad parameter raises InputError whose message starts with its key."""
    with pytest.raises(InputError) as info:
        from_spec(spec, 'L')
    assert str(info.value).startswith(key + ':'), str(info.value)


def test_constant_velocity_ramp_lobe() -> None:
    """CV ramp: h = v t, h' steps at the base circle (continuity order 0)."""
    law = from_spec({'family': 'polynomial', 'ramp': {'kind': 'constant_velocity',
                     'height': 0.3 * MM, 'velocity': V1}, 'rise': 8 * MM,
                     'half_angle': 50 * DEG}, 'lobe')
    assert law.continuity_order == 0
    assert law.support[0] == pytest.approx(-70 * DEG)
    assert law(-60 * DEG) == pytest.approx(V1 * 10 * DEG, rel=1e-12)


def test_opening_angle_on_the_s2_ramp_case_18() -> None:
    """#18 (geometric part): x0 = 0.25 mm, F0 = 250 N, c = 1.2e7 N/m, k = 1.5 open the
    valve at h = (x0 + F0/c)/k = 0.180556 mm, i.e. 22.03704 deg from the start of the
    §1.1 ramp; rigid seating speed k v_r omega = 0.2025 m/s at 1500 rpm cam."""
    from scipy.optimize import brentq

    law = from_spec(PRESETS['methods_example'], 'lobe')
    h_open = (0.25 * MM + 250 / 1.2e7) / 1.5
    a = brentq(lambda x: law(x) - h_open, law.support[0] + 1e-9, -50 * DEG, xtol=1e-15)
    assert math.degrees(a - law.support[0]) == pytest.approx(22.03704, abs=1e-5)
    omega = 2 * math.pi * 1500 / 60
    assert 1.5 * law(a, 1) * omega == pytest.approx(0.2025, abs=1e-5)


def test_every_docs_example_builds() -> None:
    """Each ```yaml example with a lift_law in docs/lift_laws.md builds with from_spec."""
    import re
    from pathlib import Path

    import yaml

    text = (Path(__file__).resolve().parent.parent / 'docs' / 'lift_laws.md').read_text()
    blocks = [b for b in re.findall(r'```yaml\n(.*?)```', text, re.S) if 'lift_law' in b]
    assert len(blocks) >= 7
    for block in blocks:
        law = from_spec(yaml.safe_load(block)['lift_law'], 'docs')
        assert law.max_lift() > 0


@pytest.mark.parametrize('exps,order', [([2, 4], 1), ([2, 6, 10], 2), ([2, 6, 10, 14, 18], 3),
                                        ([2, 10, 20, 30, 40, 50], 3)])
def test_other_exponent_counts(exps: list[int], order: int) -> None:
    """n exponents fix h..h^(n-1) at the ramp end (CV ramp end: h'' = h''' = 0)."""
    law = from_spec({'family': 'polynomial', 'ramp': RAMP, 'rise': 8 * MM,
                     'half_angle': 50 * DEG, 'exponents': exps}, 'lobe')
    ramp_end = [j for j in law.junction_report if abs(j.alpha + 50 * DEG) < 1e-12][0]
    assert ramp_end.achieved == order
    assert law(0.0) == pytest.approx(8.3 * MM, rel=1e-13)
    with pytest.raises(InputError, match=r'^lobe\.exponents'):
        from_spec({'family': 'polynomial', 'ramp': RAMP, 'rise': 8 * MM,
                   'half_angle': 50 * DEG, 'exponents': [2]}, 'lobe')


@pytest.mark.parametrize('exps,order', [([3, 4, 5], 2), ([4, 5, 6, 7], 3), ([2, 3], 1)])
def test_exponent_counts_without_ramp(exps: list[int], order: int) -> None:
    """Without a ramp the base section starts on the base circle and n exponents fix
    h..h^(n-1) there too: [3, 4, 5] is the 3-4-5 law (C2, jerk 60 H/alpha0^3 at the
    start), which used to be refused because C3 was required whatever the count."""
    law = from_spec({'family': 'polynomial', 'ramp': None, 'rise': 8 * MM,
                     'half_angle': 50 * DEG, 'exponents': exps}, 'lobe')
    start = [j for j in law.junction_report if abs(j.alpha + 50 * DEG) < 1e-12][0]
    assert start.required == order and start.achieved == order
    if exps == [3, 4, 5]:
        assert float(law(-50 * DEG, 3)) == pytest.approx(60 * 8 * MM / (50 * DEG) ** 3,
                                                         rel=1e-12)


def test_support_must_fit_one_turn() -> None:
    """alpha is wrapped to (-pi, pi]: a lobe wider than that is rejected."""
    with pytest.raises(InputError, match='support'):
        from_spec({'family': 'polynomial', 'ramp': {'kind': 'constant_velocity',
                                                    'height': 3e-4, 'velocity': 1e-5},
                   'rise': 8e-3, 'half_angle': 1.0}, 'lobe')
