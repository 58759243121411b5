"""One table, one lobe, one answer: the same real-looking rows through every route.

Tables are written as gauges and spreadsheets write them (0.01 mm rounding, 2.5-5 deg
steps, ramps cut off, a nose at 170 deg so the lobe crosses +-180 deg, inches at
0.0001 in, crank degrees, exact 0.5 deg rows) from an analytic ramp + polynomial lobe
(methods §1.1/§1.4, exact derivatives). Each goes through ``cam-bench card``,
``cam-bench dynamics TABLE``, a scene lobe table (``design check``, the scene parser),
a gauge nominal file in a scene, ``design law``, the lift-law registry's ``table``
family (the Python API) and ``reconstruct`` (its lobe law, and its own fits in the
lobe law's frame); the max lift, h'/h''/h''', the
events at several heights and the jump speed must agree route by route (they read one
lobe law) and with the analytic lobe within what the rows' rounding and step allow.
Jump speeds of an eccentric against the closed form sqrt((F0 + 2 k e)/(m e)): with h =
e (1 - cos a), the rigid contact force m w^2 e cos a + k e (1 - cos a) + F0 is lowest at
the nose (cos a = -1) once m w^2 > k, where it is F0 + 2 k e - m w^2 e.
"""
from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from cam_design import cam_card as cc
from cam_design.errors import InputError
from cam_design.lift_laws.registry import from_spec
from cam_metrology.cli import main
from cam_design.lift_table.lobe_table import lobe_law
from cam_metrology.reconstruction.synthetic import PolynomialLobe
from cam_design.lift_table.truth_lobes import BumpLobe

D = math.pi / 180.0
LOBE = PolynomialLobe()              # 8.3 mm, ramps 0.3 mm over 30 deg, support +-80 deg
HEIGHTS_MM = (0.5, 1.0, 2.0, 5.0)
INCH = 25.4


def _rows(kind: str) -> tuple[np.ndarray, np.ndarray, float, float]:
    """(angle [cam deg], lift [mm] as written, nose [cam deg], lift quantum [mm])."""
    if kind == 'q01_5deg':
        deg = np.arange(-180.0, 180.0, 5.0)
        return deg, np.round(LOBE(deg * D) * 1e5) / 1e2, 0.0, 0.01
    if kind == 'q01_2p5deg_seam':           # nose at 170 deg: the lobe crosses +-180
        deg = np.arange(-180.0, 180.0, 2.5)
        rel = (deg - 170.0 + 180.0) % 360.0 - 180.0
        return deg, np.round(LOBE(rel * D) * 1e5) / 1e2, 170.0, 0.01
    if kind == 'inch_2p5deg':                # 0.0001 in
        deg = np.arange(-180.0, 180.0, 2.5)
        return deg, np.round(LOBE(deg * D) * 1e3 / INCH * 1e4) / 1e4, 0.0, 1e-4 * INCH
    if kind == 'exact_0p5deg':
        deg = np.arange(-180.0, 180.0, 0.5)
        return deg, LOBE(deg * D) * 1e3, 0.0, 0.0
    raise ValueError(kind)


KINDS = ('q01_5deg', 'q01_2p5deg_seam', 'inch_2p5deg', 'exact_0p5deg')


def _csv(path: Path, kind: str, *, crank: bool = False) -> Path:
    deg, lift, _nose, _q = _rows(kind)
    unit = 'Cam Lift (in)' if kind.startswith('inch') else 'Valve Lift [mm]'
    head = 'Crank Angle [deg]' if crank else 'Cam Angle [deg]'
    ang = 2.0 * deg if crank else deg
    digits = 4 if kind.startswith('inch') else (2 if kind.startswith('q01') else 9)
    path.write_text(f'{head},{unit}\n' + ''.join(f'{a:g},{v:.{digits}f}\n'
                                                 for a, v in zip(ang, lift)),
                    encoding='utf-8')
    return path


def _mm(kind: str) -> tuple[np.ndarray, np.ndarray]:
    """The rows in rad and m."""
    deg, lift, _nose, _q = _rows(kind)
    scale = INCH * 1e-3 if kind.startswith('inch') else 1e-3
    return deg * D, lift * scale


def _truth(heights_mm=HEIGHTS_MM) -> dict:
    return cc.card_from_law(LOBE_LAW, tuple(h * 1e-3 for h in heights_mm))


#: the same lobe as a lift law of the registry (methods §1.4 example; junctions known)
LOBE_LAW = from_spec({'family': 'preset', 'name': 'methods_example'})


def _allow_deg(q_m: float, step_deg: float, height_m: float) -> float:
    """What rounding q and the step allow an event to move [deg]: 4 q/sqrt(12) over the
    slope at the event, plus 0.02 deg (the smoothing's bias at a 5 deg step)."""
    t = _truth((height_m * 1e3,))['heights'][0]
    slope = abs(float(LOBE(t['opening_deg'] * D, 1))) * D        # m/deg
    return 4.0 * q_m / math.sqrt(12.0) / slope + 0.02 + 0.004 * step_deg


# ------------------------------------------------------------------------ card
@pytest.mark.parametrize('kind', KINDS)
def test_card_route_matches_the_lobe_and_the_cam(tmp_path: Path, kind: str) -> None:
    table = _csv(tmp_path / f'{kind}.csv', kind)
    out = tmp_path / 'card.json'
    heights = ','.join(f'{h:g}' for h in HEIGHTS_MM)
    assert main(['card', str(table), '--heights-mm', heights, '--json', str(out)]) == 0
    (card,) = json.loads(out.read_text(encoding='utf-8'))['cards'].values()
    a, h = _mm(kind)
    law = lobe_law(a, h, key=table.name)
    direct = cc.card_from_law(law, tuple(x * 1e-3 for x in HEIGHTS_MM))
    _deg, _lift, nose, q_mm = _rows(kind)
    q = q_mm * 1e-3
    # route vs the component: the same law; the CSV carries the lifts to 1e-12 m (the
    # exact table) or to its own rounding, which the jerk at a ramp's start feels most
    assert card['max_lift_m'] == pytest.approx(direct['max_lift_m'], abs=1e-9)
    for k in ('acceleration_max_si', 'acceleration_min_si', 'velocity_max_si', 'jerk_max_si'):
        assert card[k] == pytest.approx(direct[k], rel=2e-5)
    # the component vs the cam: max lift within the rounding (+1 um of smoothing bias)
    truth = _truth()
    assert card['max_lift_m'] == pytest.approx(truth['max_lift_m'], abs=q + 2e-6)
    # h'' peak within 6 % of the cam's (rounding of 0.01 mm at 5 deg: the smoothing's bias)
    assert card['acceleration_max_si'] == pytest.approx(truth['acceleration_max_si'], rel=0.06)
    assert card['acceleration_min_si'] == pytest.approx(truth['acceleration_min_si'], rel=0.06)
    step = float(np.median(np.diff(_deg)))
    for got, ref in zip(card['heights'], truth['heights']):
        allow = _allow_deg(q, step, ref['height_m'])
        for side in ('opening_deg', 'closing_deg'):
            off = (got[side] - ref[side] - nose + 180.0) % 360.0 - 180.0   # whole turns
            assert abs(off) <= allow, (got['height_mm'], side, off, allow)


