"""Optimisation of cam designs (``cam_design.optimize``, ``cam-bench design optimize``).

Independent truth:

* Bang-bang: a rise of lift H over the half-angle alpha0 with h'' bounded by +A (up)
  and -D (down), and h <= H, has the largest area when it accelerates at +A, then
  decelerates at -D until it reaches H with h' = 0, then dwells at H. With peak velocity
  V: V = A w1 = D w2 and H = V (w1 + w2) / 2, so V = sqrt(2 H / (1/A + 1/D)),
  w1 = V/A, w2 = V/D. The composite family with a dwell segment must find w1, w2.
* Two-segment constant acceleration (no dwell): h'(alpha0) = 0 and h(alpha0) = H give
  V = 2H/alpha0 for any switch phi1; the area is H (alpha0 + phi2)/3, largest for the
  shortest phi1 = V/A that the bound on +A allows (when D is not binding).
* Constraints are checked on the returned lift table by finite differences, not by the
  optimiser's own metrics; relaxing a bound never lowers the optimum.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from cam_design.errors import InputError
from cam_design.lift_laws import from_spec
from cam_design.optimize import optimize, parse_spec
from cam_metrology.cli import main

H = 0.008
A_POS, A_NEG = 0.06, 0.025


def _bang_bang(a_pos: float, a_neg: float) -> tuple[float, float]:
    v = math.sqrt(2 * H / (1 / a_pos + 1 / a_neg))
    return v / a_pos, v / a_neg


def test_composite_recovers_the_bang_bang_optimum() -> None:
    spec = parse_spec({'family': 'composite',
                       'fixed': {'max_lift': H, 'half_duration_deg': 60},
                       'constraints': {'max_positive_acceleration': A_POS,
                                       'max_negative_acceleration': A_NEG}})
    res = optimize(spec)
    w1, w2 = _bang_bang(A_POS, A_NEG)
    assert res.status == 'optimal'
    assert res.parameters['segments[0].width'] == pytest.approx(w1, rel=1e-6)
    assert res.parameters['segments[1].width'] == pytest.approx(w2, rel=1e-6)
    assert all(c['active'] for c in res.constraints.values())      # both bounds active
    # the area of the closed form: up + down + dwell, over the whole symmetric lobe
    a0 = math.radians(60)
    area = 2 * (A_POS * w1 ** 3 / 6 + H * w2 - A_NEG * w2 ** 3 / 6 + H * (a0 - w1 - w2))
    assert res.metrics['fullness'] == pytest.approx(area / (H * 2 * a0), rel=1e-5)


def test_constant_acceleration_switch_in_closed_form() -> None:
    a0 = math.radians(60)
    spec = parse_spec({'family': 'constant_acceleration',
                       'fixed': {'max_lift': H, 'half_duration_deg': 60},
                       'objective': 'fullness',
                       'constraints': {'max_positive_acceleration': A_POS,
                                       'max_negative_acceleration': A_NEG}})
    res = optimize(spec)
    phi1 = (2 * H / a0) / A_POS
    assert res.parameters['positive_width'] == pytest.approx(phi1, rel=1e-6)
    assert res.constraints['max_positive_acceleration']['active']
    assert not res.constraints['max_negative_acceleration']['active']
    assert res.metrics['fullness'] == pytest.approx((a0 + (a0 - phi1)) / 3 / a0, rel=1e-5)
    assert res.start['improvement'] > 0


def test_constraints_hold_on_the_returned_table() -> None:
    """Second differences of the lift table (a fine resample of the returned lift_law
    block, as a user would paste it) stay within the bounds."""
    spec = parse_spec({'family': 'composite',
                       'fixed': {'max_lift': H, 'half_duration_deg': 60},
                       'constraints': {'max_positive_acceleration': A_POS,
                                       'max_negative_acceleration': A_NEG}})
    res = optimize(spec)
    law = from_spec(res.lift_law, 'pasted')
    a = np.linspace(*law.support, 120001)
    h = law(a, 0)
    h2 = np.diff(h, 2) / (a[1] - a[0]) ** 2
    assert h2.max() <= A_POS * (1 + 1e-5) and -h2.min() <= A_NEG * (1 + 1e-5)
    table = res.table
    assert table['lift_m'][0] == pytest.approx(0.0, abs=1e-12)
    assert max(table['lift_m']) == pytest.approx(H, rel=1e-9)


def test_relaxing_a_constraint_never_lowers_the_optimum() -> None:
    values = []
    for a_pos in (0.03, 0.045, 0.06, 0.09, 0.2):
        spec = parse_spec({'family': 'composite', 'starts': 2,
                           'fixed': {'max_lift': H, 'half_duration_deg': 60},
                           'constraints': {'max_positive_acceleration': a_pos,
                                           'max_negative_acceleration': A_NEG}})
        values.append(optimize(spec).metrics['fullness'])
    assert all(b >= a - 1e-9 for a, b in zip(values, values[1:])), values
    assert values[-1] > values[0]


PISTON = {'crank_radius': 0.04, 'rod_length': 0.14, 'clearance': 0.0012,
          'opening_crank_angle': -0.3}


def _clearance_by_hand(law, piston: dict) -> float:
    """min over the lobe of s(phi) + y0 - h: exact slider-crank, phi from the opening."""
    a = np.linspace(*law.support, 200001)
    h = law(a, 0)
    a_open = a[np.nonzero(h > 0)[0][0]]
    phi = piston['opening_crank_angle'] + 2 * (a - a_open)
    r, rod = piston['crank_radius'], piston['rod_length']
    s = r * (1 - np.cos(phi)) + rod - np.sqrt(rod ** 2 - (r * np.sin(phi)) ** 2)
    return float(np.min(s + piston['clearance'] - h))


def test_valve_piston_clearance_constraint_holds_and_binds() -> None:
    doc = {'family': 'constant_acceleration', 'fixed': {'max_lift': H, 'half_duration_deg': 60},
           'constraints': {'max_positive_acceleration': A_POS,
                           'max_negative_acceleration': A_NEG},
           'piston': PISTON}
    free = optimize(parse_spec(doc))
    assert _clearance_by_hand(from_spec(free.lift_law, 'x'), PISTON) < 0.0005  # it binds
    fullness = []
    for limit in (0.0005, 0.0004):
        doc['constraints'] = {**doc['constraints'], 'min_valve_piston_clearance': limit}
        res = optimize(parse_spec(doc))
        assert res.status == 'optimal'
        c = res.constraints['min_valve_piston_clearance']
        assert c['active'] and c['value'] == pytest.approx(limit, rel=1e-6)
        assert _clearance_by_hand(from_spec(res.lift_law, 'x'), PISTON) == pytest.approx(
            limit, rel=5e-4)   # 0.25 um: the 4001-sample grid
        fullness.append(res.metrics['fullness'])
    assert free.metrics['fullness'] > fullness[1] > fullness[0]   # relaxing never hurts


def test_nose_oil_film_has_its_closed_form_ceiling() -> None:
    """Flat tappet, (2.12) at the nose: h_min = K (R0 + H) sqrt(g |2g - 1|) with
    g = 1 + h''/(R0 + H). Below g = 1/2 its largest value is K (R0 + H)/sqrt(8), at
    g = 1/4: a limit just under it forces h''(nose) = -3/4 (R0 + H); one over it is
    infeasible while the deceleration bound keeps g < 1/2."""
    r0, k = 0.02, 1e-4
    ceiling = k * (r0 + H) / math.sqrt(8)
    doc = {'family': 'constant_acceleration', 'fixed': {'max_lift': H, 'half_duration_deg': 60},
           'constraints': {'max_positive_acceleration': A_POS,
                           'max_negative_acceleration': A_NEG},
           'base_radius': r0, 'lubrication': {'k_film': k}}
    doc['constraints']['min_nose_oil_film'] = 0.9995 * ceiling
    res = optimize(parse_spec(doc))
    assert res.status == 'optimal'
    law = from_spec(res.lift_law, 'x')
    g = 1 + float(law(0.0, 2)) / (r0 + H)
    assert g == pytest.approx(0.25, abs=0.02)
    assert k * (r0 + H) * math.sqrt(g * abs(2 * g - 1)) >= 0.9995 * ceiling * (1 - 1e-6)
    doc['constraints']['min_nose_oil_film'] = 1.01 * ceiling
    assert optimize(parse_spec(doc)).status == 'infeasible'


def test_infeasible_spec_names_the_most_violated_constraint() -> None:
    """H = 8 mm over 60 deg needs V = 2H/alpha0 and so a1 >= V/alpha0 = 0.0146 m/rad^2
    even with the whole flank accelerating: a bound of 0.01 cannot be met."""
    spec = parse_spec({'family': 'constant_acceleration',
                       'fixed': {'max_lift': H, 'half_duration_deg': 60},
                       'constraints': {'max_positive_acceleration': 0.01}})
    res = optimize(spec)
    assert res.status == 'infeasible'
    assert 'max_positive_acceleration' in res.message
    assert not res.constraints['max_positive_acceleration']['satisfied']


def test_integer_exponents_by_differential_evolution() -> None:
    ramp = {'kind': 'constant_acceleration_velocity', 'height': 3.0e-4,
            'velocity': 8.594366926962348e-4, 'angle': math.radians(30)}
    spec = parse_spec({'family': 'polynomial', 'seed': 1, 'generations': 15,
                       'fixed': {'rise': H, 'half_angle': math.radians(50), 'ramp': ramp},
                       'free': {'exponents[2]': [8, 24, True], 'exponents[3]': [26, 40, True]},
                       'constraints': {'max_negative_acceleration': 0.05}})
    res = optimize(spec)
    assert res.status == 'optimal'
    e2, e3 = res.parameters['exponents[2]'], res.parameters['exponents[3]']
    assert isinstance(e2, int) and 8 <= e2 <= 24 and 26 <= e3 <= 40
    law = from_spec(res.lift_law, 'x')
    a = np.linspace(*law.support, 20001)
    assert -law(a, 2).min() <= 0.05 * (1 + 1e-9)
    # better than the book's 2-6-10-14 example on the same ramp and angles
    base = from_spec({'family': 'polynomial', 'rise': H, 'half_angle': math.radians(50),
                      'ramp': ramp, 'exponents': [2, 6, 10, 14]}, 'base')
    from cam_design.checks import fullness
    ab = np.linspace(*base.support, 20001)
    assert res.metrics['fullness'] > fullness(ab, base(ab, 0))


def test_jump_speed_objective_reports_the_sdof_value() -> None:
    """The jump speed the optimiser reports is what an independent SDOF run sees: no
    separation 15 rpm below it, a separation 15 rpm above it."""
    from cam_design.optimize import _sdof_params
    from cam_design.valve_train.sdof import simulate

    vt = {'rocker_ratio': 1.5, 'lash': 2.5e-4, 'mass': 0.12, 'stiffness': 1.2e7,
          'damping': 60, 'spring_rate': 3e4, 'spring_preload': 250}
    ramp = {'kind': 'constant_velocity', 'height': 3e-4, 'velocity': 8.594366926962348e-4}
    spec = parse_spec({'family': 'constant_acceleration', 'generations': 2, 'seed': 3,
                       'fixed': {'max_lift': H, 'half_duration_deg': 70, 'ramp': ramp},
                       'valve_train': vt, 'objective': 'jump_speed_rpm'})
    res = optimize(spec)
    jump = res.metrics['jump_speed_rpm']
    law, params = from_spec(res.lift_law, 'x'), _sdof_params(vt)
    assert not simulate(law, params, jump - 15, step_deg=1.0).events.separations
    assert simulate(law, params, jump + 15, step_deg=1.0).events.separations


@pytest.mark.parametrize('doc, key', [
    ({'family': 'fb2'}, 'family'),
    ({'family': 'composite', 'fixed': {'max_lift': H, 'half_duration_deg': 200}},
     'fixed.half_duration_deg'),
    ({'family': 'constant_acceleration', 'fixed': {'max_lift': H, 'half_duration_deg': 60},
      'constraints': {'max_speed': 1}}, 'constraints.max_speed'),
    ({'family': 'constant_acceleration', 'fixed': {'max_lift': H, 'half_duration_deg': 60},
      'free': {'positive_width': [0.5, 0.1]}}, 'free.positive_width'),
    ({'family': 'constant_acceleration', 'fixed': {'max_lift': H, 'half_duration_deg': 60},
      'objective': 'jump_speed_rpm'}, 'valve_train'),
    ({'family': 'constant_acceleration', 'fixed': {'max_lift': H, 'half_duration_deg': 60},
      'constraints': {'min_radius_of_curvature': 0.002}}, 'base_radius'),
    ({'family': 'composite', 'fixed': {'max_lift': H}, 'free': {'segments[7].width': [0, 1]}},
     'free.segments[7].width'),
    ({'family': 'constant_acceleration', 'colour': 'red'}, 'colour'),
])
def test_bad_specs_name_the_key(doc: dict, key: str) -> None:
    with pytest.raises(InputError) as info:
        parse_spec(doc)
    assert info.value.key == key


def test_cli_summary_exit_codes_and_json(tmp_path, capsys) -> None:
    good = tmp_path / 'spec.yaml'
    good.write_text('family: constant_acceleration\n'
                    'fixed: {max_lift: 0.008, half_duration_deg: 60}\n'
                    'objective: fullness\n'
                    'constraints: {max_positive_acceleration: 0.06, '
                    'max_negative_acceleration: 0.025}\n')
    assert main(['design', 'optimize', str(good)]) == 0
    out = capsys.readouterr().out
    assert 'status: optimal' in out and 'ACTIVE' in out and 'family: constant_acceleration' in out
    js = tmp_path / 'r.json'
    assert main(['design', 'optimize', str(good), '--json', str(js), '--plot',
                 str(tmp_path / 'p')]) == 0
    assert (tmp_path / 'p' / 'optimum.png').stat().st_size > 10000
    import json
    doc = json.loads(js.read_text())
    assert doc['status'] == 'optimal' and doc['lift_law']['family'] == 'constant_acceleration'
    bad = tmp_path / 'bad.yaml'
    bad.write_text(good.read_text().replace('0.06', '0.01'))
    assert main(['design', 'optimize', str(bad)]) == 1          # infeasible
    assert 'infeasible' in capsys.readouterr().out
    wrong = tmp_path / 'wrong.yaml'
    wrong.write_text('family: mfb2\n')
    assert main(['design', 'optimize', str(wrong)]) == 2
    err = capsys.readouterr().err
    assert err.count('\n') == 1 and 'family' in err and 'constant_acceleration' in err


DEG, MM = math.pi / 180, 1e-3
S2_RAMP = {'kind': 'constant_acceleration_velocity', 'height': 0.3 * MM,
           'velocity': 0.015 * MM / DEG, 'angle': 30 * DEG}


@pytest.mark.parametrize('doc, name, limit', [
    ({'family': 'polydyne', 'generations': 4,
      'fixed': {'rocker_ratio': 1.5, 'lash': 0.25 * MM, 'mass': 0.12, 'stiffness': 1.2e7,
                'spring_rate': 3e4, 'spring_preload': 250.0, 'design_cam_speed_rpm': 1500,
                'valve_lift': 8 * MM, 'half_angle': 50 * DEG}},
     'max_positive_acceleration', 0.05),
    ({'family': 'dual_peak', 'starts': 2,
      'fixed': {'ramp': S2_RAMP, 'rise': 8 * MM, 'half_angle': 50 * DEG,
                'connection': {'start': 5 * DEG, 'angle': 40 * DEG, 'point_angle': 20 * DEG,
                               'point_lift': 0.1 * MM},
                'secondary': {'rise': 1.5 * MM, 'half_angle': 20 * DEG,
                              'ramp': {'height': 0.25 * MM, 'velocity': 0.0125 * MM / DEG,
                                       'angle': 30 * DEG}}}},
     'max_positive_acceleration', 0.08),
], ids=['polydyne', 'dual_peak'])
def test_polydyne_and_dual_peak_families_meet_their_constraint(
        doc: dict, name: str, limit: float) -> None:
    """Both remaining families optimise; the constraint holds on finite differences of
    the pasted law (not the optimiser's own derivatives)."""
    res = optimize(parse_spec({**doc, 'constraints': {name: limit}}))
    assert res.status == 'optimal', res.message
    law = from_spec(res.lift_law, 'pasted')
    a = np.linspace(*law.support, 200001)
    d = a[1] - a[0]
    h = law(a, 0)
    value = (np.diff(h, 2) / d ** 2).max()
    assert value <= limit * (1 + 1e-3)
    assert res.metrics['fullness'] >= res.start['objective'] - 1e-9 or not res.start[
        'feasible']


def test_jerk_of_a_law_with_acceleration_steps_is_infinite() -> None:
    """A ramp junction or a constant-acceleration segment makes h'' jump: the jerk is a
    Dirac pulse, so max_jerk can never hold (finite differences of the table grow
    without bound as the step shrinks), and the optimiser says so."""
    doc = {'family': 'constant_acceleration', 'starts': 1,
           'fixed': {'max_lift': H, 'half_duration_deg': 60},
           'constraints': {'max_jerk': 10.0}}
    res = optimize(parse_spec(doc))
    assert res.status == 'infeasible' and 'max_jerk' in res.message
    law = from_spec(res.lift_law, 'x')
    fd = [np.abs(np.diff(law(np.linspace(*law.support, n), 0), 3)).max()
          / ((law.support[1] - law.support[0]) / (n - 1)) ** 3 for n in (2001, 20001)]
    assert fd[1] > 5 * fd[0]      # ten times finer, ten times larger: unbounded
