"""`cam-bench design law|check|rocker` through cam_metrology.cli.main (no subprocess)."""
from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from cam_metrology.cli import main

CHECK = """\
lift_law: {family: preset, name: flat_tappet_intake}
base_radius: 0.0165
rocker_ratio: 1.0
lash: 0.0002
cam_speed_rpm: 3000
valve: {seat_diameter: 0.030, seat_angle: 0.7853981633974483, seat_width: 0.0015}
spring: {preload: 250.0, rate: 30000.0}
masses: {valve: 0.045, spring: 0.040, retainer: 0.012, tappet: 0.050}
contact: {width: 0.012, youngs_modulus: 2.06e11}
lubrication: {k_film: 1.0e-4}
piston: {crank_radius: 0.040, rod_length: 0.140, clearance: 0.0012,
         opening_crank_angle: -0.3141592653589793}
"""


def test_rocker_json(capsys: pytest.CaptureFixture) -> None:
    """#1 through the CLI (lengths in m)."""
    rc = main(['design', 'rocker', '--arm-length', '0.0458', '--base-radius', '0.0323',
               '--max-swing-deg', '7.865', '--eccentricity', '0.0009', '--json', '-'])
    assert rc == 0
    out = json.loads(capsys.readouterr().out)
    assert out['eta_deg'] == pytest.approx(3.089302, abs=2e-6)
    assert out['frame_length_m'] == pytest.approx(0.057501894, abs=2e-9)
    assert out['projected_frame_length_m'] == pytest.approx(0.057494851, abs=2e-9)
    assert out['delta_deg'] == pytest.approx(0.118066, abs=1e-6)


def test_rocker_bad_input(capsys: pytest.CaptureFixture) -> None:
    """Bad input -> exit 2 with the key in the message."""
    rc = main(['design', 'rocker', '--arm-length', '-1', '--base-radius', '0.0323',
               '--max-swing-deg', '7.865'])
    assert rc == 2
    assert '--arm-length' in capsys.readouterr().err