def test_crank_degrees_read_and_the_unhalved_angles_warned(tmp_path: Path) -> None:
    """The same 5 deg table with a crank-angle header gives the same card; the crank
    angles under a cam-angle header give a lobe 320 deg wide: a warning naming crank_deg."""
    cam = _csv(tmp_path / 'cam.csv', 'q01_5deg')
    crank = _csv(tmp_path / 'crank.csv', 'q01_5deg', crank=True)
    cards = []
    for path in (cam, crank):
        out = tmp_path / f'{path.stem}.json'
        assert main(['card', str(path), '--json', str(out)]) == 0
        (card,) = json.loads(out.read_text(encoding='utf-8'))['cards'].values()
        cards.append(card)
    assert cards[1]['max_lift_m'] == pytest.approx(cards[0]['max_lift_m'], abs=1e-9)
    assert cards[1]['heights'][0]['duration_cam_deg'] == pytest.approx(
        cards[0]['heights'][0]['duration_cam_deg'], abs=1e-6)
    assert 'crank_deg' not in cards[0].get('warning', '')
    deg, lift, _n, _q = _rows('q01_5deg')
    wrong = tmp_path / 'wrong.csv'   # crank degrees written under a cam header
    wrong.write_text('Cam Angle [deg],Valve Lift [mm]\n' + ''.join(
        f'{2 * a:g},{v:.2f}\n' for a, v in zip(deg[np.abs(deg) <= 90], lift[np.abs(deg) <= 90])),
        encoding='utf-8')
    out = tmp_path / 'wrong.json'
    assert main(['card', str(wrong), '--json', str(out)]) == 0
    (card,) = json.loads(out.read_text(encoding='utf-8'))['cards'].values()
    assert 'crank_deg' in card['warning'] and 'cam deg wide' in card['warning']


# --------------------------------------------------------------- scene and design
def _scene(path: Path, a: np.ndarray, h: np.ndarray, lash: float = 0.0) -> Path:
    path.write_text(
        'camshaft_id: routes\nprobe: {kind: flat, radius: 0}\nbase_circle_radius: 0.018\n'
        f'lobes:\n  - id: lobe\n    follower: flat\n    lift: {{alpha: {json.dumps(a.tolist())}'
        f', h: {json.dumps(h.tolist())}}}\n'
        f'valve_train: {{model: sdof, rocker_ratio: 1.0, lash: {lash}, mass: 0.1, '
        'stiffness: 1.0e9, damping: 2.0e4, spring_rate: 20000, spring_preload: 200, '
        'cam_speed_rpm: [3000]}\n', encoding='utf-8')
    return path


@pytest.mark.parametrize('kind', ['q01_5deg', 'exact_0p5deg'])
def test_scene_table_design_check_and_card_read_one_lobe(tmp_path: Path, kind: str,
                                                         capsys) -> None:
    """A scene lobe table (rad, m): the scene parser's law is the table's lobe law, and
    design check reports the h'' extremes of the card of the same rows (item 6)."""
    from cam_metrology.scene.parse import load_scene

    a, h = _mm(kind)
    sel = np.abs(a) <= math.pi - 1e-12
    scene = _scene(tmp_path / 'scene.yaml', a[sel], h[sel])
    parsed = load_scene(str(scene)).lobes[0].lift
    law = lobe_law(a[sel], h[sel], key='x')
    x = np.linspace(-85 * D, 85 * D, 3401)
    for nu, tol in ((0, 1e-12), (1, 1e-10), (2, 1e-9), (3, 1e-8)):
        assert np.max(np.abs(parsed(x, nu) - law(x, nu))) <= tol   # m/rad^nu
    table = _csv(tmp_path / 'lobe.csv', kind)
    out = tmp_path / 'card.json'
    assert main(['card', str(table), '--json', str(out)]) == 0
    (card,) = json.loads(out.read_text(encoding='utf-8'))['cards'].values()
    capsys.readouterr()
    assert main(['design', 'check', str(scene), '--rpm', '3000', '--json', '-']) == 0
    check = json.loads(capsys.readouterr().out)
    # h'' [mm/rad^2]: the card's of the same rows (0.05 % for the two samplings)
    assert check['max_acceleration_mm_per_rad2'] == pytest.approx(
        card['acceleration_max_si'] * 1e3, rel=5e-4)
    assert check['min_acceleration_mm_per_rad2'] == pytest.approx(
        card['acceleration_min_si'] * 1e3, rel=5e-4)
    # curvature of the flat-follower profile rho = R0 + h + h'' and the rigid contact
    # force m w^2 h'' + k h + F0 at 3000 rpm, from the lobe law itself
    y = np.linspace(-85 * D, 85 * D, 34001)
    rho = 0.018 + law(y) + law(y, 2)
    assert check['min_rho1_mm'] == pytest.approx(float(np.min(rho)) * 1e3, abs=0.01)
    omega = 3000.0 * math.pi / 30.0
    force = 0.1 * omega ** 2 * law(y, 2) + 2.0e4 * law(y) + 200.0
    assert check['min_contact_force_n'] == pytest.approx(float(np.min(force)), abs=0.5)


