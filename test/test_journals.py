"""Journals as features and the straightness of the shaft: a 3-lobed journal and a bent
shaft recovered within the noise from a simulated bag (closed forms), journal keys
validated with one-line errors."""
from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

from cam_design.errors import InputError
from cam_metrology.metrology.journals import analyze_journal, straightness
from cam_metrology.scene.parse import parse_scene

NOISE = 0.1e-6
SCENE = {'camshaft_id': 'J-1', 'base_circle_radius': 0.017,
         'probe': {'kind': 'roller', 'radius': 0.00625, 'zero_radius': 0.0165},
         'lobes': [],
         'journals': [{'id': f'journal_{i + 1}', 'radius': 0.0125, 'axial_position': z}
                      for i, z in enumerate((0.0, 0.2, 0.4))]}


@pytest.fixture(scope='module')
def report(tmp_path_factory):
    """Three journals, 3-lobed by 1 um, on a shaft bent by 10 um towards 30 deg; the
    probe reads 0 at 16.5 mm (its zero 0.5 mm below the 17 mm base circle)."""
    from cam_metrology.offline.analyze import analyze_report
    from cam_metrology.simulation.bench import SimParams, write_sim_bag

    tol = {'roundness_max_um': 3, 'diameter_um': 2}
    doc = dict(SCENE, journals=[dict(j, tolerances=tol) for j in SCENE['journals']])
    bag = tmp_path_factory.mktemp('journals') / 'bent'
    write_sim_bag(bag, parse_scene(yaml.safe_dump(doc)),
                  SimParams(journal_lobes=3, journal_lobing=1e-6, bend=10e-6,
                            bend_direction_deg=30.0, probe_noise=NOISE, seed=2))
    return analyze_report(str(bag), only_metrology=True)


def test_three_lobed_journal(report) -> None:
    """Each journal: the 3-UPR harmonic at 1 um within 4 standard errors (0.1 sqrt(2/3600)
    um), roundness 2 um (peak-to-valley of the lobing; the filter passes 3 UPR at
    0.9975) within 0.1 um, diameter deviation 0 within 4 standard errors of the mean
    reading (x2), and the verdict passes."""
    se = NOISE * 1e6 * math.sqrt(2.0 / 3600)
    for jid in ('journal_1', 'journal_2', 'journal_3'):
        f = report['features'][jid]
        assert f['status'] == 'ok' and f['kind'] == 'journal'
        lobing = next(h for h in f['harmonics'] if h['upr'] == 3)
        assert lobing['amplitude_um'] == pytest.approx(1.0, abs=4 * se)
        assert f['roundness_um'] == pytest.approx(2.0 * 0.9975, abs=0.1)
        assert f['diameter_deviation_um'] == pytest.approx(0.0, abs=8 * se / math.sqrt(2))
        assert f['verdict']['result'] == 'pass'


def test_bent_shaft(report) -> None:
    """Bow 10 um at mid-span (z = 0.2 m) towards 30 deg: run-out TIR 20 um there, 0 at the
    ends; the straight line fitted through (0, B, 0) leaves (-B/3, 2B/3, -B/3), so the
    straightness is 4B/3 = 13.333 um, the bow 2B/3 at 200 mm towards 30 deg."""
    mid = report['features']['journal_2']
    assert mid['runout_um'] == pytest.approx(20.0, abs=0.01)
    assert mid['runout_direction_deg'] == pytest.approx(30.0, abs=0.1)
    assert report['features']['journal_1']['runout_um'] < 0.05
    shaft = report['shaft']
    assert shaft['straightness_um'] == pytest.approx(40.0 / 3.0, abs=0.02)
    assert shaft['bow_at_mm'] == pytest.approx(200.0)
    assert shaft['bow_direction_deg'] == pytest.approx(30.0, abs=0.2)


def test_straightness_removes_a_tilted_axis() -> None:
    """A straight but tilted and offset axis has straightness 0. One end centre moved by
    3 um (four equally spaced centres): the least-squares line's residuals are
    3 (delta_j0 - h_j0) with the leverages h_j0 = 1/4 + (z_j - zbar)(z_0 - zbar) / 5 (in
    steps): 0.7, 0.4, 0.1, -0.2, so the largest is 1.2 um at the second centre and the
    straightness 2.4 um."""
    z = [0.0, 0.1, 0.2, 0.3]
    line = [[5.0 + 10 * zi, -2.0 + 4 * zi] for zi in z]
    assert straightness(z, line)['straightness_um'] == pytest.approx(0.0, abs=1e-12)
    bent = [list(p) for p in line]
    bent[0][1] += 3.0
    out = straightness(z, bent)
    assert out['straightness_um'] == pytest.approx(2 * 3.0 * 0.4, abs=1e-9)
    assert out['bow_at_mm'] == pytest.approx(100.0)


