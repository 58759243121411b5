"""Scene validation: one test per class of bad input, messages name key path and value."""
from __future__ import annotations

import copy
import math
import subprocess
import sys

import numpy as np
import pytest
import yaml

from cam_design.errors import InputError
from cam_metrology.scene.parse import load_scene, parse_scene


def _table(n: int = 41, lift: float = 4e-3, half: float = 1.5) -> dict:
    """A smooth symmetric lobe table: h = lift cos^4(pi a / (2 half)) (C3 at the ends);
    flat-tappet radius of curvature 16.5 + 4 - 17.5 = 3 mm at the nose (no undercut)."""
    a = np.linspace(-half, half, n)
    h = lift * np.cos(0.5 * np.pi * a / half) ** 4
    h[0] = h[-1] = 0.0
    return {'alpha': a.tolist(), 'h': h.tolist()}


def _base() -> dict:
    return {
        'camshaft_id': 'T-1',
        'direction': 1,
        'probe': {'kind': 'roller', 'radius': 0.0125},
        'base_circle_radius': 0.0165,
        'lobes': [
            {'id': 'lobe_1', 'nominal_phase': 0.5, 'follower': 'flat', 'lift': _table()},
            {'id': 'lobe_2', 'nominal_phase': -1.0, 'follower': 'flat', 'lift': _table()},
        ],
        'dowel_pin': {'pin_radius': 0.0025, 'circle_radius': 0.0115, 'probe_radius': 0.002,
                      'nominal_angle': 0.0},
        'compute': ['nose', 'pin', 'asymmetry', 'reconstruction', 'dynamics'],
        'valve_train': {'model': 'sdof', 'rocker_ratio': 1.5, 'lash': 0.00025, 'mass': 0.12,
                        'stiffness': 1.2e7, 'damping': 60.0, 'spring_rate': 3.0e4,
                        'spring_preload': 250.0, 'valve_damping': 0.0,
                        'seat': {'stiffness': 1.0e9, 'damping': 2000.0},
                        'cam_speed_rpm': [1500, 3000]},
    }


def _parse(doc: dict):
    return parse_scene(yaml.safe_dump(doc))


def _bad(mutate, key: str, *fragments: str) -> InputError:
    doc = _base()
    mutate(doc)
    with pytest.raises(InputError) as info:
        _parse(doc)
    err = info.value
    assert err.key == key, str(err)
    text = str(err)
    assert text.startswith(f'{key}: got ')
    for frag in fragments:
        assert frag in text, text
    return err


# ---------------------------------------------------------------------- valid input

def test_valid_scene_round_trip():
    doc = _base()
    scene = _parse(doc)
    assert scene.camshaft_id == 'T-1' and scene.direction == 1
    assert scene.probe.kind == 'roller' and scene.probe.radius == 0.0125
    assert scene.base_circle_radius == 0.0165
    assert [lobe.id for lobe in scene.lobes] == ['lobe_1', 'lobe_2']
    lobe = scene.lobes[0]
    assert lobe.follower.kind == 'flat' and lobe.nominal_phase == 0.5
    a = np.array(doc['lobes'][0]['lift']['alpha'])
    np.testing.assert_allclose(lobe.lift(a), doc['lobes'][0]['lift']['h'], atol=1e-15)
    assert lobe.lift(0.0) == pytest.approx(4e-3)
    assert lobe.lift(2.0) == 0.0 and lobe.lift_spec is None
    assert scene.dowel_pin.circle_radius == 0.0115 and scene.dowel_pin.nominal_angle == 0.0
    assert scene.compute == frozenset(doc['compute'])
    vt = scene.valve_train
    assert (vt.model, vt.rocker_ratio, vt.lash, vt.cam_speed_rpm) == (
        'sdof', 1.5, 0.00025, (1500.0, 3000.0))
    assert vt.seat.stiffness == 1e9 and vt.seat.restitution is None
    assert scene.idle_timeout == 1.0 and scene.warnings == ()
    assert scene.text == yaml.safe_dump(doc)


def test_optional_parts_and_defaults():
    doc = _base()
    for k in ('dowel_pin', 'compute', 'valve_train', 'direction', 'camshaft_id'):
        del doc[k]
    for lobe in doc['lobes']:
        del lobe['nominal_phase']
        del lobe['follower']
    scene = _parse(doc)
    assert scene.dowel_pin is None and scene.valve_train is None and scene.compute is None
    assert scene.direction == 1 and scene.camshaft_id == ''
    assert scene.lobes[0].follower.kind == 'flat' and scene.lobes[0].nominal_phase is None
    assert scene.wants('dynamics')


