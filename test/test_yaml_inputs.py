"""YAML inputs as people write them: a key given twice (YAML keeps the last, silently),
a tab-indented line, a byte-order mark. Every YAML the commands read (design and grind
files, ``--valve-train``, scenes) must refuse the first two in one line naming the key
path and both lines (exit 2) and read the third."""
from __future__ import annotations

from pathlib import Path

import pytest

from cam_design.errors import InputError
from cam_metrology.cli import main
from cam_metrology.inputs.yaml_input import load_yaml

CHECK = ('lift_law: {family: preset, name: flat_tappet_intake}\n'
         'base_radius: 0.0165\nrocker_ratio: 1.0\nlash: 0.0002\n')
VALVE_TRAIN = ('valve_train:\n  model: sdof\n  rocker_ratio: 1.5\n  lash: 0.00025\n'
               '  mass: 0.12\n  stiffness: 1.2e7\n  damping: 60.0\n  spring_rate: 3.0e4\n'
               '  spring_preload: 250.0\n  cam_speed_rpm: [1500]\n')


def test_duplicate_key_names_its_path_and_both_lines() -> None:
    text = 'a:\n  b: 1\n  c: [ {d: 1, d: 2} ]\n'
    with pytest.raises(InputError, match=r"f.yaml: a.c\[0\].d: got 'd'; expected unique "
                                         r'keys in a mapping \(given at lines 3 and 3'):
        load_yaml(text, 'f.yaml')
    assert load_yaml('x: &m {a: 1}\ny:\n  <<: *m\n  b: 2\n', 'f') == {
        'x': {'a': 1}, 'y': {'a': 1, 'b': 2}}     # a merge key is not a duplicate


