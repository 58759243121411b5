"""bagio: CDR encoders, the MCAP writer, AnyReader iteration and the fast JointState path.

Every bag written here must open with rosbags AND with mcap + mcap_ros2 alone
(interfaces.md, Bags) and decode to exactly what was written.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from cam_design.errors import InputError
from cam_metrology import bagio
from cam_metrology.cores.outputs import ERROR, OK, Status, StatusOutput, TableOutput, TextOutput

JS = 'sensor_msgs/msg/JointState'


def _ts():
    return bagio.typestore()


def _joint_state_obj(frame_id, stamp_ns, names, positions, velocity=()):
    ts = _ts()
    sec, nsec = divmod(stamp_ns, 1_000_000_000)
    header = ts.types['std_msgs/msg/Header'](
        stamp=ts.types['builtin_interfaces/msg/Time'](sec=sec, nanosec=nsec), frame_id=frame_id)
    return ts.types[JS](header=header, name=list(names),
                        position=np.asarray(positions, dtype=float),
                        velocity=np.asarray(velocity, dtype=float),
                        effort=np.zeros(0))


def _mcap_decoded(bag: Path, topic: str | None = None) -> list[tuple[str, int, object]]:
    """(topic, log_time, decoded) with mcap + mcap_ros2 only (no rosbags, no package)."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    (mcap_file,) = bag.glob('*.mcap')
    with open(mcap_file, 'rb') as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        return [(ch.topic, msg.log_time, dec) for _, ch, msg, dec in
                reader.iter_decoded_messages(topics=None if topic is None else [topic])]


# ------------------------------------------------------------------------ encoders

@pytest.mark.parametrize('frame_id', ['lobe_1', 'dowel_pin', '', 'x' * 13, 'lobe_ü'])
@pytest.mark.parametrize('stamp_ns', [0, 1_700_000_000_123_456_789, 999_999_999])
def test_encode_joint_state_is_byte_identical_to_typestore(frame_id, stamp_ns):
    ts = _ts()
    obj = _joint_state_obj(frame_id, stamp_ns, ['camshaft', 'probe'], [1.25, -3.5e-3])
    expected = bytes(ts.serialize_cdr(obj, JS))
    got = bagio.encode_joint_state(frame_id, stamp_ns, 1.25, -3.5e-3)
    assert got == expected
    back = ts.deserialize_cdr(got, JS)
    assert back.header.frame_id == frame_id
    assert back.header.stamp.sec * 10**9 + back.header.stamp.nanosec == stamp_ns
    assert list(back.name) == ['camshaft', 'probe']
    assert back.position.tolist() == [1.25, -3.5e-3]


@pytest.mark.parametrize('names,positions', [
    (['probe', 'camshaft', 'table_z'], [1.0, 2.0, 3.0]),
    (['a'], []),
    ([], []),
])
def test_encode_joint_state_positions_matches_typestore(names, positions):
    ts = _ts()
    obj = _joint_state_obj('lobe_2', 5, names, positions)
    assert bagio.encode_joint_state_positions('lobe_2', 5, names, positions) == \
        bytes(ts.serialize_cdr(obj, JS))


@pytest.mark.parametrize('text', ['', 'a', 'scene: {x: 1}\n', 'ünïcode ✓', 'y' * 1000])
def test_encode_string_round_trip(text):
    ts = _ts()
    cdr = bagio.encode_string(text)
    assert cdr == bytes(ts.serialize_cdr(ts.types['std_msgs/msg/String'](data=text),
                                         'std_msgs/msg/String'))
    assert bagio.decode(cdr, 'std_msgs/msg/String').data == text


def test_encode_table_layout_and_round_trip():
    data = np.arange(12, dtype=float).reshape(4, 3) * 0.5
    out = TableOutput('/metrology/lift', 'lobe_1', ('alpha_rad', 'lift_m', 'design_lift_m'),
                      data)
    msg = bagio.decode(bagio.encode_output(out), 'std_msgs/msg/Float64MultiArray')
    dims = msg.layout.dim
    assert (dims[0].label, dims[0].size, dims[0].stride) == ('lobe_1', 4, 12)
    assert (dims[1].label, dims[1].size, dims[1].stride) == (
        'alpha_rad,lift_m,design_lift_m', 3, 3)
    assert msg.data.tolist() == data.reshape(-1).tolist()
    label, columns, back = bagio.table_from_msg(msg)
    assert label == 'lobe_1' and columns == out.columns
    np.testing.assert_array_equal(back, data)


