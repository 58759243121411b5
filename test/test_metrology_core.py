"""MetrologyCore end to end without ROS: message and bulk paths, feature segmentation,
input irregularities, failures, skipped items, phases and the report schema."""
from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pytest

from cam_design.dowel_pin import DowelPinGeometry
from cam_design.errors import InputError
from cam_metrology.bagio import LightJointState
from cam_metrology.metrology.core import LIFT, REPORT, RESULT, MetrologyCore
from cam_metrology.metrology.synthetic import PolynomialRampCam, sample_lobe, sample_pin
from cam_metrology.cores.outputs import ERROR, OK, StatusOutput, TableOutput, TextOutput
from cam_metrology.scene.parse import parse_scene

CAM = PolynomialRampCam(rise=7e-3, half_angle=np.radians(55))
PIN = DowelPinGeometry(2.5e-3, 11.5e-3, 2.0e-3)
PIN_ANGLE = np.radians(3 / 60 + 44 / 3600)
NOSES = {'lobe_1': np.radians(37.0) + PIN_ANGLE, 'lobe_2': np.radians(147.0) + PIN_ANGLE,
         'lobe_3': np.radians(250.0)}


def scene_text(pin: bool = True, compute: str | None = None, direction: int = 1) -> str:
    """Three lobes with a tabulated design lift (flat follower, flat probe)."""
    a = np.radians(np.arange(-86.0, 86.0001, 0.25))
    table = {'alpha': a.tolist(), 'h': np.clip(CAM(a), 0.0, None).tolist()}
    lobes = []
    for i, fid in enumerate(NOSES, 1):
        phase = float(np.radians(37.0 + 110 * (i - 1)))
        nominal = f'    nominal_phase: {phase!r}\n' if i < 3 else ''
        lobes.append(f'  - id: {fid}\n{nominal}    follower: flat\n'
                     f'    lift: {json.dumps(table)}\n')
    text = (f'camshaft_id: test-cam-7\ndirection: {direction}\n'
            'probe: {kind: flat}\nbase_circle_radius: 0.02\nidle_timeout: 0.5\n'
            'lobes:\n' + ''.join(lobes))
    if pin:
        text += ('dowel_pin: {pin_radius: 0.0025, circle_radius: 0.0115, '
                 'probe_radius: 0.002}\n')
    if compute:
        text += f'compute: {compute}\n'
    return text


def string(text: str) -> SimpleNamespace:
    return SimpleNamespace(data=text)


def feature_arrays(fid: str, law, t0_ns: int, direction: int = 1, **kw):
    """(frame_ids, stamps, theta, s) of one feature, stamps from t0_ns at 1 kHz."""
    if fid == 'dowel_pin':
        smp = sample_pin(PIN, PIN_ANGLE, n_per_rev=3600, zero=-0.003, **kw)
    else:
        smp = sample_lobe(law, NOSES.get(fid, 1.0), direction, n_per_rev=3600, zero=0.001, **kw)
    return [fid] * smp.theta.size, smp.stamp_ns + t0_ns, smp.theta.copy(), smp.s.copy()


def collect(outputs):
    res = {'status': [], 'table': [], 'report': []}
    for out in outputs:
        if isinstance(out, StatusOutput):
            assert out.topic == RESULT
            res['status'] += list(out.statuses)
        elif isinstance(out, TableOutput):
            assert out.topic == LIFT
            res['table'].append(out)
        elif isinstance(out, TextOutput):
            assert out.topic == REPORT
            res['report'].append(json.loads(out.text))
    return res


def law_of(scene, fid):
    return scene.lobe(fid if fid in NOSES else 'lobe_1').lift


def run_bulk(text: str, features=('lobe_1', 'lobe_2', 'lobe_3', 'dowel_pin'), mutate=None,
             params=None, direction=1):
    scene = parse_scene(text)
    core = MetrologyCore(params)
    outs = core.handle('/bench/scene', string(text), 0)
    t0 = 0
    for fid in features:
        ids, st, th, s = feature_arrays(fid, None if fid == 'dowel_pin' else law_of(scene, fid),
                                        t0, direction)
        if mutate and fid in mutate:
            ids, st, th, s = mutate[fid](ids, st, th, s)
        outs += core.handle_samples(ids, st, th, s)
        t0 = int(st.max()) + 1_000_000
    outs += core.finish()
    return core, collect(outs)


