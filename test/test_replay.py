"""In-process replay: delivery order, routing between cores, ticks, bulk path, finish."""
from __future__ import annotations

import numpy as np
import pytest

from cam_design.errors import InputError
from cam_metrology import bagio
from cam_metrology.cores.outputs import OK, Status, StatusOutput, TableOutput, TextOutput
from cam_metrology.offline.replay import order_cores, run_offline, write_outputs

JS = bagio.JOINT_STATES
LIFT = '/metrology/lift'
PROFILE = '/reconstruction/profile'
RESULT = '/dynamics/result'


class Source:
    """Like metrology: collects samples per feature, publishes a lift table per feature."""

    name = 'source'
    subscriptions = {'/bench/scene': 'std_msgs/msg/String', JS: 'sensor_msgs/msg/JointState',
                     '/bench/feature_done': 'std_msgs/msg/String'}
    publications = {LIFT: 'std_msgs/msg/Float64MultiArray',
                    '/metrology/report': 'std_msgs/msg/String'}

    def __init__(self, log):
        self.log = log
        self.samples = []
        self.ticks = []

    def handle(self, topic, msg, stamp_ns):
        if topic == JS:
            pos = dict(zip(msg.name, msg.position))
            stamp = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
            self.samples.append((msg.header.frame_id, stamp, pos['camshaft'], pos['probe'],
                                 stamp_ns))
            return []
        self.log.append((self.name, topic, msg.data, stamp_ns))
        if topic == '/bench/feature_done':
            rows = [s for s in self.samples if s[0] == msg.data]
            data = np.array([[s[2], s[3]] for s in rows])
            return [TableOutput(LIFT, msg.data, ('alpha_rad', 'lift_m'), data)]
        return []

    def tick(self, now_ns):
        self.ticks.append(now_ns)
        return []

    def finish(self):
        self.log.append((self.name, 'finish'))
        return [TextOutput('/metrology/report', '{"done": %d}' % len(self.samples))]


class BulkSource(Source):
    """The same with the bulk path."""

    def __init__(self, log):
        super().__init__(log)
        self.bulk_calls = []

    def handle_samples(self, frame_ids, stamp_ns, theta, s, rx_ns=None):
        self.bulk_calls.append((len(theta), rx_ns))
        for f, st, th, v in zip(frame_ids, stamp_ns, theta, s):
            self.samples.append((str(f), int(st), float(th), float(v), rx_ns))
        return []


class Mid:
    """Like reconstruction: turns each lift table into a profile table."""

    name = 'mid'
    subscriptions = {LIFT: 'std_msgs/msg/Float64MultiArray'}
    publications = {PROFILE: 'std_msgs/msg/Float64MultiArray'}

    def __init__(self, log):
        self.log = log

    def handle(self, topic, msg, stamp_ns):
        label, columns, data = bagio.table_from_msg(msg)
        self.log.append((self.name, topic, label, stamp_ns))
        return [TableOutput(PROFILE, f'{label}/spline', columns, 2 * data)]

    def tick(self, now_ns):
        return []

    def finish(self):
        self.log.append((self.name, 'finish'))
        return []


class Sink:
    """Like dynamics: consumes profiles, reports at finish."""

    name = 'sink'
    subscriptions = {PROFILE: 'std_msgs/msg/Float64MultiArray'}
    publications = {RESULT: 'diagnostic_msgs/msg/DiagnosticArray'}

    def __init__(self, log):
        self.log = log
        self.tables = []

    def handle(self, topic, msg, stamp_ns):
        label, _, data = bagio.table_from_msg(msg)
        self.log.append((self.name, topic, label, stamp_ns))
        self.tables.append((label, data))
        return []

    def tick(self, now_ns):
        return []

    def finish(self):
        self.log.append((self.name, 'finish'))
        return [StatusOutput(RESULT, tuple(Status(label, OK, 'seen')
                                           for label, _ in self.tables))]


def _bag(path, gap_s=0.0, with_recorded_output=False):
    """scene, 2 features x 5 samples (+ feature_done), optional gap in feature 2."""
    t = 1_000_000_000
    with bagio.BagWriter(path) as w:
        w.write('/bench/scene', t, bagio.encode_string('scene'))
        w.add_topic('/unrelated', 'std_msgs/msg/String')
        for k, fid in enumerate(('lobe_1', 'lobe_2')):
            for i in range(5):
                t += 1_000_000
                if k == 1 and i == 2:
                    t += int(gap_s * 1e9)
                w.write(JS, t, bagio.encode_joint_state(fid, t - 10, 0.1 * i + k, 1e-3 * i))
                w.write('/unrelated', t, bagio.encode_string('x'))
            w.write('/bench/feature_done', t + 1, bagio.encode_string(fid))
        if with_recorded_output:
            w.write_output(TableOutput(LIFT, 'stale', ('a',), np.zeros((1, 1))), t + 5)