def test_encode_table_rejects_wrong_shape():
    with pytest.raises(InputError, match='lobe_1.data'):
        bagio.encode_table('lobe_1', ('a', 'b'), np.zeros((3, 3)))


def test_encode_statuses_round_trip():
    out = StatusOutput('/metrology/result', (
        Status('lobe_1', OK, 'ok', {'angle_deg': '37.1234', 'angle_std_deg': '0.0004'}),
        Status('dowel_pin', ERROR, 'no contact samples', {}, hardware_id='bench'),
    ), stamp_ns=3_000_000_007)
    msg = bagio.decode(bagio.encode_output(out), 'diagnostic_msgs/msg/DiagnosticArray')
    assert msg.header.stamp.sec == 3 and msg.header.stamp.nanosec == 7
    got = bagio.statuses_from_msg(msg)
    assert got == [
        {'name': 'lobe_1', 'level': OK, 'message': 'ok', 'hardware_id': '',
         'values': {'angle_deg': '37.1234', 'angle_std_deg': '0.0004'}},
        {'name': 'dowel_pin', 'level': ERROR, 'message': 'no contact samples',
         'hardware_id': 'bench', 'values': {}},
    ]


def test_encode_status_stamp_defaults_to_given_stamp():
    out = StatusOutput('/metrology/result', (Status('a', OK, ''),))
    msg = bagio.decode(bagio.encode_output(out, 2_500_000_000),
                       'diagnostic_msgs/msg/DiagnosticArray')
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == (2, 500_000_000)


def test_encode_text_output():
    cdr = bagio.encode_output(TextOutput('/metrology/report', '{"a": 1}'))
    assert bagio.decode(cdr, 'std_msgs/msg/String').data == '{"a": 1}'


def test_encode_output_rejects_other_objects():
    with pytest.raises(InputError, match='output'):
        bagio.encode_output('not an output')   # type: ignore[arg-type]


# -------------------------------------------------------------------------- writer

def _write_small_bag(path: Path) -> dict[str, list]:
    """A bag with every kind of topic; returns what was written per topic."""
    written: dict[str, list] = {'/bench/scene': [], '/bench/joint_states': [],
                                '/metrology/lift': [], '/metrology/result': []}
    with bagio.BagWriter(path) as w:
        w.add_topic('/bench/scene', 'std_msgs/msg/String')
        w.add_topic('/bench/joint_states', JS)
        w.write('/bench/scene', 10, bagio.encode_string('camshaft_id: x'))
        written['/bench/scene'].append('camshaft_id: x')
        for i in range(50):
            stamp = 1_000 + 10 * i
            fid = 'lobe_1' if i < 30 else 'dowel_pin'
            w.write('/bench/joint_states', stamp,
                    bagio.encode_joint_state(fid, stamp, 0.01 * i, 1e-4 * i))
            written['/bench/joint_states'].append((fid, stamp, 0.01 * i, 1e-4 * i))
        table = TableOutput('/metrology/lift', 'lobe_1', ('alpha_rad', 'lift_m'),
                            np.array([[0.0, 1.0], [0.5, 2.0]]))
        w.write_output(table, 2_000)
        written['/metrology/lift'].append(table)
        status = StatusOutput('/metrology/result', (Status('lobe_1', OK, 'done',
                                                           {'angle_deg': '1.5'}),))
        w.write_output(status, 2_001)
        written['/metrology/result'].append(status)
    return written


