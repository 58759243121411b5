"""Reconstruction inputs (CSV, gauge files, messages) and `cam-bench reconstruct`."""
from __future__ import annotations

import json
import math
import types
from pathlib import Path

import numpy as np
import pytest

from cam_design.errors import InputError
from cam_metrology.cli import main
from cam_metrology.inputs.lift_tables import read_csv_table, read_gauge_file, read_table_file
from cam_metrology.reconstruction.synthetic import DEG, PolynomialLobe, simulate
from cam_metrology.wire.layouts import table_from_msg

LOBE = PolynomialLobe()
REPO = Path(__file__).resolve().parent.parent


def write_csv(path: Path, header: str, rows: np.ndarray) -> Path:
    np.savetxt(path, rows, delimiter=',', header=header, comments='')
    return path


def write_gauge(path: Path, radius: str = '12.5', steps: str | None = None,
                rows: list[str] | None = None) -> Path:
    if rows is None:
        ad = np.arange(0.0, 360.0, 1.0)
        hh = LOBE(np.where(ad > 180, ad - 360, ad) * DEG) * 1e3
        rows = [f'{x:.1f}\t{y:.6f}' + ('  M1' if i % 30 == 0 else '')
                for i, (x, y) in enumerate(zip(ad, hh))]
    steps = str(len(rows)) if steps is None else steps
    path.write_text('\n'.join([radius, steps, *rows]) + '\n')
    return path


def msg(label: str, columns: tuple[str, ...], data: np.ndarray) -> types.SimpleNamespace:
    dims = [types.SimpleNamespace(label=label, size=data.shape[0], stride=data.size),
            types.SimpleNamespace(label=','.join(columns), size=data.shape[1],
                                  stride=data.shape[1])]
    return types.SimpleNamespace(layout=types.SimpleNamespace(dim=dims, data_offset=0),
                                 data=data.ravel().tolist())


def test_csv_units_from_column_names(tmp_path):
    a = np.arange(-180.0, 180.0, 1.0)
    p = write_csv(tmp_path / 'x.csv', 'alpha_deg,lift_mm,design_lift_um',
                  np.column_stack([a, LOBE(a * DEG) * 1e3, LOBE(a * DEG) * 1e6]))
    t = read_csv_table(p)
    assert np.allclose(t.alpha, a * DEG)
    assert np.allclose(t.lift, LOBE(a * DEG), atol=1e-15)
    assert np.allclose(t.design, t.lift, atol=1e-15)
    assert t.feature == 'x'


def test_csv_malformed_lines_name_the_line(tmp_path):
    p = tmp_path / 'bad.csv'
    p.write_text('alpha_rad,lift_m\n0.0,0.0\n0.1,abc\n')
    with pytest.raises(InputError, match='bad.csv:3'):
        read_csv_table(p)
    p.write_text('alpha_rad,lift_m\n0.0,0.0\n0.1\n')
    with pytest.raises(InputError, match='bad.csv:3'):
        read_csv_table(p)
    p.write_text('angle,lift_m\n0.0,0.0\n')
    with pytest.raises(InputError, match='header'):
        read_csv_table(p)
    p.write_text('alpha_grad,lift_m\n0.0,0.0\n')
    with pytest.raises(InputError, match='alpha_grad'):
        read_csv_table(p)


def test_gauge_file_default_units_and_markers(tmp_path):
    t = read_gauge_file(write_gauge(tmp_path / 'g.txt'))
    assert t.follower == ('roller', pytest.approx(0.0125))
    assert t.alpha.size == 360
    assert t.alpha[1] == pytest.approx(DEG)
    assert t.lift.max() == pytest.approx(8.3e-3, rel=1e-6)
    assert 'deg' in t.notes[0] and 'mm' in t.notes[0]


def test_gauge_file_unit_override_and_closing_row(tmp_path):
    rows = [f'{math.radians(d):.9f} {1000 * LOBE(math.radians(d if d <= 180 else d - 360)):.4f}'
            for d in range(0, 361)]
    p = write_gauge(tmp_path / 'g.txt', radius='0', steps='360', rows=rows)
    t = read_gauge_file(p, angle_unit='rad', length_unit='um')
    assert t.alpha.size == 361 and t.follower == ('knife', 0.0)
    assert t.lift.max() == pytest.approx(8.3e-6, rel=1e-4)