def test_journal_alone_eccentric_and_lobed() -> None:
    theta = np.arange(720) * (2 * math.pi / 720)
    s = 1e-3 + 5e-6 * np.cos(theta - 1.0) + 2e-6 * np.cos(4 * theta)
    out = analyze_journal(theta, s, radius=0.02, zero_radius=0.019)
    assert out['runout_um'] == pytest.approx(10.0, abs=1e-9)
    assert out['diameter_deviation_um'] == pytest.approx(0.0, abs=1e-9)
    assert out['roundness_um'] == pytest.approx(4.0 * math.exp(-math.log(2) * (4 / 50) ** 2),
                                                abs=1e-6)
    assert analyze_journal(theta, s, 0.02, None)['diameter_deviation_um'] is None


@pytest.mark.parametrize('edit, key', [
    (lambda d: d['journals'][0].pop('radius'), 'journals[0].radius: got None'),
    (lambda d: d['journals'][1].pop('axial_position'), 'journals[1].axial_position'),
    (lambda d: d['journals'][0].update(radius=12.5), 'journals[0].radius'),
    (lambda d: d['journals'][2].update(id='journal_1'), 'journals[2].id'),
    (lambda d: d['probe'].update(zero_radius=-1), 'probe.zero_radius'),
])
def test_bad_journal_keys_are_one_line(edit, key) -> None:
    doc = yaml.safe_load(yaml.safe_dump(SCENE))
    edit(doc)
    with pytest.raises(InputError) as err:
        parse_scene(yaml.safe_dump(doc))
    assert str(err.value).startswith(key) and '\n' not in str(err.value)