def test_routing_order_between_cores(tmp_path):
    bag = tmp_path / 'bag'
    _bag(bag)
    log = []
    src, mid, sink = Source(log), Mid(log), Sink(log)
    res = run_offline(bag, [sink, mid, src])   # given downstream first: reordered
    events = [e[:3] for e in log]
    assert events == [
        ('source', '/bench/scene', 'scene'),
        ('source', '/bench/feature_done', 'lobe_1'),
        ('mid', LIFT, 'lobe_1'),
        ('sink', PROFILE, 'lobe_1/spline'),
        ('source', '/bench/feature_done', 'lobe_2'),
        ('mid', LIFT, 'lobe_2'),
        ('sink', PROFILE, 'lobe_2/spline'),
        ('source', 'finish'), ('mid', 'finish'), ('sink', 'finish'),
    ]
    # routed outputs carry the log time of the message that caused them
    done_1 = next(e for e in log if e[2] == 'lobe_1')[3]
    assert next(e for e in log if e[:2] == ('mid', LIFT))[3] == done_1
    # samples of a feature were all delivered before its feature_done
    assert [s[0] for s in src.samples] == ['lobe_1'] * 5 + ['lobe_2'] * 5
    assert src.samples[0][1] == src.samples[0][4] - 10   # header stamp vs log time
    label, data = sink.tables[1]
    want = 2 * np.array([[1.0 + 0.1 * i, 1e-3 * i] for i in range(5)])
    np.testing.assert_allclose(data, want)
    # every output collected, with its source, in production order
    assert [(o.source, o.output.topic) for o in res.outputs] == [
        ('source', LIFT), ('mid', PROFILE), ('source', LIFT), ('mid', PROFILE),
        ('source', '/metrology/report'), ('sink', RESULT)]
    assert res.report() == {'done': 10}
    assert res.delivered == {'/bench/scene': 1, '/bench/feature_done': 2, JS: 10}
    assert res.samples == 10


def test_bulk_and_per_sample_paths_agree(tmp_path):
    bag = tmp_path / 'bag'
    _bag(bag, gap_s=0.5)
    a, b = Source([]), BulkSource([])
    run_offline(bag, [a])
    run_offline(bag, [b])
    assert [s[:4] for s in a.samples] == [s[:4] for s in b.samples]
    # runs are cut at the feature_done messages and at the 0.5 s gap; rx_ns is the
    # log time of each run's last sample
    assert [n for n, _ in b.bulk_calls] == [5, 2, 3]
    assert [rx for _, rx in b.bulk_calls] == [a.samples[i][4] for i in (4, 6, 9)]
    c = BulkSource([])
    run_offline(bag, [c], bulk=False)
    assert c.bulk_calls == [] and [s[:4] for s in c.samples] == [s[:4] for s in a.samples]


def test_ticks_fire_inside_gaps(tmp_path):
    bag = tmp_path / 'bag'
    _bag(bag, gap_s=0.5)
    src = Source([])
    run_offline(bag, [src], tick_period_ns=100_000_000)
    t_before = src.samples[6][4]
    t_after = src.samples[7][4]
    inside = [t for t in src.ticks if t_before < t < t_after]
    assert inside[:4] == [t_before + k * 100_000_000 for k in range(1, 5)]
    assert inside[-1] == t_after - 1
    # and a final tick after the stream (the live timer keeps running)
    assert src.ticks[-1] > src.samples[-1][4] + 10**11


def test_long_gap_ticks_are_capped(tmp_path):
    bag = tmp_path / 'bag'
    _bag(bag, gap_s=3600.0)
    src = Source([])
    run_offline(bag, [src], tick_period_ns=1_000_000)
    assert len(src.ticks) < 1000


def test_recorded_outputs_are_regenerated_not_doubled(tmp_path):
    bag = tmp_path / 'bag'
    _bag(bag, with_recorded_output=True)
    log = []
    res = run_offline(bag, [Source(log), Mid(log)])
    seen = [e[2] for e in log if e[0] == 'mid' and len(e) > 2]
    assert seen == ['lobe_1', 'lobe_2']   # not the recorded 'stale' table
    assert res.regenerated_topics == (LIFT,)


def test_progress_and_empty_core_list(tmp_path):
    bag = tmp_path / 'bag'
    _bag(bag)
    calls = []
    run_offline(bag, [Source([])], progress=lambda d, t: calls.append((d, t)))
    assert calls[-1] == (13, 13)
    res = run_offline(bag, [])
    assert res.outputs == [] and res.delivered == {}
    with pytest.raises(InputError, match='tick_period_ns'):
        run_offline(bag, [], tick_period_ns=0)