@pytest.mark.parametrize('kwargs, line', [
    ({'radius': 'abc'}, 1),
    ({'radius': '-1'}, 1),
    ({'steps': '12.5'}, 2),
    ({'steps': '100'}, 362),
    ({'rows': ['0 0', '1 0.1', '2 x', '3 0.3']}, 5),
    ({'rows': ['0 0', '1 0.1 M 7', '2 0.2']}, 4),
    ({'rows': ['0 0', '1 nan', '2 0.2']}, 4),
])
def test_gauge_file_malformed_lines(tmp_path, kwargs, line):
    p = write_gauge(tmp_path / 'g.txt', **kwargs)
    with pytest.raises(InputError, match=f'g.txt:{line}'):
        read_gauge_file(p)


def test_gauge_bad_units_and_missing_file(tmp_path):
    p = write_gauge(tmp_path / 'g.txt')
    with pytest.raises(InputError, match='angle_unit'):
        read_gauge_file(p, angle_unit='grad')
    with pytest.raises(FileNotFoundError):
        read_table_file(tmp_path / 'none.txt')
    assert read_table_file(p).follower[0] == 'roller'


def test_message_tables():
    data = np.column_stack([np.arange(4.0), np.arange(4.0) * 2, np.zeros(4)])
    label, cols, arr = table_from_msg(msg('lobe_1', ('alpha_rad', 'lift_m', 'x'), data))
    assert label == 'lobe_1' and cols == ('alpha_rad', 'lift_m', 'x')
    assert np.array_equal(arr, data)
    bad = msg('lobe_1', ('alpha_rad', 'lift_m', 'x'), data)
    bad.data = bad.data[:-1]
    with pytest.raises(InputError, match='lobe_1.data'):
        table_from_msg(bad)


# --- CLI ---------------------------------------------------------------------------------

def test_cli_table_json(tmp_path, capsys):
    a, h = simulate(LOBE, 720, 0.5e-6, seed=1, outliers=2)
    p = write_csv(tmp_path / 'm.csv', 'alpha_rad,lift_m,design_lift_m',
                  np.column_stack([a, h, LOBE(a)]))
    out = tmp_path / 'r.json'
    assert main(['reconstruct', str(p), '--json', str(out), '--rpm', '3000',
                 '--step-deg', '0.5']) == 0
    doc = json.loads(out.read_text())
    assert doc['kind'] == 'table' and doc['follower']['kind'] == 'flat'
    spl, har = doc['features']['m']['spline'], doc['features']['m']['harmonic']
    for r in (spl, har):
        n = len(r['alpha_rad'])
        assert n == 720
        for key in ('lift_m', 'velocity_m_per_rad', 'acceleration_m_per_rad2',
                    'jerk_m_per_rad3', 'velocity_m_per_s', 'acceleration_m_per_s2'):
            assert len(r[key]) == n
        assert r['rms_residual_m'] < 1e-6 and r['why']
        assert r['design_errors']['rms_error_lift_m'] < 0.5e-6
        assert len(r['outliers_deg']) == 2
        assert len(r['residual_m']) == len(r['residual_alpha_rad']) == 718
    assert spl['smoothing'] > 0 and isinstance(har['order'], int)
    assert har['spectrum']['order'][0] == 0
    omega = 3000 * math.pi / 30
    assert spl['acceleration_m_per_s2'][100] == pytest.approx(
        omega ** 2 * spl['acceleration_m_per_rad2'][100])


def test_cli_human_output_plot_and_caps(tmp_path, capsys):
    a, h = simulate(LOBE, 360, 0.5e-6, seed=2)
    p = write_csv(tmp_path / 't.csv', 'alpha_rad,lift_m', np.column_stack([a, h]))
    assert main(['reconstruct', str(p), '--method', 'harmonic', '--harmonics', '100000',
                 '--plot', str(tmp_path / 'plots')]) == 0
    text = capsys.readouterr().out
    assert 't/harmonic: order' in text and 'Nyquist' in text
    assert (tmp_path / 'plots' / 't.png').stat().st_size > 10_000
    assert main(['reconstruct', str(p), '--json', '-', '--method', 'spline',
                 '--smoothing', '1e-9', '--feature', 'lobe_9']) == 0
    doc = json.loads(capsys.readouterr().out)
    assert list(doc['features']) == ['lobe_9']
    assert doc['features']['lobe_9']['spline']['smoothing'] == pytest.approx(1e-9)


