"""Bags that are damaged, foreign or odd (docs/contract.md §4).

Each bag is built in tmp_path from one clean simulated bag: an invalid scene, JointStates
without a joint or with fewer positions than names, two scenes that disagree, a Jazzy
service-event topic and a vendor type, flipped bytes in a chunk, a truncated file, huge
string length fields. The expected behaviour is asserted exactly: the message names the
key, the joint or the byte range; intact data are kept; the numbers of intact features
equal those of the clean bag.
"""
from __future__ import annotations

import json
import shutil
import struct
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

from cam_design.errors import InputError
from cam_metrology import bagio
from cam_metrology.bagio import check as bagcheck
from cam_metrology.scene.recorded import require_scenes
from cam_metrology.cli import main

SCENE_FILE = Path(__file__).resolve().parents[1] / 'bags' / 'scenes' / 'two_lobes_no_pin.yaml'
JS = bagio.JOINT_STATES
SRV_DEF = ('=' * 80 + '\nSRV: example_interfaces/srv/AddTwoInts\nint64 a\nint64 b\n'
           '---\nint64 sum\n')


# ------------------------------------------------------------------ bag builders

@pytest.fixture(scope='module')
def clean(tmp_path_factory):
    """A clean two-lobe bag (720 samples per lobe, 0.5 um noise) and its report."""
    from cam_metrology.scene.parse import load_scene
    from cam_metrology.simulation.bench import SimParams, write_sim_bag

    root = tmp_path_factory.mktemp('clean')
    bag = root / 'clean'
    run = write_sim_bag(bag, load_scene(SCENE_FILE),
                        SimParams(samples_per_rev=720, probe_noise=0.5e-6, seed=3))
    return bag, _report(bag, root / 'clean.json'), run.truth


def _report(bag: Path, out: Path, *extra: str) -> dict:
    assert main(['analyze', str(bag), '--only-metrology', '--json', str(out), *extra]) == 0
    return json.loads(out.read_text())


def _rebuild(src: Path, dst: Path, edit=None, extra_topics=()) -> Path:
    """A copy of ``src`` whose messages go through ``edit(topic, stamp, cdr, index)``
    -> list of (topic, stamp, cdr) (index: position within the topic)."""
    seen: dict[str, int] = {}
    with bagio.BagWriter(dst) as writer:
        bagio.add_topics_like(writer, src)
        for topic, msgtype, qos, msgdef in extra_topics:
            writer.add_topic(topic, msgtype, qos, msgdef)
        for m in bagio.iter_messages(src, raw=True):
            k = seen.get(m.topic, 0)
            seen[m.topic] = k + 1
            out = [(m.topic, m.stamp_ns, m.msg)] if edit is None else \
                edit(m.topic, m.stamp_ns, bytes(m.msg), k)
            for topic, stamp, cdr in out:
                writer.write(topic, stamp, cdr)
    return dst


def _rechunk(src: Path, dst: Path, chunk_size: int = 16384, compression: str = 'none') -> Path:
    """``src`` rewritten by the mcap library's writer (small chunks, CRCs on), as the
    C++ writer of ``ros2 bag record`` would store it; metadata.yaml kept."""
    from mcap.reader import make_reader
    from mcap.writer import CompressionType, Writer

    shutil.copytree(src, dst)
    (f_src,) = src.glob('*.mcap')
    with open(f_src, 'rb') as fi, open(dst / f_src.name, 'wb') as fo:
        reader = make_reader(fi)
        summary = reader.get_summary()
        writer = Writer(fo, chunk_size=chunk_size,
                        compression=getattr(CompressionType, compression.upper()))
        writer.start(profile='ros2', library='test')
        sids = {sid: writer.register_schema(sc.name, sc.encoding, sc.data)
                for sid, sc in summary.schemas.items()}
        cids = {cid: writer.register_channel(ch.topic, ch.message_encoding,
                                             sids[ch.schema_id], ch.metadata)
                for cid, ch in summary.channels.items()}
        for _, ch, m in reader.iter_messages(log_time_order=False):
            writer.add_message(cids[ch.id], m.log_time, m.data, m.publish_time, m.sequence)
        writer.finish()
    return dst


def _mcap(bag: Path) -> Path:
    (path,) = bag.glob('*.mcap')
    return path


def _chunks(path: Path) -> list:
    """Chunk indexes of a file from the mcap library (independent of bagcheck)."""
    from mcap.reader import make_reader

    with open(path, 'rb') as f:
        return sorted(make_reader(f).get_summary().chunk_indexes,
                      key=lambda c: c.chunk_start_offset)