def test_writer_bag_opens_with_rosbags_and_mcap(tmp_path):
    bag = tmp_path / 'bag'
    written = _write_small_bag(bag)
    assert (bag / 'metadata.yaml').exists()
    # rosbags
    msgs = list(bagio.iter_messages(bag))
    assert [m.stamp_ns for m in msgs] == sorted(m.stamp_ns for m in msgs)
    js = [m for m in msgs if m.topic == '/bench/joint_states']
    assert [(m.msg.header.frame_id, m.stamp_ns, float(m.msg.position[0]),
             float(m.msg.position[1])) for m in js] == written['/bench/joint_states']
    # mcap + mcap_ros2 alone
    dec = _mcap_decoded(bag)
    by_topic: dict[str, list] = {}
    for topic, log_time, msg in dec:
        by_topic.setdefault(topic, []).append((log_time, msg))
    assert [m.data for _, m in by_topic['/bench/scene']] == ['camshaft_id: x']
    got = [(m.header.frame_id, t, m.position[0], m.position[1])
           for t, m in by_topic['/bench/joint_states']]
    assert got == written['/bench/joint_states']
    (_, lift), = by_topic['/metrology/lift']
    assert lift.layout.dim[0].label == 'lobe_1'
    assert lift.layout.dim[1].label == 'alpha_rad,lift_m'
    assert list(lift.data) == [0.0, 1.0, 0.5, 2.0]
    (_, res), = by_topic['/metrology/result']
    assert res.status[0].name == 'lobe_1'
    assert [(kv.key, kv.value) for kv in res.status[0].values] == [('angle_deg', '1.5')]


def test_writer_scene_topic_is_latched_in_metadata_and_mcap(tmp_path):
    bag = tmp_path / 'bag'
    _write_small_bag(bag)
    meta = yaml.safe_load((bag / 'metadata.yaml').read_text())
    info = meta['rosbag2_bagfile_information']
    assert info['storage_identifier'] == 'mcap' and info['version'] == 9
    qos = {t['topic_metadata']['name']: t['topic_metadata']['offered_qos_profiles']
           for t in info['topics_with_message_count']}
    assert qos['/bench/scene'][0]['durability'] == 'transient_local'
    assert qos['/bench/scene'][0]['depth'] == 1
    assert qos['/bench/scene'][0]['reliability'] == 'reliable'
    assert qos['/bench/joint_states'][0]['durability'] == 'volatile'
    assert qos['/bench/joint_states'][0]['depth'] == 1000
    # the MCAP channel metadata (what ros2 bag play reads) says the same
    from mcap.reader import make_reader

    (mcap_file,) = bag.glob('*.mcap')
    with open(mcap_file, 'rb') as f:
        channels = make_reader(f).get_summary().channels
    scene = next(c for c in channels.values() if c.topic == '/bench/scene')
    assert yaml.safe_load(scene.metadata['offered_qos_profiles'])[0]['durability'] == \
        'transient_local'


def test_writer_refuses_to_overwrite(tmp_path):
    bag = tmp_path / 'bag'
    _write_small_bag(bag)
    before = sorted(p.name for p in bag.iterdir())
    with pytest.raises(InputError, match='never overwritten'):
        bagio.BagWriter(bag)
    assert sorted(p.name for p in bag.iterdir()) == before
    (tmp_path / 'plainfile').write_text('x')
    with pytest.raises(InputError):
        bagio.BagWriter(tmp_path / 'plainfile')


def test_writer_topic_errors(tmp_path):
    with bagio.BagWriter(tmp_path / 'bag') as w:
        with pytest.raises(InputError, match='ROS 2 Jazzy message type'):
            w.add_topic('/x', 'nope_msgs/msg/Nothing')
        w.add_topic('/x', 'std_msgs/msg/String')
        w.add_topic('/x', 'std_msgs/msg/String')   # idempotent
        with pytest.raises(InputError, match='registered type'):
            w.add_topic('/x', JS)
        with pytest.raises(InputError, match='registered with add_topic'):
            w.write('/unknown', 0, b'')
        with pytest.raises(InputError, match='qos_yaml'):
            w.add_topic('/y', 'std_msgs/msg/String', qos_yaml='- {history: 7}')
        w.write('/bench/feature_done', 1, bagio.encode_string('lobe_1'))   # auto-added
        assert w.counts == {'/x': 0, '/bench/feature_done': 1}