def test_cli_errors_exit_2(tmp_path, capsys):
    g = write_gauge(tmp_path / 'g.txt', steps='7')
    assert main(['reconstruct', str(g)]) == 2
    assert 'g.txt:' in capsys.readouterr().err
    assert main(['reconstruct', str(tmp_path / 'missing.csv')]) == 2
    a, h = simulate(LOBE, 360, 0.5e-6, seed=2)
    p = write_csv(tmp_path / 't.csv', 'alpha_rad,lift_m', np.column_stack([a, h]))
    assert main(['reconstruct', str(p), '--smoothing', '-1']) == 2
    assert main(['reconstruct', str(p), '--harmonics', '-3']) == 2
    assert main(['reconstruct', str(p), '--rpm', '0']) == 2


def test_cli_gauge_file(tmp_path, capsys):
    g = write_gauge(tmp_path / 'g.txt')
    assert main(['reconstruct', str(g), '--json', '-']) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc['follower'] == {'kind': 'roller', 'radius_m': 0.0125,
                               'note': 'no scene: no design follower conversion'}
    spl = doc['features']['g']['spline']
    assert max(spl['lift_m']) == pytest.approx(8.3e-3, abs=1e-7)
    assert spl['parameters']['outliers'] == 0


def test_cli_bag_goes_through_metrology_and_reconstruction(tmp_path, capsys):
    bag = REPO / 'bags' / 'no_pin_no_valve_train'
    if not bag.exists():
        pytest.skip('fixture bag not present')
    assert main(['reconstruct', str(bag), '--json', '-', '--feature', 'lobe_2',
                 '--method', 'spline', '--step-deg', '0.5']) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc['kind'] == 'bag' and list(doc['features']) == ['lobe_2']
    spl = doc['features']['lobe_2']['spline']
    assert spl['ok'] and spl['design_errors']['rms_error_lift_m'] < 1e-6
    assert spl['noise_sigma_m'] == pytest.approx(0.5e-6, rel=0.3)


def test_centre_on_nose_and_cli_option(tmp_path, capsys):
    from cam_design.lift_table.samples import LiftTable, centre_on_nose

    ad = np.arange(0.0, 360.0, 1.0)
    for offset in (0.0, 37.37, 180.0, -120.5):
        rel = (ad - offset + 180.0) % 360.0 - 180.0
        table, shift = centre_on_nose(LiftTable('g', ad * DEG, LOBE(rel * DEG)))
        assert math.degrees(shift) == pytest.approx(offset, abs=1e-3)
        assert 'shifted' in table.notes[-1]
    with pytest.raises(InputError, match='constant'):
        centre_on_nose(LiftTable('g', ad * DEG, np.zeros(ad.size)))
    rows = [f'{d:.1f} {1e3 * LOBE(math.radians((d - 90 + 180) % 360 - 180)):.6f}'
            for d in ad]
    g = write_gauge(tmp_path / 'g.txt', rows=rows)
    assert main(['reconstruct', str(g), '--center-nose', '--method', 'harmonic',
                 '--json', '-']) == 0
    har = json.loads(capsys.readouterr().out)['features']['g']['harmonic']
    assert any('re-centred' in n for n in har['notes'])
    assert har['parameters']['half_angle_rad'] == pytest.approx(math.radians(82), abs=0.05)


def test_cli_rebound_threshold(tmp_path, capsys):
    a, h = simulate(LOBE, 180, 0.0, seed=1)          # 2 deg steps, noise-free
    p = write_csv(tmp_path / 'c.csv', 'alpha_rad,lift_m', np.column_stack([a, h]))
    assert main(['reconstruct', str(p), '--method', 'spline', '--json', '-',
                 '--rebound-threshold', '1e6']) == 0
    spl = json.loads(capsys.readouterr().out)['features']['c']['spline']
    assert spl['parameters']['outliers'] == 0 and spl['max_residual_m'] < 1e-8
    assert main(['reconstruct', str(p), '--rebound-threshold', '0']) == 2


