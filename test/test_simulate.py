"""The simulated bench: lifts, truth, angle conventions, determinism, bag output."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
import yaml

from cam_design.dowel_pin import DowelPinGeometry
from cam_design.errors import InputError
from cam_design.follower import Follower
from cam_metrology import bagio
from cam_metrology.scene.parse import load_scene, parse_scene
from cam_metrology.simulation.bench import (DOWEL_PIN, SimParams, iter_joint_state_messages,
                                            probe_lift, scene_with_direction, simulate,
                                            write_sim_bag)

DEG = math.pi / 180.0


def _asym_table() -> dict:
    """An asymmetric lobe: rise over 100 deg, fall over 80 deg, 3 mm (cos^4 flanks);
    radius of curvature > 4 mm on the 16.5 mm base circle (no undercut)."""
    a = np.linspace(-100 * DEG, 80 * DEG, 181)
    x = np.where(a < 0, a / (100 * DEG), a / (80 * DEG))
    h = 3e-3 * np.cos(0.5 * np.pi * x) ** 4
    h[0] = h[-1] = 0.0
    return {'alpha': a.tolist(), 'h': h.tolist()}


def _scene(probe=None, direction=1, pin=True, lobes=None) -> object:
    doc = {
        'camshaft_id': 'SIM-1', 'direction': direction,
        'probe': probe or {'kind': 'flat', 'radius': 0.0},
        'base_circle_radius': 0.0165,
        'lobes': lobes or [
            {'id': 'lobe_1', 'nominal_phase': 40 * DEG, 'lift': _asym_table()},
            {'id': 'lobe_2', 'nominal_phase': -100 * DEG, 'lift': _asym_table()},
        ],
    }
    if pin:
        doc['dowel_pin'] = {'pin_radius': 0.0025, 'circle_radius': 0.0115,
                            'probe_radius': 0.002, 'nominal_angle': 0.0}
    return parse_scene(yaml.safe_dump(doc))


def _alpha(theta, nose, direction):
    return (np.pi - np.mod(np.pi - direction * (theta - nose), 2 * np.pi))


# ------------------------------------------------------------------------- lifts

def test_noise_free_lobe_lift_is_the_design_lift_at_the_true_angle():
    scene = _scene()
    params = SimParams(samples_per_rev=7200, probe_zero_offset=-1.234e-3)
    run = simulate(scene, params)
    for feat in run.features[:2]:
        law = scene.lobe(feat.id).lift   # same follower: no conversion
        expected = -1.234e-3 + law(_alpha(feat.theta, feat.true_angle, 1))
        np.testing.assert_allclose(feat.s, expected, rtol=0, atol=1e-15)
        # the maximum is at alpha = 0 (the nose) within a sample (spline of the table)
        k = int(np.argmax(feat.s))
        assert abs(_alpha(feat.theta[k], feat.true_angle, 1)) <= 2 * np.pi / 7200


def test_lift_is_converted_to_a_roller_probe():
    scene = _scene(probe={'kind': 'roller', 'radius': 0.0125})
    run = simulate(scene, SimParams(samples_per_rev=3600))
    feat = run.features[0]
    law = probe_lift(scene, 'lobe_1')
    lobe = scene.lobe('lobe_1')
    from cam_design import follower as fol
    if hasattr(fol, 'convert_lift'):
        assert law is not lobe.lift
        ref = fol.convert_lift(lobe.lift, 0.0165, Follower('flat'), Follower('roller', 0.0125))
        a = _alpha(feat.theta, feat.true_angle, 1)
        np.testing.assert_allclose(feat.s - 5e-4, ref(a), atol=1e-12)
        assert run.truth['features']['lobe_1']['lift_conversion'] == 'flat -> roller'
        # a roller sees the same lift on the base circle and at the nose of a convex cam
        assert float(np.max(feat.s - 5e-4)) == pytest.approx(lobe.lift.max_lift(), abs=2e-6)
        # but a different flank
        assert np.max(np.abs((feat.s - 5e-4) - lobe.lift(a))) > 1e-5


def test_direction_minus_one_mirrors_the_lobe():
    plus = simulate(_scene(direction=1), SimParams(seed=3))
    minus = simulate(_scene(direction=-1), SimParams(seed=3))
    f_p, f_m = plus.features[0], minus.features[0]
    assert f_p.true_angle == f_m.true_angle   # truth independent of the direction
    law = _scene().lobe('lobe_1').lift
    d = f_m.theta - f_m.true_angle
    np.testing.assert_allclose(f_m.s - 5e-4, law(_alpha(f_m.theta, f_m.true_angle, -1)),
                               atol=1e-15)
    # with direction -1, the rise flank (alpha < 0) comes AFTER the nose in theta
    k = int(np.argmin(np.abs(np.mod(d + np.pi, 2 * np.pi) - np.pi - 30 * DEG)))
    assert f_m.s[k] - 5e-4 == pytest.approx(float(law(-30 * DEG)), abs=1e-4)
    assert not np.allclose(f_p.s, f_m.s)   # the lobe is asymmetric


def test_wrapped_and_unwrapped_give_the_same_samples():
    scene = _scene()
    a = simulate(scene, SimParams(wrapped=False, start_theta=5.0, revolutions=2.5, seed=1,
                                  probe_noise=1e-6))
    b = simulate(scene, SimParams(wrapped=True, start_theta=5.0, revolutions=2.5, seed=1,
                                  probe_noise=1e-6))
    for fa, fb in zip(a.features, b.features):
        np.testing.assert_array_equal(fa.s, fb.s)
        np.testing.assert_allclose(fb.theta, np.mod(fa.theta, 2 * np.pi), atol=1e-12)
        assert np.all((fb.theta >= 0) & (fb.theta < 2 * np.pi))
        assert fa.theta.size == 9000
    # unwrapped theta is continuous across features and starts at start_theta
    assert a.features[0].theta[0] == 5.0
    assert a.features[1].theta[0] == pytest.approx(5.0 + 2.5 * 2 * np.pi)
    assert np.all(np.diff(np.concatenate([f.theta for f in a.features])) > 0)


def test_dowel_pin_lift_and_stop():
    scene = _scene()
    params = SimParams(samples_per_rev=36000, probe_zero_offset=2e-3, pin_stop_depth=3e-4)
    run = simulate(scene, params)
    pin = run.features[-1]
    assert pin.id == DOWEL_PIN and pin.kind == 'dowel_pin'
    geo = DowelPinGeometry(0.0025, 0.0115, 0.002)
    a = _alpha(pin.theta, pin.true_angle, 1)
    inside = np.abs(a) <= geo.contact_half_angle
    np.testing.assert_allclose(pin.s[inside], 2e-3 + geo.lift(a[inside]), atol=1e-15)
    np.testing.assert_allclose(pin.s[~inside], 2e-3 + geo.lift_min - 3e-4, atol=1e-15)
    # seed 004 worked numbers (methods §7 #5): h(0) = 14 mm, alpha_max = 23.035684 deg
    assert pin.s.max() == pytest.approx(2e-3 + 14e-3, abs=1e-8)
    assert inside.sum() == pytest.approx(36000 * 2 * 23.035684 / 360, abs=2)
    # nothing is in contact behind the axis (|alpha| near pi)
    assert np.all(pin.s[np.abs(a) > 2.0] == pin.s.min())


def test_noise_levels_and_encoder_noise():
    scene = _scene()
    clean = simulate(scene, SimParams(seed=5, samples_per_rev=20000))
    noisy = simulate(scene, SimParams(seed=5, samples_per_rev=20000, probe_noise=2e-6,
                                      encoder_noise=1e-4))
    res = np.concatenate([n.s - c.s for n, c in zip(noisy.features, clean.features)])
    assert np.std(res) == pytest.approx(2e-6, rel=0.03)
    assert abs(np.mean(res)) < 5e-8
    enc = np.concatenate([n.theta - c.theta for n, c in zip(noisy.features, clean.features)])
    assert np.std(enc) == pytest.approx(1e-4, rel=0.03)
    assert noisy.truth['probe_noise_m'] == 2e-6 and noisy.truth['encoder_noise_rad'] == 1e-4


def test_runout_adds_once_per_revolution():
    scene = _scene(pin=False, lobes=[{'id': 'lobe_1', 'lift': _asym_table()}])
    a = simulate(scene, SimParams(seed=2))
    b = simulate(scene, SimParams(seed=2, runout=5e-6))
    np.testing.assert_allclose(b.features[0].s - a.features[0].s,
                               5e-6 * np.cos(a.features[0].theta), atol=1e-18)


# ------------------------------------------------------------------------- truth

def test_truth_angles_phases_and_errors():
    scene = _scene()
    given = {'lobe_1': 1.0, 'lobe_2': -2.0 + 2 * np.pi, DOWEL_PIN: 0.25}
    run = simulate(scene, SimParams(true_angles=given))
    feats = run.truth['features']
    assert list(feats) == ['lobe_1', 'lobe_2', DOWEL_PIN] == run.truth['measurement_order']
    assert feats['lobe_1']['angle_deg'] == pytest.approx(math.degrees(1.0))
    assert feats[DOWEL_PIN]['angle_deg'] == pytest.approx(math.degrees(0.25))
    assert feats['lobe_1']['phase_deg'] == pytest.approx(math.degrees(0.75))
    assert feats['lobe_1']['phase_error_deg'] == pytest.approx(math.degrees(0.75) - 40)
    # lobe_2: phase wraps to (-180, 180]: -2.25 rad = -128.9 deg; nominal -100 deg
    assert feats['lobe_2']['phase_deg'] == pytest.approx(math.degrees(-2.25))
    assert feats['lobe_2']['phase_error_deg'] == pytest.approx(math.degrees(-2.25) + 100)
    assert run.truth['camshaft_id'] == 'SIM-1'
    json.dumps(run.truth)   # JSON-able
    assert [f.true_angle for f in run.features] == pytest.approx([1.0, 2 * np.pi - 2.0, 0.25])


def test_random_truth_is_near_nominal_and_deterministic():
    scene = load_scene('config/default_scene.yaml')
    a = simulate(scene, SimParams(seed=11, probe_noise=1e-6))
    b = simulate(scene, SimParams(seed=11, probe_noise=1e-6))
    c = simulate(scene, SimParams(seed=12, probe_noise=1e-6))
    assert a.truth == b.truth
    for fa, fb in zip(a.features, b.features):
        np.testing.assert_array_equal(fa.s, fb.s)
        np.testing.assert_array_equal(fa.theta, fb.theta)
    assert a.truth['features'] != c.truth['features']
    for fid, feat in a.truth['features'].items():
        if fid == DOWEL_PIN:
            assert abs(feat['angle_deg'] - 0.0 + 360) % 360 < 1.0 or feat['angle_deg'] > 359
        else:
            assert abs(feat['phase_error_deg']) <= 0.5
    # the truth does not depend on the noise levels
    d = simulate(scene, SimParams(seed=11))
    assert d.truth['features'] == a.truth['features']


def test_scene_without_pin_and_without_nominal_phase():
    scene = _scene(pin=False, lobes=[{'id': 'lobe_1', 'lift': _asym_table()}])
    run = simulate(scene, SimParams(seed=4))
    assert [f.id for f in run.features] == ['lobe_1']
    entry = run.truth['features']['lobe_1']
    assert 'phase_deg' not in entry and 0 <= entry['angle_deg'] < 360


@pytest.mark.parametrize('kw,key', [
    ({'samples_per_rev': 4}, 'samples_per_rev'),
    ({'samples_per_rev': 10.5}, 'samples_per_rev'),
    ({'revolutions': 0}, 'revolutions'),
    ({'revolutions': 1e-4}, 'revolutions'),
    ({'probe_noise': -1e-6}, 'probe_noise'),
    ({'encoder_noise': float('nan')}, 'encoder_noise'),
    ({'rate': 0}, 'rate'),
    ({'true_angles': {'lobe_9': 1.0}}, 'true_angles'),
    ({'true_angles': {'lobe_1': float('inf')}}, 'true_angles.lobe_1'),
])
def test_bad_params(kw, key):
    with pytest.raises(InputError) as info:
        simulate(_scene(), SimParams(**kw))
    assert info.value.key == key


# ------------------------------------------------------------------ stream and bag

def test_joint_state_stream_is_contiguous_and_ordered():
    run = simulate(_scene(), SimParams(samples_per_rev=360, rate=2000.0, feature_gap=0.1))
    msgs = list(iter_joint_state_messages(run))
    assert len(msgs) == run.sample_count == 3 * 360
    ids = [m[1] for m in msgs]
    assert ids == ['lobe_1'] * 360 + ['lobe_2'] * 360 + [DOWEL_PIN] * 360
    stamps = np.array([m[0] for m in msgs])
    assert np.all(np.diff(stamps) > 0)
    assert stamps[1] - stamps[0] == 500_000          # 2 kHz
    assert stamps[360] - stamps[359] == 100_500_000  # gap between features
    assert msgs[5][2] == run.features[0].theta[5] and msgs[5][3] == run.features[0].s[5]


def test_write_sim_bag(tmp_path):
    scene = _scene()
    bag = tmp_path / 'sim'
    calls = []
    run = write_sim_bag(bag, scene, SimParams(samples_per_rev=720, probe_noise=1e-6, seed=9),
                        progress=lambda d, t: calls.append((d, t)))
    assert calls[-1] == (run.sample_count, run.sample_count)
    topics = bagio.bag_topics(bag)
    assert topics == {'/bench/scene': ('std_msgs/msg/String', 1),
                      '/bench/truth': ('std_msgs/msg/String', 1),
                      '/bench/joint_states': ('sensor_msgs/msg/JointState', 3 * 720),
                      '/bench/feature_done': ('std_msgs/msg/String', 3)}
    msgs = list(bagio.iter_messages(bag, ['/bench/scene', '/bench/truth',
                                          '/bench/feature_done']))
    assert msgs[0].topic == '/bench/scene' and msgs[0].msg.data == scene.text
    assert msgs[1].topic == '/bench/truth' and json.loads(msgs[1].msg.data) == \
        json.loads(json.dumps(run.truth))
    assert [m.msg.data for m in msgs[2:]] == ['lobe_1', 'lobe_2', DOWEL_PIN]
    js = bagio.read_joint_states(bag)
    np.testing.assert_array_equal(js.theta, np.concatenate([f.theta for f in run.features]))
    np.testing.assert_array_equal(js.s, np.concatenate([f.s for f in run.features]))
    np.testing.assert_array_equal(js.stamp_ns, js.log_ns)
    assert js.features == ('lobe_1', 'lobe_2', DOWEL_PIN)
    # the feature_done of a feature comes after its last sample and before the next
    done = [m.stamp_ns for m in msgs[2:]]
    assert done[0] > js.stamp_ns[719] and done[0] < js.stamp_ns[720]


def test_scene_with_direction_rewrites_the_text():
    scene = load_scene('config/default_scene.yaml')
    minus = scene_with_direction(scene, -1)
    assert minus.direction == -1 and parse_scene(minus.text).direction == -1
    assert '# free text' in minus.text   # comments kept
    no_dir = _scene()
    text = no_dir.text.replace('direction: 1\n', '')
    assert scene_with_direction(parse_scene(text), -1).direction == -1
    with pytest.raises(InputError):
        scene_with_direction(scene, 0)


def test_true_angle_just_below_zero_wraps_into_range():
    run = simulate(_scene(), SimParams(true_angles={'lobe_1': -1e-17, DOWEL_PIN: 2 * np.pi}))
    assert run.truth['features']['lobe_1']['angle_deg'] == 0.0
    assert run.truth['features'][DOWEL_PIN]['angle_deg'] == 0.0


def _run(capsys, *args: str):
    """The command in-process: (exit code, stdout, stderr)."""
    from cam_metrology.cli import main
    code = main(list(args))
    out = capsys.readouterr()
    return code, out.out, out.err


def test_cli_simulate_writes_a_bag_and_prints_the_truth(tmp_path, capsys):
    out = tmp_path / 'sim'
    code, stdout, err = _run(capsys, 'simulate', str(out), '--samples-per-rev', '360',
                             '--noise-um', '1', '--seed', '7', '--direction', '-1',
                             '--wrapped', '--quiet')
    assert code == 0, err
    assert 'wrote' in stdout and '"dowel_pin"' in stdout
    truth = json.loads(stdout[stdout.index('{'):])
    assert truth['direction'] == -1 and truth['probe_noise_m'] == 1e-6
    (m,) = list(bagio.iter_messages(out, ['/bench/scene']))
    assert parse_scene(m.msg.data).direction == -1
    js = bagio.read_joint_states(out)
    assert len(js) == 5 * 360 and np.all(js.theta < 2 * np.pi)
    code, _, err = _run(capsys, 'simulate', str(out), '--samples-per-rev', '360', '--quiet')
    assert code == 2 and 'never overwritten' in err
    code, stdout, _ = _run(capsys, 'simulate', str(tmp_path / 'z'), '--samples-per-rev',
                           '360', '--zero-mm', '-2', '--runout-um', '3', '--rate', '500',
                           '--reverse', '--quiet')
    truth = json.loads(stdout[stdout.index('{'):])
    assert (truth['probe_zero_offset_m'], truth['runout_m']) == (-2e-3, 3e-6)
    assert truth['params']['rate'] == 500.0
    js = bagio.read_joint_states(tmp_path / 'z')
    assert js.stamp_ns[1] - js.stamp_ns[0] == 2_000_000
    assert truth['params']['reverse'] is True and js.theta[1] < js.theta[0]


def test_cli_simulate_progress_for_large_runs(tmp_path, capsys):
    code, _, err = _run(capsys, 'simulate', str(tmp_path / 'big'), '--samples-per-rev',
                        '12000')
    assert code == 0
    assert 'simulate: 60000/60000 samples (100 %)' in err and '(50 %)' in err


def test_cli_simulate_bad_input_exits_2(tmp_path, capsys):
    bad = tmp_path / 'bad.yaml'
    bad.write_text('probe: {kind: laser}\nbase_circle_radius: 0.01\n')
    code, _, err = _run(capsys, 'simulate', str(tmp_path / 'x'), '--scene', str(bad))
    assert code == 2 and 'probe.kind' in err
    code, _, err = _run(capsys, 'simulate', str(tmp_path / 'y'), '--samples-per-rev', '3')
    assert code == 2 and '--samples-per-rev' in err
    assert not (tmp_path / 'x').exists() and not (tmp_path / 'y').exists()


def test_cli_simulate_rounds_repeats_every_feature(tmp_path, capsys):
    out = tmp_path / 'r3'
    code, stdout, err = _run(capsys, 'simulate', str(out), '--samples-per-rev', '360',
                             '--rounds', '3', '--rate', '1000', '--quiet')
    assert code == 0, err
    assert 'wrote' in stdout and f'{3 * 5 * 360} samples' in stdout
    js = bagio.read_joint_states(out)
    assert len(js) == 3 * 5 * 360
    done = [str(m.msg.data) for m in bagio.iter_messages(out, ['/bench/feature_done'])]
    from cam_metrology.host.paths import default_scene_path
    from cam_metrology.scene.parse import load_scene
    scene = load_scene(default_scene_path())
    ids = [lobe.id for lobe in scene.lobes] + [scene.datum_id]
    assert len(ids) == 5 and done == ids * 3
    # the same samples each round, later by one run: 5 x 360 samples at 1 ms and a
    # feature gap after each of the 5 features
    n = 5 * 360
    np.testing.assert_array_equal(js.theta[n:2 * n], js.theta[:n])
    np.testing.assert_array_equal(js.s[2 * n:], js.s[:n])
    shift = js.stamp_ns[n:2 * n] - js.stamp_ns[:n]
    gap_ns = round(SimParams().feature_gap * 1e9)
    assert np.all(shift == n * 1_000_000 + 5 * gap_ns)
    for bad in ('0', '-2'):
        code, _, err = _run(capsys, 'simulate', str(tmp_path / f'x{bad}'), '--rounds', bad)
        assert code == 2 and f'--rounds: got {bad}' in err and len(err.splitlines()) == 1
        assert not (tmp_path / f'x{bad}').exists()
    with pytest.raises(SystemExit) as exc:   # argparse: not an integer
        _run(capsys, 'simulate', str(tmp_path / 'y'), '--rounds', '1.5')
    assert exc.value.code == 2 and '--rounds' in capsys.readouterr().err


def test_reverse_turning_gives_the_same_lift_at_the_same_angle():
    fwd = simulate(_scene(), SimParams(seed=8, samples_per_rev=720))
    rev = simulate(_scene(), SimParams(seed=8, samples_per_rev=720, reverse=True,
                                       start_theta=10.0))
    for f, r in zip(fwd.features, rev.features):
        assert f.true_angle == r.true_angle
        assert np.all(np.diff(r.theta) < 0)
        law = (lambda a: _scene().lobe(r.id).lift(a)) if r.kind == 'lobe' else None
        if law is not None:
            np.testing.assert_allclose(r.s - 5e-4, law(_alpha(r.theta, r.true_angle, 1)),
                                       atol=1e-15)
    assert rev.features[0].theta[0] == 10.0
