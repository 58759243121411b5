"""ReconstructionCore (NodeCore protocol) with duck-typed messages; no rclpy."""
from __future__ import annotations

import types
from pathlib import Path

import numpy as np
import pytest
import yaml

from cam_design.errors import InputError
from cam_design.follower import convert_lift
from cam_metrology.cores.outputs import ERROR, OK, WARN, StatusOutput, TableOutput
from cam_metrology.reconstruction.core import PROFILE_COLUMNS, ReconstructionCore
from cam_metrology.reconstruction.synthetic import simulate
from cam_metrology.offline.registry import load_core_class
from cam_metrology.scene.parse import parse_scene

REPO = Path(__file__).resolve().parent.parent
SCENE_TEXT = (REPO / 'config' / 'default_scene.yaml').read_text()


def msg(label, columns, data):
    dims = [types.SimpleNamespace(label=label, size=data.shape[0], stride=data.size),
            types.SimpleNamespace(label=','.join(columns), size=data.shape[1],
                                  stride=data.shape[1])]
    return types.SimpleNamespace(layout=types.SimpleNamespace(dim=dims, data_offset=0),
                                 data=data.ravel().tolist())


def scene_msg(text=SCENE_TEXT):
    return types.SimpleNamespace(data=text)


@pytest.fixture(scope='module')
def measured():
    """lobe_1 of the default scene as the roller probe sees it, 0.5 um noise."""
    scene = parse_scene(SCENE_TEXT)
    lobe = scene.lobe('lobe_1')
    seen = convert_lift(lobe.lift, scene.base_circle_radius, lobe.follower, scene.probe)
    a, h = simulate(seen, 1800, 0.5e-6, seed=21, outliers=2)
    return scene, lobe, seen, np.column_stack([a, h, seen(a)])


def tables(outputs):
    return {o.label: o for o in outputs if isinstance(o, TableOutput)}


def statuses(outputs):
    return {s.name: s for o in outputs if isinstance(o, StatusOutput) for s in o.statuses}


def test_registry_and_protocol():
    cls = load_core_class('reconstruction')
    assert cls is ReconstructionCore
    core = cls()
    assert core.name == 'reconstruction'
    assert set(core.subscriptions) == {'/bench/scene', '/metrology/lift'}
    assert set(core.publications) == {'/reconstruction/profile', '/reconstruction/result'}
    assert core.tick(0) == [] and core.finish() == []
    for key, (default, text) in cls.PARAMETERS.items():
        assert text


def test_bad_parameters():
    with pytest.raises(InputError, match='reconstruction.nope'):
        ReconstructionCore({'nope': 1})
    with pytest.raises(InputError, match='methods'):
        ReconstructionCore({'methods': 'spline,fourier'})
    with pytest.raises(InputError, match='basis'):
        ReconstructionCore({'harmonic_basis': 'wavelet'})
    with pytest.raises(InputError, match='step_deg'):
        ReconstructionCore({'step_deg': 0})


def test_lobe_profiles_converted_to_the_design_follower(measured):
    scene, lobe, seen, data = measured
    core = ReconstructionCore({'step_deg': 0.2})
    assert core.handle('/bench/scene', scene_msg(), 1) == []
    out = core.handle('/metrology/lift', msg('lobe_1', ('alpha_rad', 'lift_m', 'design_lift_m'),
                                             data), 2)
    t = tables(out)
    assert set(t) == {'lobe_1/spline', 'lobe_1/harmonic', 'lobe_1/spline/probe',
                      'lobe_1/harmonic/probe'}
    for label, table in t.items():
        assert table.topic == '/reconstruction/profile'
        assert table.columns == PROFILE_COLUMNS
        assert table.data.shape == (1800, 5) and np.all(np.isfinite(table.data))
    for method in ('spline', 'harmonic'):
        probe = t[f'lobe_1/{method}/probe'].data
        engine = t[f'lobe_1/{method}'].data
        a = probe[:, 0]
        assert np.sqrt(np.mean((probe[:, 1] - seen(a)) ** 2)) < 0.3e-6
        # converted back to the flat tappet of the design: compare with the design law
        assert np.sqrt(np.mean((engine[:, 1] - lobe.lift(a)) ** 2)) < 0.5e-6
        assert np.sqrt(np.mean((engine[:, 3] - lobe.lift(a, 2)) ** 2)) < 1.5e-3
    st = statuses(out)
    s = st['lobe_1/spline']
    assert s.level == OK, s.message
    assert float(s.values['smoothing']) > 0 and 'GCV' in s.values['why']
    assert float(s.values['rms_error_lift_m']) < 0.3e-6
    assert float(s.values['noise_sigma_m']) == pytest.approx(0.5e-6, rel=0.2)
    assert len(s.values['outliers_deg'].split(',')) == 2
    assert 'flat' in s.values['follower']
    assert float(s.values['engine_rms_error_lift_m']) < 0.5e-6
    assert float(s.values['engine_rms_error_acceleration_m_per_rad2']) < 1.5e-3
    assert float(s.values['cam_speed_rpm']) == 1500.0
    h = st['lobe_1/harmonic']
    assert int(h.values['order']) >= 10 and 'BIC' in h.values['why']
    amps = [float(v) for v in h.values['spectrum_amplitude_m'].split(',')]
    assert len(amps) == int(h.values['order']) + 1 and max(amps) > 1e-3