# --- QA findings: nothing reconstructed, bad options, unreadable tables -----------------

def _bag(path: Path, scene: bool, samples: int) -> Path:
    from cam_metrology import bagio

    with bagio.BagWriter(path) as w:
        if scene:
            w.add_topic('/bench/scene', 'std_msgs/msg/String')
            text = (REPO / 'config' / 'default_scene.yaml').read_text()
            w.write('/bench/scene', 1, bagio.encode_string(text))
        if samples:
            w.add_topic(bagio.JOINT_STATES, 'sensor_msgs/msg/JointState')
            for i in range(samples):
                w.write(bagio.JOINT_STATES, 10 + i, bagio.encode_joint_state(
                    'lobe_1', 10 + i, 2 * math.pi * i / samples, 0.0))
    return path


@pytest.mark.parametrize('scene, samples, missing', [(True, 0, '/bench/joint_states'),
                                                     (False, 50, '/bench/scene')])
def test_cli_bag_without_scene_or_samples_fails(tmp_path, capsys, scene, samples, missing):
    bag = _bag(tmp_path / 'b', scene, samples)
    assert main(['reconstruct', str(bag), '--json', '-']) == 2
    captured = capsys.readouterr()
    assert captured.out == ''
    err = captured.err.strip()
    assert len(err.splitlines()) == 1 and f'no {missing} messages' in err


def test_cli_table_with_no_or_too_few_rows_fails(tmp_path, capsys):
    empty = tmp_path / 't_empty.csv'
    empty.write_text('alpha_deg,lift_mm\n')
    assert main(['reconstruct', str(empty), '--json', '-']) == 2
    captured = capsys.readouterr()
    assert captured.out == '' and "t_empty.csv: got '0 data rows'" in captured.err
    few = tmp_path / 'few.csv'
    few.write_text('alpha_deg,lift_mm\n' + ''.join(f'{d},0\n' for d in range(3)))
    assert main(['reconstruct', str(few)]) == 2
    assert "few.csv.alpha: got '3 distinct finite angles'; expected at least 8" in \
        capsys.readouterr().err


@pytest.mark.parametrize('step', ['400', '10.5', '1e-9', '0', '-1', 'nan'])
def test_cli_step_deg_out_of_range_names_the_option(tmp_path, capsys, step):
    a, h = simulate(LOBE, 360, 0.5e-6, seed=2)
    p = write_csv(tmp_path / 't.csv', 'alpha_rad,lift_m', np.column_stack([a, h]))
    assert main(['reconstruct', str(p), '--step-deg', step]) == 2
    err = capsys.readouterr().err
    assert '--step-deg: got' in err and 'expected a step in [0.001, 10] deg' in err


def test_step_deg_limits_are_inclusive_and_checked_in_the_core(tmp_path, capsys):
    from cam_metrology.reconstruction.core import ReconstructionCore

    a, h = simulate(LOBE, 360, 0.5e-6, seed=2)
    p = write_csv(tmp_path / 't.csv', 'alpha_rad,lift_m', np.column_stack([a, h]))
    assert main(['reconstruct', str(p), '--step-deg', '10', '--method', 'spline',
                 '--json', '-']) == 0
    grid = json.loads(capsys.readouterr().out)['features']['t']['spline']['alpha_rad']
    # 10 deg multiples inside the data span (wrapped to (-180, 180] deg): -170 .. 180
    assert np.allclose(np.degrees(grid), np.arange(-170.0, 181.0, 10.0))
    with pytest.raises(InputError, match=r'reconstruction.step_deg: got 400'):
        ReconstructionCore({'step_deg': 400})


@pytest.mark.parametrize('n', ['0', '1', '-3'])
def test_cli_harmonics_below_two_is_rejected(tmp_path, capsys, n):
    a, h = simulate(LOBE, 360, 0.5e-6, seed=2)
    p = write_csv(tmp_path / 't.csv', 'alpha_rad,lift_m', np.column_stack([a, h]))
    assert main(['reconstruct', str(p), '--harmonics', n]) == 2
    assert f'--harmonics: got {n}; expected an integer >= 2' in capsys.readouterr().err


