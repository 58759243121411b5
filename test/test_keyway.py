"""Keyway datum: geometry against closed forms, the centre estimator exact without noise
and at its Cramer-Rao bound with noise, the scene keys and their bad input, and
`cam-bench analyze` end to end on a simulated keyway camshaft."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from cam_design.errors import InputError
from cam_design.keyway import BOTTOM, EDGE_MINUS, EDGE_PLUS, SHAFT, KeywayGeometry
from cam_metrology.metrology.analysis import Settings, analyze_keyway, keyway_used
from cam_metrology.metrology.features import clean_feature
from cam_metrology.metrology.flank_fit import crb_shift_std
from cam_metrology.metrology.synthetic import sample_keyway

#: a small ball that drops to the bottom of the slot, and a ball wider than the slot
FALL_IN = KeywayGeometry(width=5e-3, shaft_radius=15e-3, probe_radius=1e-3, depth=3e-3)
WIDE_BALL = KeywayGeometry(width=4e-3, shaft_radius=15e-3, probe_radius=2.5e-3)
ARCSEC = np.pi / 180 / 3600
REPO = Path(__file__).resolve().parents[1]


def _err_arcsec(measured_deg: float, true_rad: float) -> float:
    return ((measured_deg - np.degrees(true_rad) + 180.0) % 360.0 - 180.0) * 3600.0


def _analyze(smp, geo, direction=1, **settings):
    fs = clean_feature('keyway', smp.stamp_ns, smp.theta, smp.s)
    return analyze_keyway(fs, geo, direction, Settings(**settings))


# ----------------------------------------------------------------- geometry

def test_lift_closed_forms():
    """Ball on both edges at the centre: L = sqrt(R^2 - w^2/4) + sqrt(r^2 - w^2/4);
    ball on the bottom: L = R - depth + r; on the shaft h = 0; edges at arcsin(w/2R)."""
    w, big, r = 4e-3, 15e-3, 2.5e-3
    centre = np.sqrt(big**2 - w**2 / 4) + np.sqrt(r**2 - w**2 / 4) - (big + r)
    assert WIDE_BALL.lift(0.0) == pytest.approx(centre, abs=1e-15)
    assert FALL_IN.lift(0.0) == pytest.approx(-3e-3, abs=1e-15)
    assert WIDE_BALL.edge_angle == pytest.approx(np.arcsin(w / 2 / big), abs=1e-15)
    beta = FALL_IN.edge_angle
    assert FALL_IN.lift(np.array([beta, beta + 0.1, -np.pi + 1e-3])) == \
        pytest.approx([0.0, 0.0, 0.0], abs=1e-15)
    assert FALL_IN.branch(np.array([beta + 0.01, beta - 0.01, -beta + 0.01, 0.0])).tolist() \
        == [SHAFT, EDGE_PLUS, EDGE_MINUS, BOTTOM]
    # a ball narrower than the slot leaves the edge at its tangent angle arcsin(r/R)
    assert FALL_IN.edge_span() == pytest.approx(np.arcsin(1 / 15), abs=2e-5)
    assert WIDE_BALL.edge_span() == pytest.approx(WIDE_BALL.edge_angle, abs=1e-15)


@pytest.mark.parametrize('geo', [FALL_IN, WIDE_BALL])
def test_lift_derivatives_match_finite_differences(geo):
    x = np.radians(np.linspace(-20, 20, 161)) + 1e-4
    eps = 1e-7
    for nu in range(3):
        num = (geo.lift(x + eps, nu) - geo.lift(x - eps, nu)) / (2 * eps)
        ana = geo.lift(x, nu + 1)
        ok = np.isfinite(ana) & (np.abs(np.abs(x) - geo.edge_angle) > 1e-5)
        scale = np.max(np.abs(ana[ok]))
        assert np.max(np.abs(num - ana)[ok]) < 1e-6 * scale
    # C1 where the shaft meets an edge arc: the slope is 0 on both sides
    beta = geo.edge_angle
    assert np.abs(geo.lift(np.array([beta - 1e-9, beta + 1e-9]), 1)).max() < 1e-9


# ---------------------------------------------------------------- estimator

@pytest.mark.parametrize('geo', [FALL_IN, WIDE_BALL])
@pytest.mark.parametrize('direction,turn,wrapped,revs',
                         [(1, 1, False, 1.0), (-1, -1, True, 2.0)])
def test_noise_free_centre_exact(geo, direction, turn, wrapped, revs):
    """Any start, probe zero, either direction, wrapped angles and a 3 um run-out:
    the centre to < 0.001 arcsec and the run-out fitted."""
    centre = np.radians(231.123456)
    smp = sample_keyway(geo, centre, direction, n_per_rev=7200, revolutions=revs,
                        turn=turn, wrapped=wrapped, zero=-0.0123, runout=3e-6, start=1.1)
    res = _analyze(smp, geo, direction)
    v = res.values
    assert abs(_err_arcsec(v['angle_deg'], centre)) < 1e-3
    assert v['kind'] == 'keyway' and v['runout_fitted']
    assert v['fitted_runout_amplitude_um'] == pytest.approx(3.0, abs=1e-4)
    assert v['residual_rms_um'] < 1e-3
    assert res.skipped[0][0] == 'sensitive_point'


def test_crb_spread_and_bias_over_noisy_runs():
    """150 runs, 0.5 um probe noise, 2 um run-out: the spread of the centre estimates
    matches the Cramer-Rao bound (Jacobian of shift, offset and run-out harmonic on the
    samples the fit uses, at the true angles), the reported std matches it too, and the
    mean error (bias) is within 3 standard errors of zero, well under an arc-second."""
    geo, centre, sigma, runs = WIDE_BALL, np.radians(123.4567), 0.5e-6, 150
    errs, stds = [], []
    for k in range(runs):
        smp = sample_keyway(geo, centre, n_per_rev=1800, zero=0.01, noise=sigma, seed=k,
                            runout=2e-6)
        v = _analyze(smp, geo).values
        errs.append(_err_arcsec(v['angle_deg'], centre))
        stds.append(v['angle_std_deg'] * 3600)
    x = np.angle(np.exp(1j * (smp.theta - centre)))
    used = keyway_used(geo, x, np.radians(Settings().pin_edge_margin_deg))
    crb = crb_shift_std(x[used], geo.lift, sigma, smp.theta[used]) / ARCSEC
    spread = float(np.std(errs, ddof=1))
    # the sample std of 150 Gaussian errors is within +-17 % (3 sigma) of the truth
    assert 0.83 < spread / crb < 1.17, (spread, crb)
    assert abs(np.mean(stds) / crb - 1) < 0.03
    bias = float(np.mean(errs))
    assert abs(bias) < 3 * crb / np.sqrt(runs) and abs(bias) < 0.5


def test_edge_flank_without_samples_fails_the_feature():
    from cam_metrology.metrology.analysis import FeatureFailed

    smp = sample_keyway(FALL_IN, 0.5, n_per_rev=360)   # 1 deg steps: a 3.8 deg flank
    with pytest.raises(FeatureFailed, match='flank'):
        _analyze(smp, FALL_IN)


# --------------------------------------------------------------------- scene

BASE = """
probe: {kind: roller, radius: 0.0125}
base_circle_radius: 0.0165
lobes:
  - {id: in1, role: intake, nominal_phase: 1.0, lift_law: {family: preset,
     name: flat_tappet_intake}}
