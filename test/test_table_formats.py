"""Lift tables as gauges and spreadsheets really write them: a byte-order mark, Windows
line ends, tab or semicolon separators with decimal commas, a spreadsheet's ``sep=;``
line, trailing empty columns, text columns, a header repeated mid-file (files exported
in parts), gauge files with decimal commas. Each must read to the numbers written
(cosine lobe h = L/2 (1 + cos(pi alpha / beta)), checked row by row), or be refused in
one line naming the file and line."""
from __future__ import annotations

import math

import numpy as np
import pytest

from cam_design.errors import InputError
from cam_metrology.inputs.lift_tables import read_csv_table, read_table_file

L_MM, BETA_DEG = 8.0, 60.0
ANGLES = np.arange(-180.0, 180.0, 1.0)


def lobe_mm(a_deg: np.ndarray) -> np.ndarray:
    a = np.asarray(a_deg, dtype=float)
    return np.where(np.abs(a) < BETA_DEG,
                    0.5 * L_MM * (1.0 + np.cos(np.pi * a / BETA_DEG)), 0.0)


def rows(sep: str, decimal: str = '.', extra: str = '') -> list[str]:
    return [f'{a:.1f}'.replace('.', decimal) + sep + f'{h:.5f}'.replace('.', decimal) + extra
            for a, h in zip(ANGLES, lobe_mm(ANGLES))]


def check(table) -> None:
    assert table.alpha.size == ANGLES.size
    assert np.allclose(table.alpha, np.radians(ANGLES), atol=1e-12)
    assert np.allclose(table.lift, lobe_mm(ANGLES) * 1e-3, atol=6e-9)   # 5 decimals in mm


@pytest.mark.parametrize('name, text', [
    ('bom_crlf', '\ufeffalpha_deg,lift_mm\r\n' + '\r\n'.join(rows(',')) + '\r\n'),
    ('tab_decimal_comma', 'alpha_deg\tlift_mm\n' + '\n'.join(rows('\t', ',')) + '\n'),
    ('semicolon_decimal_comma', 'alpha_deg;lift_mm\n' + '\n'.join(rows(';', ',')) + '\n'),
    ('excel_sep_line', 'sep=;\nalpha_deg;lift_mm\n' + '\n'.join(rows(';', ',')) + '\n'),
    ('trailing_empty_columns', 'alpha_deg,lift_mm,,\n' + '\n'.join(rows(',', '.', ',,'))),
    ('text_column', 'alpha_deg,lift_mm,status\n' + '\n'.join(rows(',', '.', ',OK'))),
    ('unit_row', 'Angle;Lift;Note\n[deg];[mm];\n' + '\n'.join(rows(';', ',', ';x'))),
    ('unit_row_units_twice', 'alpha_deg,lift_mm\ndeg,mm\n' + '\n'.join(rows(','))),
])
def test_csv_dialects_read_the_numbers_written(tmp_path, name, text) -> None:
    path = tmp_path / f'{name}.csv'
    path.write_bytes(text.encode('utf-8'))
    check(read_table_file(path))


def test_empty_cells_are_missing_readings_dropped_and_counted(tmp_path) -> None:
    body = rows(',')
    body[190] = body[190].split(',')[0] + ','     # no reading at 10 deg
    path = tmp_path / 'gaps.csv'
    path.write_text('alpha_deg,lift_mm\n' + '\n'.join(body) + '\n', encoding='utf-8')
    table = read_csv_table(path)
    assert np.isnan(table.lift[190]) and np.count_nonzero(np.isnan(table.lift)) == 1
    keep = ~np.isnan(table.lift)
    assert np.allclose(table.lift[keep], lobe_mm(ANGLES)[keep] * 1e-3, atol=6e-9)
    assert any('1 empty cell(s)' in n for n in table.notes)
    path.write_text('alpha_deg,lift_mm\n0.5\n' + '\n'.join(body) + '\n', encoding='utf-8')
    with pytest.raises(InputError, match='gaps.csv:2: .*2 values'):
        read_csv_table(path)           # a row without its separator is still an error


