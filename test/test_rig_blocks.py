"""The rig's samples in blocks (``/rig/joint_trajectory``, JointTrajectory as the bench's
blocks): read from a bag and fed to the rig node's core, the same runs and results as
one sample per message; damaged blocks named, counted and not used."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from cam_metrology.cli import main

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / 'config' / 'rig_scene.yaml'


@pytest.fixture(scope='module')
def sim(tmp_path_factory):
    """Two synthetic runs as a per-sample bag and as a bag of 500-sample blocks."""
    from cam_metrology.rig.bag import write_rig_bag
    from cam_metrology.rig.simulate import RigNoise, simulate_scene_runs
    from cam_metrology.scene.parse import load_scene

    folder = tmp_path_factory.mktemp('rig_blocks')
    scene = load_scene(SCENE)
    runs, _ = simulate_scene_runs(scene, [1010, 1790], revolutions=3,
                                  noise=RigNoise(sample_rate=20_000.0))
    write_rig_bag(folder / 'samples', scene.text, runs)
    write_rig_bag(folder / 'blocks', scene.text, runs, block=500)
    return folder, runs, scene


def test_block_bag_gives_the_runs(sim):
    """Blocks in a bag: the same runs (names, time to 1 ns, angle and lift exact)."""
    from cam_metrology.bagio import bag_topics
    from cam_metrology.rig.runs import read_runs
    from cam_metrology.wire.topics import RIG_JOINT_STATES, RIG_JOINT_TRAJECTORY

    folder, runs, _ = sim
    topics = bag_topics(folder / 'blocks')
    assert RIG_JOINT_TRAJECTORY in topics and RIG_JOINT_STATES not in topics
    got, text = read_runs([folder / 'blocks'])
    assert text is not None and 'rig:' in text
    assert [r.name for r in got] == [r.name for r in runs]
    for a, b in zip(got, runs):
        assert a.time.size == b.time.size
        assert np.max(np.abs(a.time - b.time)) < 1.01e-9
        assert np.max(np.abs(a.angle - b.angle)) < 1e-15
        assert np.max(np.abs(a.lift - b.lift)) < 1e-18
        assert a.notes == []


def _analyze_both(folder: Path, tmp_path: Path, capsys) -> list[dict]:
    """The `rig analyze` JSON of the per-sample bag and of the block bag in ``folder``."""
    res = []
    for name in ('samples', 'blocks'):
        out = tmp_path / f'{name}.json'
        assert main(['rig', 'analyze', str(folder / name), '--json', str(out),
                     '--no-jump']) == 0, capsys.readouterr()
        res.append(json.loads(out.read_text()))
    return res


def test_analyze_blocks_and_samples_agree(sim, tmp_path, capsys):
    """`rig analyze` of the block bag equals that of the per-sample bag."""
    folder, _, _ = sim
    res = _analyze_both(folder, tmp_path, capsys)
    for a, b in zip(res[0]['runs'], res[1]['runs']):
        assert a['name'] == b['name']
        assert a['rpm'] == pytest.approx(b['rpm'], abs=1e-6)
        assert a['residual_rms_m']['nominal'] == pytest.approx(
            b['residual_rms_m']['nominal'], abs=1e-12)
        assert a['max_lift_m'] == pytest.approx(b['max_lift_m'], abs=1e-12)


def _blocks(run, start, block, drop_valve_at=()):
    """The run's blocks; those at ``drop_valve_at`` without the valve joint."""
    from cam_metrology.rig.bag import rig_blocks
    from cam_metrology.wire.cdr import encode_joint_trajectory

    out = []
    for k, (stamp, data) in enumerate(rig_blocks(run, start, block)):
        if k in drop_valve_at:
            n = min(block, run.time.size - k * block)
            t = start + np.round(run.time[k * block:k * block + n] * 1e9).astype(np.int64)
            data = encode_joint_trajectory(run.name, int(t[0]), ('camshaft',),
                                           run.angle[k * block:k * block + n].reshape(-1, 1),
                                           t - t[0])
        out.append((stamp, data))
    return out