def test_extra_architecture_keys():
    doc = _base()
    doc['idle_timeout'] = 2.5
    doc['lobes'][0]['follower'] = 'roller'
    doc['lobes'][0]['follower_radius'] = 0.011
    doc['valve_train']['seat']['restitution'] = 0.3
    doc['valve_train']['model'] = 'mdof'
    doc['valve_train']['mdof'] = {'n1': 3, 'n2': 4}
    doc['direction'] = -1
    doc['probe'] = {'kind': 'ball', 'radius': 0.002}
    scene = _parse(doc)
    assert scene.idle_timeout == 2.5 and scene.direction == -1
    assert scene.lobes[0].follower.kind == 'roller'
    assert scene.lobes[0].follower.radius == 0.011
    assert scene.valve_train.seat.restitution == 0.3
    assert scene.valve_train.mdof == {'n1': 3, 'n2': 4}
    assert scene.probe.kind == 'roller' and scene.probe.radius == 0.002
    assert scene.warnings == ()


def test_yaml11_exponent_strings_are_numbers():
    text = yaml.safe_dump(_base()).replace('1000000000.0', '1e9')
    assert '1e9' in text
    assert parse_scene(text).valve_train.seat.stiffness == 1e9


def test_lift_law_is_built_by_the_registry():
    pytest.importorskip('cam_design.lift_laws.registry')
    doc = _base()
    del doc['lobes'][0]['lift']
    doc['lobes'][0]['lift_law'] = {'family': 'preset', 'name': 'flat_tappet_intake'}
    scene = _parse(doc)
    lobe = scene.lobes[0]
    assert lobe.lift_spec == {'family': 'preset', 'name': 'flat_tappet_intake'}
    assert lobe.lift.max_lift() == pytest.approx(8.5e-3, rel=1e-6)


# ------------------------------------------------------------------ unknown keys warn

def test_unknown_keys_warn_with_path_and_are_ignored():
    doc = _base()
    doc['shift_leader'] = 'ann'
    doc['lobes'][1]['colour'] = 'red'
    doc['probe']['tip'] = 'ruby'
    doc['dowel_pin']['material'] = 'steel'
    doc['valve_train']['seat']['wear'] = 0
    doc['valve_train']['oil'] = '5W30'
    doc['lobes'][0]['lift']['units'] = 'SI'
    scene = _parse(doc)
    joined = '\n'.join(scene.warnings)
    for path in ('shift_leader', 'lobes[1].colour', 'probe.tip', 'dowel_pin.material',
                 'valve_train.seat.wear', 'valve_train.oil', 'lobes[0].lift.units'):
        assert any(w.startswith(f'{path}: unknown key') for w in scene.warnings), joined
    assert len(scene.warnings) == 7
    assert scene.lobes[1].id == 'lobe_2'


# ----------------------------------------------------------------- bad documents

@pytest.mark.parametrize('text,frag', [
    ('a: [1, 2', 'valid YAML'),
    ('', 'file is empty'),
    ('- 1\n- 2\n', 'a YAML mapping'),
    ('just text', 'a YAML mapping'),
])
def test_not_a_scene_document(text, frag):
    with pytest.raises(InputError, match=frag) as info:
        parse_scene(text, source='my.yaml')
    assert info.value.key == 'scene'


def test_yaml_error_names_line():
    with pytest.raises(InputError, match='at line 3, column 1'):
        parse_scene('a: 1\nb: [1, 2\n', source='x.yaml')


# --------------------------------------------------------------------- wrong types

def test_wrong_type_base_circle():
    _bad(lambda d: d.__setitem__('base_circle_radius', 'big'), 'base_circle_radius',
         "'big'", 'finite real number')


def test_wrong_type_lobes():
    _bad(lambda d: d.__setitem__('lobes', {'id': 'lobe_1'}), 'lobes', 'a list')


def test_wrong_type_probe():
    _bad(lambda d: d.__setitem__('probe', 'roller'), 'probe', 'a mapping')


def test_wrong_type_boolean_is_not_a_number():
    _bad(lambda d: d['valve_train'].__setitem__('mass', True), 'valve_train.mass', 'True')