@pytest.mark.parametrize('kind', ['q01_5deg', 'exact_0p5deg'])
def test_registry_table_family_is_the_card_and_dynamics_lobe(tmp_path: Path, kind: str
                                                             ) -> None:
    """``cam_design.lift_laws.from_spec({family: table, ...})`` (the Python API, a scene's
    lift_law, the design commands) gives the lobe that ``card`` and ``dynamics TABLE``
    read from the same rows in a CSV: max lift, h..h\'\'\' at angles across the lobe,
    its joins and base circle, and the events at every checking height."""
    from cam_metrology.dynamics.tables import table_input

    a, h = _mm(kind)
    api = from_spec({'family': 'table', 'alpha': a.tolist(), 'h': h.tolist()}, 'lift_law')
    table = _csv(tmp_path / f'{kind}.csv', kind)
    _name, dyn, source, _note = table_input(table)
    assert source == f'table:{api.lobe.method}'
    # the CSV carries exact lifts to 1e-9 mm (a row error e <= 5e-13 m, which the
    # quintic interpolant carries into h^(nu) with a gain below (4/step)^nu), rounded
    # lifts to their own 0.01 mm digits (no error but the decimal reading's)
    e = 5e-13 if kind.startswith('exact') else 1e-17
    step = float(np.median(np.diff(a)))
    x = np.array([-170, -90, -75, -60, -40, -10, 0, 25, 55, 70, 80, 120]) * D
    for nu in range(4):
        tol = e * (4.0 / step) ** nu                                      # m/rad^nu
        assert np.max(np.abs(api(x, nu) - dyn(x, nu))) <= tol, nu
    # and not the plain quintic interpolant the family built before: same rows, the
    # same lobe as the card (peak h'' within 0.002 % of the card's JSON)
    out = tmp_path / 'card.json'
    heights = ','.join(f'{v:g}' for v in HEIGHTS_MM)
    assert main(['card', str(table), '--heights-mm', heights, '--json', str(out)]) == 0
    (card,) = json.loads(out.read_text(encoding='utf-8'))['cards'].values()
    mine = cc.card_from_law(api, tuple(v * 1e-3 for v in HEIGHTS_MM))
    assert mine['max_lift_m'] == pytest.approx(card['max_lift_m'], abs=1e-9)
    for k in ('acceleration_max_si', 'acceleration_min_si', 'velocity_max_si', 'jerk_max_si'):
        assert mine[k] == pytest.approx(card[k], rel=2e-5), k
    for got, ref in zip(mine['heights'], card['heights']):
        for side in ('opening_deg', 'closing_deg'):
            assert got[side] == pytest.approx(ref[side], abs=1e-6)   # deg


# ---------------------------------------------------------------------- dynamics
VT = ('valve_train: {{model: sdof, rocker_ratio: 1.0, lash: {lash}, mass: {m}, '
      'stiffness: {c}, damping: {b}, spring_rate: {k}, spring_preload: {f0}, '
      'cam_speed_rpm: [1000]}}\n')
M, K, F0 = 0.1, 2.0e4, 200.0
C = 3.0e8                     # stiff (rigid closed form) yet resolved at 1 deg


def _vt(path: Path, lash: float = 0.0) -> Path:
    path.write_text(VT.format(lash=lash, m=M, c=C, b=2 * math.sqrt(C * M), k=K, f0=F0),
                    encoding='utf-8')
    return path


def _dynamics(tmp_path: Path, target: Path, *extra: str) -> dict:
    out = tmp_path / f'{target.stem}.dyn.json'
    assert main(['dynamics', str(target), '--valve-train', str(_vt(tmp_path / 'vt.yaml')),
                 '--step-deg', '1', '--json', str(out), *extra]) == 0
    (entry,) = json.loads(out.read_text(encoding='utf-8'))['features'].values()
    return entry


@pytest.mark.parametrize('peak_deg', [0.0, 170.0])
def test_eccentric_jump_speed_closed_form(tmp_path: Path, peak_deg: float) -> None:
    """An eccentric (e = 3 mm, 1 um rows every 2 deg, its nose anywhere) through
    `dynamics TABLE` with zero lash: the jump speed within 2 % of sqrt((F0 + 2 k e)/(m e)),
    and no separation at 30 % of it."""
    e = 3e-3
    truth = math.sqrt((F0 + 2 * K * e) / (M * e)) * 30.0 / math.pi
    deg = np.arange(-180.0, 180.0, 2.0)
    lift = np.round(e * (1.0 - np.cos((deg - peak_deg + 180.0) * D)) * 1e6) / 1e3
    table = tmp_path / 'ecc.csv'
    table.write_text('angle_deg,lift_mm\n' + ''.join(f'{a:g},{v:.3f}\n'
                                                     for a, v in zip(deg, lift)))
    lo, hi = int(0.9 * truth), int(1.1 * truth)
    entry = _dynamics(tmp_path, table, '--sweep', f'{lo}:{hi}:{(hi - lo) // 2}')
    assert entry['jump_speed_rpm'] == pytest.approx(truth, rel=0.02)
    slow = _dynamics(tmp_path, table, '--rpm', f'{0.3 * truth:.0f}')
    run = slow['runs'][0]
    assert not run['jump'] and not run.get('left_cam') and not run.get('bounce')


def _ramp_cut_rows() -> tuple[np.ndarray, np.ndarray]:
    """The lobe every 2.5 deg between -70 and 70 deg: its ramps cut at 0.04 mm."""
    deg = np.arange(-70.0, 70.1, 2.5)
    return deg, np.round(LOBE(deg * D) * 1e5) / 1e2