def test_header_repeated_mid_file_is_skipped_and_counted(tmp_path) -> None:
    body = rows(',')
    path = tmp_path / 'parts.csv'
    path.write_text('alpha_deg,lift_mm\n' + '\n'.join(body[:180]) + '\nalpha_deg,lift_mm\n'
                    + '\n'.join(body[180:]) + '\n', encoding='utf-8')
    table = read_csv_table(path)
    check(table)
    assert any('skipped 1 repeated header' in n for n in table.notes)


def test_a_bad_value_in_a_used_column_still_names_the_line(tmp_path) -> None:
    body = rows(',', '.', ',x')
    body[10] = body[10].replace(',', ',oops', 1)
    path = tmp_path / 'bad.csv'
    path.write_text('alpha_deg,lift_mm,note\n' + '\n'.join(body) + '\n', encoding='utf-8')
    with pytest.raises(InputError, match=r'bad.csv:12: .*numbers in the columns alpha_deg'):
        read_csv_table(path)


@pytest.mark.parametrize('radius, sep, decimal, bom', [
    ('12,5', ' ', ',', False), ('12,5', ';', ',', False), ('12,5', '\t', ',', True),
    ('12.5', ' ', '.', True),
])
def test_gauge_file_with_decimal_commas_and_bom(tmp_path, radius, sep, decimal, bom) -> None:
    a = np.arange(0.0, 360.0, 1.0)
    h = lobe_mm(np.mod(a + 180.0, 360.0) - 180.0)
    body = [f'{x:.1f}'.replace('.', decimal) + sep + f'{y:.5f}'.replace('.', decimal)
            for x, y in zip(a, h)]
    text = ('\ufeff' if bom else '') + f'{radius}\r\n360\r\n' + '\r\n'.join(body) + '\r\n'
    path = tmp_path / 'gauge.txt'
    path.write_bytes(text.encode('utf-8'))
    table = read_table_file(path)
    assert table.follower == ('roller', pytest.approx(0.0125, abs=1e-15))
    assert np.allclose(table.alpha, np.radians(a), atol=1e-12)
    assert np.allclose(table.lift, h * 1e-3, atol=6e-9)
    assert float(table.lift.max()) == pytest.approx(L_MM * 1e-3, abs=1e-12)


@pytest.mark.parametrize('line, fields', [
    ('10,5 8', ['10.5', '8']), ('10,5', ['10', '5']), ('10, 5', ['10', '5']),
    ('10 ,5', ['10', '5']), ('0,5;8,0000', ['0.5', '8.0000']), ('10.5,8.2', ['10.5', '8.2']),
    ('1,5\t2,25 M', ['1.5', '2.25', 'M'])])
def test_gauge_decimal_comma_rule(line, fields) -> None:
    """A comma is a decimal comma only in a line without a decimal point whose fields
    are already separated by blanks, semicolons or tabs, and never at a field's edge."""
    from cam_metrology.inputs.lift_tables import _gauge_fields

    assert _gauge_fields(line) == fields


def test_gauge_row_with_commas_as_separators_is_still_two_numbers(tmp_path) -> None:
    """'10,0.5' has a decimal point: the comma separates (angle 10, lift 0.5); '10,5'
    alone on a row stays angle 10, lift 5 (a separator, as before)."""
    a = np.arange(0.0, 360.0, 10.0)
    path = tmp_path / 'g.txt'
    body = [f'{x:.0f},{math.cos(math.radians(x)) + 1:.4f}' for x in a]
    path.write_text('0\n36\n' + '\n'.join(body) + '\n', encoding='utf-8')
    table = read_table_file(path)
    assert np.allclose(table.lift, (np.cos(np.radians(a)) + 1.0) * 1e-3, atol=1e-7)