def test_writer_custom_qos_and_compression(tmp_path):
    bag = tmp_path / 'bag'
    with bagio.BagWriter(bag, compression=True) as w:
        w.add_topic('/late', 'std_msgs/msg/String',
                    qos_yaml=bagio.qos_yaml(transient_local=True, depth=3))
        for i in range(200):
            w.write('/late', i, bagio.encode_string(f'm{i}'))
    meta = yaml.safe_load((bag / 'metadata.yaml').read_text())
    (topic,) = meta['rosbag2_bagfile_information']['topics_with_message_count']
    assert topic['topic_metadata']['offered_qos_profiles'][0]['depth'] == 3
    assert [m.msg.data for m in bagio.iter_messages(bag)] == [f'm{i}' for i in range(200)]
    assert [m.data for _, _, m in _mcap_decoded(bag)] == [f'm{i}' for i in range(200)]


def test_unclosed_or_missing_bag_is_a_clear_error(tmp_path):
    with pytest.raises(InputError, match='existing rosbag2'):
        list(bagio.iter_messages(tmp_path / 'nothing'))
    (tmp_path / 'half').mkdir()
    (tmp_path / 'half' / 'half_0.mcap').write_bytes(b'\x89MCAP0\r\n')
    with pytest.raises(InputError, match='metadata.yaml'):
        bagio.read_joint_states(tmp_path / 'half')


def test_iter_messages_sorts_by_log_time_and_filters(tmp_path):
    bag = tmp_path / 'bag'
    stamps = [50, 10, 40, 20, 30]
    with bagio.BagWriter(bag) as w:
        for t in stamps:
            w.write('/bench/feature_done', t, bagio.encode_string(str(t)))
        w.write('/bench/scene', 25, bagio.encode_string('s'))
    all_msgs = list(bagio.iter_messages(bag))
    assert [m.stamp_ns for m in all_msgs] == [10, 20, 25, 30, 40, 50]
    assert [m.msg.data for m in bagio.iter_messages(bag, ['/bench/feature_done'])] == \
        ['10', '20', '30', '40', '50']
    topic, msgtype, stamp, msg = next(iter(bagio.iter_messages(bag, ['/bench/scene'])))
    assert (topic, msgtype, stamp, msg.data) == ('/bench/scene', 'std_msgs/msg/String',
                                                 25, 's')
    assert list(bagio.iter_messages(bag, ['/none'])) == []
    raw = list(bagio.iter_messages(bag, ['/bench/scene'], raw=True))
    assert bytes(raw[0].msg) == bagio.encode_string('s')
    assert bagio.bag_topics(bag) == {'/bench/feature_done': ('std_msgs/msg/String', 5),
                                     '/bench/scene': ('std_msgs/msg/String', 1)}


# ------------------------------------------------------------------ fast JointState