def test_lobe_law_warnings_are_published(measured):
    """The node's statuses carry what the lobe law of the rows says (as card, dynamics
    and reconstruct do): a table that starts on the rise flank (mid-lobe, at 20 % of
    the lift) gets level WARN with the warning in its message and in ``warnings``, with
    and without a scene; the whole table gets none of them. The fits of the cut table
    run on its rows only: no angle before the first row, the spline's lift not above
    the rows by more than the noise."""
    scene, lobe, seen, data = measured
    a = data[:, 0]
    top = float(np.max(seen(a)))
    rise = np.flatnonzero((a < 0) & (seen(a) >= 0.2 * top))[0]   # the first row at 20 %
    cut = data[rise:]
    m = msg('lobe_1', ('alpha_rad', 'lift_m', 'design_lift_m'), cut)
    with_scene = ReconstructionCore({'methods': 'spline,harmonic'})
    with_scene.handle('/bench/scene', scene_msg(), 1)
    without = ReconstructionCore({'methods': 'spline'})
    without.handle('/metrology/lift', m, 1)
    for out in (with_scene.handle('/metrology/lift', m, 2), without.finish()):
        st, t = statuses(out), tables(out)
        for label, s in st.items():
            assert s.level == WARN, (label, s.message)
            assert 'starts mid-lobe' in s.values['warnings'] and 'starts mid-lobe' in s.message
            assert 'ends mid-lobe' not in s.values['warnings']
            probe = t.get(f'{label}/probe', t[label]).data
            assert probe[0, 0] >= cut[0, 0] - 1e-9                  # rad
            if label.endswith('/spline'):   # (the series has its own ripple: ~10 um)
                assert float(np.max(probe[:, 1])) <= float(np.max(cut[:, 1])) + 3e-6   # m
    whole = ReconstructionCore({'methods': 'spline'})
    whole.handle('/bench/scene', scene_msg(), 1)
    s = statuses(whole.handle('/metrology/lift', msg(
        'lobe_1', ('alpha_rad', 'lift_m', 'design_lift_m'), data), 2))['lobe_1/spline']
    assert 'mid-lobe' not in s.values.get('warnings', '') and s.level == OK, s.message


def test_table_before_scene_is_processed_when_the_scene_arrives(measured):
    _, _, _, data = measured
    core = ReconstructionCore({'methods': 'spline'})
    m = msg('lobe_1', ('alpha_rad', 'lift_m', 'design_lift_m'), data)
    assert core.handle('/metrology/lift', m, 1) == []
    out = core.handle('/bench/scene', scene_msg(), 2)
    assert 'lobe_1/spline' in tables(out)
    core2 = ReconstructionCore({'methods': 'spline'})
    core2.handle('/metrology/lift', m, 1)
    out = core2.finish()
    st = statuses(out)['lobe_1/spline']
    assert 'no scene' in st.values['follower']
    assert float(st.values['rms_error_lift_m']) < 0.3e-6     # from design_lift_m


def test_skips(measured):
    _, _, _, data = measured
    doc = yaml.safe_load(SCENE_TEXT)
    doc['compute'] = ['nose', 'pin']
    core = ReconstructionCore()
    core.handle('/bench/scene', scene_msg(yaml.safe_dump(doc)), 1)
    cols = ('alpha_rad', 'lift_m', 'design_lift_m')
    st = statuses(core.handle('/metrology/lift', msg('lobe_1', cols, data), 2))
    assert st['skipped/reconstruction/lobe_1'].values == {}
    assert 'compute' in st['skipped/reconstruction/lobe_1'].message
    core = ReconstructionCore()
    core.handle('/bench/scene', scene_msg(), 1)
    st = statuses(core.handle('/metrology/lift', msg('dowel_pin', cols, data), 2))
    assert 'dowel pin' in st['skipped/reconstruction/dowel_pin'].message
    st = statuses(core.handle('/metrology/lift', msg('lobe_9', cols, data), 3))
    assert 'no lobe' in st['skipped/reconstruction/lobe_9'].message