def test_wrong_type_in_table_entry():
    def mutate(d):
        d['lobes'][1]['lift']['alpha'][3] = 'x'
    _bad(mutate, 'lobes[1].lift.alpha[3]', "'x'", 'finite')


def test_nan_in_table_entry():
    def mutate(d):
        d['lobes'][0]['lift']['h'][5] = float('nan')
    _bad(mutate, 'lobes[0].lift.h[5]', 'nan', 'finite')


# ------------------------------------------------------------------ out of domain

def test_negative_radius():
    _bad(lambda d: d.__setitem__('base_circle_radius', -0.01), 'base_circle_radius',
         '-0.01', '> 0')


def test_negative_probe_radius():
    _bad(lambda d: d['probe'].__setitem__('radius', -1e-3), 'probe.radius', '-0.001')


def test_roller_probe_needs_radius():
    _bad(lambda d: d['probe'].__setitem__('radius', 0), 'probe.radius', 'radius > 0')


def test_negative_pin_radius():
    _bad(lambda d: d['dowel_pin'].__setitem__('pin_radius', -0.0025),
         'dowel_pin.pin_radius', '-0.0025')


def test_pin_covering_the_axis():
    _bad(lambda d: d['dowel_pin'].__setitem__('circle_radius', 0.004),
         'dowel_pin.circle_radius', '0.004', 'pin_radius + probe_radius')


def test_missing_required_key():
    _bad(lambda d: d.pop('base_circle_radius'), 'base_circle_radius', 'None')
    _bad(lambda d: d['dowel_pin'].pop('circle_radius'), 'dowel_pin.circle_radius')
    _bad(lambda d: d['valve_train'].pop('stiffness'), 'valve_train.stiffness')
    _bad(lambda d: d['lobes'][0].pop('id'), 'lobes[0].id')


def test_nothing_to_measure():
    def mutate(d):
        d['lobes'] = []
        del d['dowel_pin']
    _bad(mutate, 'lobes', 'at least one lobe')


def test_only_dowel_pin_is_valid():
    doc = _base()
    doc['lobes'] = []
    assert _parse(doc).lobes == ()


# ----------------------------------------------------------------------- tables

def test_non_increasing_alpha():
    def mutate(d):
        a = d['lobes'][1]['lift']['alpha']
        a[7] = a[6]
    err = _bad(mutate, 'lobes[1].lift.alpha[7]', 'strictly increasing')
    assert err.value == pytest.approx(_table()['alpha'][6])


def test_decreasing_alpha():
    def mutate(d):
        d['lobes'][0]['lift']['alpha'] = d['lobes'][0]['lift']['alpha'][::-1]
    _bad(mutate, 'lobes[0].lift.alpha[1]', 'strictly increasing')


def test_tables_of_different_lengths():
    def mutate(d):
        d['lobes'][0]['lift']['h'].pop()
    _bad(mutate, 'lobes[0].lift.h', '40 values', 'as many values as lobes[0].lift.alpha (41)')


def test_table_too_short():
    def mutate(d):
        d['lobes'][0]['lift'] = {'alpha': [-1, 0, 1], 'h': [0, 1e-3, 0]}
    _bad(mutate, 'lobes[0].lift.alpha', '3 points', 'at least 6')


def test_table_in_degrees():
    def mutate(d):
        d['lobes'][0]['lift']['alpha'] = [math.degrees(a) for a in
                                          d['lobes'][0]['lift']['alpha']]
    _bad(mutate, 'lobes[0].lift.alpha[0]', 'degrees given?')


def test_table_in_millimetres():
    def mutate(d):
        d['lobes'][0]['lift']['h'] = [v * 1e3 for v in d['lobes'][0]['lift']['h']]
    _bad(mutate, 'lobes[0].lift.h', 'mm given?')


def test_table_not_covering_the_lobe():
    def mutate(d):
        tab = d['lobes'][0]['lift']
        tab['alpha'] = tab['alpha'][5:]
        tab['h'] = tab['h'][5:]
    _bad(mutate, 'lobes[0].lift.h[0]', 'cover the whole lobe')


def test_negative_lift():
    def mutate(d):
        d['lobes'][0]['lift']['h'][3] = -1e-4
    _bad(mutate, 'lobes[0].lift.h[3]', '-0.0001', '>= 0')


def test_table_and_law_both_or_neither():
    def both(d):
        d['lobes'][0]['lift_law'] = {'family': 'preset', 'name': 'flat_tappet_intake'}
    _bad(both, 'lobes[0].lift', 'exactly one')
    _bad(lambda d: d['lobes'][0].pop('lift'), 'lobes[0].lift', 'exactly one')