def _irregular_messages():
    """(log_ns, cdr, expected (frame, stamp, theta, s)) of unusual but valid messages."""
    ts = _ts()
    rows = []
    plain = [('lobe_1', 100 + i, 0.1 * i, 1e-3 * i) for i in range(5)]
    for fid, st, th, s in plain:
        rows.append((st, bagio.encode_joint_state(fid, st, th, s), (fid, st, th, s)))
    # swapped order, extra joints, velocities, big-endian CDR, long frame id
    obj = _joint_state_obj('lobe_2', 200, ['probe', 'camshaft'], [7e-3, 2.5])
    rows.append((200, bytes(ts.serialize_cdr(obj, JS)), ('lobe_2', 200, 2.5, 7e-3)))
    obj = _joint_state_obj('lobe_2', 201, ['table_x', 'probe', 'spindle', 'camshaft'],
                           [9.0, 8e-3, 1.0, 2.6], velocity=[1, 2, 3, 4])
    rows.append((201, bytes(ts.serialize_cdr(obj, JS)), ('lobe_2', 201, 2.6, 8e-3)))
    obj = _joint_state_obj('lobe_2', 202, ['camshaft', 'probe'], [2.7, 9e-3])
    rows.append((202, bytes(ts.serialize_cdr(obj, JS, little_endian=False)),
                 ('lobe_2', 202, 2.7, 9e-3)))
    obj = _joint_state_obj('dowel_pin_with_a_long_name', (2**31 - 1) * 10**9 + 5,
                           ['camshafts', 'camshaft', 'probe_', 'probe'], [0, 3.0, 0, 1e-2])
    rows.append((300, bytes(ts.serialize_cdr(obj, JS)),
                 ('dowel_pin_with_a_long_name', (2**31 - 1) * 10**9 + 5, 3.0, 1e-2)))
    # missing probe joint / fewer positions than names -> NaN
    obj = _joint_state_obj('dowel_pin', 301, ['camshaft'], [3.1])
    rows.append((301, bytes(ts.serialize_cdr(obj, JS)), ('dowel_pin', 301, 3.1, np.nan)))
    obj = _joint_state_obj('dowel_pin', 302, ['camshaft', 'probe'], [3.2])
    rows.append((302, bytes(ts.serialize_cdr(obj, JS)), ('dowel_pin', 302, 3.2, np.nan)))
    obj = _joint_state_obj('dowel_pin', 303, ['camshaft', 'probe'], [np.nan, 1.0])
    rows.append((303, bytes(ts.serialize_cdr(obj, JS)), ('dowel_pin', 303, np.nan, 1.0)))
    return rows


def test_decode_joint_states_irregular_messages():
    rows = _irregular_messages()
    got = bagio.decode_joint_states([r[1] for r in rows],
                                    np.array([r[0] for r in rows], dtype=np.int64))
    exp = [r[2] for r in rows]
    assert got.frame_id.tolist() == [e[0] for e in exp]
    assert got.stamp_ns.tolist() == [e[1] for e in exp]
    np.testing.assert_array_equal(got.theta, [e[2] for e in exp])
    np.testing.assert_array_equal(got.s, [e[3] for e in exp])
    assert got.features == ('lobe_1', 'lobe_2', 'dowel_pin_with_a_long_name', 'dowel_pin')
    assert got.names[0] == ('camshaft', 'probe')
    assert ('table_x', 'probe', 'spindle', 'camshaft') in got.names
    assert ('camshaft',) in got.names


def test_decode_joint_states_rejects_truncated_message():
    good = bagio.encode_joint_state('lobe_1', 1, 0.0, 0.0)
    with pytest.raises(InputError, match='complete sensor_msgs/JointState'):
        bagio.decode_joint_states([good, good[:30]])


def test_decode_joint_states_empty():
    got = bagio.decode_joint_states([])
    assert len(got) == 0 and got.features == ()


def test_fast_path_equals_anyreader_on_irregular_bag(tmp_path):
    bag = tmp_path / 'bag'
    rows = _irregular_messages()
    with bagio.BagWriter(bag) as w:
        w.add_topic('/other', 'std_msgs/msg/String')
        for log, cdr, _ in rows:
            w.write('/bench/joint_states', log, cdr)
            w.write('/other', log, bagio.encode_string('noise'))
    fast = bagio.read_joint_states(bag)
    slow = [m.msg for m in bagio.iter_messages(bag, ['/bench/joint_states'])]
    assert len(fast) == len(slow)
    for i, msg in enumerate(slow):
        names = list(msg.name)
        pos = list(msg.position)

        def look(joint):
            k = names.index(joint) if joint in names else -1
            return pos[k] if 0 <= k < len(pos) else np.nan
        assert fast.frame_id[i] == msg.header.frame_id
        assert fast.stamp_ns[i] == msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
        np.testing.assert_array_equal([fast.theta[i], fast.s[i]],
                                      [look('camshaft'), look('probe')])
    assert fast.log_ns.tolist() == [r[0] for r in rows]


def test_fast_path_rejects_wrong_type(tmp_path):
    bag = tmp_path / 'bag'
    with bagio.BagWriter(bag) as w:
        w.add_topic('/bench/joint_states', 'std_msgs/msg/String')
        w.write('/bench/joint_states', 0, bagio.encode_string('x'))
    with pytest.raises(InputError, match='sensor_msgs/msg/JointState'):
        bagio.read_joint_states(bag)


