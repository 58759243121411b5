"""`cam-bench analyze` on simulated bags (and the committed fixture bags, if any)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from cam_metrology.cli import main

pytest.importorskip('cam_metrology.simulation.bench')


@pytest.fixture(scope='module')
def sim_bag(tmp_path_factory):
    """The default scene simulated at 720 samples/rev, noise-free, wrapped angles."""
    from cam_metrology.host.paths import default_scene_path
    from cam_metrology.scene.parse import load_scene
    from cam_metrology.simulation.bench import SimParams, write_sim_bag

    path = tmp_path_factory.mktemp('bags') / 'sim'
    run = write_sim_bag(path, load_scene(default_scene_path()),
                        SimParams(samples_per_rev=720, wrapped=True, seed=4,
                                  probe_zero_offset=-3e-3))
    return path, run.truth


def test_analyze_json_matches_truth(sim_bag, tmp_path, capsys):
    bag, truth = sim_bag
    out = tmp_path / 'report.json'
    assert main(['analyze', str(bag), '--json', str(out), '--only-metrology']) == 0
    report = json.loads(out.read_text())
    assert report['camshaft_id'] == truth['camshaft_id']
    assert isinstance(report['skipped'], list)
    for fid, t in truth['features'].items():
        f = report['features'][fid]
        assert f['kind'] == t['kind']
        for key in ('angle_deg', 'angle_std_deg'):
            assert key in f
        err = ((f['angle_deg'] - t['angle_deg'] + 180) % 360 - 180) * 3600
        assert abs(err) < 0.01, (fid, err)
        sp = ((f['sensitive_point_angle_deg'] - t['angle_deg'] + 180) % 360 - 180) * 3600
        assert abs(sp) < 0.01, (fid, sp)
        if t['kind'] == 'lobe':
            for key in ('phase_deg', 'phase_error_deg', 'asymmetry_deg'):
                assert key in f
            assert f['phase_deg'] == pytest.approx(t['phase_deg'], abs=1e-5)
            assert f['phase_error_deg'] == pytest.approx(t['phase_error_deg'], abs=1e-5)


def test_analyze_stdout_json_human_plot_and_out_bag(sim_bag, tmp_path, capsys):
    bag, _ = sim_bag
    assert main(['analyze', str(bag), '--json', '-', '--only-metrology']) == 0
    assert 'features' in json.loads(capsys.readouterr().out)
    plots, out_bag = tmp_path / 'plots', tmp_path / 'out'
    assert main(['analyze', str(bag), '--plot', str(plots), '--out-bag', str(out_bag),
                 '--only-metrology']) == 0
    text = capsys.readouterr().out
    assert 'lobe_1' in text and 'dowel_pin' in text
    assert sorted(p.name for p in plots.glob('*.png')) == sorted(
        ['lobe_1.png', 'lobe_2.png', 'lobe_3.png', 'lobe_4.png', 'dowel_pin.png'])
    from cam_metrology import bagio
    topics = bagio.bag_topics(out_bag)
    assert topics['/metrology/report'][1] >= 1
    assert topics['/metrology/lift'][1] == 5
    assert topics['/bench/joint_states'][1] == 5 * 720


def test_analyze_params_file(sim_bag, tmp_path, capsys):
    bag, _ = sim_bag
    params = tmp_path / 'p.yaml'
    params.write_text('metrology:\n  ros__parameters:\n    sp_pairs: 1\n')
    assert main(['analyze', str(bag), '--json', '-', '--only-metrology',
                 '--params', str(params)]) == 0
    params.write_text('metrology:\n  ros__parameters:\n    sp_pairs: many\n')
    assert main(['analyze', str(bag), '--params', str(params), '--only-metrology']) == 2
    assert 'metrology.sp_pairs' in capsys.readouterr().err


def test_analyze_missing_bag_exits_2(tmp_path, capsys):
    assert main(['analyze', str(tmp_path / 'nope')]) == 2
    assert 'bag' in capsys.readouterr().err


def _fixture_bags() -> list[Path]:
    root = Path(__file__).resolve().parent.parent / 'bags'
    return sorted(p for p in root.glob('*') if (p / 'metadata.yaml').exists())


@pytest.mark.parametrize('bag', _fixture_bags() or [None])
def test_fixture_bags_against_their_truth(bag, tmp_path):
    """Every committed fixture bag with a /bench/truth: angles within 4 sigma + 0.01"."""
    if bag is None:
        pytest.skip('no fixture bags committed yet')
    from cam_metrology import bagio
    truth = [m.msg.data for m in bagio.iter_messages(bag, ['/bench/truth'])]
    out = tmp_path / 'r.json'
    assert main(['analyze', str(bag), '--json', str(out), '--only-metrology']) == 0
    report = json.loads(out.read_text())
    if not truth:
        return
    t = json.loads(truth[0])
    for fid, tf in t['features'].items():
        f = report['features'].get(fid)
        if f is None or f.get('status') != 'ok':
            continue
        err = (f['angle_deg'] - tf['angle_deg'] + 180) % 360 - 180
        assert abs(err) <= 4 * f['angle_std_deg'] + 0.01 / 3600 + 1e-9, (fid, err)
        assert np.isfinite(f['angle_std_deg'])