def test_bad_scene_and_bad_tables_are_reported_not_raised(measured):
    core = ReconstructionCore()
    st = statuses(core.handle('/bench/scene', scene_msg('lobes: 3'), 1))
    assert st['scene'].level == ERROR
    core.handle('/bench/scene', scene_msg(), 2)
    bad = msg('lobe_1', ('alpha_rad', 'lift_m', 'design_lift_m'), np.zeros((3, 3)))
    st = statuses(core.handle('/metrology/lift', bad, 3))
    assert st['lobe_1'].level == ERROR and 'distinct finite angles' in st['lobe_1'].message
    nan = measured[3].copy()
    nan[:, 1] = np.nan
    columns = ('alpha_rad', 'lift_m', 'design_lift_m')
    st = statuses(core.handle('/metrology/lift', msg('lobe_2', columns, nan), 4))
    assert st['lobe_2'].level == ERROR
    wrong = msg('lobe_1', ('theta', 'lift_m'), np.zeros((10, 2)))
    st = statuses(core.handle('/metrology/lift', wrong, 5))
    assert st['lift_table'].level == ERROR


def test_table_that_ends_on_a_flank_fails_full_basis_only(measured):
    _, _, _, data = measured
    part = data[np.abs(data[:, 0]) < 1.0]
    core = ReconstructionCore({'harmonic_basis': 'full'})
    core.handle('/bench/scene', scene_msg(), 1)
    out = core.handle('/metrology/lift', msg('lobe_1', ('alpha_rad', 'lift_m',
                                                        'design_lift_m'), part), 2)
    st = statuses(out)
    assert st['lobe_1/harmonic'].level == ERROR and 'base circle' in st['lobe_1/harmonic'].message
    # the spline works; converting a table cut on the flanks to the flat design
    # follower is refused by convert_lift: WARN, and the probe's lift is published
    assert st['lobe_1/spline'].level == WARN
    assert 'conversion to the design follower failed' in st['lobe_1/spline'].message
    assert set(tables(out)) == {'lobe_1/spline'}


def test_config_file_holds_the_defaults():
    doc = yaml.safe_load((REPO / 'config' / 'reconstruction.yaml').read_text())
    params = doc['reconstruction']['ros__parameters']
    assert params == {k: v[0] for k, v in ReconstructionCore.PARAMETERS.items()}
    ReconstructionCore(params)


def test_numerical_failure_of_one_method_is_reported(measured, monkeypatch):
    from cam_metrology.reconstruction import profile

    def boom(*args, **kwargs):
        raise np.linalg.LinAlgError('singular')

    monkeypatch.setattr(profile, 'reconstruct_harmonic', boom)
    core = ReconstructionCore()
    core.handle('/bench/scene', scene_msg(), 1)
    out = core.handle('/metrology/lift', msg('lobe_1', ('alpha_rad', 'lift_m', 'design_lift_m'),
                                             measured[3]), 2)
    st = statuses(out)
    har = st['lobe_1/harmonic']
    assert har.level == ERROR and 'numerical failure' in har.message
    assert st['lobe_1/spline'].level == OK


