"""Property tests (hypothesis) over random valid parameters: continuity at every
junction to the stated order, symmetry, monotone flanks; near-degenerate ramps."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from cam_design.errors import InputError
from cam_design.lift_laws import from_spec
from cam_design.lift_laws.base import LiftLaw

DEG = math.pi / 180
MM = 1e-3
SETTINGS = settings(max_examples=40, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])


def check_continuity(law: LiftLaw) -> None:
    """Independent of the construction check: h^(nu) evaluated just left and right of
    each junction differs by at most the drift allowed by the next derivative."""
    lo, hi = law.support
    grid = np.linspace(lo, hi, 4001)
    bounds = [float(np.max(np.abs(law(grid, nu)))) for nu in range(4)]
    eps = 1e-9
    for j in law.junction_report:
        for nu in range(j.required + 1):
            left, right = law(j.alpha - eps, nu), law(j.alpha + eps, nu)
            slope = bounds[nu + 1] if nu < 3 else bounds[3] / eps
            assert abs(left - right) <= 3 * eps * slope + 1e-9 * bounds[nu] + 1e-300, (
                j, nu, left, right)


def check_symmetric(law: LiftLaw) -> None:
    """h(-a) = h(a), h'(-a) = -h'(a)."""
    a = np.linspace(0, law.support[1], 501)[1:] * 0.99937   # off the junctions
    for nu in range(4):
        scale = max(float(np.max(np.abs(law(a, nu)))), 1e-300)
        assert np.allclose(law(-a, nu), (-1) ** nu * law(a, nu), rtol=0, atol=1e-12 * scale)


ramps = st.fixed_dictionaries({
    'height': st.floats(0.1 * MM, 0.5 * MM),
    'angle': st.floats(15 * DEG, 40 * DEG),
    'fraction': st.floats(0.02, 1.0),   # position of v1 inside (H/a, 2H/a]
})


def s2_ramp(r: dict) -> dict:
    """An S2 ramp spec with v1 inside its existence interval."""
    lo = r['height'] / r['angle']
    return {'kind': 'constant_acceleration_velocity', 'height': r['height'],
            'velocity': lo * (1 + r['fraction']), 'angle': r['angle']}


@st.composite
def even_exponents(draw: st.DrawFn) -> list[int]:
    """2 < q < r < s, even, up to 50."""
    rest = draw(st.lists(st.integers(2, 25), min_size=3, max_size=3, unique=True))
    return [2] + sorted(2 * k for k in rest)


@SETTINGS
@given(r=ramps, rise=st.floats(3 * MM, 12 * MM), half=st.floats(40 * DEG, 80 * DEG),
       exps=even_exponents())
def test_polynomial_properties(r: dict, rise: float, half: float, exps: list[int]) -> None:
    """Random ramps and exponents: stated continuity holds, lobe symmetric, h >= 0."""
    law = from_spec({'family': 'polynomial', 'ramp': s2_ramp(r), 'rise': rise,
                     'half_angle': half, 'exponents': exps}, 'L')
    check_continuity(law)
    check_symmetric(law)
    assert law.continuity_order == 1
    a = np.linspace(*law.support, 2001)
    assert np.all(law(a) >= -1e-15)
    assert law(0.0) == pytest.approx(r['height'] + rise, rel=1e-12)


@SETTINGS
@given(r=ramps, rise=st.floats(5 * MM, 10 * MM), half=st.floats(45 * DEG, 75 * DEG),
       family=st.sampled_from([[2, 6, 10, 14], [2, 8, 14, 20], [2, 10, 18, 26]]))
def test_polynomial_monotone_for_practical_data(r: dict, rise: float, half: float,
                                                family: list[int]) -> None:
    """Within practical data (ramp velocity small against the base-section mean
    slope) the flanks are monotone."""
    ramp = s2_ramp(r)
    assume(ramp['velocity'] * half < 0.5 * rise)
    law = from_spec({'family': 'polynomial', 'ramp': ramp, 'rise': rise,
                     'half_angle': half, 'exponents': family}, 'L')
    assert law.flank_is_monotone()


@SETTINGS
@given(r=ramps, rise=st.floats(3 * MM, 10 * MM), half=st.floats(40 * DEG, 70 * DEG),
       p1=st.floats(0.2, 0.45), p3=st.floats(0.0, 0.3), ratio=st.floats(0.2, 1.0))
def test_constant_acceleration_properties(r: dict, rise: float, half: float, p1: float,
                                          p3: float, ratio: float) -> None:
    """Random constant-acceleration cams (2 or 3 segments): C1, symmetric, nose = H."""
    spec = {'family': 'constant_acceleration', 'ramp': s2_ramp(r), 'rise': rise,
            'half_angle': half, 'positive_width': p1 * half}
    if p3 > 0.05:
        spec.update(nose_width=p3 * half, nose_ratio=ratio)
    try:
        law = from_spec(spec, 'L')
    except InputError as exc:      # widths that give no +/- acceleration pattern
        assert exc.key == 'L.positive_width'
        return
    check_continuity(law)
    check_symmetric(law)
    assert law(0.0) == pytest.approx(r['height'] + rise, rel=1e-12)
    assert abs(law(-1e-12, 1)) < 1e-9


@SETTINGS
@given(r=ramps, rise=st.floats(3 * MM, 10 * MM), w1=st.floats(10 * DEG, 25 * DEG),
       w2=st.floats(25 * DEG, 50 * DEG),
       second=st.sampled_from(['quarter_sine', 'half_sine']))
def test_composite_properties(r: dict, rise: float, w1: float, w2: float,
                              second: str) -> None:
    """half-sine + (quarter|half)-sine segments: stated continuity and symmetry."""
    try:
        law = from_spec({'family': 'composite', 'ramp': s2_ramp(r), 'rise': rise,
                         'segments': [{'shape': 'half_sine', 'width': w1},
                                      {'shape': second, 'width': w2}]}, 'L')
    except InputError as exc:     # ramp ending with acceleration (no CV part): not C2
        assert exc.key == 'L.segments' and r['fraction'] > 1 - 1e-9
        return
    assert [j.achieved for j in law.junction_report][2] >= 2
    check_continuity(law)
    check_symmetric(law)


@SETTINGS
@given(lift=st.floats(4 * MM, 12 * MM), half=st.floats(40 * DEG, 70 * DEG),
       v=st.floats(0.005, 0.02), rpm=st.floats(300, 2000))
def test_polydyne_properties(lift: float, half: float, v: float, rpm: float) -> None:
    """Random practical polydyne cams: either flagged infeasible (naming the speed) or
    C2 at the ramp end, symmetric, with the inversion identity at random angles."""
    spec = {'family': 'polydyne', 'rocker_ratio': 1.5, 'lash': 0.25 * MM, 'mass': 0.12,
            'stiffness': 1.2e7, 'spring_rate': 3e4, 'spring_preload': 250.0,
            'design_cam_speed_rpm': rpm, 'valve_lift': lift, 'half_angle': half,
            'ramp_velocity': v * MM / DEG}
    try:
        law = from_spec(spec, 'L')
    except InputError as exc:    # infeasible contact, or a non-monotone y_d or h
        assert exc.key in ('L.design_cam_speed_rpm', 'L.half_angle')
        return
    check_continuity(law)
    check_symmetric(law)
    assert law.flank_is_monotone()
    seg, tr = law.valve_motion[0], law.train
    a = np.linspace(seg.lo, seg.hi, 50)
    rhs = tr.lash + tr.spring_preload / tr.stiffness + (1 + tr.spring_rate / tr.stiffness) \
        * seg(a) + tr.eps * seg(a, 2)
    assert np.allclose(tr.rocker_ratio * law(a), rhs, rtol=1e-12, atol=1e-16)


@SETTINGS
@given(order=st.integers(3, 30), half=st.floats(50 * DEG, 120 * DEG),
       lift=st.floats(2 * MM, 12 * MM), end=st.sampled_from([2, 4]))
def test_harmonic_properties(order: int, half: float, lift: float, end: int) -> None:
    """Minimum-acceleration N-harmonic cams: C3 at the ends, symmetric."""
    assume(order >= 3 + (end == 4))
    try:
        law = from_spec({'family': 'harmonic', 'order': order, 'half_angle': half,
                         'max_lift': lift, 'end_order': end}, 'L')
    except InputError as exc:
        assert exc.key == 'L.order'
        return
    check_continuity(law)
    check_symmetric(law)
    assert law(0.0) == pytest.approx(lift, rel=1e-10)


@pytest.mark.parametrize('fraction', [2e-9, 1e-6, 1e-3, 0.999999, 1.0])
def test_near_degenerate_s2_ramps(fraction: float) -> None:
    """v1 just above H1/alpha1 (beta1 -> 0, C_B -> inf) and at 2 H1/alpha1 (no CV part):
    the law stays finite, continuous, and reaches H1 at the ramp end."""
    h1, a1 = 0.3 * MM, 30 * DEG
    ramp = {'kind': 'constant_acceleration_velocity', 'height': h1,
            'velocity': h1 / a1 * (1 + fraction), 'angle': a1}
    law = from_spec({'family': 'polynomial', 'ramp': ramp, 'rise': 8 * MM,
                     'half_angle': 50 * DEG}, 'L')
    assert law(-50 * DEG) == pytest.approx(h1, rel=1e-12)
    a = np.linspace(*law.support, 5001)
    for nu in range(4):
        assert np.all(np.isfinite(law(a, nu)))
    check_continuity(law)


def test_degenerate_ramp_rejected() -> None:
    """v1 = H1/alpha1 (1 + 1e-12) is below the representable limit: rejected."""
    ramp = {'kind': 'constant_acceleration_velocity', 'height': 0.3 * MM,
            'velocity': 0.3 * MM / (30 * DEG) * (1 + 1e-12), 'angle': 30 * DEG}
    with pytest.raises(InputError, match=r'^L\.ramp\.velocity'):
        from_spec({'family': 'polynomial', 'ramp': ramp, 'rise': 8 * MM,
                   'half_angle': 50 * DEG}, 'L')


def test_huge_sample_counts_and_shapes() -> None:
    """10^6 points evaluate fast with the input's shape (2-D array in, 2-D out)."""
    law = from_spec({'family': 'preset', 'name': 'flat_tappet_intake'}, 'L')
    a = np.linspace(-2, 2, 1_000_000).reshape(1000, 1000)
    out = law(a, 2)
    assert out.shape == (1000, 1000) and np.all(np.isfinite(out))


