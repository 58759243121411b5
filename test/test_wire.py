"""The wire contract (``cam_metrology.wire``): codecs against the rosbags typestore,
layouts round trip, one QoS per topic whoever writes the bag, the plot views, and the
shipped Foxglove and PlotJuggler layouts against a bag written by ``simulate`` +
``analyze --out-bag`` (the writer the live recorder uses too). No rclpy here."""
from __future__ import annotations

import json
import math
import re
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from cam_design.errors import InputError
from cam_metrology.cores.outputs import OK, WARN, Status, StatusOutput, TableOutput, TextOutput
from cam_metrology.wire import cdr, layouts, plots, topics

REPO = Path(__file__).resolve().parent.parent
CLI = 'import sys; from cam_metrology.cli import main; sys.exit(main(sys.argv[1:]))'


def _typestore_cdr(msgtype: str, **fields: object) -> bytes:
    store = cdr.typestore()
    return bytes(store.serialize_cdr(store.types[msgtype](**fields), msgtype))


def _header(stamp_ns: int, frame_id: str) -> object:
    store = cdr.typestore()
    sec, nanosec = divmod(stamp_ns, 1_000_000_000)
    return store.types['std_msgs/msg/Header'](
        stamp=store.types['builtin_interfaces/msg/Time'](sec=sec, nanosec=nanosec),
        frame_id=frame_id)


@pytest.mark.parametrize('text', ['', 'a', 'abc', 'abcd', 'lobe_1 \u00b5m'])
def test_string_fast_path_equals_typestore(text: str) -> None:
    assert cdr.encode_string(text) == _typestore_cdr('std_msgs/msg/String', data=text)


@pytest.mark.parametrize('frame_id,names,positions', [
    ('lobe_1', ('camshaft', 'probe'), (1.25, -3e-4)),
    ('dowel_pin', ('table_z', 'probe', 'camshaft'), (0.1, 0.2, 0.3)),
    ('l', ('a',), ()),
    ('', (), ()),
])
def test_joint_state_fast_path_equals_typestore(frame_id: str, names: tuple[str, ...],
                                                positions: tuple[float, ...]) -> None:
    stamp = 1_767_225_600_123_456_789
    want = _typestore_cdr('sensor_msgs/msg/JointState', header=_header(stamp, frame_id),
                          name=list(names), position=np.array(positions, dtype=float),
                          velocity=np.array([], dtype=float), effort=np.array([], dtype=float))
    assert cdr.encode_joint_state_positions(frame_id, stamp, names, positions) == want


def test_vectorised_encoders_equal_one_by_one() -> None:
    rng = np.random.default_rng(3)
    stamps = 1_700_000_000_000_000_000 + np.arange(7) * 999_999_937
    theta, s = rng.normal(size=7), rng.normal(size=7) * 1e-3
    many = cdr.encode_joint_states('lobe_2', stamps, theta, s)
    assert many == [cdr.encode_joint_state('lobe_2', int(t), float(a), float(b))
                    for t, a, b in zip(stamps, theta, s)]
    names = ('lobe_2/alpha_deg', 'lobe_2/lift_mm', 'lobe_2/x')
    rows = rng.normal(size=(5, 3))
    got = cdr.encode_named_values('lobe_2', stamps[:5], names, rows)
    assert got == [cdr.encode_joint_state_positions('lobe_2', int(t), names, r)
                   for t, r in zip(stamps[:5], rows)]


@pytest.mark.parametrize('rows,columns', [(0, ('a',)), (1, ('alpha_rad', 'lift_m')),
                                          (7, ('alpha_rad', 'lift_m', 'design_lift_m'))])