def test_law_csv_json_plot(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    """design law: CSV to a file, JSON to stdout, a PNG plot."""
    spec = tmp_path / 'law.yaml'
    spec.write_text('lift_law: {family: preset, name: methods_example}\n')
    csv, png = tmp_path / 'law.csv', tmp_path / 'law.png'
    rc = main(['design', 'law', str(spec), '--step-deg', '0.5', '--csv', str(csv),
               '--json', '-', '--plot', str(png)])
    assert rc == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc['support_deg'] == pytest.approx([-80, 80])
    assert doc['max_lift_mm'] == pytest.approx(8.3)
    rows = doc['rows']
    assert len(rows) == 321
    nose = rows[160]
    assert nose[0] == pytest.approx(0.0, abs=1e-12)
    assert nose[3] == pytest.approx(-44.65130, abs=1e-5)
    lines = csv.read_text().splitlines()
    assert lines[0] == 'alpha_deg,h_mm,h1_mm_per_rad,h2_mm_per_rad2,h3_mm_per_rad3'
    assert len(lines) == 322
    assert png.stat().st_size > 1000


def test_law_table_stdout_and_errors(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    """Plain table; bad family, bad YAML and a bad step exit 2."""
    spec = tmp_path / 'law.yaml'
    spec.write_text('family: preset\nname: flat_tappet_intake\n')
    assert main(['design', 'law', str(spec), '--step-deg', '10']) == 0
    assert 'max lift 8.500000 mm' in capsys.readouterr().out
    assert main(['design', 'law', str(spec), '--step-deg', '0']) == 2
    bad = tmp_path / 'bad.yaml'
    bad.write_text('lift_law: {family: nope}\n')
    assert main(['design', 'law', str(bad)]) == 2
    assert 'lift_law.family' in capsys.readouterr().err
    bad.write_text('lift_law: [unclosed\n')
    assert main(['design', 'law', str(bad)]) == 2
    assert main(['design', 'law', str(tmp_path / 'missing.yaml')]) == 2


def test_check_json(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    """design check: every section in the JSON."""
    f = tmp_path / 'check.yaml'
    f.write_text(CHECK)
    assert main(['design', 'check', str(f), '--json', '-']) == 0
    out = json.loads(capsys.readouterr().out)
    for key in ('fullness', 'min_rho1_mm', 'max_flow_area_mm2', 'time_area_mm2_deg',
                'equivalent_mass_kg', 'no_separation', 'max_hertz_stress_mpa',
                'oil_film_nose_gamma', 'min_valve_piston_clearance_mm'):
        assert key in out
    assert out['no_separation'] is True
    assert math.isfinite(out['max_hertz_stress_mpa'])
    f.write_text(CHECK.replace('rocker_ratio: 1.0', 'rocker_ratio: -1.0'))
    assert main(['design', 'check', str(f)]) == 2
    assert 'error: rocker_ratio: got' in capsys.readouterr().err


def test_law_from_scene_lobe(capsys: pytest.CaptureFixture) -> None:
    """design law on a scene file selects a lobe by id (default scene, lobe_2)."""
    from pathlib import Path

    scene = Path(__file__).resolve().parent.parent / 'config' / 'default_scene.yaml'
    assert main(['design', 'law', str(scene), '--lobe', 'lobe_2', '--step-deg', '30',
                 '--json', '-']) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc['max_lift_mm'] == pytest.approx(7.9, abs=1e-9)
    assert main(['design', 'law', str(scene), '--lobe', 'nope']) == 2
    assert '--lobe' in capsys.readouterr().err


def test_check_roller_follower(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    """design check with a roller follower: pressure angle reported, no oil film."""
    f = tmp_path / 'check.yaml'
    f.write_text(CHECK + 'follower: {kind: roller, radius: 0.012}\n')
    assert main(['design', 'check', str(f), '--json', '-']) == 0
    out = json.loads(capsys.readouterr().out)
    assert out['follower'] == 'roller'
    assert 0 < out['pressure_angle_max_deg'] < 45
    assert 'oil_film_nose_gamma' not in out
    f.write_text(CHECK + 'follower: {kind: wheel}\n')
    assert main(['design', 'check', str(f)]) == 2
    assert 'error: follower.kind: got' in capsys.readouterr().err


def test_check_scene_lobe(capsys: pytest.CaptureFixture) -> None:
    """design check on the default scene: base circle, design follower and valve train
    from the scene (tappet-side mass = M k^2), speed override with --rpm."""
    from pathlib import Path

    import yaml

    scene = Path(__file__).resolve().parent.parent / 'config' / 'default_scene.yaml'
    vt = {k: v if isinstance(v, list) else float(v)      # PyYAML reads 1.2e7 as a string
          for k, v in yaml.safe_load(scene.read_text())['valve_train'].items()
          if k in ('rocker_ratio', 'mass', 'stiffness')}
    assert main(['design', 'check', str(scene), '--lobe', 'lobe_1', '--rpm', '1000',
                 '--json', '-']) == 0
    out = json.loads(capsys.readouterr().out)
    k = vt['rocker_ratio']
    assert out['equivalent_mass_kg'] == pytest.approx(vt['mass'] * k * k)
    assert out['natural_period_cam_deg'] == pytest.approx(
        math.degrees(1000 * math.pi / 30 * 2 * math.pi * math.sqrt(vt['mass'] / vt['stiffness'])))
    assert out['no_separation'] is True


@pytest.mark.parametrize('args, flag, value', [
    (['--max-swing-deg', '60'], '--max-swing-deg', '60.0'),
    (['--max-swing-deg', '7.865', '--eccentricity', '0.1'], '--eccentricity', '0.1'),
    (['--max-swing-deg', '7.865', '--arm-length', '1e300'], '--arm-length', '1e+300')])
def test_rocker_errors_name_the_option(args: list[str], flag: str, value: str,
                                       capsys: pytest.CaptureFixture) -> None:
    """QA: errors from the synthesis name the option and the value as typed (deg for
    the swing, not 'max_swing: got 1.047...' in rad), and never a traceback."""
    base = ['design', 'rocker', '--arm-length', '0.0458', '--base-radius', '0.0323']
    assert main(base + args) == 2
    err = capsys.readouterr().err
    assert f'{flag}: got {value};' in err and 'Traceback' not in err


@pytest.mark.parametrize('what', ['law', 'check', 'profile'])
def test_unreadable_inputs_are_one_line_errors(what: str, tmp_path: Path,
                                               capsys: pytest.CaptureFixture) -> None:
    """QA: a directory or a binary file as FILE gave IsADirectoryError /
    UnicodeDecodeError tracebacks (exit 1); a YAML syntax error gave a 5-line message.
    Each must be one line naming the file, exit 2."""
    binary = tmp_path / 'b.yaml'
    binary.write_bytes(b'\xff\xfe\x00garbage')
    broken = tmp_path / 'c.yaml'
    broken.write_text('lift_law: {family: preset, name: [unclosed\n')
    for path, got in ((tmp_path, 'a directory'), (binary, 'binary data'),
                      (broken, 'invalid YAML'), (tmp_path / 'missing.yaml', 'no such file')):
        assert main(['design', what, str(path)]) == 2
        err = capsys.readouterr().err
        assert f"{path}: got '{got}'" in err and len(err.strip().splitlines()) == 1, err


def test_law_and_check_accept_a_tabulated_scene_lobe(tmp_path: Path,
                                                     capsys: pytest.CaptureFixture) -> None:
    """QA: a scene lobe given as `lift: {alpha, h}` (as in every bags/ fixture scene) was
    rejected by `design law|check SCENE` ("expected a lobe with a lift_law mapping"). It
    is the `table` family: the interpolant passes through the samples (h(0) = 3 mm)."""
    scene = tmp_path / 'scene.yaml'
    scene.write_text('camshaft_id: x\nbase_circle_radius: 0.0165\n'
                     'probe: {kind: flat, radius: 0}\nlobes:\n  - id: lobe_1\n'
                     '    lift: {alpha: [-0.3, -0.2, -0.1, 0, 0.1, 0.2, 0.3],\n'
                     '           h: [0, 1.0e-3, 2.0e-3, 3.0e-3, 2.0e-3, 1.0e-3, 0]}\n')
    assert main(['design', 'law', str(scene), '--step-deg', '0.5', '--json', '-']) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc['family'] == 'table'
    assert doc['support_deg'] == pytest.approx([-math.degrees(0.3), math.degrees(0.3)])
    assert doc['max_lift_mm'] == pytest.approx(3.0, abs=1e-12)
    assert math.isclose(doc['rows'][0][1], 0.0, abs_tol=1e-12)
    assert main(['design', 'check', str(scene), '--json', '-']) == 0
    assert json.loads(capsys.readouterr().out)['max_lift_mm'] == pytest.approx(3.0)


def test_check_errors_use_the_users_keys(tmp_path: Path,
                                         capsys: pytest.CaptureFixture) -> None:
    """QA: `design check` errors named internal keys: `check.follower.radius`,
    `seat_angle` (for valve.seat_angle), `check.cam_speed_rpm` for `--rpm 0`, and
    `check.spring.preload` for a scene's valve_train.spring_preload."""
    base = ('lift_law: {family: preset, name: flat_tappet_intake}\nbase_radius: 0.0165\n'
            'cam_speed_rpm: 3000\nspring: {preload: 250.0, rate: 30000.0}\n'
            'equivalent_mass: 0.1\n')
    cases = [('follower: {kind: roller}\n', [], 'follower.radius: got None;'),
             ('valve: {seat_diameter: 0.03, seat_angle: 45, seat_width: 0.0015}\n', [],
              'valve.seat_angle: got 45'),
             ('', ['--rpm', '0'], '--rpm: got 0.0;')]
    for i, (extra, opts, want) in enumerate(cases):
        f = tmp_path / f'c{i}.yaml'
        f.write_text(base + extra)
        assert main(['design', 'check', str(f)] + opts) == 2
        assert f'error: {want}' in capsys.readouterr().err
    scene = Path(__file__).resolve().parent.parent / 'config' / 'default_scene.yaml'
    bad = tmp_path / 'scene.yaml'
    bad.write_text(scene.read_text().replace('spring_preload: 250.0', 'spring_preload: -250.0'))
    assert main(['design', 'check', str(bad)]) == 2
    assert 'error: valve_train.spring_preload: got -250.0;' in capsys.readouterr().err