@SETTINGS
@given(start=st.floats(1 * DEG, 25 * DEG), alpha4=st.floats(25 * DEG, 60 * DEG),
       frac=st.floats(0.3, 0.7), h_a=st.floats(0.05 * MM, 0.25 * MM),
       h5=st.floats(0.5 * MM, 3 * MM), a5=st.floats(10 * DEG, 30 * DEG))
def test_dual_peak_properties(start: float, alpha4: float, frac: float, h_a: float,
                              h5: float, a5: float) -> None:
    """Random dual-peak cams: either a clear rejection (negative or overshooting
    connection) or C2 at both connection ends, h >= 0 everywhere, stated continuity."""
    spec = {'family': 'dual_peak',
            'ramp': {'height': 0.3 * MM, 'velocity': 0.015 * MM / DEG, 'angle': 30 * DEG},
            'rise': 8 * MM, 'half_angle': 50 * DEG,
            'connection': {'start': start, 'angle': alpha4, 'point_angle': frac * alpha4,
                           'point_lift': h_a},
            'secondary': {'rise': h5, 'half_angle': a5,
                          'ramp': {'height': 0.25 * MM, 'velocity': 0.0125 * MM / DEG,
                                   'angle': 30 * DEG}}}
    try:
        law = from_spec(spec, 'L')
    except InputError as exc:    # negative/overshooting connection, or wider than 360 deg
        assert exc.key == 'L.connection.point_lift' or (exc.key == 'L'
                                                        and 'support' in str(exc))
        return
    check_continuity(law)
    a = np.linspace(*law.support, 8001)
    assert np.all(law(a) >= -1e-15)
    cut = 50 * DEG + start
    ends = [j for j in law.junction_report
            if min(abs(j.alpha - cut), abs(j.alpha - cut - alpha4)) < 1e-12]
    assert len(ends) == 2 and all(j.achieved >= 2 for j in ends)


