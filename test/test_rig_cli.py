"""`cam-bench rig`: the command line, the rig bag, and every bad input of the issue as
one line naming what is missing and what would work (exit 2, no result written)."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from cam_metrology.cli import main
from cam_metrology.rig.runs import RigRun, write_csv_run

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / 'config' / 'rig_scene.yaml'


@pytest.fixture(scope='module')
def runs(tmp_path_factory):
    """Two synthetic runs (the product's simulator; the numbers are tested in
    test_rig.py against the independent solver) as CSV files and as one bag."""
    from cam_metrology.rig.bag import write_rig_bag
    from cam_metrology.rig.simulate import RigNoise, simulate_scene_runs
    from cam_metrology.scene.parse import load_scene

    folder = tmp_path_factory.mktemp('rig')
    scene = load_scene(SCENE)
    sim, _ = simulate_scene_runs(scene, [1010, 1790], revolutions=3,
                                 noise=RigNoise(sample_rate=20_000.0, vibrometer=True))
    paths = []
    for r in sim:
        paths.append(folder / f'{r.name}.csv')
        write_csv_run(r, paths[-1])
    write_rig_bag(folder / 'bag', scene.text, sim)
    return folder, paths


def _fail(capsys, argv, out=None):
    """Run the CLI expecting a refusal: exit 2, one stderr line, nothing on stdout, no
    output file. Returns the line."""
    code = main(argv)
    cap = capsys.readouterr()
    assert code == 2, cap
    lines = cap.err.strip().splitlines()
    assert len(lines) == 1, cap.err
    assert 'Traceback' not in cap.err and cap.out == ''
    if out is not None:
        assert not Path(out).exists()
    return lines[0]


def test_analyze_csv_and_bag_agree(runs, tmp_path, capsys):
    """The same runs through CSV and through the bag give the same result; the JSON
    has the fields of the contract; the vibrometer gives the seating velocity."""
    folder, paths = runs
    a, b = tmp_path / 'a.json', tmp_path / 'b.json'
    assert main(['rig', 'analyze', *map(str, paths), '--scene', str(SCENE), '--json', str(a),
                 '--no-jump', '--plot', str(tmp_path / 'png')]) == 0
    assert main(['rig', 'analyze', str(folder / 'bag'), '--json', str(b), '--no-jump']) == 0
    ra, rb = json.loads(a.read_text()), json.loads(b.read_text())
    assert [r['name'] for r in ra['runs']] == [r['name'] for r in rb['runs']]
    for x, y in zip(ra['runs'], rb['runs']):
        assert x['rpm'] == pytest.approx(y['rpm'], abs=1e-6)
        assert x['residual_rms_m']['nominal'] == pytest.approx(
            y['residual_rms_m']['nominal'], abs=1e-12)
        for key in ('rpm', 'separated', 'separation_angle_deg', 'revolutions', 'vibrometer'):
            assert key in x
        assert x['vibrometer'] is True
        assert x['seating_velocity_m_s'] == pytest.approx(
            x['predicted']['seating_velocity_m_s'], rel=0.5)
    assert sorted(p.name for p in (tmp_path / 'png').iterdir()) == [
        'run_1010rpm.png', 'run_1790rpm.png']
    capsys.readouterr()


def test_calibrate_scene_out(runs, tmp_path, capsys):
    """calibrate writes the JSON of the contract and a scene with the calibrated values
    that parses again."""
    from cam_metrology.scene.parse import load_scene

    _, paths = runs
    out, scene_out = tmp_path / 'c.json', tmp_path / 'cal.yaml'
    assert main(['rig', 'calibrate', *map(str, paths), '--scene', str(SCENE), '--fit',
                 'stiffness,damping', '--json', str(out), '--scene-out', str(scene_out)]) == 0
    res = json.loads(out.read_text())
    p = res['parameters']['stiffness']
    assert set(p) >= {'value', 'std', 'nominal'}
    assert set(res['jump_speed_rpm']) == {'nominal', 'calibrated'}
    for r in res['runs']:
        assert set(r['residual_rms_m']) == {'nominal', 'calibrated'}
    cal = load_scene(scene_out).valve_train
    assert cal.stiffness == pytest.approx(p['value'])
    # the simulator's true train (1.0e7 N/m, 90 N s/m) within 4 std
    assert abs(p['value'] - 1.0e7) < 4 * p['std']
    d = res['parameters']['damping']
    assert abs(d['value'] - 90.0) < 4 * d['std']
    capsys.readouterr()


def test_bad_run_without_valve_or_encoder(runs, tmp_path, capsys):
    _, paths = runs
    text = paths[0].read_text().splitlines()
    for drop, word in (('valve_lift_m', 'the valve channel'),
                       ('cam_angle_rad', 'the encoder channel')):
        header = text[0].split(',')
        j = header.index(drop)
        rows = [','.join(c for k, c in enumerate(line.split(',')) if k != j) for line in text]
        bad = tmp_path / f'no_{drop}.csv'
        bad.write_text('\n'.join(rows) + '\n')
        line = _fail(capsys, ['rig', 'analyze', str(bad), '--scene', str(SCENE), '--json',
                              str(tmp_path / 'x.json')], tmp_path / 'x.json')
        assert drop in line and word in line and 'time_s,cam_angle_rad,valve_lift_m' in line


def test_bad_bag_joint_missing(tmp_path, capsys):
    from cam_metrology.rig.bag import write_rig_bag

    t = np.arange(2000) / 5000.0
    run = RigRun(name='r', time=t, angle=np.mod(100 * t, 2 * math.pi), lift=0 * t)
    # a bag whose rig messages name the lift joint 'laser' instead of 'valve'
    from cam_metrology.rig import bag as rig_bag
    saved = rig_bag.VALVE
    try:
        rig_bag.VALVE = 'laser'
        write_rig_bag(tmp_path / 'bag2', SCENE.read_text(), [run])
    finally:
        rig_bag.VALVE = saved
    line = _fail(capsys, ['rig', 'analyze', str(tmp_path / 'bag2')])
    assert "'valve'" in line and 'laser' in line


def test_bad_speed_changes_too_much(tmp_path, capsys):
    """A run whose speed ramps by 20 %: refused, naming the run, the speed range and
    what to do."""
    from cam_metrology.rig.simulate import RigNoise, simulate_run
    from cam_metrology.scene.parse import load_scene

    scene = load_scene(SCENE)
    r = simulate_run(scene.lobe('lobe_1').lift, scene.valve_train, 1200, nose=2.0,
                     noise=RigNoise(ripple=0.0, sample_rate=20_000.0), revolutions=4)
    # a ramp: time stretched so that the speed falls by 20 % over the run
    t = r.time
    T = t[-1]
    r.time = t * (1 + 0.1 * t / T) / 1.0
    path = tmp_path / 'ramp.csv'
    write_csv_run(r, path)
    line = _fail(capsys, ['rig', 'analyze', str(path), '--scene', str(SCENE)])
    assert 'run ramp speed' in line and 'steady speed' in line and 'split the run' in line


def _scene(tmp_path, **rig):
    doc = yaml.safe_load(SCENE.read_text())
    doc['rig'].update(rig)
    path = tmp_path / 'scene.yaml'
    path.write_text(yaml.safe_dump(doc))
    return path


def test_bad_lobe_id(runs, tmp_path, capsys):
    _, paths = runs
    line = _fail(capsys, ['rig', 'analyze', str(paths[0]), '--scene',
                          str(_scene(tmp_path, lobe='lobe_9'))])
    assert 'rig.lobe' in line and 'lobe_9' in line and 'lobe_1' in line


def test_bad_fit_name(runs, capsys):
    _, paths = runs
    line = _fail(capsys, ['rig', 'calibrate', str(paths[0]), '--scene', str(SCENE), '--fit',
                          'stiffness,colour'])
    assert '--fit' in line and 'colour' in line and 'stiffness, damping, mass' in line


def test_bad_unseparable_pair(runs, tmp_path, capsys):
    """Preload and lash from one speed: refused before any fit, nothing written."""
    _, paths = runs
    out = tmp_path / 'c.json'
    line = _fail(capsys, ['rig', 'calibrate', str(paths[0]), '--scene', str(SCENE), '--fit',
                          'spring_preload,lash', '--json', str(out)], out)
    assert 'spring_preload and lash cannot be separated' in line and 'would' in line


def test_rig_help(capsys):
    with pytest.raises(SystemExit):
        main(['rig', 'calibrate', '--help'])
    text = capsys.readouterr().out
    assert '--fit' in text and '--scene-out' in text


def test_rig_core_replays_a_bag_like_the_cli(runs):
    """The rig node's core fed the bag's messages in order (the live code path) gives
    the runs of `rig analyze BAG`: statuses on /rig/result, tables on /rig/valve_motion."""
    from cam_metrology.bagio import iter_messages
    from cam_metrology.cores.outputs import StatusOutput, TableOutput
    from cam_metrology.rig.core import MOTION_COLUMNS, RigCore
    from cam_metrology.rig.session import analyze
    from cam_metrology.rig.runs import read_bag_runs
    from cam_metrology.scene.parse import parse_scene
    from cam_metrology.wire.topics import RIG_JOINT_STATES, RIG_MOTION, RIG_RESULT, SCENE

    folder, _ = runs
    core = RigCore()
    outs = []
    for m in iter_messages(folder / 'bag', [SCENE, RIG_JOINT_STATES]):
        outs += core.handle(m.topic, m.msg, m.stamp_ns)
    outs += core.finish()
    statuses = [s for o in outs if isinstance(o, StatusOutput) and o.topic == RIG_RESULT
                for s in o.statuses]
    tables = [o for o in outs if isinstance(o, TableOutput) and o.topic == RIG_MOTION]
    assert [s.name for s in statuses] == ['run_1010rpm', 'run_1790rpm']
    assert [t.label for t in tables] == ['run_1010rpm', 'run_1790rpm']
    assert tables[0].columns == MOTION_COLUMNS
    bag_runs, text = read_bag_runs(folder / 'bag')
    ref = analyze(parse_scene(text), bag_runs, jump=False).result['runs']
    for s, r in zip(statuses, ref):
        assert float(s.values['rpm']) == pytest.approx(r['rpm'], abs=1e-9)
        assert float(s.values['residual_rms_m']) == pytest.approx(
            r['residual_rms_m']['nominal'], abs=1e-12)
