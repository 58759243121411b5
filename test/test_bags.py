"""The committed fixture bags: readable by rosbags and by mcap alone, truth as documented."""
from __future__ import annotations

import importlib.util
import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from cam_metrology import bagio
from cam_metrology.scene.parse import parse_scene

BAGS = Path(__file__).resolve().parent.parent / 'bags'
NAMES = ['default_clean', 'default_noisy_dirneg_wrapped', 'no_pin_no_valve_train',
         'irregular', 'runout_encoder_noise']


def _mcap_messages(bag: Path) -> list[tuple[str, int, object]]:
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    (mcap_file,) = bag.glob('*.mcap')
    with open(mcap_file, 'rb') as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        return [(ch.topic, m.log_time, d) for _, ch, m, d in reader.iter_decoded_messages()]


def _truth(bag: Path) -> dict:
    (m,) = list(bagio.iter_messages(bag, ['/bench/truth']))
    return json.loads(m.msg.data)


@pytest.mark.parametrize('name', NAMES)
def test_bag_is_small_and_complete(name):
    bag = BAGS / name
    assert (bag / 'metadata.yaml').exists()
    size = sum(p.stat().st_size for p in bag.iterdir())
    assert size <= 2_000_000
    topics = bagio.bag_topics(bag)
    for topic in ('/bench/scene', '/bench/truth', '/bench/joint_states'):
        assert topic in topics
    assert 'transient_local' in bagio.topic_qos_yaml(bag)['/bench/scene']


@pytest.mark.parametrize('name', NAMES)
def test_mcap_alone_decodes_what_the_fast_path_reads(name):
    bag = BAGS / name
    fast = bagio.read_joint_states(bag)
    js = [(t, m) for topic, t, m in _mcap_messages(bag) if topic == '/bench/joint_states']
    assert len(js) == len(fast)
    assert [t for t, _ in js] == fast.log_ns.tolist()
    theta = np.array([m.position[list(m.name).index('camshaft')] for _, m in js])
    s = np.array([m.position[list(m.name).index('probe')] for _, m in js])
    np.testing.assert_array_equal(theta, fast.theta)
    np.testing.assert_array_equal(s, fast.s)
    assert [m.header.frame_id for _, m in js] == fast.frame_id.tolist()
    assert [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for _, m in js] == \
        fast.stamp_ns.tolist()


@pytest.mark.parametrize('name', NAMES)
def test_fast_path_equals_anyreader(name):
    bag = BAGS / name
    fast = bagio.read_joint_states(bag)
    slow = [m.msg for m in bagio.iter_messages(bag, ['/bench/joint_states'])]
    names = [list(m.name) for m in slow]
    theta = np.array([m.position[n.index('camshaft')] for m, n in zip(slow, names)])
    s = np.array([m.position[n.index('probe')] for m, n in zip(slow, names)])
    np.testing.assert_array_equal(theta, fast.theta)
    np.testing.assert_array_equal(s, fast.s)
    assert [m.header.frame_id for m in slow] == fast.frame_id.tolist()


@pytest.mark.parametrize('name', NAMES)
def test_scene_and_truth_match_the_readme(name):
    bag = BAGS / name
    (scene_msg,) = list(bagio.iter_messages(bag, ['/bench/scene']))
    scene = parse_scene(scene_msg.msg.data)
    assert scene.warnings == ()
    truth = _truth(bag)
    readme = (BAGS / 'README.md').read_text()
    row = next(line for line in readme.splitlines() if line.startswith(f'| `{name}/`'))
    cell = row.rstrip(' |').split('|')[-1]
    documented = dict(re.findall(r'(lobe_\d|dowel_pin) (-?\d+\.\d+)', cell))
    assert set(documented) == set(truth['features'])
    for fid, value in documented.items():
        assert truth['features'][fid]['angle_deg'] == pytest.approx(float(value), abs=1e-6)
    fids = set(bagio.read_joint_states(bag).features)
    assert fids == set(truth['features'])
    assert [lobe.id for lobe in scene.lobes] + (['dowel_pin'] if scene.dowel_pin else []) \
        == truth['measurement_order']


def test_no_pin_bag_has_no_pin_and_no_valve_train():
    (m,) = list(bagio.iter_messages(BAGS / 'no_pin_no_valve_train', ['/bench/scene']))
    scene = parse_scene(m.msg.data)
    assert scene.dowel_pin is None and scene.valve_train is None
    assert scene.compute == frozenset({'nose', 'asymmetry', 'reconstruction'})


def test_direction_and_wrapping_of_the_noisy_bag():
    bag = BAGS / 'default_noisy_dirneg_wrapped'
    (m,) = list(bagio.iter_messages(bag, ['/bench/scene']))
    assert parse_scene(m.msg.data).direction == -1
    fast = bagio.read_joint_states(bag)
    assert np.all((fast.theta >= 0) & (fast.theta < 2 * math.pi))
    assert np.sum(np.diff(fast.theta) < -math.pi) >= 9   # wraps: 2 rev x 5 features
    truth = _truth(bag)
    assert truth['probe_noise_m'] == 1e-6 and truth['direction'] == -1