def with_value(doc: dict, path: tuple, value: object) -> dict:
    """A deep copy of ``doc`` with the item at ``path`` (keys/indices) set to ``value``."""
    import copy

    out = copy.deepcopy(doc)
    node = out
    for k in path[:-1]:
        node = node[k]
    node[path[-1]] = value
    return out


def test_garbage_in_every_parameter_of_every_docs_example() -> None:
    """Stress: each parameter of each docs/lift_laws.md example replaced by None, text,
    a negative, zero, 1e300, NaN, a list or a mapping: from_spec either builds
    a law or raises InputError - never another exception, never a non-finite law."""
    import re
    from pathlib import Path

    import yaml

    text = (Path(__file__).resolve().parent.parent / 'docs' / 'lift_laws.md').read_text()
    specs = [yaml.safe_load(b)['lift_law']
             for b in re.findall(r'```yaml\n(.*?)```', text, re.S) if 'lift_law' in b]
    bad = [None, 'abc', -1, 0, 1e300, float('nan'), [], {'x': 1}]

    def paths(d: object, pre: tuple = ()) -> list[tuple]:
        out: list[tuple] = []
        items = d.items() if isinstance(d, dict) else (
            enumerate(d) if isinstance(d, list) else ())
        for k, v in items:
            out.append(pre + (k,))
            if not (isinstance(d, list) and len(d) > 3):   # long numeric lists: once
                out.extend(paths(v, pre + (k,)))
        return out

    for spec in specs:
        for path in paths(spec):
            for value in bad:
                try:
                    law = from_spec(with_value(spec, path, value), 'L')
                except InputError:
                    continue
                a = np.linspace(*law.support, 101)
                assert np.all(np.isfinite(law.derivatives(a))), (path, value)