def test_table_layout_equals_typestore_and_round_trips(rows: int, columns: tuple[str, ...]
                                                       ) -> None:
    data = np.arange(rows * len(columns), dtype=float).reshape(rows, len(columns)) / 7.0
    got = layouts.encode_table('lobe_3/spline', columns, data)
    store = cdr.typestore()
    dim = store.types['std_msgs/msg/MultiArrayDimension']
    want = _typestore_cdr(
        'std_msgs/msg/Float64MultiArray',
        layout=store.types['std_msgs/msg/MultiArrayLayout'](
            dim=[dim(label='lobe_3/spline', size=rows, stride=rows * len(columns)),
                 dim(label=','.join(columns), size=len(columns), stride=len(columns))],
            data_offset=0),
        data=data.reshape(-1))
    assert got == want
    label, cols, back = layouts.table_from_msg(cdr.decode(got, topics.TABLE))
    assert (label, cols) == ('lobe_3/spline', columns)
    assert np.array_equal(back, data)


def test_table_decoder_names_the_label_on_bad_layouts() -> None:
    dim = SimpleNamespace
    msg = SimpleNamespace(layout=SimpleNamespace(
        dim=[dim(label='lobe_1', size=3, stride=6), dim(label='a,b', size=2, stride=2)],
        data_offset=0), data=[1.0] * 5)
    with pytest.raises(InputError, match='lobe_1.data'):
        layouts.table_from_msg(msg)
    msg.layout.dim = msg.layout.dim[:1]
    with pytest.raises(InputError, match='layout.dim'):
        layouts.table_from_msg(msg)
    with pytest.raises(InputError, match='lobe_1.data'):
        layouts.encode_table('lobe_1', ('a', 'b'), np.zeros((3, 3)))


def test_statuses_round_trip() -> None:
    sts = (Status('lobe_1', OK, 'ok', {'angle_deg': '36.7756'}, 'bench'),
           Status('skipped/pin', WARN, 'no pin'))
    msg = cdr.decode(layouts.encode_statuses(sts, 1_700_000_000_500_000_000), topics.STATUS)
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == (1_700_000_000, 500_000_000)
    assert layouts.statuses_from_msg(msg) == [
        {'name': 'lobe_1', 'level': OK, 'message': 'ok', 'hardware_id': 'bench',
         'values': {'angle_deg': '36.7756'}},
        {'name': 'skipped/pin', 'level': WARN, 'message': 'no pin', 'hardware_id': '',
         'values': {}}]


def test_topic_table_is_consistent() -> None:
    # a latched topic keeps one message; a sample stream is never latched
    assert topics.LATCHED_TOPICS == {topics.SCENE, topics.TRUTH, topics.METROLOGY_REPORT}
    assert topics.qos_of(topics.JOINT_STATES).keep_all
    assert not topics.qos_of(topics.JOINT_STATES).transient_local
    # every output and plot topic is offered transient local (late joiners)
    for topic in topics.OUTPUT_TOPICS + topics.PLOT_TOPICS + (topics.DIAGNOSTICS,):
        assert topics.qos_of(topic).transient_local, topic
    # a curve burst (MAX_POINTS per curve, a few curves per feature) fits the history
    assert topics.PLOT_POINTS.depth >= 8 * plots.MAX_POINTS
    assert set(topics.OUTPUT_TOPICS) == set(plots.CURVE_TOPICS) | set(plots.STATUS_NODES) | {
        topics.METROLOGY_REPORT}