# --------------------------------------------------------------- kinds and choices

def test_unknown_follower_kind():
    _bad(lambda d: d['lobes'][1].__setitem__('follower', 'mushroom'), 'lobes[1].follower',
         "'mushroom'", 'flat | roller | knife')


def test_unknown_probe_kind():
    _bad(lambda d: d['probe'].__setitem__('kind', 'laser'), 'probe.kind', "'laser'")


def test_roller_design_follower_needs_radius():
    _bad(lambda d: d['lobes'][0].__setitem__('follower', 'roller'),
         'lobes[0].follower_radius', 'radius > 0')


@pytest.mark.parametrize('value', [0, 2, -2, 0.5, True, 'cw'])
def test_direction_not_plus_minus_one(value):
    _bad(lambda d: d.__setitem__('direction', value), 'direction', '+1 or -1')


def test_duplicate_lobe_ids():
    _bad(lambda d: d['lobes'][1].__setitem__('id', 'lobe_1'), 'lobes[1].id', "'lobe_1'",
         'unique id (lobes[0] has it already)')


def test_lobe_named_dowel_pin():
    _bad(lambda d: d['lobes'][1].__setitem__('id', 'dowel_pin'), 'lobes[1].id', 'reserved')


def test_unknown_compute_item():
    _bad(lambda d: d.__setitem__('compute', ['nose', 'pin', 'coffee']), 'compute[2]',
         "'coffee'", 'one of nose, pin')


def test_nominal_phase_in_degrees():
    _bad(lambda d: d['lobes'][0].__setitem__('nominal_phase', 90.0),
         'lobes[0].nominal_phase', '90.0', 'degrees given?')


# ------------------------------------------------------------------- valve_train

def test_valve_train_unknown_model():
    _bad(lambda d: d['valve_train'].__setitem__('model', 'fem'), 'valve_train.model',
         "'fem'", 'sdof | mdof')


@pytest.mark.parametrize('key,value', [
    ('mass', 0.0), ('mass', -0.1), ('stiffness', -1.0), ('rocker_ratio', 0.0),
    ('lash', -1e-4), ('damping', -1.0), ('spring_preload', float('inf')),
])
def test_valve_train_values(key, value):
    _bad(lambda d: d['valve_train'].__setitem__(key, value), f'valve_train.{key}')


def test_valve_train_seat_and_speeds():
    _bad(lambda d: d['valve_train']['seat'].__setitem__('stiffness', 0),
         'valve_train.seat.stiffness')
    _bad(lambda d: d['valve_train']['seat'].__setitem__('restitution', 1.5),
         'valve_train.seat.restitution', '[0, 1]')
    _bad(lambda d: d['valve_train'].__setitem__('cam_speed_rpm', [1500, -3000]),
         'valve_train.cam_speed_rpm[1]', '-3000')
    _bad(lambda d: d['valve_train'].__setitem__('cam_speed_rpm', []),
         'valve_train.cam_speed_rpm')


# ------------------------------------------------------------------------ lift_law

def test_lift_law_bad_parameters_name_the_key():
    pytest.importorskip('cam_design.lift_laws.registry')

    def mutate(d):
        del d['lobes'][1]['lift']
        d['lobes'][1]['lift_law'] = {'family': 'no_such_family'}
    err = _bad(mutate, 'lobes[1].lift_law.family', "'no_such_family'")
    assert 'polynomial' in str(err)


def test_lift_law_impossible_parameter():
    pytest.importorskip('cam_design.lift_laws.registry')

    def mutate(d):
        del d['lobes'][0]['lift']
        d['lobes'][0]['lift_law'] = {'family': 'preset', 'name': 'nope'}
    with pytest.raises(InputError) as info:
        doc = _base()
        mutate(doc)
        _parse(doc)
    assert info.value.key.startswith('lobes[0].lift_law')


def test_lift_law_not_a_mapping():
    def mutate(d):
        del d['lobes'][0]['lift']
        d['lobes'][0]['lift_law'] = 'polydyne'
    _bad(mutate, 'lobes[0].lift_law', 'a mapping')