def _angles(report: dict) -> dict[str, float]:
    return {k: v['angle_deg'] for k, v in report['features'].items()}


# ------------------------------------------------------------------ (a) invalid scene

def test_invalid_scene_names_its_key_in_analyze_and_bag_info(clean, tmp_path, capsys):
    bag = _rebuild(clean[0], tmp_path / 'badscene', lambda t, s, c, k: [
        (t, s, bagio.encode_string(SCENE_FILE.read_text().replace(
            'base_circle_radius: 0.0165', 'base_circle_radius: -3')))
        if t == '/bench/scene' else (t, s, c)])
    capsys.readouterr()
    assert main(['analyze', str(bag), '--only-metrology']) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert '/bench/scene.base_circle_radius: got -3; expected a number > 0' in err
    assert 'no /bench/scene' not in err
    assert main(['bag', 'info', str(bag)]) == 0
    assert 'scene: invalid: /bench/scene.base_circle_radius: got -3' in capsys.readouterr().out
    with pytest.raises(InputError) as exc:
        require_scenes(bag)
    assert exc.value.key == '/bench/scene.base_circle_radius'


def test_scene_that_is_not_yaml_is_named_by_topic(clean, tmp_path, capsys):
    bag = _rebuild(clean[0], tmp_path / 'notyaml', lambda t, s, c, k: [
        (t, s, bagio.encode_string('lobes: [')) if t == '/bench/scene' else (t, s, c)])
    capsys.readouterr()
    assert main(['analyze', str(bag), '--only-metrology']) == 2
    assert capsys.readouterr().err.startswith('cam-bench analyze: error: /bench/scene: ')


# ------------------------------------------------------------------ (b) joints

def _renamed(names, positions_of=lambda th, s: (th, s), only=None):
    def edit(topic, stamp, cdr, k):
        if topic != JS or (only is not None and k not in only):
            return [(topic, stamp, cdr)]
        js = bagio.decode_joint_states([cdr])
        fid = str(js.frame_id[0])
        pos = positions_of(float(js.theta[0]), float(js.s[0]))
        return [(topic, stamp, bagio.encode_joint_state_positions(
            fid, int(js.stamp_ns[0]), names, pos))]
    return edit


@pytest.mark.parametrize('names, joint', [(('camshaft', 'probe_z'), 'probe'),
                                          (('cam', 'probe'), 'camshaft')])
def test_joint_state_without_a_joint_names_it(clean, tmp_path, capsys, names, joint):
    bag = _rebuild(clean[0], tmp_path / 'nojoint', _renamed(names))
    capsys.readouterr()
    assert main(['analyze', str(bag), '--only-metrology']) == 2
    err = capsys.readouterr().err
    assert f"/bench/joint_states[0].name: got {list(names)!r}" in err
    assert f"a joint named '{joint}'" in err and '(1440 of 1440 messages)' in err


def test_fewer_positions_than_names_names_the_field(clean, tmp_path, capsys):
    bag = _rebuild(clean[0], tmp_path / 'short', _renamed(('camshaft', 'probe'),
                                                          lambda th, s: (th,)))
    capsys.readouterr()
    assert main(['analyze', str(bag), '--only-metrology']) == 2
    err = capsys.readouterr().err
    assert "/bench/joint_states[0].position: got \"1 values for 2 names ['camshaft', " \
           "'probe']\"; expected one position per name (1440 of 1440 messages)" in err


def test_some_messages_without_probe_are_counted_and_reported(clean, tmp_path, capsys):
    # 20 samples of lobe_1 (messages 0..719, theta = k * 0.5 deg) at theta 300-310 deg,
    # on the base circle (the lobe spans 123 +- 90 deg)
    lost = set(range(600, 620))
    bag = _rebuild(clean[0], tmp_path / 'partial',
                   _renamed(('camshaft', 'probe_z'), only=lost))
    rep = _report(bag, tmp_path / 'partial.json')
    err = capsys.readouterr().err
    assert "warning: /bench/joint_states[600].name: got ['camshaft', 'probe_z']" in err
    assert '(20 of 1440 messages)' in err
    assert any('[600].name' in w for w in rep['warnings'])
    lobe = rep['features']['lobe_1']
    assert lobe['samples_received'] == 720 and lobe['samples_nan_dropped'] == 20
    ref = clean[1]['features']
    # the lost samples are on the base circle: the angle moves by less than its
    # standard uncertainty; lobe_2 is untouched (same numbers)
    assert abs(lobe['angle_deg'] - ref['lobe_1']['angle_deg']) < 3 * ref['lobe_1']['angle_std_deg']
    assert rep['features']['lobe_2']['angle_deg'] == pytest.approx(
        ref['lobe_2']['angle_deg'], abs=1e-9)