@pytest.fixture(scope='module')
def demo_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``cam-bench simulate`` of the default (demo) scene, then ``analyze --out-bag``:
    the bench topics, every output and every plot view, through the bag writer."""
    tmp = tmp_path_factory.mktemp('wire')
    sim, out = tmp / 'sim', tmp / 'analysed'
    for args in (['simulate', str(sim), '--samples-per-rev', '1800', '--noise-um', '0.5',
                  '--seed', '11', '--quiet'],
                 ['analyze', str(sim), '--out-bag', str(out)]):
        done = subprocess.run([sys.executable, '-c', CLI, *args], capture_output=True,
                              text=True, timeout=300)
        assert done.returncode == 0, done.stdout + done.stderr
    return out


def test_every_topic_has_one_qos_whoever_writes_the_bag(demo_bag: Path,
                                                        tmp_path: Path) -> None:
    from cam_metrology import bagio

    # the bag writer's default for each topic of the table
    plain = tmp_path / 'plain'
    with bagio.BagWriter(plain) as w:
        for topic, (msgtype, _) in topics.TOPICS.items():
            w.add_topic(topic, msgtype)
    written = bagio.topic_qos_yaml(plain)
    # simulate (the input bag of demo_bag) and analyze --out-bag (outputs, plot views)
    analysed = bagio.topic_qos_yaml(demo_bag)
    simulated = bagio.topic_qos_yaml(demo_bag.parent / 'sim')
    # a bag holds one form of the sample stream: here one sample per message, so not
    # the blocks topic (/bench/joint_trajectory, test_blocks.py); the rig's own graph is
    # not in a bench analysis (test_ros_rig.py records it)
    unused = {topics.JOINT_TRAJECTORY}
    assert set(analysed) >= set(topics.TOPICS) - unused - set(topics.RIG_GRAPH)
    for topic in set(topics.TOPICS) - unused:
        want = topics.qos_of(topic).bag_yaml()
        assert written[topic] == want, topic
        if topic not in topics.RIG_GRAPH:
            assert analysed[topic] == want, topic
        if topic in simulated:
            assert simulated[topic] == want, topic
    assert set(simulated) == set(topics.BENCH_TOPICS) - unused
    # the depth of /bench/joint_states that the committed fixture bags store
    assert bagio.topic_qos_yaml(REPO / 'bags' / 'default_clean')[topics.JOINT_STATES] == \
        topics.qos_of(topics.JOINT_STATES).bag_yaml()
    assert 'depth: 1000' in written[topics.JOINT_STATES]


def test_bags_are_zstd_by_default_and_plain_ones_read_too(demo_bag: Path) -> None:
    from cam_metrology import bagio
    from cam_metrology.bagio.check import mcap_files

    def compressions(bag: Path) -> set[str]:
        from mcap.reader import make_reader
        with open(mcap_files(bag)[0], 'rb') as f:
            summary = make_reader(f).get_summary()
        return {c.compression for c in summary.chunk_indexes}

    assert compressions(demo_bag) == {'zstd'}
    assert compressions(demo_bag.parent / 'sim') == {'zstd'}
    plain = REPO / 'bags' / 'no_pin_no_valve_train'
    assert compressions(plain) == {''}
    assert len(bagio.read_joint_states(plain)) > 0


def _bag_messages(bag: Path, topic: str) -> list[object]:
    from cam_metrology import bagio
    return [m.msg for m in bagio.iter_messages(bag, [topic])]


def test_curves_are_plot_ready_and_equal_the_tables(demo_bag: Path) -> None:
    lift = {}
    for msg in _bag_messages(demo_bag, topics.METROLOGY_LIFT):
        label, cols, data = layouts.table_from_msg(msg)
        lift[label] = dict(zip(cols, data.T))
    points: dict[str, list[dict[str, float]]] = {}
    for msg in _bag_messages(demo_bag, topics.PLOT_LIFT):
        frame, values = layouts.values_from_msg(msg)
        points.setdefault(frame, []).append(values)
    assert set(points) == set(lift)
    for frame, rows in points.items():
        assert 10 < len(rows) <= plots.MAX_POINTS
        alpha = np.array([r[f'{frame}/alpha_deg'] for r in rows])
        assert np.all(np.diff(alpha) >= 0)          # a curve against angle, in angle order
        err = np.array([r[f'{frame}/lift_error_um'] for r in rows])
        lift_mm = np.array([r[f'{frame}/lift_mm'] for r in rows])
        design = np.array([r[f'{frame}/design_lift_mm'] for r in rows])
        assert np.allclose(err, (lift_mm - design) * 1e3, rtol=0, atol=1e-9)
        # every point is a row of the table, in the units of the names
        table_alpha = np.degrees(lift[frame]['alpha_rad'])
        k = np.searchsorted(np.sort(table_alpha), alpha)
        assert np.allclose(np.sort(table_alpha)[np.clip(k, 0, len(table_alpha) - 1)], alpha,
                           rtol=0, atol=1e-9)
    # a JointState's arrays stay far below PlotJuggler's default array clamp (500): a
    # curve's handful of columns, the values' fixed layout
    for topic, most in ((topics.PLOT_LIFT, 16), (topics.PLOT_PROFILE, 16),
                        (topics.PLOT_MOTION, 16), (topics.METROLOGY_VALUES, 64)):
        assert all(len(m.position) <= most for m in _bag_messages(demo_bag, topic)), topic


def test_values_and_diagnostics_repeat_the_report(demo_bag: Path) -> None:
    report = json.loads(_bag_messages(demo_bag, topics.METROLOGY_REPORT)[-1].data)
    values = dict(layouts.values_from_msg(m) for m in
                  _bag_messages(demo_bag, topics.METROLOGY_VALUES))
    assert set(values) == set(report['features']) | {'part'}
    for fid, feat in report['features'].items():
        got = values[fid]
        assert list(got) == [f'{fid}/{n}' for n in plots.VALUE_NAMES]
        assert got[f'{fid}/angle_deg'] == pytest.approx(feat['angle_deg'], abs=1e-12)
        assert got[f'{fid}/angle_std_arcsec'] == pytest.approx(
            3600 * feat['angle_std_deg'], rel=1e-12)
        assert got[f'{fid}/ok'] == (1.0 if feat['status'] == 'ok' else 0.0)
        assert got[f'{fid}/partial'] == 0.0   # offline: nothing lost
        if 'phase_error_deg' in feat:
            assert got[f'{fid}/phase_error_deg'] == pytest.approx(feat['phase_error_deg'],
                                                                  abs=1e-12)
        else:
            assert math.isnan(got[f'{fid}/phase_error_deg'])
    # the demo scene's tolerances accept this simulated part: verdict 1 (pass)
    assert report['verdict']['result'] == 'pass' and values['part']['part/verdict'] == 1.0
    for fid, feat in report['features'].items():
        if feat.get('kind') == 'lobe':
            assert values[fid][f'{fid}/verdict'] == 1.0
    diag = [st for m in _bag_messages(demo_bag, topics.DIAGNOSTICS)
            for st in layouts.statuses_from_msg(m)]
    results = [st for m in _bag_messages(demo_bag, topics.METROLOGY_RESULT)
               for st in layouts.statuses_from_msg(m)]
    assert [f'metrology: {st["name"]}' for st in results] == [
        st['name'] for st in diag if st['name'].startswith('metrology: ')]
    assert any(st['name'].startswith('dynamics: ') for st in diag)


def test_plot_views_of_other_outputs_are_empty_or_exact() -> None:
    # a progress report (final: false) publishes no values: Foxglove's indices stay fixed
    assert plots.plot_messages(TextOutput(topics.METROLOGY_REPORT, '{"final": false}'), 5) == []
    assert plots.plot_messages(TextOutput(topics.METROLOGY_REPORT, 'not json'), 5) == []
    assert plots.plot_messages(TableOutput('/other', 'x', ('a',), np.zeros((2, 1))), 5) == []
    # a feature computed on partial data says so on /metrology/values too
    report = {'final': True, 'features': {'lobe_1': {
        'status': 'ok', 'angle_deg': 10.5, 'partial': True,
        'verdict': {'result': 'fail'}}}, 'verdict': {'result': 'fail'}}
    views = plots.plot_messages(TextOutput(topics.METROLOGY_REPORT, json.dumps(report)), 5)
    values = dict(layouts.values_from_msg(cdr.decode(v.cdr, topics.JOINT_STATE))
                  for v in views)
    assert values['lobe_1']['lobe_1/partial'] == 1.0
    assert values['lobe_1']['lobe_1/verdict'] == 0.0
    assert values['lobe_1']['lobe_1/angle_deg'] == 10.5
    assert math.isnan(values['lobe_1']['lobe_1/phase_deg'])
    assert {k: v for k, v in values['part'].items() if not math.isnan(v)} == {
        'part/verdict': 0.0, 'part/complete': 0.0}
    assert list(values['part']) == ['part/verdict', 'part/complete', 'part/straightness_um',
                                    'part/bow_um']
    # units: derivative per rad -> per deg; stress Pa -> MPa
    names, vals = plots.curve_columns(
        ('alpha_rad', 'velocity_m_per_rad', 'acceleration_m_per_rad2', 'contact_stress_pa'),
        np.array([[math.pi, 1.0, 1.0, 2e9]]))
    assert names == ['alpha_deg', 'velocity_mm_per_deg', 'acceleration_mm_per_deg2',
                     'contact_stress_mpa']
    assert np.allclose(vals, [[180.0, 1e3 * math.pi / 180, 1e3 * (math.pi / 180) ** 2, 2e3]],
                       rtol=1e-15)
    # a long table: at most MAX_POINTS points, stamped apart, first and last rows kept
    n = 3 * plots.MAX_POINTS + 1
    table = TableOutput(topics.METROLOGY_LIFT, 'lobe_9', ('alpha_rad', 'lift_m'),
                        np.column_stack([np.linspace(-1, 1, n), np.zeros(n)]))
    msgs = plots.plot_messages(table, 10**18)
    assert len(msgs) <= plots.MAX_POINTS
    stamps = [m.stamp_ns for m in msgs]
    assert stamps == sorted(set(stamps)) and stamps[0] == 10**18
    # the views a node publishes, for the publishers it creates at start
    assert plots.view_topics(topics.METROLOGY_REPORT) == {topics.METROLOGY_VALUES:
                                                          topics.JOINT_STATE}
    assert plots.view_topics(topics.METROLOGY_LIFT) == {topics.PLOT_LIFT: topics.JOINT_STATE}
    assert plots.view_topics(topics.DYNAMICS_RESULT) == {topics.DIAGNOSTICS: topics.STATUS}
    assert plots.view_topics(topics.SCENE) == {}
    status = StatusOutput(topics.DYNAMICS_RESULT, (Status('lobe_1/3000rpm', OK, 'ok'),), 7)
    (diag,) = plots.plot_messages(status, 9)
    msg = cdr.decode(diag.cdr, topics.STATUS)
    assert diag.topic == topics.DIAGNOSTICS and msg.status[0].name == 'dynamics: lobe_1/3000rpm'
    assert msg.header.stamp.nanosec == 7


# ---------------------------------------------------------------------------- layouts

_FOXGLOVE_PATH = re.compile(r'^(/[\w/]+)(?:\{header\.frame_id=="([^"]+)"\})?\.position\[(\d+)\]$')


def _joint_state_names(bag: Path) -> dict[str, dict[str, list[str]]]:
    """topic -> frame_id -> names, for every JointState topic of the bag but samples."""
    from cam_metrology import bagio
    out: dict[str, dict[str, list[str]]] = {}
    for topic, (msgtype, _) in bagio.bag_topics(bag).items():
        if msgtype == topics.JOINT_STATE and topic != topics.JOINT_STATES:
            for msg in _bag_messages(bag, topic):
                out.setdefault(topic, {}).setdefault(msg.header.frame_id, list(msg.name))
    return out


def test_foxglove_layout_names_only_what_the_demo_bag_has(demo_bag: Path) -> None:
    from cam_metrology import bagio

    doc = json.loads((REPO / 'layouts' / 'foxglove_cam_bench.json').read_text())
    assert set(doc) >= {'configById', 'layout'}
    names = _joint_state_names(demo_bag)
    in_bag = bagio.bag_topics(demo_bag)
    checked = 0
    for panel, cfg in doc['configById'].items():
        if panel.startswith('DiagnosticSummary!'):
            assert cfg['topicToRender'] in in_bag
            continue
        assert panel.startswith('Plot!'), panel
        series = [p for p in cfg['paths']]
        if cfg['xAxisVal'] == 'custom':
            series.append(cfg['xAxisPath'])
        for path in series:
            m = _FOXGLOVE_PATH.match(path['value'])
            assert m, path['value']
            topic, frame, index = m.group(1), m.group(2), int(m.group(3))
            assert topic in names, topic
            assert frame in names[topic], (topic, frame)
            # the label says which quantity the index is: the bag agrees
            assert names[topic][frame][index] == path['label'], path
            checked += 1
        if cfg['xAxisVal'] == 'custom':   # x and y from the same messages (one frame)
            frames = {_FOXGLOVE_PATH.match(p['value']).group(2) for p in series}
            assert len(frames) == 1, panel
    assert checked >= 10
    titles = ' '.join(c.get('foxglovePanelTitle', '') for c in doc['configById'].values())
    for what in ('Nose', 'lift error', 'acceleration', 'valve lift'):
        assert what in titles


def test_plotjuggler_layout_names_only_what_the_demo_bag_has(demo_bag: Path) -> None:
    root = ET.parse(REPO / 'layouts' / 'plotjuggler_cam_bench.xml').getroot()
    # PlotJuggler's ROS 2 JointState parser: one series <topic>/<name>/position
    series = {f'{topic}/{name}/position' for topic, frames in
              _joint_state_names(demo_bag).items() for ns in frames.values() for name in ns}
    plots_ = root.findall('.//plot')
    assert len(plots_) == 4
    modes = []
    for plot in plots_:
        modes.append(plot.get('mode'))
        curves = plot.findall('curve')
        assert curves
        for curve in curves:
            if plot.get('mode') == 'XYPlot':
                assert curve.get('curve_x') in series, curve.get('curve_x')
                assert curve.get('curve_y') in series, curve.get('curve_y')
                assert curve.get('curve_x').endswith('/alpha_deg/position')
            else:
                assert curve.get('name') in series, curve.get('name')
    assert modes.count('XYPlot') == 3
    text = ET.tostring(root, encoding='unicode')
    for what in ('angle_deg', 'lift_error_um', 'acceleration_mm_per_deg2', 'valve_lift_mm'):
        assert what in text


def test_values_carry_form_journal_track_and_shaft_numbers() -> None:
    """/metrology/values through the pure function: each form number of a feature under
    its name, its verdict 1 pass / 0 fail (a failed zone fails the quantity) / NaN not
    judged; a lobe measured on tracks only gets a record with its taper and twist; the
    part record the shaft's straightness and bow; the earlier indices unchanged."""
    assert plots.VALUE_NAMES[:11] == (
        'angle_deg', 'angle_std_arcsec', 'phase_deg', 'phase_error_deg', 'asymmetry_deg',
        'lift_error_max_plus_um', 'lift_error_max_minus_um', 'lift_error_rms_um', 'ok',
        'verdict', 'partial')
    checks = [{'quantity': 'roundness_um', 'result': 'pass'},
              {'quantity': 'velocity_error_mm_per_rad', 'result': 'pass'},
              {'quantity': 'velocity_error_mm_per_rad[-60..-30 deg]', 'result': 'fail'},
              {'quantity': 'acceleration_error_mm_per_rad2[-60..-30 deg]', 'result': 'pass'}]
    report = {'final': True, 'complete': True, 'verdict': {'result': 'fail'},
              'shaft': {'straightness_um': 10.5, 'bow_um': 5.25},
              'lobe_tracks': {'lobe_2': {'taper_um_per_mm': 2.5,
                                         'nose_angle_difference_deg': 0.1,
                                         'verdict': {'checks': [
                                             {'quantity': 'taper_um_per_mm',
                                              'result': 'fail'}]}}},
              'features': {
                  'lobe_1': {'status': 'ok', 'roundness_um': 1.25,
                             'harmonics': [{'upr': 37, 'amplitude_um': 0.75, 'phase_deg': 3}],
                             'waviness': {'max_amplitude_um': 0.75, 'upr_at_max': 37},
                             'velocity_error_mm_per_rad': {'max_abs': 0.125, 'at_deg': -40},
                             'acceleration_error_mm_per_rad2': {'max_abs': 2.5},
                             'verdict': {'result': 'fail', 'checks': checks}},
                  'journal_1': {'status': 'ok', 'kind': 'journal', 'runout_um': 20.0,
                                'runout_direction_deg': 30.5,
                                'diameter_deviation_um': -1.5, 'verdict': {'checks': [
                                    {'quantity': 'runout_um', 'result': 'fail'},
                                    {'quantity': 'diameter_deviation_um', 'result': 'pass'}]}},
                  'lobe_2@-5': {'status': 'ok', 'nose_lift_error_um': -12.5}}}
    views = plots.plot_messages(TextOutput(topics.METROLOGY_REPORT, json.dumps(report)), 5)
    values = dict(layouts.values_from_msg(cdr.decode(v.cdr, topics.JOINT_STATE))
                  for v in views)
    assert set(values) == {'lobe_1', 'journal_1', 'lobe_2@-5', 'lobe_2', 'part'}
    lobe = {k.split('/', 1)[1]: v for k, v in values['lobe_1'].items()}
    assert list(lobe) == list(plots.VALUE_NAMES)
    assert {k: lobe[k] for k in ('harmonic_max_upr', 'harmonic_max_amplitude_um',
                                 'roundness_um', 'waviness_max_amplitude_um',
                                 'waviness_upr_at_max', 'velocity_error_max_mm_per_rad',
                                 'acceleration_error_max_mm_per_rad2',
                                 'roundness_um_verdict', 'velocity_error_max_mm_per_rad_verdict',
                                 'acceleration_error_max_mm_per_rad2_verdict')} == {
        'harmonic_max_upr': 37.0, 'harmonic_max_amplitude_um': 0.75, 'roundness_um': 1.25,
        'waviness_max_amplitude_um': 0.75, 'waviness_upr_at_max': 37.0,
        'velocity_error_max_mm_per_rad': 0.125, 'acceleration_error_max_mm_per_rad2': 2.5,
        'roundness_um_verdict': 1.0, 'velocity_error_max_mm_per_rad_verdict': 0.0,
        'acceleration_error_max_mm_per_rad2_verdict': 1.0}
    assert math.isnan(lobe['waviness_max_amplitude_um_verdict'])   # not judged
    assert math.isnan(lobe['runout_um']) and math.isnan(lobe['taper_um_per_mm'])
    journal = {k.split('/', 1)[1]: v for k, v in values['journal_1'].items()}
    assert (journal['runout_um'], journal['runout_um_verdict'], journal['runout_direction_deg'],
            journal['diameter_deviation_um'], journal['diameter_deviation_um_verdict']) == \
        (20.0, 0.0, 30.5, -1.5, 1.0)
    assert values['lobe_2@-5']['lobe_2@-5/nose_lift_error_um'] == -12.5
    tracks = {k.split('/', 1)[1]: v for k, v in values['lobe_2'].items()}
    assert (tracks['taper_um_per_mm'], tracks['taper_um_per_mm_verdict'],
            tracks['nose_angle_difference_deg']) == (2.5, 0.0, 0.1)
    assert math.isnan(tracks['nose_angle_difference_deg_verdict'])
    assert math.isnan(tracks['ok'])   # no entry of its own: not measured as a whole
    assert values['part'] == {'part/verdict': 0.0, 'part/complete': 1.0,
                              'part/straightness_um': 10.5, 'part/bow_um': 5.25}