def test_report_schema_and_phases():
    core, out = run_bulk(scene_text())
    report = out['report'][-1]
    assert report['camshaft_id'] == 'test-cam-7'
    assert set(report['features']) == {'lobe_1', 'lobe_2', 'lobe_3', 'dowel_pin'}
    for fid in ('lobe_1', 'lobe_2', 'lobe_3'):
        f = report['features'][fid]
        for key in ('kind', 'angle_deg', 'angle_std_deg', 'phase_deg', 'phase_error_deg',
                    'asymmetry_deg', 'sensitive_point_angle_deg', 'lift_error_um'):
            assert key in f, key
        assert f['kind'] == 'lobe' and f['status'] == 'ok'
        assert 0.0 <= f['angle_deg'] < 360.0
        assert (f['angle_deg'] - np.degrees(NOSES[fid])) * 3600 == pytest.approx(0, abs=0.01)
    pin = report['features']['dowel_pin']
    assert pin['kind'] == 'dowel_pin'
    assert (pin['angle_deg'] - np.degrees(PIN_ANGLE)) * 3600 == pytest.approx(0, abs=0.01)
    f1, f2, f3 = (report['features'][k] for k in ('lobe_1', 'lobe_2', 'lobe_3'))
    assert f1['phase_deg'] == pytest.approx(37.0, abs=1e-6)
    assert f1['phase_error_deg'] == pytest.approx(0.0, abs=1e-6)
    assert f2['phase_deg'] == pytest.approx(147.0, abs=1e-6)
    assert f2['phase_error_deg'] == pytest.approx(0.0, abs=1e-6)
    # phase wrapped to (-180, 180]: 250 - 0.0622 deg
    assert f3['phase_deg'] == pytest.approx(250.0 - np.degrees(PIN_ANGLE) - 360.0, abs=1e-6)
    assert f3['phase_error_deg'] is None
    assert {'what': 'phase_error/lobe_3', 'why': 'lobe has no nominal_phase'} in report['skipped']
    assert report['complete'] is True
    # one report when complete, one at finish
    assert len(out['report']) == 2
    assert [t.label for t in out['table']] == ['lobe_1', 'lobe_2', 'lobe_3', 'dowel_pin']
    assert out['table'][0].columns == ('alpha_rad', 'lift_m', 'design_lift_m')
    json.dumps(report)   # plain JSON types only


def test_message_path_equals_bulk_path_and_feature_done():
    text = scene_text(pin=False)
    scene = parse_scene(text)
    core = MetrologyCore()
    outs = core.handle('/bench/scene', string(text), 0)
    t0 = 0
    for fid in ('lobe_1', 'lobe_2'):
        ids, st, th, s = feature_arrays(fid, law_of(scene, fid), t0)
        for k in range(len(ids)):
            outs += core.handle('/bench/joint_states',
                                LightJointState(fid, int(st[k]), float(th[k]), float(s[k])),
                                int(st[k]))
        done = core.handle('/bench/feature_done', string(fid), int(st[-1]))
        assert [st_.name for o in done if isinstance(o, StatusOutput)
                for st_ in o.statuses][0] == fid   # published at feature_done
        outs += done
        t0 = int(st[-1]) + 1_000_000
    msg = collect(outs + core.finish())['report'][-1]
    _, bulk = run_bulk(text, features=('lobe_1', 'lobe_2'))
    ref = bulk['report'][-1]
    for fid in ('lobe_1', 'lobe_2'):
        assert msg['features'][fid]['angle_deg'] == ref['features'][fid]['angle_deg']
    skipped = {s['what']: s['why'] for s in msg['skipped']}
    assert skipped['pin'] == 'scene has no dowel_pin'
    assert 'phase' in skipped and 'lobe_3' in skipped


