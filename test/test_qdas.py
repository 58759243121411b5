"""Q-DAS AQDEF (DFQ) output of `analyze --dfq` and `batch --dfq`, read back with an
independent reader from PyPI (aqdefreader) and compared value by value with the report."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from cam_metrology.cli import main

aqdef = pytest.importorskip('aqdefreader')

BAG = Path(__file__).resolve().parents[1] / 'bags' / 'default_clean'


def _read(path: Path) -> list:
    """Characteristics of the first part: (description, unit, lower, upper, values,
    date/time of each value) through aqdefreader's parser (its own numeric parsing only
    understands unsigned decimal commas, so a value stays text: converted here)."""
    dfq = aqdef.DfqFile(path.read_text(encoding='utf-8').splitlines())
    assert dfq.part_count() == 1
    part = dfq.get_part(0)
    out = []
    for c in part.get_characteristics():
        def num(key):
            v = c.get_data(key)
            return None if v is None else float(v)
        out.append((c.get_data('K2002'), c.get_data('K2142'), num('K2110'), num('K2111'),
                    [float(m.value) for m in c.get_measurements()],
                    [m.datetime for m in c.get_measurements()]))
    return out, part


def test_analyze_dfq_round_trip(tmp_path: Path, capsys) -> None:
    """Every characteristic's value equals the report's field (to the 17 digits written);
    the verdict's limits come through as K2110/K2111; the date is the bag's start."""
    out = tmp_path / 'part.dfq'
    js = tmp_path / 'r.json'
    code = main(['analyze', str(BAG), '--only-metrology', '--json', str(js), '--dfq', str(out)])
    assert code in (0, 1, 3)
    report = json.loads(js.read_text())
    chars, part = _read(out)
    from datetime import datetime, timezone

    from cam_metrology.offline.batch import bag_start_ns
    start = datetime.fromtimestamp(bag_start_ns(BAG) // 10**9, timezone.utc).replace(tzinfo=None)
    assert start.day > 12   # the reader reads dd.mm month-first when both could be a month
    assert part.get_data('K1001') == report['camshaft_id']
    seen = 0
    for desc, unit, lo, hi, values, stamps in chars:
        fid, field = desc.split(' ')
        value = report['features'][fid]
        for k in field.split('.'):
            value = value[k]
        assert values == [pytest.approx(value, rel=1e-15, abs=1e-300)]
        assert unit in ('deg', 'um', 'UPR')
        assert stamps[0] == start
        checks = {c['quantity']: c for c in report['features'][fid]['verdict']['checks']}
        q = {'phase_error_deg': 'phase_error_deg',
             'lift_error_um.max_plus': 'lift_error_max_plus_um',
             'base_circle_runout_um': 'base_circle_runout_um'}.get(field)
        if q in checks:
            assert hi == pytest.approx(checks[q]['upper'], abs=1e-12)
            assert lo == (None if checks[q]['lower'] is None else
                          pytest.approx(checks[q]['lower'], abs=1e-12))
        seen += 1
    names = [c[0] for c in chars]
    assert 'lobe_1 angle_deg' in names and 'dowel_pin angle_deg' in names
    assert seen >= 5 * 1 + 4 * 4   # the pin's angle, each lobe's angle, phases, lift errors


def test_unwritable_dfq_path_is_one_line_and_keeps_the_old_file(tmp_path: Path,
                                                                capsys) -> None:
    """The new file cannot be written (its temporary file's name is too long for the file
    system, even for root): exit 2, one line naming --dfq and the path, the old file
    whole."""
    old = tmp_path / ('p' * 246 + '.dfq')
    old.write_bytes(b'K0100 0\r\n')
    code = main(['analyze', str(BAG), '--only-metrology', '--json', str(tmp_path / 'r.json'),
                 '--dfq', str(old)])
    err = capsys.readouterr().err
    assert code == 2
    lines = [x for x in err.splitlines() if x.strip()]
    assert len(lines) == 1 and '--dfq' in lines[0] and str(old) in lines[0]
    assert old.read_bytes() == b'K0100 0\r\n'


def test_dfq_of_many_parts_has_one_value_per_part(tmp_path: Path) -> None:
    """Rows of three bags (as batch tabulates them): each characteristic gets three values
    in measurement order with their operator and part ident."""
    from cam_metrology.quality.qdas import dfq_text

    rows = [{'bag': f'b{i}', 'bag_start_utc_ns': (1_767_225_600 + 86400 * 20 + i) * 10**9,
             'camshaft_id': 'CS-1', 'part_id': f'P{i}', 'operator': 'anna', 'feature': 'lobe_1',
             'status': 'ok', 'angle_deg': 30.0 + 0.001 * i, 'phase_error_deg': -0.01 * i,
             'verdict.checks': json.dumps([{'quantity': 'phase_error_deg', 'lower': -0.5,
                                            'upper': 0.5}])}
            for i in (2, 0, 1)]
    path = tmp_path / 'b.dfq'
    path.write_text(dfq_text(rows))
    chars, _ = _read(path)
    assert [c[0] for c in chars] == ['lobe_1 angle_deg', 'lobe_1 phase_error_deg']
    assert chars[0][4] == [pytest.approx(30.0 + 0.001 * i, abs=1e-12) for i in (0, 1, 2)]
    assert chars[1][2:4] == (-0.5, 0.5)
    assert [d.second for d in chars[1][5]] == [0, 1, 2] and chars[1][5][0].day == 21
    text = path.read_text()
    assert text.count('K0008/1 anna') == 3 and 'K0014/1 P0' in text


def test_zoned_quantities_carry_no_single_limit(tmp_path: Path) -> None:
    """A quantity judged by angle zones: the file's whole-lobe value (0.06 mm/rad, within
    its flank zone's 0.1 but above the lobe's own 0.03, which applies outside the zones
    only) gets no limits, so SPC does not call a passed part out of tolerance; a quantity
    without zones keeps its limits."""
    from cam_metrology.quality.qdas import characteristics

    checks = [{'quantity': 'velocity_error_mm_per_rad[-50..-10 deg]', 'lower': None,
               'upper': 0.1},
              {'quantity': 'velocity_error_mm_per_rad', 'lower': None, 'upper': 0.03},
              {'quantity': 'lift_error_um[-20..20 deg].max_plus', 'lower': -12, 'upper': 12},
              {'quantity': 'lift_error_max_plus_um', 'lower': -10, 'upper': 10},
              {'quantity': 'acceleration_error_mm_per_rad2', 'lower': None, 'upper': 0.5}]
    row = {'feature': 'lobe_1', 'status': 'ok', 'verdict.checks': json.dumps(checks),
           'velocity_error_mm_per_rad.max_abs': 0.06, 'lift_error_um.max_plus': 11.0,
           'acceleration_error_mm_per_rad2.max_abs': 0.2}
    limits = {c['field']: (c['lower'], c['upper']) for c in characteristics([row])}
    assert limits == {'lift_error_um.max_plus': (None, None),
                      'velocity_error_mm_per_rad.max_abs': (None, None),
                      'acceleration_error_mm_per_rad2.max_abs': (None, 0.5)}