def _block_bag(bag, scene, run, drop_valve_at):
    """A bag with the scene and ``run`` in blocks of 400, some without the valve."""
    from cam_metrology.bagio import BagWriter
    from cam_metrology.wire.cdr import encode_string
    from cam_metrology.wire.topics import RIG_JOINT_TRAJECTORY, SCENE, TOPIC_TYPES

    with BagWriter(bag) as w:
        w.add_topic(SCENE, TOPIC_TYPES[SCENE])
        w.add_topic(RIG_JOINT_TRAJECTORY, TOPIC_TYPES[RIG_JOINT_TRAJECTORY])
        w.write(SCENE, 1, encode_string(scene.text))
        for stamp, data in _blocks(run, 10_000_000, 400, drop_valve_at=drop_valve_at):
            w.write(RIG_JOINT_TRAJECTORY, stamp, data)
    return bag


def test_damaged_block_named_counted_not_used(sim, tmp_path):
    """A block without the valve joint: its samples are dropped, the run says how many
    and names the block; the rest is analysed."""
    from cam_metrology.rig.runs import read_runs
    from cam_metrology.rig.session import analyze
    from cam_metrology.wire.topics import RIG_JOINT_TRAJECTORY

    folder, runs, scene = sim
    bag = _block_bag(tmp_path / 'damaged', scene, runs[0], drop_valve_at=(3,))
    got, _ = read_runs([bag])
    assert got[0].time.size == runs[0].time.size - 400
    assert any('400 of' in n for n in got[0].notes)
    assert any(f'{RIG_JOINT_TRAJECTORY}[3].joint_names' in n and '1 block' in n
               for n in got[0].notes)
    res = analyze(scene, got, jump=False).result['runs'][0]
    assert res['input_notes'] == got[0].notes
    assert abs(res['rpm'] - 1010) < 0.5