@pytest.mark.parametrize('lobe_id,seed', [('lobe_1', 0), ('lobe_2', 3)])
def test_full_turn_spline_converts_like_the_harmonic(lobe_id, seed):
    """A smoothing spline over the whole turn is not periodic: its end slopes differ by
    noise (~1e-6 m/rad), which convert_lift used to refuse as a convex corner at the
    +-180 deg seam, so the spline stayed in the probe frame (QA A6). Only the lobe is
    converted now: both methods reach the design follower, to noise level."""
    from cam_design.lift_laws import TabulatedLift
    from cam_metrology.reconstruction.profile import Conversion, lobe_section, reconstruct_table
    from cam_design.lift_table.samples import LiftTable

    scene = parse_scene(SCENE_TEXT)
    lobe = scene.lobe(lobe_id)
    seen = convert_lift(lobe.lift, scene.base_circle_radius, lobe.follower, scene.probe)
    a, h = simulate(seen, 720, 0.5e-6, seed=seed)
    conv = Conversion(scene.probe, lobe.follower, scene.base_circle_radius, lobe.lift)
    out = reconstruct_table(LiftTable(feature=lobe_id, alpha=a, lift=h, design=seen(a)),
                            conversion=conv)
    for method, o in out.items():
        assert o.engine is not None, (method, o.engine_note)
        assert o.engine_note.startswith('converted'), o.engine_note
        assert o.engine_errors['max_error_lift_m'] < 1.2e-6, method
        assert o.engine_errors['rms_error_lift_m'] < 0.4e-6, method
        assert o.engine_errors['rms_error_acceleration_m_per_rad2'] < 1.5e-3, method
    rec = out['spline'].reconstruction
    # the seam really is a noise-level corner of the spline
    assert rec.alpha[0] < -3.1 and rec.alpha[-1] > 3.1
    # the section handed to convert_lift: the lift itself wherever it is above the
    # noise, exact zeros at both ends, h' there far below convert_lift's 1e-9 m/rad
    sa, sh = lobe_section(rec.alpha, rec.lift, rec.sigma)
    i0 = int(np.searchsorted(rec.alpha, sa[0]))
    assert np.array_equal(sa, rec.alpha[i0:i0 + sa.size])
    big = np.abs(rec.lift[i0:i0 + sa.size]) > 5 * rec.sigma
    assert np.count_nonzero(big) == np.count_nonzero(np.abs(rec.lift) > 5 * rec.sigma)
    assert np.array_equal(sh[big], rec.lift[i0:i0 + sa.size][big])
    assert sh[0] == 0.0 and sh[-1] == 0.0 and -3.0 < sa[0] and sa[-1] < 3.0
    ends = np.array([sa[0], sa[-1]])
    assert np.all(np.abs(TabulatedLift(sa, sh)(ends, 1)) < 1e-10)


def test_lobe_section_of_an_exact_lift_is_the_lift():
    """Noise-free: the section is the lift (to rounding) and the conversion of a
    full-turn table is exact; a table that does not reach the base circle before its
    ends falls back to the old linear end-offset removal."""
    from cam_metrology.reconstruction.profile import lobe_section

    scene = parse_scene(SCENE_TEXT)
    lobe = scene.lobe('lobe_1')
    seen = convert_lift(lobe.lift, scene.base_circle_radius, lobe.follower, scene.probe)
    grid = np.linspace(-np.pi, np.pi, 3601)
    sa, sh = lobe_section(grid, seen(grid), 0.0)
    assert sa.size < grid.size and sh[0] == 0.0 and sh[-1] == 0.0
    np.testing.assert_array_equal(sh, seen(sa))
    cut = grid[np.abs(grid) < np.radians(92.0)]     # the roller lift: +-90 deg
    lifted = seen(cut) + 1e-7
    ca, ch = lobe_section(cut, lifted, 1e-7)
    assert ca.size == cut.size
    assert ch[0] == pytest.approx(0.0, abs=1e-18) and ch[-1] == pytest.approx(0.0, abs=1e-18)
    np.testing.assert_allclose(ch, seen(cut), rtol=0, atol=1e-18)


def test_replay_of_a_recorded_lift_table_publishes_the_lobe_law_warnings(measured, tmp_path):
    """The node's path offline: a bag holding the scene and a recorded /metrology/lift
    table that starts on the rise flank, replayed through the reconstruction core alone
    (``run_offline``, as ``analyze`` runs it): the /reconstruction/result statuses are
    WARN with the lobe law's mid-lobe warning, and the profiles cover the rows only."""
    from cam_metrology import bagio
    from cam_metrology.offline.replay import run_offline

    _, _, seen, data = measured
    a = data[:, 0]
    rise = np.flatnonzero((a < 0) & (seen(a) >= 0.2 * float(np.max(seen(a)))))[0]
    cut = data[rise:]
    bag = tmp_path / 'cut_bag'
    t = 1_000_000_000
    with bagio.BagWriter(bag) as w:
        w.write('/bench/scene', t, bagio.encode_string(SCENE_TEXT))
        w.write_output(TableOutput('/metrology/lift', 'lobe_1',
                                   ('alpha_rad', 'lift_m', 'design_lift_m'), cut), t + 1000)
    res = run_offline(bag, [ReconstructionCore({'methods': 'spline'})])
    st = {s.name: s for o in res.by_topic('/reconstruction/result') for s in o.statuses}
    s = st['lobe_1/spline']
    assert s.level == WARN and 'starts mid-lobe' in s.values['warnings'], s.message
    profiles = {o.label: o.data for o in res.by_topic('/reconstruction/profile')}
    for label, table in profiles.items():
        assert table[0, 0] >= cut[0, 0] - 1e-9 and table[-1, 0] <= cut[-1, 0] + 1e-9, label