def test_cut_ramps_are_joined_never_a_step(tmp_path: Path) -> None:
    """A table that starts and ends on the ramps (0.04 mm): the lobe law joins it to the
    base circle with zero lift, velocity, acceleration and jerk (no lift step: with zero
    lash that step was an impact at every speed); the warning says so on every route;
    at 30 % of the jump speed the valve does not separate."""
    deg, lift = _ramp_cut_rows()
    law = lobe_law(deg * D, lift * 1e-3, key='cut.csv')
    lo, hi = law.support
    ends = law.derivatives(np.array([lo, hi]))
    assert np.max(np.abs(ends)) <= 1e-12
    x = np.linspace(lo, hi, 20001)
    assert float(np.min(law(x))) >= -1e-9
    assert any('starts mid-lobe' in w for w in law.lobe.warnings)
    assert any('ends mid-lobe' in w for w in law.lobe.warnings)
    table = tmp_path / 'cut.csv'
    table.write_text('alpha_deg,lift_mm\n' + ''.join(f'{a:g},{v:.2f}\n'
                                                     for a, v in zip(deg, lift)))
    out = tmp_path / 'card.json'
    assert main(['card', str(table), '--json', str(out)]) == 0
    (card,) = json.loads(out.read_text(encoding='utf-8'))['cards'].values()
    assert 'starts mid-lobe' in card['warning']
    entry = _dynamics(tmp_path, table, '--sweep', '1000:9000:2000')
    assert 'starts mid-lobe' in entry['note']
    jump = entry['jump_speed_rpm']
    # the whole lobe jumps at about 4.4e3 rpm on this train; the lift step of the old
    # cut (12-55 um) made it 'below the sweep range'; the join keeps it within 10 %
    full = _dynamics(tmp_path, _csv(tmp_path / 'full.csv', 'q01_5deg'),
                     '--sweep', '1000:9000:2000')['jump_speed_rpm']
    assert jump is not None and jump == pytest.approx(full, rel=0.10)
    slow = _dynamics(tmp_path, table, '--rpm', f'{0.3 * jump:.0f}')['runs'][0]
    assert not slow['jump'] and not slow.get('left_cam') and not slow.get('bounce')


@pytest.mark.parametrize('kind', ['q01_5deg', 'q01_2p5deg_seam'])
def test_jump_speed_same_through_table_scene_and_reconstruct(tmp_path: Path, kind: str
                                                             ) -> None:
    """The jump speed of the table through `dynamics TABLE`, through a scene lobe table
    of the same rows, and through `reconstruct --json` then `dynamics r.json`, against
    the analytic lobe: within 2 % of the cam, within 0.5 % of each other."""
    from cam_design.valve_train.params import SdofParams
    from cam_design.valve_train.sweep import sweep

    p = SdofParams(mass=M, stiffness=C, damping=2 * math.sqrt(C * M), spring_rate=K,
                   spring_preload=F0, rocker_ratio=1.0, lash=0.0)
    truth = sweep(LOBE_LAW, p, [1000.0, 2000.0, 3000.0, 4000.0, 6000.0], step_deg=1.0, tol_rpm=2.0,
                  check=False).jump.speed
    assert truth is not None
    sweep_arg = f'{int(0.8 * truth)}:{int(1.2 * truth)}:{int(0.2 * truth)}'
    table = _csv(tmp_path / f'{kind}.csv', kind)
    speeds = {'table': _dynamics(tmp_path, table, '--sweep', sweep_arg)['jump_speed_rpm']}
    _deg, _lift, nose, _q = _rows(kind)
    if nose == 0.0:
        a, h = _mm(kind)
        scene = _scene(tmp_path / 'scene.yaml', a, h)
        out = tmp_path / 'scene.dyn.json'
        assert main(['dynamics', str(scene), '--step-deg', '1', '--sweep', sweep_arg,
                     '--json', str(out)]) == 0
        doc = json.loads(out.read_text(encoding='utf-8'))['features']['lobe']
        speeds['scene'] = doc['jump_speed_rpm']
    rec = tmp_path / 'rec.json'
    assert main(['reconstruct', str(table), '--json', str(rec)]) == 0
    speeds['reconstruct'] = _dynamics(tmp_path, rec, '--sweep', sweep_arg)['jump_speed_rpm']
    for route, v in speeds.items():
        assert v == pytest.approx(truth, rel=0.02), (route, speeds, truth)
    if 'scene' in speeds:
        assert speeds['scene'] == pytest.approx(speeds['table'], rel=0.005)


def _events_deg(alpha: np.ndarray, lift: np.ndarray, height: float) -> tuple[float, float]:
    """(opening, closing) [deg] of a lift curve at ``height`` [m]: the crossings nearest
    the top, linearly interpolated on the curve's own fine grid, in the frame where the
    top is contiguous (angles relative to the top, then back)."""
    top = float(alpha[int(np.argmax(lift))])
    rel = (alpha - top + math.pi) % (2 * math.pi) - math.pi
    order = np.argsort(rel)
    x, y = rel[order], lift[order]
    i0 = int(np.argmax(y))
    j = int(np.flatnonzero(y[:i0] < height)[-1])
    k = i0 + int(np.flatnonzero(y[i0:] < height)[0])
    a_open = x[j] + (height - y[j]) * (x[j + 1] - x[j]) / (y[j + 1] - y[j])
    a_close = x[k - 1] + (height - y[k - 1]) * (x[k] - x[k - 1]) / (y[k] - y[k - 1])
    return math.degrees(a_open + top), math.degrees(a_close + top)