def test_bag_of_blocks_without_valve_refused(sim, tmp_path, capsys):
    """Every block without the valve joint: one line naming the field and the joint."""
    from cam_metrology.wire.topics import RIG_JOINT_TRAJECTORY

    folder, runs, scene = sim
    n = -(-runs[0].time.size // 400)
    bag = _block_bag(tmp_path / 'novalve', scene, runs[0], drop_valve_at=range(n))
    code = main(['rig', 'analyze', str(bag), '--json', str(tmp_path / 'o.json')])
    cap = capsys.readouterr()
    assert code == 2
    lines = cap.err.strip().splitlines()
    assert len(lines) == 1 and 'Traceback' not in cap.err
    assert f'{RIG_JOINT_TRAJECTORY}[0].joint_names' in lines[0] and "'valve'" in lines[0]
    assert not (tmp_path / 'o.json').exists()


def _core_statuses(folder, runs, extras):
    """The rig node core's run statuses for the per-sample bag's messages (handle) and
    for the runs' 700-sample blocks decoded in batches of 5 and handed to
    ``handle_samples`` (the adapter's live path; ``extras``: with the valve velocity
    and further joints): (per message, per block) by run name."""
    from cam_metrology.bagio import decode_joint_blocks, iter_messages
    from cam_metrology.cores.outputs import StatusOutput
    from cam_metrology.rig.core import RigCore
    from cam_metrology.wire.topics import RIG_JOINT_STATES, RIG_JOINT_TRAJECTORY, SCENE

    def statuses(outs):
        return {s.name: s for o in outs if isinstance(o, StatusOutput) for s in o.statuses}

    ref = RigCore()
    outs = []
    for m in iter_messages(folder / 'samples', [SCENE, RIG_JOINT_STATES]):
        outs += ref.handle(m.topic, m.msg, m.stamp_ns)
    want = statuses(outs + ref.finish())
    core = RigCore()
    outs = []
    for m in iter_messages(folder / 'blocks', [SCENE]):
        outs += core.handle(m.topic, m.msg, m.stamp_ns)
    start = 10_000_000
    for run in runs:
        chunks = [d for _, d in _blocks(run, start, 700)]
        for i in range(0, len(chunks), 5):       # batches of 5 blocks, as the adapter
            js = decode_joint_blocks(chunks[i:i + 5], topic=RIG_JOINT_TRAJECTORY,
                                     joints=core.joints, extras=extras)
            more = {'velocity': js.lift_velocity, 'others': js.others} if extras else {}
            outs += core.handle_samples(js.frame_id, js.stamp_ns, js.theta, js.s,
                                        rx_ns=start, **more)
        start += 10**9
    return want, statuses(outs + core.finish())


def test_rig_core_takes_blocks_like_messages(sim):
    """The rig node's core fed decoded blocks (``handle_samples``, the live path of the
    adapter) publishes what it publishes for the same samples one per message."""
    folder, runs, _ = sim
    want, got = _core_statuses(folder, runs, extras=False)
    assert sorted(got) == sorted(want) == ['run_1010rpm', 'run_1790rpm']
    for name in want:
        assert float(got[name].values['rpm']) == pytest.approx(
            float(want[name].values['rpm']), abs=1e-6)
        assert float(got[name].values['residual_rms_m']) == pytest.approx(
            float(want[name].values['residual_rms_m']), abs=1e-12)


@pytest.fixture(scope='module')
def sim_channels(tmp_path_factory):
    """Two runs with a vibrometer and two further channels (spring force [N], HLA
    pressure [Pa]) as a per-sample bag and as a bag of 300-sample blocks."""
    from dataclasses import replace

    from cam_metrology.rig.bag import write_rig_bag
    from cam_metrology.rig.simulate import RigNoise, simulate_scene_runs
    from cam_metrology.scene.parse import load_scene

    folder = tmp_path_factory.mktemp('rig_block_channels')
    scene = load_scene(SCENE)
    runs, _ = simulate_scene_runs(scene, [1010, 1790], revolutions=3,
                                  noise=RigNoise(sample_rate=20_000.0, vibrometer=True))
    runs = [replace(r, channels={'spring_force': 250.0 + 3.0e4 * r.lift,
                                 'hla_pressure': 2.0e5 + 1.0e3 * np.sin(r.angle)})
            for r in runs]
    write_rig_bag(folder / 'samples', scene.text, runs)
    write_rig_bag(folder / 'blocks', scene.text, runs, block=300)
    return folder, runs, scene


def test_block_bag_carries_velocity_and_channels(sim_channels, tmp_path, capsys):
    """Blocks with the valve velocity and further joints: the runs and `rig analyze`
    equal those of the per-sample bag of the same runs (velocity and channels too)."""
    from cam_metrology.rig.runs import read_runs

    folder, runs, _ = sim_channels
    by_msg, _ = read_runs([folder / 'samples'])
    by_block, _ = read_runs([folder / 'blocks'])
    for a, b, truth in zip(by_msg, by_block, runs):
        assert a.name == b.name == truth.name
        assert b.velocity is not None and a.velocity is not None
        np.testing.assert_allclose(b.velocity, truth.velocity, rtol=0, atol=1e-15)  # m/s
        np.testing.assert_allclose(b.velocity, a.velocity, rtol=0, atol=1e-15)
        assert sorted(b.channels) == sorted(a.channels) == ['hla_pressure', 'spring_force']
        np.testing.assert_allclose(b.channels['spring_force'], a.channels['spring_force'],
                                   rtol=0, atol=1e-9)                              # N
        np.testing.assert_allclose(b.channels['hla_pressure'],
                                   truth.channels['hla_pressure'], rtol=0, atol=1e-6)  # Pa
    res = _analyze_both(folder, tmp_path, capsys)
    for a, b in zip(res[0]['runs'], res[1]['runs']):
        assert b['vibrometer'] is True and a['vibrometer'] is True
        assert b['channels'] == a['channels'] == ['hla_pressure', 'spring_force']
        assert b['seating_velocity_m_s'] == pytest.approx(a['seating_velocity_m_s'],
                                                          abs=1e-9)   # m/s
        assert b['residual_rms_m']['nominal'] == pytest.approx(
            a['residual_rms_m']['nominal'], abs=1e-12)


def test_rig_core_blocks_carry_velocity_like_messages(sim_channels):
    """Live path: blocks decoded with extras and handed to ``handle_samples`` give the
    rig node's results of the same samples one per message (the vibrometer's seating
    velocity included)."""
    from cam_metrology.rig.core import RigCore

    assert RigCore.block_extras
    folder, runs, _ = sim_channels
    want, got = _core_statuses(folder, runs, extras=True)
    assert sorted(got) == sorted(want) == ['run_1010rpm', 'run_1790rpm']
    for name in want:
        for key in ('rpm', 'seating_velocity_m_s', 'residual_rms_m'):
            assert float(got[name].values[key]) == pytest.approx(
                float(want[name].values[key]), abs=1e-9), key