# ------------------------------------------------------------------ (c) two scenes

def test_two_scenes_each_feature_with_the_scene_in_force(clean, tmp_path, capsys):
    """Scene B (another camshaft id, lobe_1 with another lift law) arrives between
    lobe_1 and lobe_2: lobe_1 keeps the result of scene A, lobe_2 is analysed with B
    (same lobe_2 as A), nothing is dropped, the report says which scene each used."""
    text_a = SCENE_FILE.read_text()
    text_b = text_a.replace('camshaft_id: FIX-2L-nopin', 'camshaft_id: FIX-2L-B').replace(
        'name: flat_tappet_intake}', 'name: methods_example}')
    assert text_b.count('methods_example') == 2
    first_lobe2 = {}

    def edit(topic, stamp, cdr, k):
        if topic == JS and k == 720:   # first sample of lobe_2
            first_lobe2['t'] = stamp
            return [('/bench/scene', stamp - 1, bagio.encode_string(text_b)),
                    (topic, stamp, cdr)]
        return [(topic, stamp, cdr)]

    bag = _rebuild(clean[0], tmp_path / 'twoscenes', edit)
    rep = _report(bag, tmp_path / 'two.json')
    err = capsys.readouterr().err
    assert 'the bag holds 2 different scenes' in err
    assert [s['camshaft_id'] for s in rep['scenes']] == ['FIX-2L-nopin', 'FIX-2L-B']
    assert rep['scenes'][1]['from_log_time_ns'] == first_lobe2['t'] - 1
    f = rep['features']
    assert (f['lobe_1']['scene_index'], f['lobe_2']['scene_index']) == (0, 1)
    assert f['lobe_1']['status'] == f['lobe_2']['status'] == 'ok'
    for fid in ('lobe_1', 'lobe_2'):
        assert f[fid]['samples_received'] == 720
        assert f[fid]['angle_deg'] == pytest.approx(clean[1]['features'][fid]['angle_deg'],
                                                    abs=1e-9)
    assert rep['camshaft_id'] == 'FIX-2L-B'


def test_scene_change_inside_the_core_closes_the_open_feature():
    """Direct core check: samples of lobe_1, then another scene, without any sample of
    another feature in between: lobe_1 is analysed with the first scene."""
    from cam_metrology.metrology.core import MetrologyCore
    from cam_metrology.scene.parse import load_scene, parse_scene
    from cam_metrology.simulation.bench import SimParams, simulate

    scene = load_scene(SCENE_FILE)
    run = simulate(scene, SimParams(samples_per_rev=720, seed=3))
    feat = run.features[0]
    core = MetrologyCore()
    core.set_scene(scene, 1)
    core.handle_samples([feat.id] * feat.theta.size, feat.stamp_ns, feat.theta, feat.s)
    other = parse_scene(scene.text.replace('FIX-2L-nopin', 'OTHER'))
    out = core.set_scene(other, int(feat.stamp_ns[-1]) + 1)
    assert any(getattr(o, 'label', None) == 'lobe_1' for o in out)   # analysed now
    rep = core.report()
    assert rep['features']['lobe_1']['scene_index'] == 0
    assert rep['features']['lobe_1']['angle_deg'] == pytest.approx(
        run.truth['features']['lobe_1']['angle_deg'], abs=1e-3)
    assert rep['features']['lobe_1']['status'] == 'ok'


# ------------------------------------------------------------------ (d) foreign types

def _foreign(clean_bag: Path, dst: Path) -> Path:
    temp = 'acme_msgs/msg/Temperature'
    extra = [('/add_two_ints/_service_event', 'example_interfaces/srv/AddTwoInts_Event',
              None, SRV_DEF),
             ('/acme/temperature', temp, None, 'float64 celsius\nstring sensor\n')]

    def edit(topic, stamp, cdr, k):
        out = [(topic, stamp, cdr)]
        if topic == JS and k % 360 == 0:
            out.append(('/add_two_ints/_service_event', stamp, b'\x00\x01\x00\x00' + bytes(40)))
            body = struct.pack('<d', 20.0 + k / 360) + struct.pack('<I', 3) + b'th\x00'
            out.append(('/acme/temperature', stamp, b'\x00\x01\x00\x00' + body))
        return out
    return _rebuild(clean_bag, dst, edit, extra)