# --------------------------------------------------------------- base circle off zero
def test_probe_zero_offset_is_taken_off_and_said() -> None:
    """A table whose base circle reads -0.05 mm (probe zeroed 0.05 mm high), and one at
    +0.5 mm: the lobe is measured from its base circle on every route (card, the
    reconstruction's fits), max lift 8 mm above it, the events at 1 mm those of the
    table from 0, and a warning says where the base circle was. A base circle with 15
    um run-out about 0, or 0.01 mm rounding, is left alone. (The +0.5 mm table used to
    be refused with a max lift of 3e33 mm: its joins to a base circle at 0.)"""
    from cam_metrology.cli.card import table_card
    from cam_metrology.reconstruction.profile import reconstruct_table
    from cam_design.lift_table.lobe_table import lobe_law
    from cam_design.lift_table.samples import LiftTable

    a = np.radians(ANGLES)
    h = lobe_mm(ANGLES) * 1e-3
    zero = table_card(a, h, (1e-3,), 'zero.csv')
    assert 'warning' not in zero
    for shift, text in ((-5e-5, '-0.0500'), (5e-4, '+0.5000')):
        card = table_card(a, h + shift, (1e-3,), 'offset.csv')
        assert card['max_lift_mm'] == pytest.approx(L_MM, abs=1e-4)
        assert f'base circle is at {text} mm' in card['warning']
        assert f'max lift above it {L_MM:.4f} mm' in card['warning']
        for key in ('opening_deg', 'closing_deg'):
            assert card['heights'][0][key] == pytest.approx(zero['heights'][0][key], abs=1e-6)
        rec = reconstruct_table(LiftTable('offset', a, h + shift), methods=('spline',))
        spline = rec['spline'].reconstruction
        assert any(f'base circle is at {text} mm' in w for w in spline.warnings)
        assert float(np.max(spline.lift)) == pytest.approx(L_MM * 1e-3, abs=2e-6)
    runout = 7.5e-6 * np.sin(a) * (np.abs(ANGLES) >= BETA_DEG)
    for rows in (h + runout, np.round(h / 1e-5) * 1e-5):
        assert not any('base circle is at' in w for w in lobe_law(a, rows).lobe.warnings)


def test_part_turn_table_on_a_flat_stretch_off_zero_is_refused() -> None:
    """Part of the turn (-120..120 deg) with the base circle at +0.5 mm: no base level
    is taken off a part-turn table (its lower quartile may be a ramp), and no join from
    0 fits a flat end (it spanned more than the turn, and the table was refused as a
    lobe of '0 mm' lift): a one-line refusal naming the flat stretch and what works."""
    from cam_design.errors import InputError
    from cam_design.lift_table.lobe_table import lobe_law

    deg = ANGLES[np.abs(ANGLES) <= 120.0]
    with pytest.raises(InputError) as err:
        lobe_law(np.radians(deg), lobe_mm(deg) * 1e-3 + 5e-4, key='part.csv')
    text = str(err.value)
    assert 'part.csv' in text and 'flat stretch at 0.5 mm' in text
    assert 'subtract the base-circle level or give the whole turn' in text


def test_dynamics_table_with_an_offset_base_circle_says_so(tmp_path, capsys) -> None:
    """dynamics TABLE: at 200 rpm the valve opens where k h = x0 + F0 / c (quasi-static,
    h of the cosine lobe): within 0.05 deg for the table from 0, and for the table
    zeroed 0.05 mm high too (the lash is set on the base circle, wherever the probe's
    zero was), with a note saying where the base circle was."""
    import json

    from cam_metrology.cli import main

    vt = tmp_path / 'vt.yaml'
    vt.write_text('valve_train: {model: sdof, rocker_ratio: 1.5, lash: 0.00025, mass: 0.12, '
                  'stiffness: 1.2e7, damping: 60.0, spring_rate: 3.0e4, '
                  'spring_preload: 250.0, seat: {stiffness: 1.0e9, damping: 2000.0}, '
                  'cam_speed_rpm: [200]}\n', encoding='utf-8')
    h_open = (0.25e-3 + 250.0 / 1.2e7) / 1.5 * 1e3   # mm
    truth = -BETA_DEG / math.pi * math.acos(2.0 * h_open / L_MM - 1.0)
    opened = {}
    for name, shift in (('zero', 0.0), ('offset', -0.05)):
        path = tmp_path / f'{name}.csv'
        path.write_text('alpha_deg,lift_mm\n' + '\n'.join(
            f'{a:.0f},{h + shift:.5f}' for a, h in zip(ANGLES, lobe_mm(ANGLES))) + '\n')
        out = tmp_path / f'{name}.json'
        assert main(['dynamics', str(path), '--valve-train', str(vt), '--step-deg', '0.5',
                     '--json', str(out)]) == 0
        (feature,) = json.loads(out.read_text())['features'].values()
        opened[name] = feature
    err = capsys.readouterr().err
    assert err.count('base circle is at -0.0500 mm') == 1
    for name in ('zero', 'offset'):
        assert opened[name]['runs'][0]['opening_deg'] == pytest.approx(truth, abs=0.05)


