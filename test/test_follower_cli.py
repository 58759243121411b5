"""`cam-bench design profile` through cam_metrology.cli.main (no ROS)."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from cam_metrology.cli import main


@pytest.fixture()
def table_file(tmp_path: Path) -> Path:
    a = np.linspace(-1.6, 1.6, 161)      # flat-design rho1 >= 5 mm: convex
    h = 0.005 * np.cos(0.5 * math.pi * a / 1.6) ** 4
    path = tmp_path / 'lobe.yaml'
    path.write_text('base_radius: 0.02\nlift:\n  alpha: ' + json.dumps(a.tolist()) +
                    '\n  h: ' + json.dumps(h.tolist()) + '\n')
    return path


def test_profile_csv_flat(table_file: Path, capsys: pytest.CaptureFixture) -> None:
    assert main(['design', 'profile', str(table_file), '--csv', '-', '--step-deg', '1']) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[0].startswith('alpha_rad,x_m,y_m,pitch_x_m')
    rows = np.array([[float(v) for v in ln.split(',')] for ln in lines[1:]])
    assert rows.shape == (360, 14)
    base = np.abs(rows[:, 0]) > 1.65
    assert np.allclose(np.hypot(rows[base, 1], rows[base, 2]), 0.02, atol=1e-12)
    assert np.allclose(rows[base, 5], 0.02, atol=1e-9)       # rho1 = R0 on the base circle


def test_profile_json_roller_converted(table_file: Path, tmp_path: Path) -> None:
    out = tmp_path / 'p.json'
    png = tmp_path / 'p.png'
    rc = main(['design', 'profile', str(table_file), '--follower', 'roller', '--radius',
               '0.008', '--design-follower', 'flat', '--json', str(out), '--plot', str(png),
               '--step-deg', '0.25'])
    assert rc == 0
    doc = json.loads(out.read_text())
    assert doc['kind'] == 'roller' and doc['undercut'] is False
    assert png.stat().st_size > 1000
    cols = doc['columns']
    rows = np.array(doc['rows'])
    x, y = rows[:, cols.index('x_m')], rows[:, cols.index('y_m')]
    # the same cam as the flat design: the flat profile's support function at every normal
    flat = tmp_path / 'f.json'
    assert main(['design', 'profile', str(table_file), '--json', str(flat)]) == 0
    fr = np.array(json.loads(flat.read_text())['rows'])
    theta = fr[:, 0] + math.pi / 2
    support = np.max(np.outer(np.cos(theta), x) + np.outer(np.sin(theta), y), axis=1)
    want = np.cos(theta) * fr[:, 1] + np.sin(theta) * fr[:, 2]
    assert np.max(np.abs(support - want)) < 1e-7      # sampling error (0.25 deg) of the max


def test_profile_text_reports_undercut(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    a = np.linspace(-0.5, 0.5, 101)
    path = tmp_path / 'sharp.yaml'
    path.write_text('alpha: ' + json.dumps(a.tolist()) + '\nh: ' +
                    json.dumps((0.01 * np.cos(math.pi * a) ** 4).tolist()) + '\n')
    rc = main(['design', 'profile', str(path), '--follower', 'roller', '--radius', '0.008',
               '--base-radius', '0.015'])
    assert rc == 0
    assert 'UNDERCUT' in capsys.readouterr().out


@pytest.mark.parametrize('extra', [['--follower', 'offset-roller', '--radius', '0.005',
                                    '--offset', '0.004', '--eta', '-1'],
                                   ['--follower', 'rocker', '--radius', '0.005',
                                    '--centre-distance', '0.045', '--arm-length', '0.035']])
def test_profile_offset_and_rocker(table_file: Path, extra: list[str],
                                   capsys: pytest.CaptureFixture) -> None:
    assert main(['design', 'profile', str(table_file), '--json', '-'] + extra) == 0
    doc = json.loads(capsys.readouterr().out)
    assert 0 < doc['pressure_angle_max_deg'] < 60


@pytest.mark.parametrize('extra,key', [
    (['--follower', 'roller', '--radius', '-0.001'], '--radius'),
    (['--follower', 'roller'], '--radius'),
    (['--follower', 'knife', '--radius', '0.002'], '--radius'),
    (['--base-radius', '-1'], '--base-radius'),
    (['--follower', 'rocker', '--radius', '0.005'], '--centre-distance'),
    (['--step-deg', '0'], '--step-deg'),
    (['--follower', 'offset-roller', '--offset', '0.5'], '--offset'),
    (['--follower', 'offset-roller', '--radius', '0.005', '--offset', '0.01',
      '--delta', '0'], '--delta'),
    (['--follower', 'rocker', '--radius', '0.005', '--centre-distance', '0.5',
      '--arm-length', '0.035'], '--centre-distance'),
    (['--follower', 'rocker', '--radius', '0.005', '--centre-distance', '0.045',
      '--arm-length', '-0.035'], '--arm-length'),
    (['--design-follower', 'roller'], '--design-radius'),
    (['--design-follower', 'knife', '--design-radius', '0.01'], '--design-radius'),
    (['--follower', 'rocker', '--radius', '0.005', '--centre-distance', '0.045',
      '--arm-length', '0.035', '--design-follower', 'flat'], '--design-follower'),
])
def test_profile_bad_input(table_file: Path, extra: list[str], key: str,
                           capsys: pytest.CaptureFixture) -> None:
    assert main(['design', 'profile', str(table_file)] + extra) == 2
    err = capsys.readouterr().err
    assert f'error: {key}: got' in err


def test_profile_unknown_follower(capsys: pytest.CaptureFixture) -> None:
    with pytest.raises(SystemExit):
        main(['design', 'profile', 'x.yaml', '--follower', 'mushroom'])
    assert 'mushroom' in capsys.readouterr().err


@pytest.mark.parametrize('text,message', [
    ('alpha: [0, 1, 2, 3, 4, 5]\nh: [0, 0, 0, 0, 0, 0]\n', 'error: --base-radius: got'),
    ('base_radius: 0.02\nlift: {alpha: [0, 1, x, 3, 4, 5], h: [0, 0, 0, 0, 0, 0]}\n',
     'error: lift.alpha: got'),
])
def test_profile_bad_file(tmp_path: Path, text: str, message: str,
                          capsys: pytest.CaptureFixture) -> None:
    path = tmp_path / 'bad.yaml'
    path.write_text(text)
    assert main(['design', 'profile', str(path)]) == 2
    assert message in capsys.readouterr().err


def test_profile_from_spec(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    path = tmp_path / 'spec.yaml'
    path.write_text('base_radius: 0.0165\n'
                    'lift_law: {family: preset, name: flat_tappet_intake}\n')
    assert main(['design', 'profile', str(path), '--json', '-']) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc['undercut'] is False
    assert doc['rho_min_m'] == pytest.approx(4.32e-3, abs=0.02e-3)   # registry comment


@pytest.mark.parametrize('delta', ['1', '-1'])
def test_profile_rocker_polar_columns(table_file: Path, delta: str,
                                      capsys: pytest.CaptureFixture) -> None:
    args = ['design', 'profile', str(table_file), '--follower', 'rocker', '--radius', '0.005',
            '--centre-distance', '0.045', '--arm-length', '0.035', '--delta', delta,
            '--polar', '--json', '-', '--step-deg', '2']
    assert main(args) == 0
    doc = json.loads(capsys.readouterr().out)
    rows = np.array(doc['rows'])
    col = doc['columns'].index
    rho = rows[:, col('polar_rho_m')]
    assert np.allclose(rho, np.hypot(rows[:, col('pitch_x_m')], rows[:, col('pitch_y_m')]),
                       rtol=0, atol=1e-15)
    assert main(args[:-4] + ['--eta', '-1']) == 2
    assert 'error: --polar: got' in capsys.readouterr().err


def test_profile_csv_carries_the_converted_lift(tmp_path: Path,
                                                capsys: pytest.CaptureFixture) -> None:
    # the CLI as a conversion tool: an eccentric disc written for a flat tappet, seen by
    # a 8 mm roller: D = e cos a + sqrt((Rc + r)^2 - e^2 sin^2 a) (methods §2.2)
    rc, e, r = 0.02, 0.005, 0.008
    a = np.linspace(-math.pi, math.pi, 721)
    path = tmp_path / 'disc.yaml'
    path.write_text(f'base_radius: {rc - e}\nalpha: {json.dumps(a.tolist())}\n'
                    f'h: {json.dumps((e * (1 + np.cos(a))).tolist())}\n')
    assert main(['design', 'profile', str(path), '--follower', 'roller', '--radius', str(r),
                 '--design-follower', 'flat', '--csv', '-', '--step-deg', '1']) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    names = lines[0].split(',')
    rows = np.array([[float(v) for v in ln.split(',')] for ln in lines[1:]])
    x = rows[:, names.index('alpha_rad')]
    want = e * np.cos(x) + np.sqrt((rc + r) ** 2 - (e * np.sin(x)) ** 2) - (rc - e + r)
    assert np.max(np.abs(rows[:, names.index('lift_m')] - want)) < 1e-10   # table spline
    assert 'jerk_m_per_rad3' in names


def test_profile_of_a_scene_lobe(capsys: pytest.CaptureFixture) -> None:
    scene = str(Path(__file__).resolve().parent.parent / 'config' / 'default_scene.yaml')
    # lobe_1 is designed for a flat tappet: its flat profile, then seen by a 2 mm ball
    assert main(['design', 'profile', scene, '--lobe', 'lobe_1', '--json', '-']) == 0
    flat = json.loads(capsys.readouterr().out)
    assert flat['rho_min_m'] == pytest.approx(4.32e-3, abs=0.02e-3)   # preset comment
    assert main(['design', 'profile', scene, '--lobe', 'lobe_1', '--follower', 'roller',
                 '--radius', '0.002', '--json', '-']) == 0
    ball = json.loads(capsys.readouterr().out)
    assert ball['rho_min_m'] == pytest.approx(flat['rho_min_m'], abs=2e-6)   # same cam
    assert main(['design', 'profile', scene, '--lobe', 'nope']) == 2
    assert 'error: --lobe: got' in capsys.readouterr().err
    # no --lobe: the first lobe, as `design law` and `design check` (QA #26)
    assert main(['design', 'profile', scene, '--json', '-']) == 0
    first = json.loads(capsys.readouterr().out)
    assert first['lobe'] == 'lobe_1' and first['rho_min_m'] == flat['rho_min_m']
    assert main(['design', 'profile', scene]) == 0
    assert capsys.readouterr().out.startswith('lobe_1 flat: 720 points')
    assert main(['design', 'profile', scene, '--lobe', 'lobe_1', '--base-radius',
                 '0.02']) == 2
    assert 'error: --base-radius' in capsys.readouterr().err


def test_profile_json_is_strict_json(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    # an infinite radius (a straight pitch piece) would be written as null, never Infinity
    a = np.linspace(-1.2, 1.2, 241)
    path = tmp_path / 'lobe.yaml'
    path.write_text('base_radius: 0.02\nalpha: ' + json.dumps(a.tolist()) + '\nh: ' +
                    json.dumps((0.004 * np.cos(0.5 * math.pi * a / 1.2) ** 4).tolist()) + '\n')
    assert main(['design', 'profile', str(path), '--follower', 'knife', '--json', '-']) == 0
    text = capsys.readouterr().out
    assert 'Infinity' not in text and 'NaN' not in text
    json.loads(text)


@pytest.mark.parametrize('step', ['10.5', '30', '0.0009', 'inf', 'nan'])
def test_profile_step_limits(table_file: Path, capsys: pytest.CaptureFixture,
                             step: str) -> None:
    assert main(['design', 'profile', str(table_file), '--step-deg', step]) == 2
    err = capsys.readouterr().err
    assert '--step-deg: got' in err and 'a step in [0.001, 10] deg' in err
    # the upper limit itself: 36 points per turn, exactly 10 deg apart
    assert main(['design', 'profile', str(table_file), '--step-deg', '10', '--csv', '-']) == 0
    alpha = [float(ln.split(',')[0]) for ln in capsys.readouterr().out.split()[1:]]
    assert len(alpha) == 36 and np.allclose(np.diff(np.degrees(alpha)), 10.0)


def test_docs_table_example_is_a_realistic_lobe(tmp_path: Path,
                                                capsys: pytest.CaptureFixture) -> None:
    """docs/lift_laws.md `family: table` example (QA #29): the interpolant stays on or
    above the base circle and follows the preset it was tabulated from."""
    import re

    import yaml

    from cam_design.lift_laws import from_spec

    text = (Path(__file__).resolve().parent.parent / 'docs' / 'lift_laws.md').read_text()
    blocks = [b for b in re.findall(r'```yaml\n(.*?)```', text, re.S) if 'family: table' in b]
    assert len(blocks) == 1
    spec = yaml.safe_load(blocks[0])['lift_law']
    law = from_spec(spec, 'docs')
    preset = from_spec({'family': 'preset', 'name': 'flat_tappet_intake'}, 'preset')
    grid = np.linspace(*law.support, 20001)
    assert float(np.min(law(grid))) >= 0.0
    assert float(np.max(np.abs(law(grid) - preset(grid)))) < 2.5e-6
    path = tmp_path / 'table.yaml'
    path.write_text(yaml.safe_dump({'base_radius': 0.0165, 'lift_law': spec}))
    assert main(['design', 'profile', str(path), '--json', '-']) == 0
    doc = json.loads(capsys.readouterr().out)
    lift = np.array([row[doc['columns'].index('lift_m')] for row in doc['rows']])
    assert lift.min() >= 0.0 and lift.max() == pytest.approx(8.5e-3, abs=1e-7)
    assert doc['undercut'] is False
    # the preset's 4.32 mm (test_profile_from_spec) within what the 5 deg table gives
    # for h'' (0.6 mm/rad^2 off near +-28 deg): rho1 = R0 + h + h''
    assert doc['rho_min_m'] == pytest.approx(4.32e-3, abs=0.2e-3)