"""


def _scene(extra: str):
    from cam_metrology.scene.parse import parse_scene

    return parse_scene(BASE + extra)


def test_scene_role_must_be_intake_or_exhaust():
    from cam_metrology.scene.parse import parse_scene

    with pytest.raises(InputError) as exc:
        parse_scene(BASE.replace('role: intake', 'role: inlet'))
    assert exc.value.key == 'lobes[0].role'


def test_scene_check_names_the_keyway_and_the_crank(capsys):
    from cam_metrology.cli import main

    assert main(['scene', 'check', str(REPO / 'config' / 'keyway_scene.yaml')]) == 0
    out = capsys.readouterr().out
    assert 'keyway: width 5 mm, shaft r=12 mm, ball r=1.5 mm, depth 3 mm' in out
    assert 'crank: cylinder 1 TDC 10 cam deg from the keyway' in out


def test_scene_keyway_and_crank_parsed():
    sc = _scene('keyway: {width: 0.005, shaft_radius: 0.012, probe_radius: 0.0015, '
                'depth: 0.003, nominal_angle: 0.1}\ncrank: {tdc_deg: 10, '
                'cylinder_tdc_deg: {1: 0, 2: 360}}\n')
    assert sc.datum_id == 'keyway' and sc.keyway.depth == 0.003
    assert sc.crank.tdc_deg == 10.0 and sc.crank.cylinder_tdc_deg == {'1': 0.0, '2': 360.0}
    assert sc.lobes[0].role == 'intake' and sc.lobes[0].cylinder == '1'


@pytest.mark.parametrize('extra,key', [
    ('keyway: {width: 0.025, shaft_radius: 0.012, probe_radius: 0.0015}', 'keyway.width'),
    ('keyway: {shaft_radius: 0.012, probe_radius: 0.0015}', 'keyway.width'),
    ('keyway: {width: 0.005, shaft_radius: 0.012, probe_radius: 0.0015}', 'keyway.depth'),
    ('keyway: {width: 0.005, shaft_radius: 0.012, probe_radius: 0.0015, depth: 0.0001}',
     'keyway.depth'),
    ('keyway: {width: 0.004, shaft_radius: 0.012, probe_radius: 0.0025}\n'
     'dowel_pin: {pin_radius: 0.0025, circle_radius: 0.0115, probe_radius: 0.002}', 'keyway'),
    ('crank: {tdc_deg: 10}', 'crank'),
    ('keyway: {width: 0.004, shaft_radius: 0.012, probe_radius: 0.0025}\ncrank: {}',
     'crank.tdc_deg'),
    ('keyway: {width: 0.004, shaft_radius: 0.012, probe_radius: 0.0025}\n'
     'crank: {tdc_deg: 10, cylinder_tdc_deg: {2: 360}}', 'lobes[0].cylinder'),
    ('keyway: {width: 0.004, shaft_radius: 0.012, probe_radius: 0.0025}\n'
     'crank: {tdc_deg: 400}', 'crank.tdc_deg'),
    ('keyway: {width: 0.004, shaft_radius: 0.012, probe_radius: 0.015}', 'keyway.probe_radius'),
])
def test_scene_bad_datum_names_the_key(extra, key):
    with pytest.raises(InputError) as exc:
        _scene(extra)
    assert exc.value.key == key
    assert '\n' not in str(exc.value)


# ----------------------------------------------------------------- end to end

def test_analyze_keyway_camshaft_end_to_end(tmp_path):
    """The example keyway scene simulated with noise and run-out: the keyway centre and
    the lobes' phases (against the keyway) within 4 reported sigma of the truth."""
    from cam_metrology.cli import main
    from cam_metrology.scene.parse import load_scene
    from cam_metrology.simulation.bench import SimParams, write_sim_bag

    bag = tmp_path / 'kw'
    run = write_sim_bag(bag, load_scene(REPO / 'config' / 'keyway_scene.yaml'),
                        SimParams(samples_per_rev=3600, probe_noise=0.5e-6, runout=2e-6,
                                  seed=11, wrapped=True))
    out, page = tmp_path / 'r.json', tmp_path / 'r.html'
    assert main(['analyze', str(bag), '--json', str(out), '--only-metrology',
                 '--report', str(page)]) == 0
    rep = json.loads(out.read_text())
    html = page.read_text()
    assert 'Crank timing' in html and 'alt="keyway lift' in html
    assert html.count('<img class="plot"') == 3
    kw = rep['features']['keyway']
    truth = run.truth['features']
    assert rep['datum'] == {'feature': 'keyway', 'angle_deg': kw['angle_deg']}
    assert rep['dowel_pin_angle_deg'] is None
    assert abs(kw['angle_deg'] - truth['keyway']['angle_deg']) * 3600 < \
        4 * kw['angle_std_deg'] * 3600
    for fid in ('intake_1', 'exhaust_1'):
        f = rep['features'][fid]
        std = np.hypot(f['angle_std_deg'], kw['angle_std_deg'])
        assert abs(f['phase_deg'] - truth[fid]['phase_deg']) < 4 * std
        assert abs(f['phase_error_deg'] - truth[fid]['phase_error_deg']) < 4 * std
    # crank timing against the keyway: the lobe separation is the difference of the
    # measured centrelines (phase + card centreline at 1 mm, from the nose), and within
    # 0.01 deg of the true phase difference (symmetric lobes)
    pair = rep['crank']['measured']['pairs'][0]
    cl = {f: rep['features'][f]['phase_deg'] +
          rep['features'][f]['cam_card']['measured']['centreline_deg']
          for f in ('intake_1', 'exhaust_1')}
    assert pair['lobe_separation_deg'] == pytest.approx(cl['intake_1'] - cl['exhaust_1'],
                                                        abs=1e-9)
    true_lsa = truth['intake_1']['phase_deg'] - truth['exhaust_1']['phase_deg']
    assert abs(pair['lobe_separation_deg'] - true_lsa) < 0.01
    assert rep['crank']['nominal']['pairs'][0]['lobe_separation_deg'] == \
        pytest.approx(110.0, abs=1e-9)