def test_harmonic_order_on_angles_in_radians_rounded_to_6_decimals() -> None:
    """The cosine lobe every 1 deg with its angles written in rad to 6 decimals (as a
    spreadsheet does): the Gram matrix of the order search is then numerically singular
    and its QR fallback used to give wrong projections, so BIC chose N = 2 (rms residual
    54 um). The order and the fit must match those of the exact angles."""
    from cam_metrology.reconstruction.profile import reconstruct_table
    from cam_design.lift_table.samples import LiftTable

    h = np.round(lobe_mm(ANGLES), 6) * 1e-3
    recs = [reconstruct_table(LiftTable('t', a, h), methods=('harmonic',))['harmonic']
            .reconstruction for a in (np.radians(ANGLES), np.round(np.radians(ANGLES), 6))]
    exact, rounded = recs
    assert rounded.why == exact.why
    assert float(np.sqrt(np.mean(rounded.residual ** 2))) < 1e-6
    assert float(np.max(rounded.lift)) == pytest.approx(L_MM * 1e-3, abs=1e-6)


# ------------------------------------------------------------------ scene nominal files
def _gauge_0_360(decimal: str = '.', angle=np.degrees, scale: float = 1.0) -> str:
    """The cosine lobe as a gauge writes it: 0..360 deg, the nose at 0 and 360."""
    a = np.arange(0.0, 361.0, 1.0)
    h = lobe_mm(np.mod(a + 180.0, 360.0) - 180.0) * scale
    rows_ = [f'{x:.6f}'.replace('.', decimal) + ' ' + f'{y:.5f}'.replace('.', decimal)
             for x, y in zip(angle(np.radians(a)), h)]
    return '0\n360\n' + '\n'.join(rows_) + '\n'


@pytest.mark.parametrize('decimal', ['.', ','])
def test_scene_nominal_file_from_0_to_360_deg(tmp_path, decimal) -> None:
    """The scene's nominal_file used to demand -180..180 ('alpha[360]: got 6.28 rad ...
    degrees given?' for a file in degrees); 0..360 is wrapped. The lobe's card then has
    the closed-form durations 2 beta/pi acos(2 y/L - 1)."""
    from cam_design.cam_card import card_from_law
    from cam_metrology.scene.parse import load_scene

    (tmp_path / 'lobe.txt').write_text(_gauge_0_360(decimal), encoding='utf-8')
    (tmp_path / 's.yaml').write_text('probe: {kind: knife}\nbase_circle_radius: 0.02\n'
                                     'lobes:\n  - {id: l1, nominal_file: lobe.txt}\n')
    lobe = load_scene(tmp_path / 's.yaml').lobe('l1')
    card = card_from_law(lobe.lift, (1e-3,))
    truth = 2.0 * BETA_DEG / math.pi * math.acos(2.0 * 1.0 / L_MM - 1.0)
    assert card['heights'][0]['duration_cam_deg'] == pytest.approx(truth, abs=0.01)
    assert card['max_lift_mm'] == pytest.approx(L_MM, abs=1e-4)