def test_light_joint_states_have_joint_state_fields():
    rows = _irregular_messages()[:3]
    samples = bagio.decode_joint_states([r[1] for r in rows])
    light = list(bagio.light_joint_states(samples))
    assert light[2].header.frame_id == 'lobe_1'
    assert (light[2].header.stamp.sec, light[2].header.stamp.nanosec) == (0, 102)
    assert list(light[2].name) == ['camshaft', 'probe']
    assert list(light[2].position) == [0.2, 2e-3]


def test_copy_bag_keeps_bytes_types_and_qos(tmp_path):
    src = tmp_path / 'src'
    _write_small_bag(src)
    dst = tmp_path / 'dst'
    with bagio.BagWriter(dst) as w:
        n = bagio.copy_bag(src, w)
    assert n == 1 + 50 + 2
    a = list(bagio.iter_messages(src, raw=True))
    b = list(bagio.iter_messages(dst, raw=True))
    assert [(m.topic, m.msgtype, m.stamp_ns, bytes(m.msg)) for m in a] == \
        [(m.topic, m.msgtype, m.stamp_ns, bytes(m.msg)) for m in b]
    meta = yaml.safe_load((dst / 'metadata.yaml').read_text())
    qos = {t['topic_metadata']['name']: t['topic_metadata']['offered_qos_profiles']
           for t in meta['rosbag2_bagfile_information']['topics_with_message_count']}
    assert qos['/bench/scene'][0]['durability'] == 'transient_local'


def test_direct_mcap_read_equals_anyreader_path_across_chunks(tmp_path):
    """Several 1 MiB chunks, ties and out-of-order log times, interleaved topics, zstd."""
    for compression in (False, True):
        bag = tmp_path / f'bag{int(compression)}'
        rng = np.random.default_rng(0)
        logs = 10**6 + np.repeat(np.arange(6000), 2) * 1000 + rng.integers(-3000, 3000, 12000)
        with bagio.BagWriter(bag, compression=compression) as w:
            for i, log in enumerate(logs.tolist()):
                fid = f'lobe_{1 + i // 4000}'
                w.write('/bench/joint_states', log,
                        bagio.encode_joint_state(fid, i, float(i), float(-i)))
                if i % 3 == 0:
                    w.write('/bench/feature_done', log, bagio.encode_string('x'))
        direct = bagio.read_joint_states(bag)
        fallback = bagio.read_joint_states(bag, direct=False)
        (bare,) = bag.glob('*.mcap')   # the same file read as a bare MCAP file
        for other in (fallback, bagio.read_joint_states(bare),
                      bagio.read_joint_states(bare, direct=False)):
            for k in ('frame_id', 'stamp_ns', 'log_ns', 'theta', 's'):
                np.testing.assert_array_equal(getattr(direct, k), getattr(other, k))
        assert direct.features == fallback.features == ('lobe_1', 'lobe_2', 'lobe_3')
        assert np.all(np.diff(direct.log_ns) >= 0)
        slow = [m.msg for m in bagio.iter_messages(bag, ['/bench/joint_states'])]
        assert [m.header.stamp.nanosec for m in slow] == direct.stamp_ns.tolist()
        from mcap.reader import make_reader

        (mcap_file,) = bag.glob('*.mcap')
        with open(mcap_file, 'rb') as f:
            assert len(make_reader(f).get_summary().chunk_indexes) >= 2


def test_negative_log_time_is_an_input_error(tmp_path):
    with bagio.BagWriter(tmp_path / 'bag') as w:
        with pytest.raises(InputError, match='log time'):
            w.write('/bench/scene', -1, bagio.encode_string('x'))