def test_reconstruct_fits_a_lobe_across_the_seam_in_the_lobe_frame(tmp_path: Path) -> None:
    """The same 2.5 deg rows with the nose at 0 and at 170 deg (the lobe across +-180):
    `reconstruct`'s spline and harmonic fits of the turned rows are the fits of the
    centred rows, turned (they used to be cut at +-180 deg: 4.6 x the acceleration of
    the card); and they give the card's lobe within what their own smoothing allows."""
    deg = np.arange(-180.0, 180.0, 2.5)
    docs = {}
    for nose in (0.0, 170.0):
        rel = (deg - nose + 180.0) % 360.0 - 180.0
        lift = np.round(LOBE(rel * D) * 1e5) / 1e2
        table = tmp_path / f'nose{nose:g}.csv'
        table.write_text('alpha_deg,lift_mm\n' + ''.join(f'{a:g},{v:.2f}\n'
                                                         for a, v in zip(deg, lift)))
        out = tmp_path / f'nose{nose:g}.json'
        assert main(['reconstruct', str(table), '--json', str(out)]) == 0
        doc = json.loads(out.read_text(encoding='utf-8'))
        cout = tmp_path / f'card{nose:g}.json'
        assert main(['card', str(table), '--heights-mm', '0.5,1,5', '--json', str(cout)]) == 0
        (card,) = json.loads(cout.read_text(encoding='utf-8'))['cards'].values()
        docs[nose] = (doc['features'][table.stem], doc['lobes'][table.stem], card)
    centred, turned = docs[0.0], docs[170.0]
    assert any('turned by 170.0 deg' in n for n in turned[0]['spline']['notes'])
    assert not any('turned by' in n for n in centred[0]['spline']['notes'])
    for method in ('spline', 'harmonic'):
        c, t = centred[0][method], turned[0][method]
        assert c['ok'] and t['ok'], method
        ca, ta = np.array(c['alpha_rad']), np.array(t['alpha_rad'])
        assert np.all(np.diff(ca) > 0) and -math.pi < ca[0] and ca[-1] <= math.pi
        # the lobe at 170 deg is not in (-180, 180]: the turn centred on it, -10..350 deg
        assert np.all(np.diff(ta) > 0) and -10 * D < ta[0] and ta[-1] <= 350 * D
        for col in ('lift_m', 'velocity_m_per_rad', 'acceleration_m_per_rad2',
                    'jerk_m_per_rad3'):
            cv, tv = np.array(c[col]), np.array(t[col])
            # the same fit: turned back onto the centred grid (both on multiples of the
            # grid step; 170 deg is one), within 1e-9 of the column's peak
            at = np.interp(ca, (ta - 170.0 * D + math.pi) % (2 * math.pi) - math.pi, tv,
                           period=2 * math.pi)
            on_lobe = np.abs(ca) <= 100.0 * D
            # the harmonic series' h'' jumps at its section edges +-Phi: which side a
            # grid point on an edge takes is float rounding, in either frame
            edge = c['parameters'].get('half_angle_rad')
            if edge is not None:
                on_lobe &= np.abs(np.abs(ca) - edge) > 1e-9
            assert np.max(np.abs(at[on_lobe] - cv[on_lobe])) <= 1e-9 * np.max(np.abs(cv)), \
                (method, col)
        for height in (0.5e-3, 1e-3, 5e-3):
            co = _events_deg(ca, np.array(c['lift_m']), height)
            to = _events_deg(ta, np.array(t['lift_m']), height)
            for x, y in zip(co, to):
                assert (y - x - 170.0 + 180.0) % 360.0 - 180.0 == pytest.approx(0.0, abs=1e-6)
    # the card and the lobe law in reconstruct's JSON: one lobe, in either frame
    for lobe, _lobe, card in (centred, turned):
        assert _lobe['max_lift_m'] == pytest.approx(card['max_lift_m'], abs=1e-9)
        spline = lobe['spline']
        # the spline (its own criterion) against the card's lobe: max lift within the
        # 0.01 mm rounding, peak h'' within 5 % (the two smoothing levels), events
        # within what the rounding and the step allow the card (twice: two smoothings)
        assert max(spline['lift_m']) == pytest.approx(card['max_lift_m'], abs=1e-5)
        acc = np.array(spline['acceleration_m_per_rad2'])
        assert float(np.max(acc)) == pytest.approx(card['acceleration_max_si'], rel=0.05)
        assert float(np.min(acc)) == pytest.approx(card['acceleration_min_si'], rel=0.05)
        a = np.array(spline['alpha_rad'])
        for row in card['heights']:
            got = _events_deg(a, np.array(spline['lift_m']), row['height_m'])
            allow = 2.0 * _allow_deg(1e-5, 2.5, row['height_m'])
            for x, side in zip(got, ('opening_deg', 'closing_deg')):
                assert (x - row[side] + 180.0) % 360.0 - 180.0 == pytest.approx(0.0, abs=allow)


# ---------------------------------------------------------------------- refusals
def test_card_heights_outside_the_lobe(tmp_path: Path, capsys) -> None:
    """A height at or above the max lift: a one-line refusal naming it; below the rows'
    base level: the seat-to-seat duration, with a note; below a mid-lobe start: the
    join's events, with a note (never a traceback, never a silent 0)."""
    table = _csv(tmp_path / 'lobe.csv', 'q01_5deg')
    assert main(['card', str(table), '--heights-mm', '9']) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and 'Traceback' not in err
    assert "--heights-mm[0]: got '9 mm'" in err and 'below the max lift (8.' in err
    out = tmp_path / 'c.json'
    assert main(['card', str(table), '--heights-mm', '0.001', '--json', str(out)]) == 0
    (card,) = json.loads(out.read_text(encoding='utf-8'))['cards'].values()
    entry = card['heights'][0]
    assert 'base-circle level' in entry['note'] and entry['duration_cam_deg'] > 150.0
    deg, lift = _ramp_cut_rows()
    cut = tmp_path / 'cut.csv'
    cut.write_text('alpha_deg,lift_mm\n' + ''.join(f'{a:g},{v:.2f}\n'
                                                   for a, v in zip(deg, lift)))
    assert main(['card', str(cut), '--heights-mm', '0.02,1', '--json', str(out)]) == 0
    (card,) = json.loads(out.read_text(encoding='utf-8'))['cards'].values()
    assert 'join to the base circle' in card['heights'][0]['note']
    assert 'note' not in card['heights'][1]
    ref = _truth((1.0,))['heights'][0]
    assert card['heights'][1]['duration_cam_deg'] == pytest.approx(
        ref['duration_cam_deg'], abs=2 * _allow_deg(1e-5, 2.5, 1e-3))


def test_refusals_name_the_rows() -> None:
    deg = np.arange(-180.0, 180.0, 2.5)
    lift = LOBE(deg * D)
    high = (deg >= -20) & (deg <= 20)     # only the top of the lobe: 83 % of the lift
    with pytest.raises(InputError, match=r"top\.csv: got 'a table that starts at \d\.\d+ mm "
                                         r"\(\d+ % of its max lift\)'.*give the whole lobe"):
        lobe_law(deg[high] * D, lift[high], key='top.csv')
    part = np.abs(deg) <= 60                     # covers the lobe only, a gap of 240 deg
    law = lobe_law(deg[part] * D, lift[part], key='part.csv')
    x = np.linspace(*law.support, 20001)
    assert float(np.max(law(x))) <= float(np.max(lift)) + 1e-6   # never bridged above
    # a sensor trace taken for exact (noise 0): its 20 um scatter, interpolated at
    # 0.5 deg, is an acceleration no 8 mm lobe of 160 deg can have
    fine = np.arange(-180.0, 180.0, 0.5)
    noisy = LOBE(fine * D) + np.random.default_rng(3).normal(0.0, 2e-5, fine.size)
    with pytest.raises(InputError, match=r"noisy\.csv: got 'peak acceleration .* m/rad\^2'; "
                                         r'expected a lobe its lift'):
        lobe_law(fine * D, noisy, key='noisy.csv', noise=0.0)
    assert lobe_law(fine * D, noisy, key='noisy.csv').lobe.method == 'smoothed'