@pytest.mark.parametrize('kwargs, words', [
    ({'angle': lambda r: r}, 'the values look like radians'),
    ({'scale': 1000.0}, 'the values look like micrometres'),
])
def test_scene_nominal_file_in_other_units_names_them(tmp_path, kwargs, words) -> None:
    from cam_metrology.scene.parse import load_scene

    (tmp_path / 'lobe.txt').write_text(_gauge_0_360(**kwargs), encoding='utf-8')
    (tmp_path / 's.yaml').write_text('probe: {kind: knife}\nbase_circle_radius: 0.02\n'
                                     'lobes:\n  - {id: l1, nominal_file: lobe.txt}\n')
    with pytest.raises(InputError, match=words) as exc:
        load_scene(tmp_path / 's.yaml')
    assert exc.value.key == 'lobes[0].nominal_file'


def test_a_table_with_two_lobes_says_which_one_the_numbers_are_of() -> None:
    """Two cosine lobes (8 mm at 0 deg, 7.2 mm at 120 deg) in one table: the card is of
    the highest, exactly (closed-form duration), and says where the other one is; a
    single lobe, a dual-peak lobe (valley above the base circle) or a one-row spike on
    the base circle is not flagged."""
    from cam_metrology.cli.card import table_card
    from cam_design.lift_table.samples import other_lobes_warning

    a = np.radians(ANGLES)
    second = np.mod(ANGLES - 120.0 + 180.0, 360.0) - 180.0
    h = (lobe_mm(ANGLES) + 0.9 * lobe_mm(second)) * 1e-3
    card = table_card(a, h, (1e-3,), 'two.csv')
    truth = 2.0 * BETA_DEG / math.pi * math.acos(2.0 * 1.0 / L_MM - 1.0)
    assert card['heights'][0]['duration_cam_deg'] == pytest.approx(truth, abs=0.01)
    assert 'holds 2 lobes' in card['warning'] and '120.0 deg (7.2 mm)' in card['warning']
    single = lobe_mm(ANGLES) * 1e-3
    assert other_lobes_warning(a, single) is None
    dual = (lobe_mm(1.5 * (ANGLES + 30.0)) + lobe_mm(1.5 * (ANGLES - 30.0))) * 0.6e-3
    assert other_lobes_warning(a, dual) is None
    spike = single.copy()
    spike[300] = 2e-3
    assert other_lobes_warning(a, spike) is None


def test_card_of_a_table_with_a_cut_off_ramp() -> None:
    """A lobe standing on a 0.3 mm step (ramp cut off at +-60 deg), every 1 deg, 0.01 mm
    rounding: the card was refused ('a table without steps', a dynamics rule); its
    1 mm events are away from the step and have the closed form 2 beta/pi acos((1 -
    0.3)/3.85 - 1); the area is 0.3 x 120 + 3.85 x 120 mm deg. The note names the step."""
    from cam_metrology.cli.card import table_card

    a_deg = ANGLES
    h = np.where(np.abs(a_deg) < BETA_DEG,
                 0.3 + 3.85 * (1.0 + np.cos(np.pi * a_deg / BETA_DEG)), 0.0)
    card = table_card(np.radians(a_deg), np.round(h, 2) * 1e-3, (1e-3,), 'cut.csv')
    truth = 2.0 * BETA_DEG / math.pi * math.acos(0.7 / 3.85 - 1.0)
    slope = 3.85 * math.pi / BETA_DEG * math.sin(math.radians(truth / 2 * 180 / BETA_DEG))
    allow = 2 * (4.0 * 0.01 / math.sqrt(12.0) / slope + 0.02)     # both events
    assert card['heights'][0]['duration_cam_deg'] == pytest.approx(truth, abs=allow)
    assert card['area_mm_deg'] == pytest.approx(0.3 * 120 + 3.85 * 120, rel=2e-3)
    assert 'lift jumps by 0.31 mm' in card['note'] and 'not the cam' in card['note']