def test_recover_an_interrupted_recording(tmp_path, capsys):
    bag = tmp_path / 'full'
    with bagio.BagWriter(bag) as w:
        w.write('/bench/scene', 1, bagio.encode_string('scene text'))
        for i in range(30000):
            w.write('/bench/joint_states', 10 + i, bagio.encode_joint_state('lobe_1', i, i, -i))
    (mcap_file,) = bag.glob('*.mcap')
    crashed = tmp_path / 'crashed'
    crashed.mkdir()
    data = mcap_file.read_bytes()
    (crashed / 'crashed_0.mcap').write_bytes(data[: int(len(data) * 0.7)])
    with pytest.raises(InputError, match='metadata.yaml'):
        bagio.read_joint_states(crashed)
    counts = bagio.recover_bag(crashed, tmp_path / 'fixed')
    assert counts['/bench/scene'] == 1
    assert 10000 < counts['/bench/joint_states'] < 30000
    js = bagio.read_joint_states(tmp_path / 'fixed')
    np.testing.assert_array_equal(js.theta, np.arange(len(js)))
    assert 'transient_local' in bagio.topic_qos_yaml(tmp_path / 'fixed')['/bench/scene']
    with pytest.raises(InputError):
        bagio.recover_bag(tmp_path / 'nothing', tmp_path / 'x')
    from cam_metrology.cli import main

    assert main(['bag', 'recover', str(crashed), str(tmp_path / 'fixed2')]) == 0
    out = capsys.readouterr().out
    assert f"/bench/joint_states: {counts['/bench/joint_states']}" in out


def test_write_after_close_is_an_input_error(tmp_path):
    w = bagio.BagWriter(tmp_path / 'bag')
    w.close()
    w.close()   # idempotent
    with pytest.raises(InputError, match='closed'):
        w.write('/bench/scene', 1, bagio.encode_string('x'))


def test_fast_path_tolerates_trailing_bytes():
    """rclpy's serialize_message adds 4 (uninitialised) trailing bytes (platform.md)."""
    cdrs = [bagio.encode_joint_state('lobe_1', i, 0.5 * i, 1e-3 * i) + b'\xaa\xbb\xcc\xdd'
            for i in range(5)]
    got = bagio.decode_joint_states(cdrs)
    np.testing.assert_array_equal(got.theta, 0.5 * np.arange(5))
    np.testing.assert_array_equal(got.s, 1e-3 * np.arange(5))


def test_sqlite3_bag_goes_through_the_fallback(tmp_path):
    from rosbags.rosbag2 import StoragePlugin, Writer

    bag = tmp_path / 'sqlite'
    ts = bagio.typestore()
    with Writer(bag, version=9, storage_plugin=StoragePlugin.SQLITE3) as w:
        conn = w.add_connection('/bench/joint_states', JS, typestore=ts)
        for i in range(20):
            w.write(conn, 100 + i, bagio.encode_joint_state('lobe_1', i, float(i), -float(i)))
    got = bagio.read_joint_states(bag)
    np.testing.assert_array_equal(got.theta, np.arange(20.0))
    assert got.log_ns.tolist() == list(range(100, 120))


@pytest.mark.parametrize('frame_id', ['lobe_1', 'dowel_pin', '', 'x' * 13])
def test_vectorised_encoder_equals_the_scalar_one(frame_id):
    rng = np.random.default_rng(1)
    stamps = np.sort(rng.integers(0, 2**31 * 10**9 - 1, 50))
    theta = rng.normal(size=50) * 100
    s = rng.normal(size=50) * 1e-3
    theta[3] = np.nan
    got = bagio.encode_joint_states(frame_id, stamps, theta, s)
    exp = [bagio.encode_joint_state(frame_id, int(st), float(th), float(v))
           for st, th, v in zip(stamps, theta, s)]
    assert got == exp
    with pytest.raises(InputError, match='same length'):
        bagio.encode_joint_states('a', stamps, theta[:3], s)