@pytest.mark.parametrize('argv, text, path', [
    (['design', 'check'], CHECK + 'lash: 0.002\n', 'lash'),
    (['grind', 'table'], CHECK + 'grinding:\n  wheel_radius: 0.2\n  step_deg: 0.5\n'
                                 '  step_deg: 5\n', 'grinding.step_deg'),
])
def test_design_and_grind_files_refuse_duplicate_keys(tmp_path: Path, capsys, argv, text,
                                                      path) -> None:
    f = tmp_path / 'in.yaml'
    f.write_text(text, encoding='utf-8')
    assert main(argv + [str(f)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and f'{path}: got' in err and 'unique keys' in err


def _table(tmp_path: Path) -> Path:
    import numpy as np

    a = np.arange(-180.0, 180.0, 1.0)
    h = np.where(np.abs(a) < 60, 4.0 * (1 + np.cos(np.pi * a / 60)), 0.0)
    p = tmp_path / 't.csv'
    p.write_text('alpha_deg,lift_mm\n' + ''.join(f'{x:.0f},{y:.5f}\n' for x, y in zip(a, h)),
                 encoding='utf-8')
    return p


@pytest.mark.parametrize('text, words', [
    (VALVE_TRAIN.replace('  mass: 0.12\n', '  mass: 0.12\n  mass: 1.2\n'),
     ['valve_train.mass: got', 'given at lines 5 and 6']),
    (VALVE_TRAIN.replace('  mass: 0.12\n', '\tmass: 0.12\n'),
     ['valid YAML', 'line 5', 'indented with a tab']),
])
def test_valve_train_file_faults_are_one_line(tmp_path: Path, capsys, text, words) -> None:
    vt = tmp_path / 'vt.yaml'
    vt.write_text(text, encoding='utf-8')
    assert main(['dynamics', str(_table(tmp_path)), '--valve-train', str(vt),
                 '--rpm', '1500']) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and 'Traceback' not in err
    for w in words:
        assert w in err


def test_byte_order_mark_is_read(tmp_path: Path, capsys) -> None:
    f = tmp_path / 'bom.yaml'
    f.write_bytes(b'\xef\xbb\xbf' + CHECK.encode('utf-8'))
    assert main(['design', 'check', str(f), '--json', '-']) == 0
    assert '"max_lift_mm": 8.5' in capsys.readouterr().out


# ---------------------------------------------------------------- lengths in mm, rpm text
GRIND = CHECK + 'grinding:\n  design: {kind: flat}\n  wheel_radius: 0.2\n  step_deg: 0.5\n'


@pytest.mark.parametrize('argv, text, words', [
    (['design', 'check'], CHECK.replace('0.0165', '16.5'),
     'base_radius: got 16.5; expected a radius in metres (at most 0.5 m); 16.5 looks like '
     'millimetres: write 0.0165'),
    (['design', 'check'], CHECK + 'cam_speed_rpm: 3000rpm\n',
     "cam_speed_rpm: got '3000rpm'; expected a finite real number"),
    (['design', 'check'], CHECK + 'cam_speed_rpm: -3000\n',
     'cam_speed_rpm: got -3000; expected a number > 0'),
    (['grind', 'table'], GRIND.replace('0.0165', '16.5'), 'base_radius: got 16.5;'),
    (['grind', 'table'], GRIND.replace('wheel_radius: 0.2', 'wheel_radius: 200'),
     'grinding.wheel_radius: got 200; expected a wheel radius in metres (at most 1 m); 200 '
     'looks like millimetres: write 0.2'),
])
def test_unit_slips_and_text_speeds_are_refused(tmp_path: Path, capsys, argv, text,
                                                words) -> None:
    """A base radius of 16.5 (mm) gave rho1 = 16488 mm and a 200 m wheel a centre
    distance of 200 km, silently; a speed of '3000rpm' was ignored without a spring."""
    f = tmp_path / 'in.yaml'
    f.write_text(text, encoding='utf-8')
    assert main(argv + [str(f)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and words in err


def test_rocker_lengths_in_mm_are_refused(capsys) -> None:
    assert main(['design', 'rocker', '--arm-length', '45.8', '--base-radius', '0.0323',
                 '--max-swing-deg', '7.865']) == 2
    assert "--arm-length: got 45.8; expected a length in metres (at most 0.5 m); 45.8 looks " \
           'like millimetres: write 0.0458' in capsys.readouterr().err


def test_lift_law_angle_in_degrees_names_the_unit(tmp_path: Path, capsys) -> None:
    f = tmp_path / 'law.yaml'
    f.write_text('lift_law: {family: polynomial, ramp: none, rise: 0.008, half_angle: 60, '
                 'exponents: [2, 10, 18, 26]}\n', encoding='utf-8')
    assert main(['design', 'law', str(f)]) == 2
    assert 'lift_law.half_angle: got 60.0; expected an angle <= 3.14159 rad; 60 looks like ' \
           'degrees: write 1.0472' in capsys.readouterr().err


def test_profile_roller_radius_in_mm_is_refused(tmp_path: Path, capsys) -> None:
    """--radius 12.5 (mm) gave a 12.5 m roller (pressure angle 0.06 deg), silently."""
    f = tmp_path / 'cam.yaml'
    f.write_text(CHECK, encoding='utf-8')
    assert main(['design', 'profile', str(f), '--follower', 'roller', '--radius', '12.5']) == 2
    assert '--radius: got 12.5; expected a radius in metres (at most 0.5 m); 12.5 looks ' \
           'like millimetres: write 0.0125' in capsys.readouterr().err


def test_reconstruct_roller_radius_in_mm_is_refused(tmp_path: Path, capsys) -> None:
    assert main(['reconstruct', str(_table(tmp_path)), '--follower', 'roller',
                 '--radius', '12.5']) == 2
    assert '--radius: got 12.5; expected a radius in metres (at most 0.5 m); 12.5 looks ' \
           'like millimetres: write 0.0125' in capsys.readouterr().err


@pytest.mark.parametrize('extra, fixed, words', [
    ('base_radius: 16.5\n', '0.008', 'base_radius: got 16.5; expected a radius in metres'),
    ('', '8', 'fixed.max_lift: got 8.0; expected a lift in metres (at most 0.25 m); 8 looks '
              'like millimetres: write 0.008'),
])
def test_optimize_spec_lengths_in_mm_are_refused_up_front(tmp_path: Path, capsys, extra,
                                                          fixed, words) -> None:
    """base_radius 16.5 made every curvature constraint trivially true; max_lift 8 ran
    six SLSQP starts before a 'free: ... every candidate was rejected' refusal."""
    f = tmp_path / 'spec.yaml'
    f.write_text(f'family: constant_acceleration\nfixed: {{max_lift: {fixed}, '
                 'half_duration_deg: 60}\nobjective: fullness\nconstraints: '
                 '{min_radius_of_curvature: 0.005}\n' + extra, encoding='utf-8')
    assert main(['design', 'optimize', str(f)]) == 2
    captured = capsys.readouterr()
    assert words in captured.err and 'start 1/' not in captured.out + captured.err
