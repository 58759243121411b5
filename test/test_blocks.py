"""Blocks of samples (``/bench/joint_trajectory``, trajectory_msgs/JointTrajectory):
the encoder against the rosbags typestore, the decoder against rosbags' own decode,
blocks and single samples giving the same report, and every damaged block named in one
line while the rest of the bag is still analysed (docs/contract.md §2)."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from cam_metrology import bagio
from cam_metrology.bagio import BagWriter, decode_joint_blocks, encode_joint_trajectory
from cam_metrology.offline.analyze import analyze_bag
from cam_metrology.host.paths import default_scene_path
from cam_metrology.scene.parse import load_scene
from cam_metrology.simulation.bench import SimParams, simulate, write_sim_bag
from cam_metrology.wire.cdr import encode_sample_blocks, encode_string, typestore
from cam_metrology.wire.topics import (FEATURE_DONE, JOINT_TRAJECTORY, JOINT_TRAJECTORY_TYPE,
                                       SCENE, STRING)

TRAJ = JOINT_TRAJECTORY_TYPE


def _rosbags_block(frame: str, stamp_ns: int, names: list[str], rows: list[list[float]],
                   offsets_ns: list[int], velocities: dict[int, list[float]] | None = None,
                   little_endian: bool = True) -> bytes:
    """A JointTrajectory built and serialised by rosbags (the independent encoder)."""
    ts = typestore()
    T, P = ts.types[TRAJ], ts.types['trajectory_msgs/msg/JointTrajectoryPoint']
    H, Tm = ts.types['std_msgs/msg/Header'], ts.types['builtin_interfaces/msg/Time']
    D = ts.types['builtin_interfaces/msg/Duration']
    empty = np.zeros(0)
    pts = [P(positions=np.asarray(r, dtype=float),
             velocities=np.asarray((velocities or {}).get(i, []), dtype=float),
             accelerations=empty, effort=empty,
             time_from_start=D(sec=int(o // 10**9), nanosec=int(o % 10**9)))
           for i, (r, o) in enumerate(zip(rows, offsets_ns))]
    msg = T(header=H(stamp=Tm(sec=stamp_ns // 10**9, nanosec=stamp_ns % 10**9),
                     frame_id=frame), joint_names=names, points=pts)
    return bytes(ts.serialize_cdr(msg, TRAJ, little_endian=little_endian))


@pytest.mark.parametrize('frame,names,n', [
    ('lobe_1', ['camshaft', 'probe'], 7), ('dowel_pin', ['a', 'camshaft', 'probe'], 3),
    ('l', ['probe', 'camshaft'], 1), ('lobe_22', ['camshaft', 'probe'], 0),
    ('x' * 13, ['camshaft'], 4)])
def test_encoder_writes_the_bytes_of_the_rosbags_typestore(frame, names, n):
    rng = np.random.default_rng(5)
    rows = rng.normal(size=(n, len(names)))
    offsets = np.sort(rng.integers(0, 3 * 10**9, n))
    stamp = 1_767_225_600 * 10**9 + 123_456_789
    got = encode_joint_trajectory(frame, stamp, names, rows, offsets)
    assert got == _rosbags_block(frame, stamp, names, rows.tolist(), offsets.tolist())


def test_decoder_reads_what_rosbags_wrote_uniform_irregular_and_big_endian():
    stamp = 1_700_000_000 * 10**9 + 5
    rows = [[0.1 * k, 1e-3 * k, 7.0] for k in range(6)]
    offs = [k * 250_000 for k in range(6)]
    names = ['lvdt_1', 'spare', 'cam_encoder']   # another order, an extra joint
    blocks = [
        _rosbags_block('lobe_1', stamp, names, rows, offs),
        # velocities on some points only: points of different layouts (walked)
        _rosbags_block('lobe_1', stamp + 2_000_000, names, rows, offs,
                       velocities={1: [1.0, 2.0, 3.0], 4: [0.5]}),
        _rosbags_block('lobe_1', stamp + 4_000_000, names, rows, offs, little_endian=False),
    ]
    js = decode_joint_blocks(blocks, np.array([10, 20, 30]),
                             joints=('cam_encoder', 'lvdt_1'))
    assert js.issues == ()
    assert js.block_sizes.tolist() == [6, 6, 6]
    want_theta = np.tile([r[2] for r in rows], 3)
    want_s = np.tile([r[0] for r in rows], 3)
    # a decode copies the bytes: the values agree to 0 (stated tolerance, not identity)
    np.testing.assert_allclose(js.theta, want_theta, rtol=0, atol=0)
    np.testing.assert_allclose(js.s, want_s, rtol=0, atol=0)
    shifts = (0, 2_000_000, 4_000_000)
    want_stamp = np.concatenate([stamp + d + np.array(offs) for d in shifts])
    assert js.stamp_ns.tolist() == want_stamp.tolist()
    assert js.log_ns.tolist() == [10] * 6 + [20] * 6 + [30] * 6
    assert set(js.frame_id.tolist()) == {'lobe_1'}


@pytest.mark.parametrize('names,n', [
    (['camshaft', 'valve'], 5), (['camshaft', 'valve', 'f'], 4),
    (['valve', 'camshaft', 'spring', 'hla'], 1)])
def test_encoder_with_velocities_writes_the_rosbags_bytes(names, n):
    """Points with one velocity per joint (a vibrometer's), against rosbags."""
    rng = np.random.default_rng(8)
    rows, vel = rng.normal(size=(n, len(names))), rng.normal(size=(n, len(names)))
    offsets = np.sort(rng.integers(0, 3 * 10**9, n))
    for frame in ('run', 'run_1010rpm'):   # the points start 4- and 8-aligned
        got = encode_joint_trajectory(frame, 10**9 + 7, names, rows, offsets, vel)
        want = _rosbags_block(frame, 10**9 + 7, names, rows.tolist(), offsets.tolist(),
                              velocities={i: v for i, v in enumerate(vel.tolist())})
        assert got == want


def test_decoder_extras_velocity_and_further_joints():
    """``extras``: the lift joint's velocity (NaN at points without one per joint) and
    the further joints' positions, uniform, walked and big-endian blocks alike."""
    stamp = 1_700_000_000 * 10**9
    rows = [[0.1 * k, 1e-3 * k, 7.0 + k] for k in range(5)]
    vels = [[1.0 + k, 2.0 * k, 3.0] for k in range(5)]
    offs = [k * 250_000 for k in range(5)]
    names = ['lvdt', 'spring', 'enc']
    every = dict(enumerate(vels))
    blocks = [
        _rosbags_block('r', stamp, names, rows, offs, velocities=every),
        _rosbags_block('r', stamp + 2_000_000, names, rows, offs,
                       velocities={1: vels[1], 3: [0.5]}),            # walked
        _rosbags_block('r', stamp + 4_000_000, names, rows, offs, velocities=every,
                       little_endian=False),
        _rosbags_block('r', stamp + 6_000_000, ['enc', 'lvdt'], [r[:2] for r in rows], offs),
    ]
    js = decode_joint_blocks(blocks, joints=('enc', 'lvdt'), extras=True)
    assert js.issues == ()
    lift_vel = [v[0] for v in vels]
    nan = math.nan
    want = lift_vel + [nan, vels[1][0], nan, nan, nan] + lift_vel + [nan] * 5
    np.testing.assert_allclose(js.lift_velocity, want, rtol=0, atol=0)
    assert list(js.others) == ['spring']
    spring = [r[1] for r in rows]
    np.testing.assert_allclose(js.others['spring'], spring * 3 + [nan] * 5, rtol=0, atol=0)
    plain = decode_joint_blocks(blocks, joints=('enc', 'lvdt'))
    assert plain.lift_velocity is None and plain.others == {}
    np.testing.assert_allclose(plain.s, js.s, rtol=0, atol=0)


@pytest.fixture(scope='module')
def pair(tmp_path_factory):
    """The same simulated measurement as single samples and as blocks of 700."""
    root = tmp_path_factory.mktemp('blocks')
    scene = load_scene(default_scene_path())
    params = SimParams(probe_noise=5e-7, encoder_noise=2e-6, seed=4, samples_per_rev=3600)
    run = write_sim_bag(root / 'single', scene, params)
    write_sim_bag(root / 'blocks', scene, params, samples_per_message=700)
    return root / 'single', root / 'blocks', run, scene, params


def test_blocks_and_single_samples_give_the_same_report(pair):
    single, blocks, run, _, _ = pair
    a = analyze_bag(str(single), plot_tables=False).report
    b = analyze_bag(str(blocks), plot_tables=False).report
    assert list(a['features']) == list(b['features']) == list(run.truth['features'])
    for fid, fa in a['features'].items():
        fb = b['features'][fid]
        assert fb['samples_received'] == fa['samples_received'] == run.truth['features'][
            fid]['samples']
        for key in ('angle_deg', 'angle_std_deg', 'phase_deg', 'asymmetry_deg'):
            if fa.get(key) is None:
                assert fb.get(key) is None
                continue
            # the same samples through the same code: equal to rounding (1e-9 deg)
            assert fb[key] == pytest.approx(fa[key], abs=1e-9), (fid, key)
        # and both right: within 5 standard uncertainties of the true angle
        truth = run.truth['features'][fid]['angle_deg']
        err = (fb['angle_deg'] - truth + 180.0) % 360.0 - 180.0
        assert abs(err) < 5 * fb['angle_std_deg'] + 1e-4, (fid, err)


def test_bag_info_counts_blocks_as_samples(pair, capsys):
    from cam_metrology.cli import main
    _, blocks, run, _, _ = pair
    assert main(['bag', 'info', str(blocks)]) == 0
    out = capsys.readouterr().out
    n_blocks = sum(math.ceil(f.theta.size / 700) for f in run.features)
    assert f'samples: {run.sample_count} (in {n_blocks} blocks on {JOINT_TRAJECTORY})' in out
    for f in run.features:
        assert f'  {f.id}: {f.theta.size} samples' in out


# --------------------------------------------------------------- damaged blocks
PER = 500


def _damaged_bag(path: Path, scene, params, damage) -> dict[str, int]:
    """A block bag of the default scene where ``damage(fid, k, block)`` may replace the
    k-th block (start stamp, names, rows, offsets) of feature fid by raw CDR (or None to
    keep it, or ``b''`` to drop it). Returns {feature: blocks written}."""
    run = simulate(scene, params)
    written: dict[str, int] = {}
    with BagWriter(path) as w:
        w.add_topic(SCENE, STRING)
        w.add_topic(JOINT_TRAJECTORY, TRAJ)
        w.add_topic(FEATURE_DONE, STRING)
        t0 = int(run.features[0].stamp_ns[0])
        w.write(SCENE, t0 - 1_000_000, encode_string(scene.text))
        for f in run.features:
            blocks = encode_sample_blocks(f.id, f.stamp_ns, f.theta, f.s, PER)
            for k, (log, cdr) in enumerate(blocks):
                a = k * PER
                b = min(a + PER, f.theta.size)
                rows = np.column_stack((f.theta[a:b], f.s[a:b]))
                off = f.stamp_ns[a:b] - f.stamp_ns[a]
                new = damage(f.id, k, (int(f.stamp_ns[a]), rows, off))
                if new == b'':
                    continue
                w.write(JOINT_TRAJECTORY, log, cdr if new is None else new)
                written[f.id] = written.get(f.id, 0) + 1
            w.write(FEATURE_DONE, int(f.stamp_ns[-1]) + 1000, encode_string(f.id))
    return written


NAMES = ['camshaft', 'probe']


def _case(name: str):
    """damage(fid, k, block) for the case ``name``: the 3rd block of lobe_2 damaged."""
    def damage(fid, k, block):
        if fid != 'lobe_2' or k != 2:
            return None
        stamp, rows, off = block
        if name == 'empty block':
            return encode_joint_trajectory('lobe_2', stamp, NAMES, rows[:0], off[:0])
        if name == 'time_from_start backwards':
            off = off.copy()
            off[10], off[11] = off[11], off[10]
            return encode_joint_trajectory('lobe_2', stamp, NAMES, rows, off)
        if name == 'missing joint':
            return encode_joint_trajectory('lobe_2', stamp, ['camshaft', 'lvdt'], rows, off)
        if name == 'mismatched lengths':
            return _rosbags_block('lobe_2', stamp, NAMES,
                                  [list(r) for r in rows[:5]] + [[float(rows[5, 0])]]
                                  + [list(r) for r in rows[6:]], off.tolist())
        if name == 'invalid stamp':
            raw = bytearray(encode_joint_trajectory('lobe_2', stamp, NAMES, rows, off))
            raw[8:12] = (2_000_000_000).to_bytes(4, 'little')   # header.stamp.nanosec
            return bytes(raw)
        if name == 'frame_id inside a feature':
            return encode_joint_trajectory('lobe_3', stamp, NAMES, rows, off)
        if name == 'block straddling two features':
            # labelled lobe_2, but its samples run on past the start of the next block
            off = off.copy()
            off[-1] += 10 * 10**9
            return encode_joint_trajectory('lobe_2', stamp, NAMES, rows, off)
        if name == 'truncated message':
            return encode_joint_trajectory('lobe_2', stamp, NAMES, rows, off)[:-30]
        raise AssertionError(name)
    return damage


@pytest.mark.parametrize('case,key,expected', [
    ('empty block', '.points', 'at least one point'),
    ('time_from_start backwards', '.points[11].time_from_start', 'never decrease'),
    ('missing joint', '.joint_names', "a joint named 'probe'"),
    ('mismatched lengths', '.points[5].positions', 'one position per joint name'),
    ('invalid stamp', '.header.stamp', 'a valid time'),
    ('frame_id inside a feature', '.header.frame_id', 'one frame_id for all the blocks'),
    ('block straddling two features', '.points', 'split a block at a feature boundary'),
    ('truncated message', '', 'a complete trajectory_msgs/JointTrajectory'),
])
def test_a_damaged_block_is_named_and_the_rest_analysed(tmp_path, case, key, expected):
    scene = load_scene(default_scene_path())
    # two revolutions per feature: without the damaged block every angle is still seen
    params = SimParams(probe_noise=5e-7, seed=2, samples_per_rev=3600, revolutions=2.0)
    _damaged_bag(tmp_path / 'bag', scene, params, _case(case))
    run = simulate(scene, params)
    analysis = analyze_bag(str(tmp_path / 'bag'), plot_tables=False)
    lines = [w for w in analysis.warnings if JOINT_TRAJECTORY in w]
    assert len(lines) == 1, analysis.warnings
    line = lines[0]
    assert '\n' not in line
    # which message (index on the topic: lobe_1's blocks, then lobe_2's 3rd), which
    # field, what would work
    index = math.ceil(run.features[0].theta.size / PER) + 2
    assert f'{JOINT_TRAJECTORY}[{index}]{key}' in line, line
    assert expected in line, line
    assert '1 block not used' in line, line
    report = analysis.report
    assert list(report['features']) == [f.id for f in run.features]
    for f in run.features:
        got = report['features'][f.id]
        truth = run.truth['features'][f.id]['angle_deg']
        err = (got['angle_deg'] - truth + 180.0) % 360.0 - 180.0
        assert abs(err) < 5 * got['angle_std_deg'] + 1e-4, (f.id, err)
        no_samples = case in ('empty block', 'truncated message', 'invalid stamp')
        lost = PER if f.id == 'lobe_2' and not no_samples else 0
        dropped = got.get('samples_nan_dropped', 0)
        if no_samples:
            # the block gave no samples at all: lobe_2 has PER fewer
            want = f.theta.size - (PER if f.id == 'lobe_2' else 0)
            assert got['samples_received'] == want, (f.id, got['samples_received'])
        else:
            assert dropped == lost, (f.id, dropped)


def test_joint_names_from_the_parameters_and_a_missing_name_is_named(tmp_path):
    """A bench with its own joint names: analysed with angle_joint/lift_joint set in a
    parameter file, and without them every block is named as unusable (exit-2 error)."""
    from cam_design.errors import InputError
    scene = load_scene(default_scene_path())
    params = SimParams(probe_noise=5e-7, seed=2, samples_per_rev=720)
    names = ['spindle', 'cam_encoder', 'lvdt_1']

    def rename(fid, k, block):
        stamp, rows, off = block
        full = np.column_stack((np.zeros(len(rows)), rows))
        return encode_joint_trajectory(fid, stamp, names, full, off)
    _damaged_bag(tmp_path / 'bag', scene, params, rename)
    yaml_file = tmp_path / 'bench.yaml'
    yaml_file.write_text('metrology:\n  ros__parameters:\n    angle_joint: cam_encoder\n'
                         '    lift_joint: lvdt_1\n', encoding='utf-8')
    report = analyze_bag(str(tmp_path / 'bag'), str(yaml_file), only_metrology=True,
                         plot_tables=False).report
    run = simulate(scene, params)
    for f in run.features:
        truth = run.truth['features'][f.id]['angle_deg']
        err = (report['features'][f.id]['angle_deg'] - truth + 180.0) % 360.0 - 180.0
        assert abs(err) < 5 * report['features'][f.id]['angle_std_deg'] + 1e-4
    with pytest.raises(InputError) as exc:
        analyze_bag(str(tmp_path / 'bag'), only_metrology=True, plot_tables=False)
    text = str(exc.value)
    assert f'{JOINT_TRAJECTORY}[0].joint_names' in text and 'camshaft' in text and \
        'angle_joint' in text, text


def test_iter_joint_states_merges_both_sample_topics_in_log_time(tmp_path):
    """A bag holding both forms (a bench switching to blocks mid-run): one stream,
    log-time order, every sample once."""
    from cam_metrology.wire.cdr import encode_joint_states
    from cam_metrology.wire.topics import JOINT_STATE, JOINT_STATES
    st = 10**18 + np.arange(40) * 1_000_000
    th, s = np.linspace(0, 1, 40), np.linspace(0, 1e-3, 40)
    with BagWriter(tmp_path / 'bag') as w:
        w.add_topic(JOINT_STATES, JOINT_STATE)
        w.add_topic(JOINT_TRAJECTORY, TRAJ)
        head = encode_joint_states('lobe_1', st[:15], th[:15], s[:15])
        for stamp, cdr in zip(st[:15].tolist(), head):
            w.write(JOINT_STATES, stamp, cdr)
        for log, cdr in encode_sample_blocks('lobe_1', st[15:30], th[15:30], s[15:30], 4):
            w.write(JOINT_TRAJECTORY, log, cdr)
        tail = encode_joint_states('lobe_1', st[30:], th[30:], s[30:])
        for stamp, cdr in zip(st[30:].tolist(), tail):
            w.write(JOINT_STATES, stamp, cdr)
    for block_bytes in (1, bagio.STREAM_BLOCK_BYTES):
        parts = list(bagio.iter_joint_states(tmp_path / 'bag', block_bytes=block_bytes))
        got = np.concatenate([p.stamp_ns for p in parts])
        assert got.tolist() == st.tolist()
        np.testing.assert_allclose(np.concatenate([p.theta for p in parts]), th, rtol=0,
                                   atol=0)


def test_bag_recover_keeps_every_intact_block(tmp_path):
    """A recording of blocks cut inside a chunk (a recorder killed): ``bag recover``
    keeps every block of the intact chunks whole, each decoding to its samples."""
    import shutil

    from mcap.reader import make_reader
    scene = load_scene(default_scene_path())
    params = SimParams(probe_noise=5e-7, seed=1, samples_per_rev=3600, revolutions=4.0)
    write_sim_bag(tmp_path / 'full', scene, params, compression=False,
                  samples_per_message=PER)
    shutil.copytree(tmp_path / 'full', tmp_path / 'cut')
    (path,) = (tmp_path / 'cut').glob('*.mcap')
    with open(path, 'rb') as f:
        chunks = sorted(make_reader(f).get_summary().chunk_indexes,
                        key=lambda c: c.chunk_start_offset)
    assert len(chunks) >= 3
    keep = len(chunks) // 2
    path.write_bytes(path.read_bytes()[:chunks[keep].chunk_start_offset + 100])
    (tmp_path / 'cut' / 'metadata.yaml').unlink()   # as a writer that never closed
    counts = bagio.recover_bag(tmp_path / 'cut', tmp_path / 'fixed')
    # the truth from the intact bag: the blocks logged within the kept chunks
    end = max(c.message_end_time for c in chunks[:keep])
    full = [b for b in bagio.iter_joint_states(tmp_path / 'full')]
    logs = np.concatenate([b.log_ns for b in full])
    want_blocks = len(np.unique(logs[logs <= end]))
    assert counts[JOINT_TRAJECTORY] == want_blocks
    got = list(bagio.iter_joint_states(tmp_path / 'fixed'))
    assert all(b.issues == () for b in got)
    assert sum(len(b) for b in got) == int(np.count_nonzero(logs <= end))
    np.testing.assert_allclose(np.concatenate([b.theta for b in got]),
                               np.concatenate([b.theta for b in full])[logs <= end],
                               rtol=0, atol=0)