def test_header_refusal_names_the_column(tmp_path: Path, capsys) -> None:
    bad = tmp_path / 'bad.csv'
    bad.write_text('Crank Angle [deg],Ventilhub [mm]\n0,0\n10,1\n', encoding='utf-8')
    assert main(['card', str(bad)]) == 2
    err = capsys.readouterr().err
    assert "'Ventilhub [mm]' could not be read" in err and 'no lift column' in err


def test_trace_of_the_open_valve_only_is_never_bridged(tmp_path: Path, capsys) -> None:
    """A trace that covers only the open part of a lobe whose nose is at 180 deg (rows
    118..242 deg, 236 deg of the turn absent): the lobe law keeps the rows contiguous
    and never rises above them (joined to the base circle, warned as mid-lobe on both
    sides); the reconstruction, which fits over (-180, 180], says when its fit bridges
    the gap above the rows; its fits turn the rows first and never leave their range."""
    deg = np.arange(118.0, 242.1, 1.0)
    lift_mm = np.round(LOBE((deg - 180.0) * D) * 1e5) / 1e2
    law = lobe_law(deg * D, lift_mm * 1e-3, key='open.csv')
    x = np.linspace(*law.support, 20001)
    assert float(np.max(law(x))) <= float(np.max(lift_mm)) * 1e-3 + 1e-5
    assert law.support[0] < 118.0 * D and law.support[1] > 242.0 * D
    assert sum('mid-lobe' in w for w in law.lobe.warnings) == 2
    table = tmp_path / 'open.csv'
    table.write_text('alpha_deg,lift_mm\n' + ''.join(f'{a:g},{v:.2f}\n'
                                                     for a, v in zip(deg, lift_mm)))
    out = tmp_path / 'rec.json'
    main(['reconstruct', str(table), '--json', str(out)])
    doc = json.loads(out.read_text(encoding='utf-8'))
    lobe = doc['lobes']['open']
    assert lobe['max_lift_m'] == pytest.approx(float(np.max(lift_mm)) * 1e-3, abs=1e-5)
    # the fits run on the rows turned by 180 deg and come back in the table's own
    # contiguous angles: no output angle in the 236 deg without rows, no lift above the
    # rows by more than their rounding
    spline = doc['features']['open']['spline']
    assert any('turned by 180.0 deg' in n for n in spline['notes'])
    for name, method in doc['features']['open'].items():
        assert method['ok'], name
        a = np.degrees(np.array(method['alpha_rad']))
        assert a[0] >= 118.0 - 1e-6 and a[-1] <= 242.0 + 1e-6, name
        assert np.allclose(np.diff(a), 0.1, atol=1e-9), name          # deg, no gap
        assert max(method['lift_m']) <= float(np.max(lift_mm)) * 1e-3 + 1e-5, name
    assert max(spline['lift_m']) == pytest.approx(lobe['max_lift_m'], abs=1e-5)
    # nor does a gauge nominal file of the whole turn get a lift where no row was
    capsys.readouterr()
    assert main(['reconstruct', str(table), '--follower', 'roller', '--radius', '0.0125',
                 '--nominal', str(tmp_path / 'nominal.txt'), '--json', str(out)]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and 'Traceback' not in err
    assert "--nominal: got 'a reconstruction of open without rows from 242.0 to 118.0 " \
           "deg'" in err and 'a table over the whole turn' in err
    assert not (tmp_path / 'nominal.txt').exists()


@pytest.mark.parametrize('frame_deg', [(-180.0, 180.0), (0.0, 360.0)])
def test_noisy_table_across_the_seam_is_smoothed_in_the_turned_frame(frame_deg) -> None:
    """Rows with 1 um of scatter written to 0.0001 mm (the noise is judged from the
    rows, not from the digits), the nose at 180 deg so the lobe crosses the seam, in a
    -180..180 and a 0..360 deg frame: the lobe law is the smoothed lobe (max lift and
    events at 1 mm as the analytic lobe's, within what 1 um at 2.5 deg allows), never a
    refusal. (The fairing made of the rows before the turn was once reused for the
    turned rows: a 3.85 mm rms miss and 'tabulate more points'.)"""
    deg = np.arange(frame_deg[0], frame_deg[1], 2.5) + 2.5
    rel = (deg - 180.0 + 180.0) % 360.0 - 180.0
    noise = np.random.default_rng(4).normal(0.0, 1e-6, deg.size)
    lift = np.round((LOBE(rel * D) + noise) * 1e7) / 1e7
    law = lobe_law(deg * D, lift)
    assert law.lobe.method == 'smoothed'
    assert abs(law.max_lift() - float(LOBE(np.array([0.0]))[0])) < 5e-6
    lo, hi = law.support
    fine = np.linspace(lo, hi, 40001)
    opening, closing = _events_deg(fine, law(fine), 1e-3)
    t = _truth((1.0,))['heights'][0]
    assert abs((opening - 180.0 + 180.0) % 360.0 - 180.0 - t['opening_deg']) < 0.05
    assert abs((closing - 180.0 + 180.0) % 360.0 - 180.0 - t['closing_deg']) < 0.05
    # the joins to the base circle are told in the table frame (the lobe's ends are
    # 74-85 deg from its nose at 180 deg: the law's lobe ends at +-80 deg, the join runs
    # out to where a rise from the base circle through the smoothed lobe's jets starts,
    # up to 5 deg beyond at this noise), not in the turned frame (+-74-85 deg)
    said = re.search(r'jerk at (\S+)\.\.(\S+) deg, (\S+)\.\.(\S+) deg', law.lobe.note())
    assert said is not None
    for value in said.groups():
        # in the frame of the lobe's events: continuous across it, 74-85 deg from the
        # nose on either side (95-106 and 254-265 deg)
        assert 74.0 < abs(float(value) - 180.0) < 85.0, law.lobe.note()


# ------------------------------------------------------------ one frame at the seam
C2_LOBE = BumpLobe()                 # 8 mm, h = H (1 - x^2)^3 over +-75 deg: C2


def _seam_csv(path: Path, lobe, step: float, lo: float, hi: float, nose: float) -> Path:
    """``lobe`` tabulated every ``step`` deg from ``lo`` to ``hi`` (both rows: a closed
    turn, as gauges write it), its nose at ``nose`` deg, lifts rounded to 0.01 mm."""
    deg = np.arange(lo, hi + 1e-9, step)
    rel = (deg - nose + 180.0) % 360.0 - 180.0
    lift = np.round(np.asarray(lobe(rel * D), dtype=float) * 1e5) / 1e2
    path.write_text('Cam Angle [deg],Valve Lift [mm]\n' + ''.join(
        f'{a:g},{v:.2f}\n' for a, v in zip(deg, lift)), encoding='utf-8')
    return path


def _event_allow_deg(lobe, q_m: float, step_deg: float, height_m: float, at_deg: float
                     ) -> float:
    """What rounding q and the step allow an event of ``lobe`` to move [deg]: 4 q/sqrt(12)
    over the slope at the event, plus 0.02 deg (smoothing bias) and 0.004 x the step."""
    slope = abs(float(lobe(np.array([at_deg * D]), 1)[0])) * D        # m/deg
    return 4.0 * q_m / math.sqrt(12.0) / slope + 0.02 + 0.004 * step_deg


#: (lobe, step [deg], first and last row [deg], nose [deg], the nose's angle in the one
#: frame [deg]: the lobe in the turn of the first row)
SEAM_CASES = {
    'ramped_2.5_m180_nose180': (LOBE, 2.5, -180.0, 180.0, 180.0, -180.0),
    'ramped_1_0to360_nose0': (LOBE, 1.0, 0.0, 360.0, 0.0, 0.0),
    'c2_1_m180_nose180': (C2_LOBE, 1.0, -180.0, 180.0, 180.0, -180.0),
    'c2_2.5_0to360_nose360': (C2_LOBE, 2.5, 0.0, 360.0, 360.0, 0.0),
    'ramped_2.5_0to360_nose200': (LOBE, 2.5, 0.0, 360.0, 200.0, 200.0),
    'c2_2.5_m180_nose170': (C2_LOBE, 2.5, -180.0, 180.0, 170.0, 170.0),
}


def _seam_truth(lobe, heights: tuple[float, ...]) -> dict:
    """The analytic lobe's card, nose at 0: the ramped lobe's from its lift law; the C2
    lobe's in closed form (events at +-w sqrt(1 - (y/H)^(1/3)), peak h'' on 0.001 deg)."""
    if lobe is LOBE:
        return cc.card_from_law(LOBE_LAW, heights)
    w, top = C2_LOBE.half_width, C2_LOBE.rise
    fine = np.linspace(-w, w, 300001)
    rows = []
    for y in heights:
        x = math.degrees(w * math.sqrt(1.0 - (y / top) ** (1.0 / 3.0)))
        rows.append({'height_m': y, 'opening_deg': -x, 'closing_deg': x})
    return {'max_lift_m': top, 'heights': rows,
            'acceleration_max_si': float(np.max(C2_LOBE(fine, 2)))}


@pytest.mark.parametrize('case', list(SEAM_CASES))
def test_a_lobe_at_the_seam_has_one_frame_on_every_route(tmp_path: Path, case: str) -> None:
    """A closed table (-180..180 or 0..360 deg, both end rows) whose lobe sits at or
    across the seam: the card, the lobe law `dynamics TABLE` runs, the lobe law
    `reconstruct` writes (and `dynamics r.json` reads back) state the nose, the events
    at 0.1 and 1 mm, the duration and the peak h'' in one frame: the lobe in the turn of
    the table's first row (a nose at the seam at the first row), the same numbers on
    each route (1e-6 deg, 1e-9 m, 1e-6 relative: one law), and the analytic lobe's,
    moved to that nose, within what the rounding and the step allow. (The card said
    -180 deg and the dynamics +180 deg for the same rows; the closed -180..180 table was
    a traceback: its two rows at +-180 deg fell on one angle once turned.) reconstruct's
    own spline, over the turn centred on the lobe, has its events there too."""
    from cam_metrology.cli.card import table_card
    from cam_metrology.cli.reconstruct import lobe_entry
    from cam_metrology.dynamics.tables import table_input
    from cam_metrology.inputs.lift_tables import read_table_file
    from cam_metrology.reconstruction.profile import reconstruct_table
    from cam_design.lift_table.lobe_table import lobe_from_jets

    lobe, step, lo, hi, nose, expected = SEAM_CASES[case]
    path = _seam_csv(tmp_path / f'{case}.csv', lobe, step, lo, hi, nose)
    heights = (1e-3, 1e-4)
    table = read_table_file(path)
    cards = {'card': table_card(table.alpha, table.lift, heights, path.name)}
    _name, dyn, _source, _note = table_input(path)
    cards['dynamics TABLE'] = cc.card_from_law(dyn, heights)
    entry = lobe_entry(table, path.name)
    assert entry['ok'], entry
    jets = np.array([entry[k] for k in ('lift_m', 'velocity_m_per_rad',
                                        'acceleration_m_per_rad2', 'jerk_m_per_rad3')])
    rec = lobe_from_jets(np.array(entry['alpha_rad']), jets, key='r.json')
    cards['reconstruct (r.json)'] = cc.card_from_law(rec, heights)
    truth = _seam_truth(lobe, heights)
    # reconstruct's own spline (its own smoothing level) over the turn centred on the
    # lobe when the lobe is not in (-180, 180]: its events where the card's are
    spline = reconstruct_table(table, methods=('spline',))['spline'].reconstruction
    assert spline is not None
    for want in cards['card']['heights']:
        got = _events_deg(spline.alpha, spline.lift, want['height_m'])
        for x, k in zip(got, ('opening_deg', 'closing_deg')):
            allow = 2.0 * _event_allow_deg(lobe, 1e-5, step, want['height_m'],
                                           want[k] - expected)
            assert abs(x - want[k]) <= allow, ('spline', k, x, want[k])
    # and its warning that alpha = 0 is not on the lobe names the lobe axis there too
    said = [re.search(r'the lobe axis is at (\S+) deg', w) for w in spline.warnings]
    axes = [float(m.group(1)) for m in said if m]
    assert len(axes) == (1 if abs(expected) > 90.0 else 0), spline.warnings
    for axis in axes:
        assert axis == pytest.approx(expected, abs=0.05)
    ref = cards['card']
    assert ref['centreline_deg'] == pytest.approx(expected, abs=0.05), ref
    for route, card in cards.items():
        assert card['max_lift_m'] == pytest.approx(ref['max_lift_m'], abs=1e-9), route
        # the r.json law is the lobe law on a 0.1 deg grid (a cubic Hermite between
        # its jets): its h'' within 1e-4 of the peak, its events within 1e-4 deg
        tol_deg, rel = (1e-4, 1e-4) if route.startswith('reconstruct') else (1e-6, 1e-6)
        for k in ('max_lift_alpha_deg', 'centreline_deg'):
            assert card[k] == pytest.approx(ref[k], abs=tol_deg), (route, k)
        assert card['acceleration_max_si'] == pytest.approx(ref['acceleration_max_si'],
                                                            rel=rel), route
        for got, want in zip(card['heights'], ref['heights']):
            for k in ('opening_deg', 'closing_deg', 'duration_cam_deg'):
                assert got[k] == pytest.approx(want[k], abs=tol_deg), (route, k)
        # against the cam: max lift within the rounding, the events where the analytic
        # lobe's are once its nose is put at the expected angle (no whole turns allowed)
        assert card['max_lift_m'] == pytest.approx(truth['max_lift_m'], abs=1e-5 + 2e-6)
        assert card['acceleration_max_si'] == pytest.approx(truth['acceleration_max_si'],
                                                            rel=0.06), route
        for got, want in zip(card['heights'], truth['heights']):
            for k in ('opening_deg', 'closing_deg'):
                allow = _event_allow_deg(lobe, 1e-5, step, want['height_m'], want[k])
                assert abs(got[k] - (want[k] + expected)) <= allow, (route, k, got[k], allow)


def test_seam_table_card_and_dynamics_print_one_frame(tmp_path: Path, capsys) -> None:
    """`cam-bench card` and `cam-bench dynamics` on one closed -180..180 deg table with
    the nose at 180 deg: the card's centreline and events, the dynamics' valve events
    and its valve lift at 1 mm, all around -180 deg (the turn of the first row)."""
    path = _seam_csv(tmp_path / 'seam.csv', LOBE, 2.5, -180.0, 180.0, 180.0)
    assert main(['card', str(path), '--heights-mm', '1']) == 0
    text = capsys.readouterr().out
    row = next(line for line in text.splitlines() if line.strip().startswith('1.0000'))
    opens, closes, _dur, _crank, centre = (float(v) for v in row.split()[1:])
    assert centre == pytest.approx(-180.0, abs=0.01)
    t = _truth((1.0,))['heights'][0]
    allow = _allow_deg(1e-5, 2.5, 1e-3)
    assert opens == pytest.approx(t['opening_deg'] - 180.0, abs=allow)
    assert closes == pytest.approx(t['closing_deg'] - 180.0, abs=allow)
    entry = _dynamics(tmp_path, path, '--rpm', '1000')
    run = entry['runs'][0]
    # the valve leaves and returns to its seat where the lobe does (support ends,
    # -260..-100 deg), and its lift passes 1 mm where the card's events are
    assert -265.0 < run['opening_deg'] < opens < closes < run['closing_deg'] < -95.0
    got = _events_deg(np.radians(run['alpha_deg']), np.array(run['valve_lift_m']), 1e-3)
    # a 1 deg grid, a stiff train at 1000 rpm (1 um of deflection): within 0.05 deg
    assert got[0] == pytest.approx(opens, abs=0.05)
    assert got[1] == pytest.approx(closes, abs=0.05)


def test_a_scene_nominal_file_keeps_the_scene_frame(tmp_path: Path) -> None:
    """A gauge nominal file written 0..360 deg with its nose at 300 deg: in a scene (whose
    angles are from the lobe centreline, in (-180, 180]) its lobe is at -60 deg, inside
    [-180, 180] where the follower conversion takes it (as it was before the one-frame
    rule); the same file given to `card` is told in its own turn (nose 300 deg)."""
    from cam_metrology.cli.card import table_card
    from cam_metrology.inputs.lift_tables import read_gauge_file
    from cam_metrology.scene.parse import load_scene

    deg = np.arange(0.0, 360.0, 0.5)
    lift_mm = np.round(LOBE(((deg - 300.0 + 180.0) % 360.0 - 180.0) * D) * 1e7) / 1e4
    gauge = tmp_path / 'lobe.txt'
    gauge.write_text('0.0\n' + f'{deg.size}\n' + ''.join(
        f'{a:.4f} {v:.4f}\n' for a, v in zip(deg, lift_mm)), encoding='utf-8')
    (tmp_path / 's.yaml').write_text(
        'probe: {kind: roller, radius: 0.0125}\nbase_circle_radius: 0.0165\n'
        'lobes:\n  - {id: lobe, nominal_file: lobe.txt}\n', encoding='utf-8')
    law = load_scene(tmp_path / 's.yaml').lobe('lobe').lift
    lo, hi = law.support
    assert -math.pi <= lo < hi <= math.pi
    peak = cc.card_from_law(law, (1e-3,))
    assert peak['centreline_deg'] == pytest.approx(-60.0, abs=0.01)
    table = read_gauge_file(gauge)
    card = table_card(table.alpha, table.lift, (1e-3,), gauge.name)
    assert card['centreline_deg'] == pytest.approx(300.0, abs=0.01)
    assert card['heights'][0]['duration_cam_deg'] == pytest.approx(
        peak['heights'][0]['duration_cam_deg'], abs=1e-6)
