"""`cam-bench spc` on small tables whose answers are computed by hand."""
from __future__ import annotations

import json
import math
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

from cam_metrology.cli import main


def _write_csv(path: Path, header: list[str], rows: list[list]) -> None:
    path.write_text('\n'.join([','.join(header)] + [','.join(map(str, r)) for r in rows])
                    + '\n')


@pytest.fixture
def table(tmp_path: Path) -> Path:
    """Five parts in measurement order, lobe_1 phase errors 10, 12, 11, 13, 12 (mdeg)."""
    path = tmp_path / 'r.csv'
    vals = [0.010, 0.012, 0.011, 0.013, 0.012]
    rows = [[f'bag{i}', i, 'lobe_1', 'ok', v] for i, v in enumerate(vals)]
    rows.append(['bag9', 9, 'lobe_1', 'failed', ''])
    _write_csv(path, ['bag', 'bag_start_utc_ns', 'feature', 'status', 'phase_error_deg'], rows)
    return path


def test_chart_and_capability_by_hand(table: Path, tmp_path: Path, capsys) -> None:
    out = tmp_path / 'spc.json'
    assert main(['spc', str(table), '--quantity', 'phase_error_deg', '--tolerance',
                 'phase_error_deg=0.005:0.018', '--json', str(out), '--report',
                 str(tmp_path / 'spc.html')]) == 0
    doc = json.loads(out.read_text())
    (entry,) = doc['spc']
    sigma = 0.0015 / 1.128
    assert entry['n'] == 5                                  # the failed row is left out
    assert entry['chart']['centre'] == pytest.approx(0.0116)
    assert entry['chart']['ucl'] == pytest.approx(0.0116 + 3 * sigma)
    assert entry['capability']['cpk'] == pytest.approx(0.0064 / (3 * sigma))
    assert entry['capability']['ppk'] == pytest.approx(0.0064 / (3 * math.sqrt(1.3e-6)))

    class Images(HTMLParser):
        found: list = []

        def handle_starttag(self, tag, attrs):
            if tag == 'img':
                self.found.append(dict(attrs)['src'])
    parser = Images()
    parser.feed((tmp_path / 'spc.html').read_text())
    assert len(parser.found) == 1 and parser.found[0].startswith('data:image/png;base64,')


def test_gauge_rr_from_a_table(tmp_path: Path, capsys) -> None:
    rng = np.random.default_rng(5)
    rows = []
    for p in range(10):
        true = rng.normal(0, 0.01)
        for o in 'ABC':
            for t in range(3):
                rows.append([f'b{p}{o}{t}', 'lobe_1', 'ok', p, o, t,
                             true + rng.normal(0, 0.002)])
    path = tmp_path / 'grr.csv'
    _write_csv(path, ['bag', 'feature', 'status', 'part_id', 'operator', 'trial', 'angle_deg'],
               rows)
    assert main(['spc', str(path), '--grr', '--quantity', 'angle_deg', '--json', '-']) == 0
    doc = json.loads(capsys.readouterr().out)
    (g,) = doc['gauge_rr']
    assert g['parts'] == 10 and g['operators'] == 3 and g['trials'] == 3
    assert 5 < g['percent_grr'] < 40 and g['ndc'] >= 3


@pytest.mark.parametrize('argv, word', [
    (['--tolerance', 'phase_error_deg=a:b'], '--tolerance'),
    (['--quantity', 'nope_deg'], '--quantity'),
    (['--grr'], '--grr'),
])
def test_bad_input_is_one_line(table: Path, argv: list, word: str, capsys) -> None:
    assert main(['spc', str(table)] + argv) == 2
    err = capsys.readouterr().err
    assert err.count('\n') == 1 and word in err


def test_capability_against_the_scene_limits(tmp_path: Path) -> None:
    """Without --tolerance, Cpk uses the limits the scene gave the verdict (the rows'
    verdict.checks), here [-0.002, 0.018] deg: hand-computed as in the first test."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    vals = [0.010, 0.012, 0.011, 0.013, 0.012]
    checks = json.dumps([{'quantity': 'phase_error_deg', 'value': 0.0, 'lower': -0.002,
                          'upper': 0.018, 'unit': 'deg', 'result': 'pass'}])
    path = tmp_path / 'r.parquet'
    pq.write_table(pa.table({'bag': [f'bag{i}' for i in range(5)],
                             'bag_start_utc_ns': list(range(5)),
                             'feature': ['lobe_1'] * 5, 'status': ['ok'] * 5,
                             'phase_error_deg': vals, 'verdict.checks': [checks] * 5}), path)
    out = tmp_path / 'spc.json'
    assert main(['spc', str(path), '--quantity', 'phase_error_deg', '--json', str(out)]) == 0
    (entry,) = json.loads(out.read_text())['spc']
    sigma = 0.0015 / 1.128
    assert entry['tolerance'] == [-0.002, 0.018]
    assert entry['tolerance_source'].startswith('scene')
    assert entry['capability']['cpk'] == pytest.approx((0.018 - 0.0116) / (3 * sigma))


def test_a_table_of_another_kind_is_refused_by_its_columns(tmp_path: Path, capsys) -> None:
    """A lift table (CSV, but not a batch result) names the missing columns."""
    path = tmp_path / 'lobe.csv'
    path.write_text('alpha_deg,lift_mm\n0,0\n5,1\n')
    assert main(['spc', str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count('\n') == 1
    assert 'columns alpha_deg, lift_mm and no bag, feature, status' in err
