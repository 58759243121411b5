"""Lobe taper and twist from two or more tracks across the lobe's width (frame_id
``<lobe>@<z mm>``): recovered within the noise from a simulated bag; a track label that
does not parse fails that feature with a one-line reason."""
from __future__ import annotations

import pytest
import yaml

from cam_design.errors import InputError
from cam_metrology.metrology.tracks import taper_and_twist, track_label
from cam_metrology.scene.parse import parse_scene
from scene_docs import default_doc


@pytest.fixture(scope='module')
def report(tmp_path_factory):
    """Lobe 1 of the default scene on tracks at -5, 0, +5 mm: its nose lift grows 2 um per
    mm of width and its nose turns 0.01 deg per mm; 0.2 um probe noise."""
    from cam_metrology.offline.analyze import analyze_report
    from cam_metrology.simulation.bench import SimParams, write_sim_bag

    doc = default_doc(lobes=1)
    bag = tmp_path_factory.mktemp('tracks') / 'tapered'
    write_sim_bag(bag, parse_scene(yaml.safe_dump(doc)),
                  SimParams(samples_per_rev=3600, lobe_tracks_mm=(-5.0, 0.0, 5.0),
                            taper_um_per_mm=2.0, twist_deg_per_mm=0.01, probe_noise=0.2e-6,
                            seed=4))
    return analyze_report(str(bag), only_metrology=True)


def test_taper_and_twist_recovered(report) -> None:
    """Taper 2 um/mm within 0.02 um/mm (the nose lift error of each track averages ~20
    samples of 0.2 um noise over 10 mm of width: se ~ 0.045 um / 10 mm x sqrt 2), twist
    0.01 deg/mm within 2e-4 deg/mm (nose angle std ~0.4 arcsec per track), the nose-angle
    difference 0.1 deg between the outer tracks; every track judged like the lobe."""
    tr = report['lobe_tracks']['lobe_1']
    assert tr['tracks'] == ['lobe_1@-5', 'lobe_1@0', 'lobe_1@5']
    assert tr['taper_um_per_mm'] == pytest.approx(2.0, abs=0.02)
    assert tr['twist_deg_per_mm'] == pytest.approx(0.01, abs=2e-4)
    assert tr['nose_angle_difference_deg'] == pytest.approx(0.1, abs=2e-3)
    for fid in tr['tracks']:
        f = report['features'][fid]
        assert f['status'] == 'ok' and f['track_of'] == 'lobe_1'
        assert f['verdict']['result'] in ('pass', 'fail')
    assert report['complete'] is True
    assert not any(s['what'] == 'lobe_1' for s in report['skipped'])


def test_track_label_parses_or_names_the_frame_id() -> None:
    assert track_label('lobe_1') is None
    assert track_label('lobe_1@-4.5') == ('lobe_1', -4.5)
    for bad in ('lobe_1@', 'lobe_1@left', '@3', 'lobe_1@nan'):
        with pytest.raises(InputError) as err:
            track_label(bad)
        msg = str(err.value)
        assert msg.startswith(f"frame_id: got '{bad}'") and '\n' not in msg


def test_unparsable_track_fails_that_feature_in_one_line(tmp_path) -> None:
    """Samples under frame_id lobe_1@left: that feature fails with the one-line reason;
    nothing else is affected."""
    import numpy as np

    from cam_metrology.metrology.core import MetrologyCore

    with open('config/default_scene.yaml', encoding='utf-8') as f:
        scene = parse_scene(f.read())
    core = MetrologyCore()
    core.set_scene(scene)
    n = 720
    core.handle_samples(['lobe_1@left'] * n, np.arange(n) * 1000, np.linspace(0, 6.28, n),
                        np.zeros(n))
    core.finish()
    res = core.results['lobe_1@left']
    assert res.failed.startswith("frame_id: got 'lobe_1@left'; expected <lobe id>@<track")
    assert '\n' not in res.failed


def test_two_tracks_are_enough_and_one_is_not() -> None:
    f = {'status': 'ok', 'angle_deg': 359.99, 'nose_lift_error_um': 0.0, 'track_mm': -2.0}
    g = {'status': 'ok', 'angle_deg': 0.03, 'nose_lift_error_um': 4.0, 'track_mm': 2.0}
    out = taper_and_twist({'a@-2': f, 'a@2': g})
    assert out['taper_um_per_mm'] == pytest.approx(1.0, abs=1e-12)
    assert out['nose_angle_difference_deg'] == pytest.approx(0.04, abs=1e-9)   # across 0
    assert taper_and_twist({'a@-2': f}) is None


def test_taper_and_twist_tolerances_in_the_verdict() -> None:
    from cam_metrology.metrology.tolerances import judge_tracks
    from cam_metrology.scene.model import Tolerances

    feats = {'l@-2': {'status': 'ok', 'angle_deg': 10.0, 'nose_lift_error_um': -3.0,
                      'track_mm': -2.0, 'track_of': 'l'},
             'l@2': {'status': 'ok', 'angle_deg': 10.05, 'nose_lift_error_um': 3.0,
                     'track_mm': 2.0, 'track_of': 'l'}}
    v = judge_tracks(Tolerances(taper_max_um_per_mm=1.0, twist_max_deg=0.1), 'l', feats)
    res = {c['quantity']: c['result'] for c in v['checks']}
    assert res == {'taper_um_per_mm': 'fail', 'nose_angle_difference_deg': 'pass'}
    v = judge_tracks(Tolerances(taper_max_um_per_mm=1.0), 'l', {'l@-2': feats['l@-2']})
    assert v['result'] == 'not checked'


def test_tracks_in_the_html_report(report) -> None:
    """The HTML form section's tracks table gives each tracked lobe's taper (2 um/mm
    within 0.02, printed to 3 decimals), nose-angle difference and twist in arcsec/mm."""
    from cam_metrology.report.form_html import form_html

    tr = report['lobe_tracks']['lobe_1']
    text = form_html(report)
    row = text[text.index('<table id="tracks">'):].split('<tr>')[2]
    assert '<td class="l">lobe_1@-5, lobe_1@0, lobe_1@5</td>' in row
    assert f"<td>{tr['taper_um_per_mm']:.3f}</td>" in row
    assert f"<td>{tr['nose_angle_difference_deg']:.4f}</td>" in row
    assert f"<td>{tr['twist_deg_per_mm'] * 3600:.2f}</td>" in row
    assert abs(tr['twist_deg_per_mm'] * 3600 - 36.0) < 0.72