def _shuffle_dup_nan(ids, st, th, s):
    rng = np.random.default_rng(5)
    order = rng.permutation(len(ids))
    dup = rng.choice(len(ids), 50, replace=False)
    order = np.concatenate([order, dup])
    th, s, st = th[order].copy(), s[order].copy(), st[order].copy()
    free = np.flatnonzero(~np.isin(order, dup))[:10]   # NaN on samples never duplicated
    s[free[:7]] = np.nan
    th[free[7:]] = np.nan
    return [ids[0]] * order.size, st, th, s


def _drop_fall_flank(ids, st, th, s):
    alpha = np.angle(np.exp(1j * (th - NOSES['lobe_3'])))
    keep = ~((alpha > 0.2) & (alpha < 1.3))
    return [ids[0]] * int(keep.sum()), st[keep], th[keep], s[keep]


def test_irregular_inputs_and_failed_flank():
    _, out = run_bulk(scene_text(), mutate={'lobe_2': _shuffle_dup_nan,
                                            'lobe_3': _drop_fall_flank})
    rep = out['report'][-1]['features']
    f2 = rep['lobe_2']
    assert f2['status'] == 'ok'
    assert (f2['angle_deg'] - np.degrees(NOSES['lobe_2'])) * 3600 == pytest.approx(0, abs=0.01)
    assert f2['samples_nan_dropped'] == 10
    assert f2['samples_duplicate_dropped'] == 50
    assert f2['samples_used'] == 3600 - 10
    f3 = rep['lobe_3']
    assert f3['status'] == 'failed' and 'fall flank' in f3['reason']
    assert f3['angle_deg'] is None
    errors = [s for s in out['status'] if s.name == 'lobe_3']
    assert errors and errors[0].level == ERROR and 'fall flank' in errors[0].message
    assert all(s.level == OK for s in out['status'] if s.name in ('lobe_1', 'lobe_2'))
    assert rep['lobe_1']['status'] == 'ok' and rep['dowel_pin']['status'] == 'ok'


def test_direction_minus_one():
    text = scene_text(pin=False, direction=-1)
    _, out = run_bulk(text, features=('lobe_1', 'lobe_2', 'lobe_3'), direction=-1)
    rep = out['report'][-1]['features']
    for fid in NOSES:
        assert (rep[fid]['angle_deg'] - np.degrees(NOSES[fid])) * 3600 == pytest.approx(
            0, abs=0.01)


def test_idle_timeout_ends_feature_and_samples_before_scene_wait():
    text = scene_text(pin=False)
    scene = parse_scene(text)
    core = MetrologyCore({'idle_timeout': 0.2})
    ids, st, th, s = feature_arrays('lobe_1', law_of(scene, 'lobe_1'), 0)
    assert core.handle_samples(ids, st, th, s, rx_ns=int(st[-1])) == []
    assert core.tick(int(st[-1]) + 100_000_000) == []
    assert core.tick(int(st[-1]) + 300_000_000) == []          # ended, but no scene yet
    out = collect(core.handle('/bench/scene', string(text), int(st[-1])))
    assert [s_.name for s_ in out['status']] == ['lobe_1']


def test_compute_restricts_and_unknown_feature_fails():
    text = scene_text(compute='[nose]')
    _, out = run_bulk(text, features=('lobe_1', 'lobe_9', 'dowel_pin'))
    rep = out['report'][-1]
    skipped = {s['what']: s['why'] for s in rep['skipped']}
    assert skipped['pin'] == 'compute does not ask for pin'
    assert skipped['asymmetry'] == 'compute does not ask for asymmetry'
    assert rep['features']['lobe_1']['asymmetry_deg'] is None
    assert rep['features']['lobe_9']['status'] == 'failed'
    assert 'not in the scene' in rep['features']['lobe_9']['reason']
    assert rep['features']['dowel_pin']['status'] == 'skipped'


def test_bad_parameters_raise_input_error():
    with pytest.raises(InputError, match='metrology.no_such'):
        MetrologyCore({'no_such': 1})
    with pytest.raises(InputError, match='metrology.min_flank_samples'):
        MetrologyCore({'min_flank_samples': -3})