def test_analyze_noisy_bag_with_runout_and_encoder_noise(tmp_path):
    """Probe noise, encoder noise and run-out: errors within 4 reported sigma (+ bias
    of the unmodelled run-out, checked with fit_runout)."""
    from cam_metrology.metrology.core import MetrologyCore
    from cam_metrology.host.paths import default_scene_path
    from cam_metrology.offline.replay import run_offline
    from cam_metrology.scene.parse import load_scene
    from cam_metrology.simulation.bench import SimParams, write_sim_bag

    bag = tmp_path / 'noisy'
    run = write_sim_bag(bag, load_scene(default_scene_path()),
                        SimParams(samples_per_rev=1440, revolutions=2, probe_noise=1e-6,
                                  encoder_noise=2e-6, runout=2e-6, seed=11, start_theta=1.0))
    report = run_offline(bag, [MetrologyCore({'fit_runout': True})]).report()
    for fid, t in run.truth['features'].items():
        f = report['features'][fid]
        assert f['status'] == 'ok', f
        err = (f['angle_deg'] - t['angle_deg'] + 180) % 360 - 180
        assert abs(err) < 4 * f['angle_std_deg'] + 1e-7, (fid, err, f['angle_std_deg'])


BAGS = Path(__file__).resolve().parent.parent / 'bags'


def _report(bag: Path, tmp_path: Path, *extra: str) -> dict:
    out = tmp_path / f'{bag.name}.json'
    assert main(['analyze', str(bag), '--json', str(out), *extra]) == 0
    return json.loads(out.read_text())


def test_fixture_irregular_bag_counts(tmp_path):
    bag = BAGS / 'irregular'
    if not (bag / 'metadata.yaml').exists():
        pytest.skip('fixture bag irregular not committed')
    rep = _report(bag, tmp_path, '--only-metrology')
    for fid in ('lobe_1', 'lobe_2', 'lobe_3', 'lobe_4', 'dowel_pin'):
        f = rep['features'][fid]
        assert f['status'] == 'ok'
        # 1800 samples: s NaN every 97th, theta NaN every 503rd, every 89th twice
        assert f['samples_nan_dropped'] >= 1800 // 97
        assert f['samples_duplicate_dropped'] >= 1800 // 89 - 1
        assert f['samples_used'] <= 1800
    assert rep['complete'] is True   # no feature_done: ended by frame change and timeout


def test_fixture_no_pin_bag_skips(tmp_path):
    bag = BAGS / 'no_pin_no_valve_train'
    if not (bag / 'metadata.yaml').exists():
        pytest.skip('fixture bag no_pin_no_valve_train not committed')
    rep = _report(bag, tmp_path)
    whats = {s['what'] for s in rep['skipped']}
    assert {'pin', 'phase'} <= whats
    for fid in ('lobe_1', 'lobe_2'):
        assert rep['features'][fid]['phase_deg'] is None
        assert rep['features'][fid]['asymmetry_deg'] is not None


def test_analyze_bag_without_scene_exits_2(tmp_path, capsys):
    from cam_metrology import bagio
    bag = tmp_path / 'noscene'
    with bagio.BagWriter(bag) as writer:
        writer.add_topic(bagio.JOINT_STATES, 'sensor_msgs/msg/JointState')
        for k in range(10):
            writer.write(bagio.JOINT_STATES, 1000 + k,
                         bagio.encode_joint_state('lobe_1', 1000 + k, 0.01 * k, 0.0))
    assert main(['analyze', str(bag), '--only-metrology']) == 2
    assert 'no /bench/scene' in capsys.readouterr().err