def test_bag_with_service_events_and_vendor_types_is_listed_and_analysed(
        clean, tmp_path, capsys):
    bag = _foreign(clean[0], tmp_path / 'foreign')
    capsys.readouterr()
    assert main(['bag', 'info', str(bag)]) == 0
    out = capsys.readouterr().out
    assert '/add_two_ints/_service_event example_interfaces/srv/AddTwoInts_Event' in out
    assert '/acme/temperature' in out and 'acme_msgs/msg/Temperature' in out
    rep = _report(bag, tmp_path / 'foreign.json', '--out-bag', str(tmp_path / 'out'))
    assert _angles(rep) == pytest.approx(_angles(clean[1]), abs=1e-9)
    # the vendor type decodes from the definition recorded in the bag
    temps = [m.msg.celsius for m in bagio.iter_messages(bag, ['/acme/temperature'])]
    assert temps == pytest.approx([20.0, 21.0, 22.0, 23.0])
    # the service event is listed, copied, and decoding it is a clear error
    with pytest.raises(InputError, match='topic /add_two_ints/_service_event'):
        list(bagio.iter_messages(bag, ['/add_two_ints/_service_event']))
    out_topics = bagio.bag_topics(tmp_path / 'out')
    assert out_topics['/add_two_ints/_service_event'] == (
        'example_interfaces/srv/AddTwoInts_Event', 4)
    assert out_topics['/acme/temperature'][1] == 4


# ------------------------------------------------------------------ (e) damaged chunks

def test_bags_written_here_carry_chunk_crcs(clean):
    from mcap.reader import make_reader
    from mcap.records import Chunk
    from mcap.stream_reader import StreamReader

    path = _mcap(clean[0])
    crcs = [r.uncompressed_crc for r in StreamReader(str(path), emit_chunks=True).records
            if isinstance(r, Chunk)]
    assert crcs and all(crcs)
    with open(path, 'rb') as f:   # the mcap library validates them
        n = sum(1 for _ in make_reader(f, validate_crcs=True).iter_messages())
    assert n == sum(c for _, c in bagio.bag_topics(clean[0]).values())
    assert bagcheck.check_bag(clean[0]) == []


def _flip(path: Path, offset: int) -> None:
    data = bytearray(path.read_bytes())
    data[offset] ^= 0x5A
    path.write_bytes(bytes(data))


@pytest.mark.parametrize('compression', ['none', 'zstd'])
def test_flipped_byte_in_a_chunk_is_named_and_recovered(clean, tmp_path, capsys,
                                                        compression):
    bag = _rechunk(clean[0], tmp_path / 'chunked', compression=compression)
    path = _mcap(bag)
    chunks = _chunks(path)
    assert len(chunks) >= 4
    # a chunk holding lobe_2 samples only: the one whose start time follows lobe_2's start
    truth = clean[2]
    k = len(chunks) * 3 // 4
    victim = chunks[k]
    _flip(path, victim.chunk_start_offset + victim.chunk_length - 40)
    start, end = victim.chunk_start_offset, victim.chunk_start_offset + victim.chunk_length
    capsys.readouterr()
    assert main(['analyze', str(bag), '--only-metrology']) == 2
    err = capsys.readouterr().err
    assert f'bytes {start}-{end}' in err
    assert f'log time {victim.message_start_time / 1e9:.6f}-' in err
    n_lost = sum(1 for _ in _chunk_messages(_mcap(clean[0]), victim))
    assert f'{n_lost} messages of /bench/joint_states' in err
    if compression == 'none':
        assert 'CRC-32 mismatch' in err
    # independent: the mcap library's own CRC validation fails too (uncompressed case)
    assert main(['bag', 'check', str(bag)]) == 1
    assert f'damaged: {path.name} bytes {start}-{end}' in capsys.readouterr().out
    # recover keeps every other chunk
    assert main(['bag', 'recover', str(bag), str(tmp_path / 'fixed')]) == 0
    out = capsys.readouterr().out
    assert f'dropped: {path.name} bytes {start}-{end}' in out
    kept = bagio.read_joint_states(tmp_path / 'fixed')
    assert len(kept) == 1440 - n_lost
    rep = _report(tmp_path / 'fixed', tmp_path / 'fixed.json')
    ref = clean[1]['features']
    lost_ids = {str(f) for f in _lost_frames(_mcap(clean[0]), victim)}
    assert lost_ids and lost_ids <= {'lobe_1', 'lobe_2'}
    for fid in ('lobe_1', 'lobe_2'):
        got = rep['features'][fid]
        if fid in lost_ids:
            assert got['samples_received'] < 720
        else:   # an intact feature: the same numbers as the clean bag
            assert got['samples_received'] == 720
            assert got['angle_deg'] == pytest.approx(ref[fid]['angle_deg'], abs=1e-9)
            assert got['angle_std_deg'] == pytest.approx(ref[fid]['angle_std_deg'], rel=1e-9)
    assert truth['features']['lobe_1']['samples'] == 720