def test_journal_without_radius_from_the_command_line(tmp_path, capsys) -> None:
    from cam_metrology.cli import main

    doc = yaml.safe_load(yaml.safe_dump(SCENE))
    del doc['journals'][0]['radius']
    path = tmp_path / 'scene.yaml'
    path.write_text(yaml.safe_dump(doc))
    assert main(['scene', 'check', str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count('\n') == 0 and 'journals[0].radius' in err


B_UM, DIRECTION_DEG = 10.0, 30.0


@pytest.fixture(scope='module')
def lobed_report(tmp_path_factory):
    """The default scene's two lobes at z = 0.1 and 0.3 m between the three journals at
    0, 0.2 and 0.4 m (a third lobe without an axial_position), on a shaft bent by 10 um
    towards 30 deg; 0.1 um probe noise."""
    from cam_metrology.offline.analyze import analyze_report
    from cam_metrology.simulation.bench import SimParams, write_sim_bag
    from scene_docs import default_doc

    doc = default_doc(lobes=3)
    for lobe, z in zip(doc['lobes'], (0.1, 0.3)):
        lobe['axial_position'] = z
    doc['journals'] = SCENE['journals']
    doc['probe']['zero_radius'] = doc['base_circle_radius'] - 0.5e-3
    bag = tmp_path_factory.mktemp('journals') / 'bent_lobes'
    write_sim_bag(bag, parse_scene(yaml.safe_dump(doc)),
                  SimParams(bend=B_UM * 1e-6, bend_direction_deg=DIRECTION_DEG,
                            probe_noise=NOISE, seed=3))
    return doc, analyze_report(str(bag), only_metrology=True)


def test_bent_shaft_with_lobes(lobed_report) -> None:
    """Centres B sin(pi z / 0.4 m) at z = 0, 0.1, 0.2, 0.3, 0.4 m: (0, B/sqrt2, B, B/sqrt2,
    0), symmetric about 0.2 m, so the least-squares line is level at their mean
    B (1 + sqrt2) / 5 and the largest residual is at mid-span, B (4 - sqrt2) / 5 =
    5.172 um (the ends leave B (1 + sqrt2) / 5 = 4.828 um): straightness 2 B (4 - sqrt2)
    / 5 = 10.343 um towards 30 deg. Each lobe's base-circle centre is B / sqrt2 =
    7.071 um towards 30 deg. Tolerance 0.05 um: the base-circle arc of ~220 deg of 3600
    samples fixes a centre to ~0.01 um at 0.1 um noise; the third lobe is left out with
    the note that it has no axial_position."""
    doc, report = lobed_report
    for lobe in doc['lobes'][:2]:
        a, b = report['features'][lobe['id']]['base_circle_eccentricity_um']
        assert math.hypot(a, b) == pytest.approx(B_UM / math.sqrt(2), abs=0.05)
        assert math.degrees(math.atan2(b, a)) == pytest.approx(DIRECTION_DEG, abs=0.5)
        assert report['features'][lobe['id']]['axial_position_mm'] == \
            pytest.approx(lobe['axial_position'] * 1e3)
    shaft = report['shaft']
    assert shaft['from'] == ['journal_1', doc['lobes'][0]['id'], 'journal_2',
                             doc['lobes'][1]['id'], 'journal_3']
    assert shaft['straightness_um'] == pytest.approx(2 * B_UM * (4 - math.sqrt(2)) / 5,
                                                     abs=0.05)
    assert shaft['bow_um'] == pytest.approx(B_UM * (4 - math.sqrt(2)) / 5, abs=0.025)
    assert shaft['bow_at_mm'] == pytest.approx(200.0)
    assert shaft['bow_direction_deg'] == pytest.approx(DIRECTION_DEG, abs=0.5)
    assert shaft['left_out'] == [{'feature': doc['lobes'][2]['id'],
                                  'why': 'no axial_position in the scene'}]


def test_lobe_without_base_circle_is_left_out() -> None:
    """A lobe scanned only over its lift (no base-circle samples) has no centre: it is
    left out of the straightness with the reason. The three journals, equally spaced with
    the first centre moved by 3 um, leave residuals 3 (delta_j0 - h_j0) with the leverages
    h_j0 = 1/3 + (z_j - zbar)(z_0 - zbar) / 2 (in steps) = 5/6, 1/3, -1/6: 0.5, -1, 0.5 um,
    so the straightness is 2 um."""
    from cam_metrology.metrology.analysis import Settings, analyze_lobe
    from cam_metrology.metrology.features import clean_feature
    from cam_metrology.metrology.journals import shaft_straightness
    from cam_metrology.metrology.synthetic import PolynomialRampCam, sample_lobe

    cam, nose = PolynomialRampCam(), math.radians(222.0)
    smp = sample_lobe(cam, nose, 1, n_per_rev=3600, zero=0.0042)
    keep = np.abs(np.angle(np.exp(1j * (smp.theta - nose)))) < math.radians(75.0)
    fs = clean_feature('lobe_1', smp.stamp_ns[keep], smp.theta[keep], smp.s[keep])
    lobe = {**analyze_lobe(fs, cam, 1, Settings()).values, 'status': 'ok'}
    assert lobe['base_circle_eccentricity_um'] is None
    features = {'lobe_1': lobe,
                **{f'journal_{k}': {'kind': 'journal', 'status': 'ok', 'eccentricity_um': e}
                   for k, e in enumerate(([0.0, 3.0], [0.0, 0.0], [0.0, 0.0]), start=1)}}
    out = shaft_straightness(features, {'journal_1': 0.0, 'lobe_1': 0.05, 'journal_2': 0.1,
                                        'journal_3': 0.2})
    assert out['from'] == ['journal_1', 'journal_2', 'journal_3']
    assert out['left_out'] == [{'feature': 'lobe_1', 'why': 'fewer than 10 base-circle '
                                'samples: no base-circle centre'}]
    assert out['straightness_um'] == pytest.approx(2.0, abs=1e-9)


@pytest.mark.parametrize('value, expected', [(100.0, 'millimetres given?'),
                                             ('near', 'a finite real number')])
def test_bad_lobe_axial_position_is_one_line(value, expected) -> None:
    from scene_docs import default_doc

    doc = default_doc(lobes=1)
    doc['lobes'][0]['axial_position'] = value
    with pytest.raises(InputError) as err:
        parse_scene(yaml.safe_dump(doc))
    assert str(err.value).startswith('lobes[0].axial_position') and \
        '\n' not in str(err.value)
    assert expected in str(err.value)


def test_human_report_names_the_lobes_left_out(lobed_report) -> None:
    """The human report of ``analyze`` gives the straightness with the number of centres
    and one line per feature left out, with the reason."""
    from cam_metrology.cli.analyze import form_lines

    doc, report = lobed_report
    lines = form_lines(report)
    assert any(line.startswith('shaft straightness 10.3') and 'from 5 centres' in line
               for line in lines)
    assert f"shaft straightness leaves out {doc['lobes'][2]['id']}: no axial_position in " \
        'the scene' in lines