def test_bare_mcap_file_reads_like_its_directory(tmp_path):
    bag = tmp_path / 'bag'
    _write_small_bag(bag)
    (bare,) = bag.glob('*.mcap')
    assert bagio.bag_topics(bare) == bagio.bag_topics(bag)
    assert bagio.topic_qos_yaml(bare) == bagio.topic_qos_yaml(bag)
    a = [(m.topic, m.msgtype, m.stamp_ns, bytes(m.msg))
         for m in bagio.iter_messages(bag, raw=True)]
    b = [(m.topic, m.msgtype, m.stamp_ns, bytes(m.msg))
         for m in bagio.iter_messages(bare, raw=True)]
    assert a == b
    decoded = list(bagio.iter_messages(bare, ['/bench/scene']))
    assert decoded[0].msg.data == 'camshaft_id: x'
    bad = tmp_path / 'bad.mcap'
    bad.write_bytes(b'not an mcap file at all')
    with pytest.raises(InputError, match='MCAP'):
        bagio.bag_topics(bad)


def test_fast_path_rejects_other_cdr_encapsulations():
    good = bagio.encode_joint_state('lobe_1', 1, 0.0, 0.0)
    xcdr2 = b'\x00\x07' + good[2:]
    with pytest.raises(InputError, match='plain CDR encapsulation') as info:
        bagio.decode_joint_states([good, xcdr2])
    assert info.value.key == '/bench/joint_states[1]'


def test_bare_mcap_written_by_mcap_ros2(tmp_path):
    """Another program: the mcap_ros2 writer (own CDR encoder, no rosbag2 directory)."""
    from mcap_ros2.writer import Writer

    ts = bagio.typestore()
    path = tmp_path / 'other.mcap'
    with open(path, 'wb') as f:
        writer = Writer(f)
        js_schema = writer.register_msgdef(
            'sensor_msgs/msg/JointState', ts.generate_msgdef(JS, ros_version=2)[0])
        str_schema = writer.register_msgdef(
            'std_msgs/msg/String', ts.generate_msgdef('std_msgs/msg/String', ros_version=2)[0])
        writer.write_message('/bench/scene', str_schema, {'data': 'scene'}, log_time=5)
        for i in range(100):
            names = ['probe', 'camshaft'] if i % 2 else ['camshaft', 'probe', 'spindle']
            pos = [1e-4 * i, 0.01 * i] if i % 2 else [0.01 * i, 1e-4 * i, 7.0]
            writer.write_message('/bench/joint_states', js_schema, {
                'header': {'stamp': {'sec': 1, 'nanosec': i}, 'frame_id': 'lobe_1'},
                'name': names, 'position': pos, 'velocity': [], 'effort': []},
                log_time=10 + i)
        writer.finish()
    js = bagio.read_joint_states(path)
    np.testing.assert_allclose(js.theta, 0.01 * np.arange(100), rtol=0, atol=0)
    np.testing.assert_allclose(js.s, 1e-4 * np.arange(100), rtol=0, atol=0)
    assert js.stamp_ns.tolist() == [10**9 + i for i in range(100)]
    assert js.log_ns.tolist() == [10 + i for i in range(100)]
    fallback = bagio.read_joint_states(path, direct=False)
    np.testing.assert_array_equal(fallback.theta, js.theta)
    (scene,) = list(bagio.iter_messages(path, ['/bench/scene']))
    assert scene.msg.data == 'scene'


def test_bag_message_is_a_tuple(tmp_path):
    bag = tmp_path / 'bag'
    with bagio.BagWriter(bag) as w:
        w.write('/bench/scene', 3, bagio.encode_string('s'))
    (m,) = list(bagio.iter_messages(bag))
    assert m[0] == m.topic == '/bench/scene' and m[2] == 3 and m[3].data == 's'
    assert tuple(m)[:3] == ('/bench/scene', 'std_msgs/msg/String', 3)


def test_bag_connections_with_qos_and_latching(tmp_path):
    bag = tmp_path / 'bag'
    _write_small_bag(bag)
    conns = bagio.bag_connections(bag)
    assert set(conns) == set(bagio.bag_topics(bag))
    scene = conns['/bench/scene']
    assert scene == (('std_msgs/msg/String', 1, scene.qos_yaml, True))
    assert 'transient_local' in scene.qos_yaml
    js = conns['/bench/joint_states']
    assert (js.msgtype, js.count, js.latched) == ('sensor_msgs/msg/JointState', 50, False)
    (bare,) = bag.glob('*.mcap')
    assert bagio.bag_connections(bare) == conns