def _chunk_messages(clean_path: Path, chunk) -> list:
    """JointState messages of the clean file whose log time lies in the chunk's range
    (the rechunked copy holds the same messages in the same order)."""
    from mcap.reader import make_reader

    with open(clean_path, 'rb') as f:
        return [m for _, ch, m in make_reader(f).iter_messages(
            topics=[JS], starting_at=chunk.message_start_time,
            ending_at=chunk.message_end_time)]


def _lost_frames(clean_path: Path, chunk) -> set[str]:
    msgs = _chunk_messages(clean_path, chunk)
    return set(bagio.decode_joint_states([m.data for m in msgs]).features)


def test_flipped_byte_in_an_uncompressed_bag_of_ours_is_detected(clean, tmp_path):
    bag = tmp_path / 'ours'
    shutil.copytree(clean[0], bag)
    path = _mcap(bag)
    (chunk,) = _chunks(path)[:1]
    _flip(path, chunk.chunk_start_offset + chunk.chunk_length // 2)
    with pytest.raises(InputError, match='CRC-32 mismatch'):
        bagio.read_joint_states(bag)


def test_truncated_file_names_the_tail_and_recover_keeps_the_chunks_before(
        clean, tmp_path, capsys):
    bag = _rechunk(clean[0], tmp_path / 'chunked')
    path = _mcap(bag)
    chunks = _chunks(path)
    cut = chunks[len(chunks) // 2].chunk_start_offset + 100
    path.write_bytes(path.read_bytes()[:cut])
    capsys.readouterr()
    assert main(['analyze', str(bag), '--only-metrology']) == 2
    err = capsys.readouterr().err
    assert f'bytes {chunks[len(chunks) // 2].chunk_start_offset}-{cut}' in err
    assert 'the file ends inside a record' in err
    counts = bagio.recover_bag(bag, tmp_path / 'fixed')
    expect = sum(1 for c in chunks[:len(chunks) // 2] for _ in _chunk_messages(
        _mcap(clean[0]), c))
    assert counts[JS] == expect
    assert [(d.start, d.end) for d in counts.damaged] == [
        (chunks[len(chunks) // 2].chunk_start_offset, cut)]


def test_corrupted_length_field_resyncs_on_the_summary(clean, tmp_path):
    """A chunk whose record length is garbage: the walk resumes at the next chunk of
    the summary, so only that chunk is lost."""
    bag = _rechunk(clean[0], tmp_path / 'chunked')
    path = _mcap(bag)
    chunks = _chunks(path)
    victim = chunks[2]
    data = bytearray(path.read_bytes())
    data[victim.chunk_start_offset + 1:victim.chunk_start_offset + 9] = \
        struct.pack('<Q', 2**62)
    path.write_bytes(bytes(data))
    damaged = bagcheck.check_bag(bag)
    assert [(d.start, d.end) for d in damaged] == [
        (victim.chunk_start_offset, chunks[3].chunk_start_offset)]
    counts = bagio.recover_bag(bag, tmp_path / 'fixed')
    lost = len(_chunk_messages(_mcap(clean[0]), victim))
    assert counts[JS] == 1440 - lost


# ------------------------------------------------------------------ (f) huge strings

def _joint_cdr_with_frame_len(length: int) -> bytes:
    cdr = bytearray(bagio.encode_joint_state('lobe_1', 5, 0.1, 0.2))
    cdr[12:16] = struct.pack('<I', length)
    return bytes(cdr)


def test_huge_frame_id_length_field_is_refused_without_allocating(clean, tmp_path, capsys):
    bad = _joint_cdr_with_frame_len(0xFFFFFFF0)
    tracemalloc.start()
    try:
        with pytest.raises(InputError) as exc:
            bagio.decode_joint_states([bagio.encode_joint_state('lobe_1', 1, 0, 0)] * 100
                                      + [bad])
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert exc.value.key == '/bench/joint_states[100]'
    assert peak < 16 * 2**20
    bag = _rebuild(clean[0], tmp_path / 'huge', lambda t, s, c, k: [
        (t, s, bad if t == JS and k == 300 else c)])
    capsys.readouterr()
    assert main(['analyze', str(bag), '--only-metrology']) == 2
    assert '/bench/joint_states[300]' in capsys.readouterr().err


def test_long_frame_ids_decode_in_bounded_memory():
    """20 000 messages, one with a 4000-byte frame id (allowed): the old gather matrix
    was 20 000 x 4000 bytes (80 MB, several copies); blocks keep the peak far lower."""
    short = bagio.encode_joint_state('lobe_1', 1, 0.5, 0.25)
    longer = bagio.encode_joint_state('x' * 4000, 2, 0.5, 0.25)
    msgs = [short] * 19_999 + [longer]
    tracemalloc.start()
    try:
        js = bagio.decode_joint_states(msgs)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert js.features == ('lobe_1', 'x' * 4000)
    assert int((js.frame_id == 'lobe_1').sum()) == 19_999
    np.testing.assert_array_equal(js.theta, 0.5)
    assert peak < 60 * 2**20
    over = bagio.encode_joint_state('y' * (bagio.MAX_NAME_BYTES + 1), 3, 0.0, 0.0)
    with pytest.raises(InputError) as exc:
        bagio.decode_joint_states([short, over])
    assert exc.value.key == '/bench/joint_states[1].header.frame_id'


def test_huge_string_length_in_a_scene_message_is_a_clear_error(clean, tmp_path, capsys):
    def edit(topic, stamp, cdr, k):
        if topic == '/bench/scene':
            cdr = cdr[:4] + struct.pack('<I', 0xFFFFFFF0) + cdr[8:]
        return [(topic, stamp, cdr)]
    bag = _rebuild(clean[0], tmp_path / 'hugescene', edit)
    capsys.readouterr()
    assert main(['analyze', str(bag), '--only-metrology']) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and '/bench/scene' in err


def test_fill_chunk_crcs_on_a_bag_written_by_plain_rosbags(tmp_path, capsys):
    """rosbags alone stores CRC 0 (no CRC): `bag check` says so; filling them in place
    makes the mcap library's validation pass and a flipped byte detectable."""
    from mcap.reader import make_reader
    from rosbags.rosbag2 import StoragePlugin, Writer

    bag = tmp_path / 'plain'
    with Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        conn = w.add_connection(JS, 'sensor_msgs/msg/JointState', typestore=bagio.typestore())
        for i in range(20000):
            w.write(conn, 10 + i, bagio.encode_joint_state('lobe_1', i, i * 1e-3, 0.0))
    path = _mcap(bag)
    assert main(['bag', 'check', str(bag)]) == 0
    assert 'none with a CRC-32' in capsys.readouterr().out
    n_chunks = len(_chunks(path))
    assert n_chunks >= 2
    assert bagcheck.fill_chunk_crcs(path) == n_chunks
    with open(path, 'rb') as f:
        assert sum(1 for _ in make_reader(f, validate_crcs=True).iter_messages()) == 20000
    assert main(['bag', 'check', str(bag)]) == 0
    assert f'({n_chunks} with a CRC-32)' in capsys.readouterr().out
    last = _chunks(path)[-1]
    _flip(path, last.chunk_start_offset + last.chunk_length - 50)
    assert main(['bag', 'check', str(bag)]) == 1
    assert 'CRC-32 mismatch' in capsys.readouterr().out


def test_file_cut_between_records_is_named_and_fully_recovered(clean, tmp_path, capsys):
    bag = _rechunk(clean[0], tmp_path / 'chunked')
    path = _mcap(bag)
    chunks = _chunks(path)
    cut = chunks[3].chunk_start_offset   # whole records before, no DataEnd, no footer
    path.write_bytes(path.read_bytes()[:cut])
    (d,) = bagcheck.check_bag(bag)
    assert (d.start, d.end) == (cut, cut) and 'without its DataEnd and footer' in d.reason
    capsys.readouterr()
    assert main(['bag', 'recover', str(bag), str(tmp_path / 'fixed')]) == 0
    assert f'note: {path.name} bytes {cut}-{cut}' in capsys.readouterr().out
    kept = bagio.read_joint_states(tmp_path / 'fixed')
    expect = sum(len(_chunk_messages(_mcap(clean[0]), c)) for c in chunks[:3])
    assert len(kept) == expect