def test_joint_state_without_the_joints_counts_as_nan_sample():
    text = scene_text(pin=False)
    core = MetrologyCore()
    core.handle('/bench/scene', string(text), 0)
    msg = SimpleNamespace(name=['a', 'b'], position=[0.0, 0.0],
                          header=SimpleNamespace(frame_id='lobe_1',
                                                 stamp=SimpleNamespace(sec=0, nanosec=5)))
    assert core.handle('/bench/joint_states', msg, 0) == []
    rep = collect(core.finish())['report'][-1]['features']['lobe_1']
    assert rep['status'] == 'failed' and rep['samples_nan_dropped'] == 1
    assert '0 valid samples' in rep['reason']


def test_invalid_scene_is_reported():
    core = MetrologyCore()
    out = collect(core.handle('/bench/scene', string('direction: 3'), 0))
    assert out['status'][0].level == ERROR and 'invalid scene' in out['status'][0].message


def test_default_scene_roller_probe_flat_design():
    """The embedded default scene (flat-tappet lobes, 12.5 mm roller probe)."""
    from cam_metrology.metrology.analysis import seen_lift
    from cam_metrology.host.paths import default_scene_path
    try:
        scene = parse_scene(default_scene_path().read_text())
    except (InputError, FileNotFoundError) as exc:
        pytest.skip(f'default scene not usable yet: {exc}')
    core = MetrologyCore()
    outs = core.handle('/bench/scene', string(scene.text), 0)
    truth = {}
    for i, lobe in enumerate(scene.lobes):
        seen = seen_lift(lobe, scene.probe, scene.base_circle_radius)
        truth[lobe.id] = np.radians(20.0 + 90 * i)
        smp = sample_lobe(seen, truth[lobe.id], 1, n_per_rev=3600, zero=0.01)
        outs += core.handle_samples([lobe.id] * smp.theta.size, smp.stamp_ns, smp.theta, smp.s)
    rep = collect(outs + core.finish())['report'][-1]['features']
    for fid, nose in truth.items():
        assert rep[fid]['status'] == 'ok', rep[fid]
        assert (rep[fid]['angle_deg'] - np.degrees(nose)) * 3600 == pytest.approx(0, abs=0.01)
        assert (rep[fid]['sensitive_point_angle_deg'] - np.degrees(nose)) * 3600 == \
            pytest.approx(0, abs=0.01)


def test_config_file_matches_parameters(config_dir):
    """config/metrology.yaml sets every parameter to its documented default."""
    from cam_metrology.cli.analyze import load_params
    params = load_params(str(config_dir / 'metrology.yaml'))['metrology']
    assert set(params) == set(MetrologyCore.PARAMETERS)
    for name, (default, _) in MetrologyCore.PARAMETERS.items():
        assert params[name] == default and type(params[name]) is type(default), name
    MetrologyCore(params)


def test_result_status_values_are_flat_strings():
    _, out = run_bulk(scene_text())
    lobe = next(s for s in out['status'] if s.name == 'lobe_1')
    assert lobe.hardware_id == 'lobe' and lobe.level == OK
    for key in ('angle_deg', 'angle_std_deg', 'sensitive_point_angle_deg', 'validity.valid',
                'lift_error_um.rms', 'samples_used'):
        assert isinstance(lobe.values[key], str), key
    assert float(lobe.values['angle_deg']) == pytest.approx(np.degrees(NOSES['lobe_1']),
                                                            abs=1e-6)
    pin = next(s for s in out['status'] if s.name == 'dowel_pin')
    assert pin.hardware_id == 'dowel_pin' and 'phase_deg' not in pin.values
    # lobes measured before the pin are published again after it, with their phase
    lobe1 = [s for s in out['status'] if s.name == 'lobe_1']
    assert len(lobe1) == 2 and 'phase_deg' not in lobe1[0].values
    assert float(lobe1[1].values['phase_deg']) == pytest.approx(37.0, abs=1e-6)


def test_parameter_type_message_grammar() -> None:
    """`expected an integer`, not `expected a int` (QA #21, metrology side)."""
    from cam_metrology.metrology.analysis import _typed
    with pytest.raises(InputError, match='expected an integer'):
        _typed('sp_pairs', 'x', int)
    with pytest.raises(InputError, match=r'expected a number >= 0 \(finite\)'):
        _typed('window', float('nan'), float)