def test_order_cores_is_topological_and_stable():
    log = []
    src, mid, sink = Source(log), Mid(log), Sink(log)
    assert order_cores([sink, mid, src]) == [src, mid, sink]
    assert order_cores([src, sink, mid]) == [src, mid, sink]
    other = Source(log)
    assert order_cores([other, src]) == [other, src]


def test_write_outputs_merges_in_log_time(tmp_path):
    bag = tmp_path / 'bag'
    _bag(bag, with_recorded_output=True)
    log = []
    res = run_offline(bag, [Source(log), Mid(log), Sink(log)])
    out = tmp_path / 'out'
    n = write_outputs(res, out)
    assert n == len(res.outputs) == 6
    msgs = list(bagio.iter_messages(out))
    stamps = [m.stamp_ns for m in msgs]
    assert stamps == sorted(stamps)
    topics = bagio.bag_topics(out)
    assert topics[LIFT] == ('std_msgs/msg/Float64MultiArray', 2)   # stale one dropped
    assert topics[PROFILE] == ('std_msgs/msg/Float64MultiArray', 2)
    assert topics[RESULT] == ('diagnostic_msgs/msg/DiagnosticArray', 1)
    assert topics['/unrelated'] == ('std_msgs/msg/String', 10)
    # the lift of lobe_1 comes right after lobe_1's feature_done
    names = [(m.topic, getattr(m.msg, 'data', None) if m.topic != LIFT
              else m.msg.layout.dim[0].label) for m in msgs]
    i = names.index(('/bench/feature_done', 'lobe_1'))
    assert names[i + 1] == (LIFT, 'lobe_1')
    # input bytes unchanged
    a = [bytes(m.msg) for m in bagio.iter_messages(bag, [JS], raw=True)]
    b = [bytes(m.msg) for m in bagio.iter_messages(out, [JS], raw=True)]
    assert a == b
    qos = bagio.topic_qos_yaml(out)
    assert 'transient_local' in qos['/bench/scene']


def test_replay_of_a_bare_mcap_file(tmp_path):
    bag = tmp_path / 'bag'
    _bag(bag)
    (bare,) = bag.glob('*.mcap')
    a, b = [], []
    run_offline(bag, [Source(a), Mid(a), Sink(a)])
    run_offline(bare, [Source(b), Mid(b), Sink(b)])
    assert a == b


def test_write_outputs_bag_decodes_with_mcap_alone(tmp_path):
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    bag = tmp_path / 'bag'
    _bag(bag)
    res = run_offline(bag, [Source([]), Mid([]), Sink([])])
    out = tmp_path / 'out'
    write_outputs(res, out)
    (path,) = out.glob('*.mcap')
    with open(path, 'rb') as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        got = {}
        for _, ch, _, msg in reader.iter_decoded_messages():
            got.setdefault(ch.topic, []).append(msg)
    assert [m.layout.dim[0].label for m in got[PROFILE]] == ['lobe_1/spline', 'lobe_2/spline']
    np.testing.assert_allclose(np.reshape(got[PROFILE][1].data, (5, 2)),
                               2 * np.array([[1.0 + 0.1 * i, 1e-3 * i] for i in range(5)]))
    assert [s.name for s in got[RESULT][0].status] == ['lobe_1/spline', 'lobe_2/spline']
    assert got['/metrology/report'][0].data == '{"done": 10}'


def test_a_bags_scenes_are_read_once_for_the_check_and_the_replay(monkeypatch):
    """``analyze`` checks the bag's scenes before the replay (``bag_warnings``) and the
    replay takes the sample joint names from its first scene (``sample_joints_of``):
    each scene message is parsed once (it was parsed twice), and the report is the one
    of a fresh read of the scenes at every call."""
    from pathlib import Path

    from cam_metrology.offline.analyze import analyze_report
    from cam_metrology.report.golden import golden_of
    from cam_metrology.scene import recorded

    bag = Path(__file__).resolve().parent.parent / 'bags' / 'default_clean'
    scenes = sum(1 for _ in bagio.iter_messages(bag, [recorded.SCENE_TOPIC]))
    assert scenes >= 1
    parsed = []
    real = recorded.parse_scene

    def counting(*args, **kwargs):
        parsed.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(recorded, 'parse_scene', counting)
    recorded._LAST.clear()
    once = golden_of(analyze_report(str(bag), None))
    assert len(parsed) == scenes
    # the same report with the scenes read afresh at every call
    monkeypatch.setattr(recorded, 'bag_scenes', recorded._read_scenes)
    fresh = golden_of(analyze_report(str(bag), None))
    assert len(parsed) == 3 * scenes
    assert once == fresh