def test_irregular_bag_is_irregular():
    bag = BAGS / 'irregular'
    fast = bagio.read_joint_states(bag)
    assert ('camshaft', 'probe', 'table_z') in fast.names
    assert ('table_z', 'probe', 'camshaft') in fast.names
    assert np.isnan(fast.s).sum() > 50 and np.isnan(fast.theta).sum() > 10
    assert np.any(np.diff(fast.stamp_ns) < 0)            # header stamps out of order
    assert np.all(np.diff(fast.log_ns) > 0)              # receive times in order
    pairs = set()
    dup = 0
    for st, fid in zip(fast.stamp_ns.tolist(), fast.frame_id.tolist()):
        dup += (st, fid) in pairs
        pairs.add((st, fid))
    assert dup > 50
    assert 'other' not in fast.features
    topics = bagio.bag_topics(bag)
    assert '/bench/feature_done' not in topics and '/rosout_text' in topics


def _close(a: object, b: object, path: str) -> None:
    """Equal structure; floats within 1e-12 relative (+1e-15 absolute): far below the
    physical resolution (1 nm, 0.001 arcsec), far above the last-bit differences that
    another CPU's libm or BLAS produces."""
    if isinstance(a, dict):
        assert isinstance(b, dict) and set(a) == set(b), path
        for k in a:
            _close(a[k], b[k], f'{path}.{k}')
    elif isinstance(a, (list, tuple)):
        assert isinstance(b, (list, tuple)) and len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b)):
            _close(x, y, f'{path}[{i}]')
    elif isinstance(a, float) and isinstance(b, float):
        assert b == pytest.approx(a, rel=1e-12, abs=1e-15, nan_ok=True), path
    else:
        assert a == b, path


def _plain(value: object) -> object:
    """A decoded message as dicts, lists and scalars (dataclass fields, arrays as lists)."""
    import dataclasses

    if dataclasses.is_dataclass(value):
        return {f.name: _plain(getattr(value, f.name)) for f in dataclasses.fields(value)
                if f.name != '__msgtype__'}
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


def test_fixtures_are_reproducible(tmp_path):
    """Regenerating the fixtures gives the same bags: topics, stamps, frame ids, joint
    names and texts exactly, numbers within a stated tolerance (never bit for bit: the
    committed bags were made on another CPU)."""
    spec = importlib.util.spec_from_file_location('make_bags', BAGS / 'make_bags.py')
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert module.main(['--out', str(tmp_path)]) == 0
    for name in NAMES:
        a = list(bagio.iter_messages(BAGS / name))
        b = list(bagio.iter_messages(tmp_path / name))
        assert [(m.topic, m.msgtype, m.stamp_ns) for m in a] == \
            [(m.topic, m.msgtype, m.stamp_ns) for m in b], name
        for i, (ma, mb) in enumerate(zip(a, b)):
            where = f'{name}[{i}] {ma.topic}'
            if ma.msgtype == 'sensor_msgs/msg/JointState':
                assert (ma.msg.header.stamp.sec, ma.msg.header.stamp.nanosec,
                        ma.msg.header.frame_id, list(ma.msg.name)) == \
                    (mb.msg.header.stamp.sec, mb.msg.header.stamp.nanosec,
                     mb.msg.header.frame_id, list(mb.msg.name)), where
                np.testing.assert_allclose(np.asarray(mb.msg.position),
                                           np.asarray(ma.msg.position), rtol=1e-12,
                                           atol=1e-15, err_msg=where)
            elif ma.msgtype == 'std_msgs/msg/String':
                try:
                    _close(json.loads(ma.msg.data), json.loads(mb.msg.data), where)
                except json.JSONDecodeError:
                    assert ma.msg.data == mb.msg.data, where
            else:
                _close(_plain(ma.msg), _plain(mb.msg), where)


def test_cli_bag_info_on_a_fixture(capsys):
    from cam_metrology.cli import main

    assert main(['bag', 'info', str(BAGS / 'no_pin_no_valve_train')]) == 0
    out = capsys.readouterr().out
    assert '/bench/scene' in out and 'latched' in out
    assert 'lobe_1: 3600 samples' in out and 'no dowel pin' in out
    assert main(['bag', 'info', str(BAGS / 'nope')]) == 2
    assert 'existing rosbag2' in capsys.readouterr().err


@pytest.mark.parametrize('name', NAMES)
def test_metrology_core_recovers_the_documented_truth(name):
    """End to end through replay.run_offline: the fixtures are consistent with their truth."""
    core_module = pytest.importorskip('cam_metrology.metrology.core')
    from cam_metrology.offline.replay import run_offline

    bag = BAGS / name
    truth = _truth(bag)
    params = {'fit_runout': True} if truth['runout_m'] else None   # see bags/README.md
    result = run_offline(bag, [core_module.MetrologyCore(params)])
    report = result.report()
    assert report is not None
    assert set(report['features']) == set(truth['features'])
    for fid, exp in truth['features'].items():
        got = report['features'][fid]
        err = (got['angle_deg'] - exp['angle_deg'] + 180.0) % 360.0 - 180.0
        tol = 1e-5 if truth['probe_noise_m'] == 0 else max(6 * got['angle_std_deg'], 1e-4)
        assert abs(err) < tol, (fid, got['angle_deg'], exp['angle_deg'])
