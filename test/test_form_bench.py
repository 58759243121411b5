"""Chatter on a simulated camshaft, end to end: bench simulator -> bag -> analyze. The
report's harmonics and waviness recover the chatter within the noise, the verdict judges
the scene's form tolerances, and a band the sampling cannot resolve is refused in one line
(the lobe's other results stand)."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
import yaml

from cam_metrology.scene.parse import parse_scene
from scene_docs import default_doc

NOISE = 0.2e-6
SPR = 3600


def _doc() -> dict:
    doc = default_doc()
    doc['tolerances'] = {'waviness_max_um': 0.5, 'roundness_max_um': 3.0}
    return doc


@pytest.fixture(scope='module')
def chatter_report(tmp_path_factory):
    from cam_metrology.offline.analyze import analyze_report
    from cam_metrology.simulation.bench import SimParams, write_sim_bag

    scene = parse_scene(yaml.safe_dump(_doc()))
    bag = tmp_path_factory.mktemp('form') / 'chatter'
    write_sim_bag(bag, scene, SimParams(samples_per_rev=SPR, probe_noise=NOISE, seed=5,
                                        chatter_upr=37, chatter_amplitude=0.8e-6))
    return analyze_report(str(bag), only_metrology=True)


def test_chatter_37_upr_recovered_and_rejected(chatter_report) -> None:
    """0.8 um at 37 UPR all round every lobe, 0.2 um probe noise at 3600 samples/rev: the
    largest harmonic is 37 UPR at 0.8 um within 4 standard errors (0.2 sqrt(2/3600) um:
    the lift table keeps every sample), and the waviness tolerance of 0.5 um fails it."""
    se = NOISE * 1e6 * math.sqrt(2.0 / SPR)
    for fid in ('lobe_1', 'lobe_2', 'lobe_3', 'lobe_4'):
        f = chatter_report['features'][fid]
        top = f['harmonics'][0]
        assert top['upr'] == 37
        assert top['amplitude_um'] == pytest.approx(0.8, abs=4 * se)
        assert f['waviness']['upr_at_max'] == 37
        assert f['waviness']['max_amplitude_um'] == pytest.approx(0.8, abs=4 * se)
        checks = {c['quantity']: c for c in f['verdict']['checks']}
        assert checks['waviness_max_amplitude_um']['result'] == 'fail'
        # the chatter (0.8 um, 37 UPR) passes the 50 UPR filter at exp(-ln2 (37/50)^2)
        # = 0.684: about 2 x 0.547 um PV, under the 3 um roundness limit
        assert 0.9 < f['roundness_um'] < 3.0
        assert checks['roundness_um']['result'] == 'pass'
    assert chatter_report['verdict']['result'] == 'fail'


def test_clean_part_passes_the_form_tolerances(tmp_path) -> None:
    from cam_metrology.offline.analyze import analyze_report
    from cam_metrology.simulation.bench import SimParams, write_sim_bag

    scene = parse_scene(yaml.safe_dump(_doc()))
    write_sim_bag(tmp_path / 'clean', scene, SimParams(samples_per_rev=720,
                                                       probe_noise=NOISE, seed=6))
    rep = analyze_report(str(tmp_path / 'clean'), only_metrology=True)
    assert rep['verdict']['result'] == 'pass'
    wav = rep['features']['lobe_1']['waviness']
    assert wav['max_amplitude_um'] < 0.1


def test_band_beyond_nyquist_is_one_line_and_the_lobe_stands(tmp_path) -> None:
    """720 samples per revolution resolve 360 UPR: a waviness band to 500 UPR gives the
    one-line reason under skipped (form/lobe_1) and form_error; the nose angle stands and
    the waviness tolerance is 'not checked', never passed."""
    from cam_metrology.offline.analyze import analyze_report
    from cam_metrology.simulation.bench import SimParams, write_sim_bag

    doc = _doc()
    doc['form'] = {'cutoff_upr': 50, 'waviness_band_upr': [100, 500]}
    scene = parse_scene(yaml.safe_dump(doc))
    write_sim_bag(tmp_path / 'coarse', scene, SimParams(samples_per_rev=720, seed=7))
    rep = analyze_report(str(tmp_path / 'coarse'), only_metrology=True)
    f = rep['features']['lobe_1']
    assert f['status'] == 'ok' and f['angle_deg'] is not None
    assert '\n' not in f['form_error']
    assert f['form_error'].startswith('form.waviness_band_upr: got [100, 500]; expected a '
                                      'band up to at most 360 UPR')
    skipped = {s['what']: s['why'] for s in rep['skipped']}
    assert skipped['form/lobe_1'] == f['form_error']
    assert rep['verdict']['result'] == 'not checked'


@pytest.mark.parametrize('form, key', [
    ({'cutoff_upr': 0}, 'form.cutoff_upr'),
    ({'waviness_band_upr': [50, 20]}, 'form.waviness_band_upr'),
    ({'waviness_band_upr': [20, 'x']}, 'form.waviness_band_upr[1]'),
])
def test_bad_form_block_names_the_key(form, key) -> None:
    from cam_design.errors import InputError

    doc = _doc()
    doc['form'] = form
    with pytest.raises(InputError) as err:
        parse_scene(yaml.safe_dump(doc))
    assert str(err.value).startswith(key + ':')


def test_simulated_chatter_model() -> None:
    """The simulator's chatter is A cos(k theta) on the chattered arc only."""
    from cam_metrology.simulation.bench import SimParams, chatter

    theta = np.linspace(0, 2 * np.pi, 721)
    alpha = theta - np.pi
    p = SimParams(chatter_upr=5, chatter_amplitude=1e-6, chatter_extent_deg=90,
                  chatter_centre_deg=0.0)
    c = chatter(theta, alpha, p)
    inside = np.abs(alpha) <= np.radians(45) + 1e-12
    assert np.allclose(c[inside], 1e-6 * np.cos(5 * theta[inside]), atol=1e-18)
    assert np.all(c[~inside] == 0.0)
    assert json.dumps(p.validated().chatter_upr) == '5'
