"""The cam card against closed forms (constant-acceleration lobe), the crank-degree
conversion and LSA against a hand-computed example, `cam-bench card`, and nominal-profile
files written by `design law --nominal` read back by the gauge reader."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from cam_design import cam_card as cc
from cam_design.errors import InputError
from cam_design.lift_laws.registry import from_spec
from cam_metrology.cli import main

DEG = math.pi / 180.0
# constant acceleration without ramps: H = 8 mm, alpha0 = 60 deg, phi1 = 20 deg
H, A0, P1 = 8e-3, 60 * DEG, 20 * DEG
P2 = A0 - P1
A1 = 2 * H / (P1 * A0)          # m/rad^2, positive acceleration
A2 = A1 * P1 / P2               # m/rad^2, magnitude of the negative one
SPEC = {'family': 'constant_acceleration', 'ramp': 'none', 'rise': H, 'half_angle': A0,
        'positive_width': P1}


def closed_events(y: float) -> tuple[float, float]:
    """Opening/closing [rad] at height y from the inverse of the closed-form lift:
    h = A1 t^2 / 2 for t <= phi1, h = H - A2 (alpha0 - t)^2 / 2 after (t from the start)."""
    t = math.sqrt(2 * y / A1) if y <= A1 * P1 ** 2 / 2 else A0 - math.sqrt(2 * (H - y) / A2)
    return -A0 + t, A0 - t


HEIGHTS = (1e-4, 1e-3, 1.27e-3, 4e-3, 7.9e-3)


def test_design_card_against_closed_forms() -> None:
    card = cc.card_from_law(from_spec(SPEC), HEIGHTS, rocker_ratio=1.5)
    assert card['max_lift_m'] == pytest.approx(H, abs=1e-12)
    assert card['max_valve_lift_m'] == pytest.approx(1.5 * H, abs=1e-12)
    for entry, y in zip(card['heights'], HEIGHTS):
        o, c = closed_events(y)
        assert entry['height_m'] == y
        assert entry['opening_deg'] == pytest.approx(math.degrees(o), abs=1e-8)
        assert entry['closing_deg'] == pytest.approx(math.degrees(c), abs=1e-8)
        assert entry['duration_cam_deg'] == pytest.approx(math.degrees(c - o), abs=1e-8)
        assert entry['duration_crank_deg'] == pytest.approx(2 * math.degrees(c - o), abs=2e-8)
        assert entry['centreline_deg'] == pytest.approx(0.0, abs=1e-8)
    # area of one flank: A1 phi1^3 / 6 + H phi2 - A2 phi2^3 / 6, twice
    area = 2 * (A1 * P1 ** 3 / 6 + H * P2 - A2 * P2 ** 3 / 6)
    assert card['area_m_rad'] == pytest.approx(area, rel=1e-10)
    assert card['fullness'] == pytest.approx(area / (H * 2 * A0), rel=1e-6)
    assert card['velocity_max_si'] == pytest.approx(A1 * P1, rel=1e-3)   # on the grid
    assert card['velocity_max_mm_per_deg'] == pytest.approx(A1 * P1 * 1e3 * DEG, rel=1e-3)
    assert card['acceleration_max_si'] == pytest.approx(A1, rel=1e-9)
    assert card['acceleration_min_mm_per_deg2'] == pytest.approx(-A2 * 1e3 * DEG ** 2,
                                                                 rel=1e-9)


def test_measured_card_of_a_shifted_noisy_table() -> None:
    law = from_spec(SPEC)
    shift = 0.3 * DEG
    a = np.arange(-180, 180, 0.1) * DEG
    rng = np.random.default_rng(5)
    exact = cc.card_from_table(a, law(a - shift), HEIGHTS[:3], law)
    for entry, y in zip(exact['heights'], HEIGHTS):
        o, c = closed_events(y)
        assert entry['opening_deg'] == pytest.approx(math.degrees(o + shift), abs=1e-7)
        assert entry['closing_deg'] == pytest.approx(math.degrees(c + shift), abs=1e-7)
    assert exact['max_lift_m'] == pytest.approx(H, abs=1e-10)
    # 0.5 um of noise, no reference (a local quadratic): events to ~0.01 deg
    noisy = cc.card_from_table(a, law(a) + rng.normal(0, 5e-7, a.size), (1e-3,))
    o, c = closed_events(1e-3)
    assert noisy['heights'][0]['opening_deg'] == pytest.approx(math.degrees(o), abs=0.01)
    assert noisy['heights'][0]['closing_deg'] == pytest.approx(math.degrees(c), abs=0.01)
    assert noisy['max_lift_m'] == pytest.approx(H, abs=1e-6)


def test_height_above_max_lift_names_the_key() -> None:
    with pytest.raises(InputError) as err:
        cc.card_from_law(from_spec(SPEC), (1e-3, 9e-3), key='--heights-mm')
    assert err.value.key == '--heights-mm[1]' and 'below the max lift (8.0000 mm)' in str(
        err.value)
    with pytest.raises(InputError):
        cc.parse_heights_mm('1,-2')
    assert cc.parse_heights_mm('1,1.27,0.1') == pytest.approx((1e-3, 1.27e-3, 1e-4))


def test_crank_events_and_lsa_hand_example() -> None:
    """Intake centreline 106 ATDC, exhaust 114 BTDC, both 240 crank deg at the height:
    IVO 14 BTDC, IVC 46 ABDC, EVO 54 BBDC, EVC 6 ATDC, LSA 110 cam deg."""
    card = {'centreline_deg': 0.0, 'heights': [
        {'height_m': 1e-3, 'opening_deg': -60.0, 'closing_deg': 60.0,
         'centreline_deg': 0.0}]}
    intake = cc.crank_events(card, 'intake', 106.0)['events'][0]
    assert intake['opens_btdc_deg'] == pytest.approx(14.0)
    assert intake['closes_abdc_deg'] == pytest.approx(46.0)
    exhaust = cc.crank_events(card, 'exhaust', 114.0)['events'][0]
    assert exhaust['opens_bbdc_deg'] == pytest.approx(54.0)
    assert exhaust['closes_atdc_deg'] == pytest.approx(6.0)
    assert cc.lobe_separation_deg(106.0, 114.0) == pytest.approx(110.0)
    with pytest.raises(InputError):
        cc.crank_events(card, 'inlet', 106.0)


def test_centreline_crank_hand_example() -> None:
    """Datum-relative timing by hand: TDC 10 cam deg after the datum; an intake nose at
    phase 63 -> 2 (63 - 10) = 106 ATDC; an exhaust at -47 -> 2 (-47 - 10) = -114 (114
    BTDC); a centreline 0.5 cam deg after the nose adds 1 crank deg; cylinder 2 (TDC
    360 crank deg after cylinder 1's) with its intake 180 cam deg later -> 106 again;
    direction -1 with the signs of phases and TDC reversed -> the same engine."""
    f = cc.centreline_crank_atdc
    assert f(63.0, 0.0, 1, 10.0) == pytest.approx(106.0, abs=1e-12)
    assert f(-47.0, 0.0, 1, 10.0) == pytest.approx(-114.0, abs=1e-12)
    assert f(63.0, 0.5, 1, 10.0) == pytest.approx(107.0, abs=1e-12)
    assert f(63.0 + 180.0 - 360.0, 0.0, 1, 10.0, 360.0) == pytest.approx(106.0, abs=1e-12)
    assert f(-63.0, 0.0, -1, -10.0) == pytest.approx(106.0, abs=1e-12)
    assert f(190.0, 0.0, 1, 0.0) == pytest.approx(-340.0, abs=1e-12)   # 380 - 720


@pytest.mark.parametrize('direction', [1, -1])
def test_card_of_a_scene_with_a_crank_datum(tmp_path, capsys, direction) -> None:
    """config/keyway_scene.yaml: intake 106 ATDC, exhaust 114 BTDC, LSA 110 cam deg; the
    events at 1 mm are the centreline -+ half the crank duration (hand rule). With the
    other direction, phases and TDC negated describe the same engine."""
    text = open('config/keyway_scene.yaml', encoding='utf-8').read()
    if direction == -1:
        text = (text.replace('direction: 1 ', 'direction: -1 ')
                .replace('1.0995574287564276', '-1.0995574287564276')
                .replace('-0.8203047484373349', '0.8203047484373349')
                .replace('tdc_deg: 10.0', 'tdc_deg: -10.0'))
    path = tmp_path / 'kw.yaml'
    path.write_text(text, encoding='utf-8')
    assert main(['card', str(path), '--heights-mm', '1', '--json', '-']) == 0
    doc = json.loads(capsys.readouterr().out)
    pair = doc['crank']['pairs'][0]
    assert pair['intake_centreline_atdc_deg'] == pytest.approx(106.0, abs=1e-9)
    assert pair['exhaust_centreline_btdc_deg'] == pytest.approx(114.0, abs=1e-9)
    assert pair['lobe_separation_deg'] == pytest.approx(110.0, abs=1e-9)
    half = doc['cards']['intake_1']['heights'][0]['duration_crank_deg'] / 2
    ev_in = doc['cards']['intake_1']['crank']['events'][0]
    ev_ex = doc['cards']['exhaust_1']['crank']['events'][0]
    assert ev_in['opens_btdc_deg'] == pytest.approx(half - 106.0, abs=1e-6)
    assert ev_in['closes_abdc_deg'] == pytest.approx(106.0 + half - 180.0, abs=1e-6)
    assert ev_ex['opens_bbdc_deg'] == pytest.approx(114.0 + half - 180.0, abs=1e-6)
    assert ev_ex['closes_atdc_deg'] == pytest.approx(half - 114.0, abs=1e-6)
    assert main(['card', str(path), '--heights-mm', '1']) == 0
    assert 'lobe separation 110.000 cam deg' in capsys.readouterr().out


def test_card_cli_on_the_default_scene(capsys) -> None:
    assert main(['card', 'config/default_scene.yaml', '--pair', 'lobe_1,lobe_2',
                 '--intake-centreline-deg', '106', '--heights-mm', '1', '--json', '-']) == 0
    doc = json.loads(capsys.readouterr().out)
    lsa = doc['lobe_separation']
    assert lsa['lobe_separation_deg'] == pytest.approx(110.0, abs=1e-9)   # 147 - 37
    assert lsa['exhaust_centreline_btdc_deg'] == pytest.approx(114.0, abs=1e-9)
    c1 = doc['cards']['lobe_1']
    assert c1['max_lift_m'] == pytest.approx(8.5e-3, abs=1e-9)
    dur = c1['heights'][0]['duration_crank_deg']
    assert c1['crank']['events'][0]['opens_btdc_deg'] == pytest.approx(dur / 2 - 106, abs=1e-6)
    assert main(['card', 'config/default_scene.yaml', '--pair', 'lobe_1,lobe_9']) == 2
    assert '--pair' in capsys.readouterr().err


@pytest.mark.parametrize('args,radius', [
    (['test/_nominal_law.yaml'], 0.0),
    (['config/default_scene.yaml', '--lobe', 'lobe_2'], 12.5e-3),
])
def test_nominal_file_round_trip(tmp_path, args, radius) -> None:
    from cam_metrology.inputs.lift_tables import read_gauge_file
    from cam_metrology.scene.parse import load_scene

    if args[0].startswith('test/_'):
        path = tmp_path / 'law.yaml'
        path.write_text('lift_law: ' + json.dumps(SPEC) + '\n')
        args = [str(path)]
        law = from_spec(SPEC)
    else:
        from cam_metrology.metrology.analysis import seen_lift
        scene = load_scene(args[0])
        law = seen_lift(scene.lobe('lobe_2'), scene.probe, scene.base_circle_radius,
                        tabulate_step=None)
    out = tmp_path / 'nominal.txt'
    assert main(['design', 'law', *args, '--nominal', str(out),
                 '--nominal-step-deg', '0.25']) == 0
    table = read_gauge_file(out)
    assert table.alpha.size == 1441
    assert table.follower == (('roller', radius) if radius else ('knife', 0.0))
    assert np.max(np.abs(table.lift - law(table.alpha))) < 1e-9
    card = cc.card_from_table(table.alpha, table.lift, (1e-3,), source='table')
    ref = cc.card_from_law(law, (1e-3,))
    assert card['heights'][0]['duration_cam_deg'] == pytest.approx(
        ref['heights'][0]['duration_cam_deg'], abs=2e-3)


def test_event_and_peak_uncertainties_match_the_scatter() -> None:
    """The reported standard uncertainties of measured events and max lift agree with
    their scatter over 60 noisy tables (ratio within 0.7..1.4: 60 runs give ~10 %)."""
    law = from_spec(SPEC)
    a = np.arange(-180, 180, 0.25) * DEG
    rng = np.random.default_rng(11)
    opens, peaks, s_open, s_peak = [], [], [], []
    for _ in range(60):
        h = law(a) + rng.normal(0, 1e-6, a.size)
        o, c = cc.table_events(a, h, 1e-3, law)
        at, peak = cc.table_peak(a, h, law)
        opens.append(o)
        peaks.append(peak)
        s_open.append(cc.table_events_std(a, h, 1e-3, (o, c), law)[0])
        s_peak.append(cc.table_peak_std(a, h, law, at))
    assert np.std(opens, ddof=1) / np.mean(s_open) == pytest.approx(1.0, abs=0.35)
    assert np.std(peaks, ddof=1) / np.mean(s_peak) == pytest.approx(1.0, abs=0.35)
    o, _ = closed_events(1e-3)
    assert abs(np.mean(opens) - o) < 4 * np.mean(s_open) / math.sqrt(60)


def test_scene_lobe_from_a_nominal_file(tmp_path, capsys) -> None:
    """design law --nominal writes the lobe as the scene probe sees it; a scene lobe
    that takes its design from that file (relative path, roller of the file's radius)
    reproduces the lift to 0.1 um over the lobe and stays on the base circle outside."""
    from cam_metrology.metrology.analysis import seen_lift
    from cam_metrology.scene.parse import load_scene

    scene = load_scene('config/default_scene.yaml')
    law = seen_lift(scene.lobe('lobe_2'), scene.probe, scene.base_circle_radius,
                    tabulate_step=None)
    (tmp_path / 'files').mkdir()
    out = tmp_path / 'files' / 'lobe_2.txt'
    assert main(['design', 'law', 'config/default_scene.yaml', '--lobe', 'lobe_2',
                 '--nominal', str(out), '--nominal-step-deg', '0.25']) == 0
    text = ('probe: {kind: roller, radius: 0.0125}\nbase_circle_radius: 0.0165\n'
            'lobes:\n  - {id: lobe_2, nominal_file: files/lobe_2.txt}\n')
    (tmp_path / 's.yaml').write_text(text)
    lobe = load_scene(tmp_path / 's.yaml').lobe('lobe_2')
    assert (lobe.follower.kind, lobe.follower.radius) == ('roller', 0.0125)
    assert lobe.nominal_file == str(out)
    a = np.radians(np.linspace(-179.9, 179.9, 7197))
    assert np.max(np.abs(lobe.lift(a) - law(a))) < 1e-7
    lo, hi = lobe.lift.support
    assert np.all(lobe.lift(a[(a < lo) | (a > hi)]) == 0.0)
    capsys.readouterr()


@pytest.mark.parametrize('edit,key', [
    ('nominal_file: nope.txt', 'lobes[0].nominal_file'),
    ('nominal_file: files/lobe.txt, follower: flat', 'lobes[0].follower'),
    ('nominal_file: files/lobe.txt, lift_law: {family: preset, name: flat_tappet_intake}',
     'lobes[0].lift'),
])
def test_scene_nominal_file_bad_input(tmp_path, edit, key) -> None:
    from cam_metrology.report.nominal_file import law_gauge_text
    from cam_metrology.scene.parse import load_scene

    (tmp_path / 'files').mkdir()
    (tmp_path / 'files' / 'lobe.txt').write_text(law_gauge_text(from_spec(SPEC), 0.5, 0.0))
    (tmp_path / 's.yaml').write_text('probe: {kind: knife}\nbase_circle_radius: 0.02\n'
                                     f'lobes:\n  - {{id: l1, {edit}}}\n')
    with pytest.raises(InputError) as exc:
        load_scene(tmp_path / 's.yaml')
    assert exc.value.key == key


def test_reconstruct_writes_a_nominal_file(tmp_path, capsys) -> None:
    """reconstruct --nominal: the reconstructed lift read back to 0.1 um at every row."""
    from cam_metrology.inputs.lift_tables import read_gauge_file

    law = from_spec(SPEC)
    a = np.radians(np.arange(-180.0, 180.0, 0.2))
    csv = tmp_path / 't.csv'
    csv.write_text('alpha_deg,lift_mm\n' + ''.join(
        f'{x:.6f},{y:.9f}\n' for x, y in zip(np.degrees(a), law(a) * 1e3)))
    out = tmp_path / 'rec.txt'
    assert main(['reconstruct', str(csv), '--follower', 'roller', '--radius', '0.01',
                 '--method', 'spline', '--nominal', str(out), '--json',
                 str(tmp_path / 'r.json')]) == 0
    table = read_gauge_file(out)
    assert table.follower == ('roller', 0.01) and table.alpha.size == 3601
    doc = json.loads((tmp_path / 'r.json').read_text())
    assert doc['features']
    # against the exact law: the reconstruction itself is within its own error, and
    # the file carries it to 0.1 um (here: the spline of exact data, < 0.1 um too)
    assert np.max(np.abs(table.lift - law(table.alpha))) < 1e-7
    assert main(['reconstruct', str(csv), '--follower', 'flat', '--nominal',
                 str(tmp_path / 'flat.txt')]) == 2
    assert '--nominal' in capsys.readouterr().err


@pytest.mark.parametrize('unit_args,angle_scale,length_scale', [
    ([], 1.0 / DEG, 1e3),                                        # deg, mm (the default)
    (['--angle-unit', 'rad', '--length-unit', 'm'], 1.0, 1.0),
    (['--angle-unit', 'deg', '--length-unit', 'um'], 1.0 / DEG, 1e6)])
def test_card_of_a_gauge_file_in_any_unit(tmp_path, capsys, unit_args, angle_scale,
                                          length_scale) -> None:
    """`card TABLE --angle-unit/--length-unit`: the same lobe written in rad/m or deg/um
    gives the closed-form card (durations within 0.02 deg at 0.1 deg sampling, max lift
    within 0.01 um); a scene with a unit option is refused naming the option."""
    law = from_spec(SPEC)
    alpha = np.linspace(-math.pi, math.pi, 3601)
    rows = [f'{a * angle_scale:.12g} {law(a) * length_scale:.12g}' for a in alpha]
    path = tmp_path / 'lobe.txt'
    path.write_text('\n'.join(['0', str(alpha.size - 1)] + rows) + '\n', encoding='utf-8')
    assert main(['card', str(path), *unit_args, '--heights-mm', '1,4', '--json', '-']) == 0
    card = next(iter(json.loads(capsys.readouterr().out)['cards'].values()))
    assert card['max_lift_m'] == pytest.approx(H, abs=1e-8)
    for entry, y in zip(card['heights'], (1e-3, 4e-3)):
        opening, closing = closed_events(y)
        assert entry['opening_deg'] == pytest.approx(opening / DEG, abs=0.02)
        assert entry['duration_cam_deg'] == pytest.approx((closing - opening) / DEG, abs=0.02)
    assert main(['card', 'config/default_scene.yaml', '--angle-unit', 'rad']) == 2
    assert '--angle-unit' in capsys.readouterr().err


def test_law_area_against_the_closed_form_and_adaptive_quadrature() -> None:
    """The card's area rule (composite Gauss-Legendre, one vectorised call of the law)
    against the closed form of the constant-acceleration lobe, and against scipy's
    adaptive quad (1e-12 relative) on a smoothed 3600-row table lobe with h'' jumps."""
    from scipy.integrate import quad

    from cam_design.lift_table.lobe_table import lobe_law
    from cam_design.lift_table.truth_lobes import families, measured_table

    law = from_spec(SPEC)
    lo, hi = law.support
    # each flank: A1 P1^3 / 6 + H P2 - A2 P2^3 / 6 [m rad]
    closed = 2.0 * (A1 * P1 ** 3 / 6.0 + H * P2 - A2 * P2 ** 3 / 6.0)
    breaks = sorted({lo, hi, *(j for j in getattr(law, 'junctions', ()) if lo < j < hi)})
    assert cc.law_area(law, breaks) == pytest.approx(closed, rel=1e-12, abs=1e-15)
    fam = next(f for f in families() if f.name == 'circular arc')
    a, h = measured_table(fam.law, 2 * math.pi / 3600, sigma=0.5e-6, seed=7)
    table = lobe_law(a, h, key='t')
    lo, hi = table.support
    # the lobe has four h'' jumps inside its support (panels straddle them)
    assert len(table.lobe.rec.parameter['junctions_deg']) == 4
    ref = quad(lambda x: float(table(np.array([x]), 0)[0]), lo, hi, limit=400,
               epsabs=1e-16, epsrel=1e-12)[0]
    # 1e-11 m rad: 1e-9 of the lobe's area, far below the card's printed digits
    assert cc.law_area(table, [lo, hi]) == pytest.approx(ref, abs=1e-11)


def test_card_text_prints_no_negative_zero() -> None:
    """A nose on 0 deg that the root finder puts at -1e-13 deg prints 0.0000, not
    -0.0000, in a column of the same width; a real negative angle keeps its sign."""
    card = cc.card_from_law(from_spec(SPEC), HEIGHTS)
    entry = card['heights'][0]
    near = dict(card, max_lift_alpha_deg=-1e-14,
                heights=[dict(entry, centreline_deg=-1e-13)])
    exact = dict(card, max_lift_alpha_deg=0.0, heights=[dict(entry, centreline_deg=0.0)])
    text, want = cc.card_text({'x': near}), cc.card_text({'x': exact})
    assert '-0.000' not in text
    assert text == want
    assert f'{entry["opening_deg"]:.3f}' in text and entry['opening_deg'] < 0.0