def test_lift_law_without_registry(monkeypatch):
    import cam_metrology.scene.parse as sp

    monkeypatch.setattr(sp, '_registry', lambda: None)

    def mutate(d):
        del d['lobes'][0]['lift']
        d['lobes'][0]['lift_law'] = {'family': 'polydyne'}
    _bad(mutate, 'lobes[0].lift_law.family', 'not available')


# -------------------------------------------------------------------- whole file

def test_nothing_half_applied_on_late_error():
    doc = _base()
    doc['valve_train']['mass'] = -1   # the last block validated
    text = yaml.safe_dump(doc)
    with pytest.raises(InputError):
        parse_scene(text)
    good = copy.deepcopy(_base())
    assert _parse(good).valve_train.mass == 0.12


def test_load_scene_errors(tmp_path):
    with pytest.raises(InputError, match='existing scene file'):
        load_scene(tmp_path / 'missing.yaml')
    with pytest.raises(InputError, match='not a directory'):
        load_scene(tmp_path)
    p = tmp_path / 's.yaml'
    p.write_text(yaml.safe_dump(_base()))
    assert load_scene(p).camshaft_id == 'T-1'


CLI = 'import sys; from cam_metrology.cli import main; sys.exit(main(sys.argv[1:]))'


def _cli(*args: str, stdin: str | None = None) -> subprocess.CompletedProcess:
    """The real command in a new process (exit code, no traceback)."""
    return subprocess.run([sys.executable, '-c', CLI, *args], input=stdin,
                          capture_output=True, text=True, timeout=120)


def _run(capsys, *args: str) -> tuple[int, str, str]:
    """The command in-process (fast): (exit code, stdout, stderr)."""
    from cam_metrology.cli import main
    code = main(list(args))
    out = capsys.readouterr()
    return code, out.out, out.err


def test_cli_scene_check_valid_and_warnings(tmp_path, capsys):
    doc = _base()
    doc['shift_leader'] = 'ann'
    p = tmp_path / 's.yaml'
    p.write_text(yaml.safe_dump(doc))
    code, out, err = _run(capsys, 'scene', 'check', str(p))
    assert code == 0, err
    assert 'valid scene' in out and 'lobe_2' in out
    assert 'warning: shift_leader: unknown key' in out


def test_cli_scene_check_invalid_exits_2(tmp_path):
    doc = _base()
    doc['lobes'][1]['lift']['alpha'][7] = doc['lobes'][1]['lift']['alpha'][6]
    p = tmp_path / 's.yaml'
    p.write_text(yaml.safe_dump(doc))
    res = _cli('scene', 'check', str(p))
    assert res.returncode == 2
    assert 'lobes[1].lift.alpha[7]' in res.stderr and 'Traceback' not in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1


def test_design_lift_that_the_probe_cannot_follow_warns():
    pytest.importorskip('cam_design.follower').convert_lift
    doc = _base()
    # a sharp lobe: flat-tappet radius of curvature R0 + h + h'' < 0 at the nose
    doc['lobes'][0]['lift'] = _table(n=41, lift=8e-3, half=0.6)
    scene = _parse(doc)
    assert any(w.startswith('lobes[0].lift: the design lift cannot be seen by the roller')
               for w in scene.warnings), scene.warnings
    assert not any(w.startswith('lobes[1]') for w in scene.warnings)


def test_scene_check_reads_stdin(capsys, monkeypatch):
    import io

    monkeypatch.setattr('sys.stdin', io.StringIO(yaml.safe_dump(_base())))
    code, out, _ = _run(capsys, 'scene', 'check', '-')
    assert code == 0 and 'lobe_1' in out


def test_duplicate_key_is_an_error_not_a_silent_overwrite():
    text = yaml.safe_dump(_base()).replace('  lash: 0.00025\n',
                                           '  lash: 0.00025\n  lash: 0.0025\n')
    assert text.count('lash:') == 2
    with pytest.raises(InputError, match='unique keys') as info:
        parse_scene(text)
    assert info.value.value == 'lash' and 'line' in str(info.value)


def test_lobe_width_for_hertz_stress():
    """lobes[].width (m) is optional, parsed as a positive length, and rejected if not."""
    doc = _base()
    doc['lobes'][0]['width'] = 0.014
    scene = _parse(doc)
    assert scene.lobes[0].width == 0.014 and scene.lobes[1].width is None
    assert not any('width' in w for w in scene.warnings)

    def mutate(d):
        d['lobes'][1]['width'] = -0.01
    _bad(mutate, 'lobes[1].width', '-0.01', '> 0')