def test_harmonic_order_below_two_and_underfit(tmp_path, capsys):
    from cam_metrology.reconstruction.core import ReconstructionCore
    from cam_metrology.reconstruction.harmonic import HarmonicOptions, reconstruct_harmonic
    from cam_design.lift_table.samples import clean_samples

    a, h = simulate(LOBE, 720, 0.5e-6, seed=3)
    data = clean_samples(a, h)
    for basis in ('section', 'full'):
        for order in (0, 1):
            with pytest.raises(InputError, match='harmonic.order'):
                reconstruct_harmonic(data, HarmonicOptions(basis=basis, order=order))
    with pytest.raises(InputError, match='reconstruction.harmonics: got 1'):
        ReconstructionCore({'harmonics': 1})
    low = reconstruct_harmonic(data, HarmonicOptions(order=2))
    assert low.parameter['order'] == 2 and low.rms_residual > 20 * low.sigma
    assert any('too low for this lobe' in w for w in low.warnings)
    auto = reconstruct_harmonic(data)
    assert auto.rms_residual < 2 * auto.sigma
    assert not any('too low' in w for w in auto.warnings)
    p = write_csv(tmp_path / 't.csv', 'alpha_rad,lift_m', np.column_stack([a, h]))
    assert main(['reconstruct', str(p), '--method', 'harmonic', '--harmonics', '2']) == 0
    assert 'order set by the caller (N = 2) is too low' in capsys.readouterr().out


@pytest.mark.parametrize('content, got', [
    (b'\xff\xfe\x00', "got 'binary data'"),
    (b'angle,lift\n0,0\n1,1\n', "t.csv:header: got 'angle'"),
    (b'# comment\n\ncamshaft_id: X\nlobes: []\n', "t.csv:3: got 'camshaft_id: X'"),
])
def test_cli_unreadable_or_unrecognised_table(tmp_path, capsys, content, got):
    p = tmp_path / 't.csv'
    p.write_bytes(content)
    assert main(['reconstruct', str(p)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and got in err
    assert 'alpha_deg|alpha_rad' in err and 'lift_mm|lift_um|lift_m' in err
    assert 'gauge profile file' in err


@pytest.mark.parametrize('extra, option', [(['--follower', 'knife'], '--follower'),
                                           (['--radius', '0.5'], '--radius'),
                                           (['--center-nose'], '--center-nose'),
                                           (['--angle-unit', 'rad'], '--angle-unit'),
                                           (['--length-unit', 'mm'], '--length-unit')])
def test_cli_table_options_with_a_bag_are_rejected(tmp_path, capsys, extra, option):
    bag = _bag(tmp_path / 'b', True, 50)
    assert main(['reconstruct', str(bag), *extra]) == 2
    err = capsys.readouterr().err
    assert f'{option}: got' in err and 'no value with a BAG' in err


def test_cli_human_output_counts_dropped_rows(tmp_path, capsys):
    a, h = simulate(LOBE, 360, 0.5e-6, seed=2)
    h[[5, 200]] = np.nan
    p = write_csv(tmp_path / 'n.csv', 'alpha_rad,lift_m', np.column_stack([a, h]))
    assert main(['reconstruct', str(p), '--method', 'spline']) == 0
    out = capsys.readouterr().out
    assert out.count('dropped 2 non-finite sample(s)') == 1


def test_noise_free_table_gives_no_rounding_residual_warning():
    """QA: the spline on a noise-free bag warned 'max residual 2.15e-14 m exceeds 7
    noise sigma (6.82e-18 m)'. Rounding-level residuals stay quiet; a real 50 um bump on
    the same table is still reported with its angle."""
    from cam_metrology.reconstruction.profile import reconstruct_table
    from cam_design.lift_table.samples import LiftTable

    a = np.radians(np.arange(-180.0, 180.0, 0.5))
    outcomes = reconstruct_table(LiftTable('t', a, LOBE(a)), methods=('spline',))
    rec = outcomes['spline'].reconstruction
    assert rec is not None and rec.sigma < 1e-12
    assert 0 < rec.max_residual < 1e-9          # rounding level (~1e-14 m), not zero
    assert not [w for w in rec.warnings if 'max residual' in w]
    rec.residual = rec.residual.copy()
    rec.residual[100] = 50e-6
    rec.check_residuals()
    assert any('max residual 5e-05 m at' in w and 'exceeds 1e-09 m' in w
               for w in rec.warnings)
