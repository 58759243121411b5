"""`analyze` reads each scene once: the bag check and the three cores share one parse.

Before, the bag's scene was parsed by the bag check and again by each core (four parses
of one text); the count here is the number of times the validation itself ran.
"""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from cam_metrology.offline.analyze import analyze_bag
from cam_metrology.scene import parse

ROOT = Path(__file__).resolve().parent.parent
CLEAN = ROOT / 'bags' / 'default_clean'
SCENE = ROOT / 'config' / 'default_scene.yaml'


def test_analyze_parses_the_bag_scene_once(monkeypatch: pytest.MonkeyPatch) -> None:
    calls: list[str] = []
    real = parse._parse_document

    def counting(text: str, source: str, base_dir: object) -> object:
        calls.append(source)
        return real(text, source, base_dir)

    monkeypatch.setattr(parse, '_parse_document', counting)
    run = analyze_bag(str(CLEAN))
    assert calls == ['/bench/scene']
    assert any(f.get('status') == 'ok' for f in run.report['features'].values())


def test_parses_are_shared_only_inside_the_block() -> None:
    text = SCENE.read_text()
    assert parse.parse_scene(text) is not parse.parse_scene(text)
    with parse.shared_parses():
        first = parse.parse_scene(text)
        assert parse.parse_scene(text) is first
        assert parse.parse_scene(text, source='other') is not first
    assert parse.parse_scene(text) is not first


def test_bagio_imports_no_scene_module() -> None:
    code = ('import sys, cam_metrology.bagio; '
            'print([m for m in sys.modules if m.startswith("cam_metrology.scene")])')
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                         check=True, cwd=ROOT).stdout.strip()
    assert out == '[]'


def test_report_is_taken_as_data_and_equals_the_published_text() -> None:
    import json

    from cam_metrology.cores.outputs import TextOutput
    from cam_metrology.wire.topics import METROLOGY_REPORT

    run = analyze_bag(str(CLEAN))
    assert run.report is run.metrology.final_report
    texts = [o.text for _, o in run.outputs
             if isinstance(o, TextOutput) and o.topic == METROLOGY_REPORT]
    published = json.loads(texts[-1])
    added = {'provenance', 'crank', 'skipped', 'warnings'}
    assert {k: v for k, v in published.items() if k not in added | {'features'}} == \
        {k: v for k, v in run.report.items() if k not in added | {'features'}}
    for fid, feature in published['features'].items():   # analyze adds the cam cards
        assert {k: v for k, v in run.report['features'][fid].items() if k != 'cam_card'} \
            == feature


def test_each_lobe_is_referenced_once_for_cards_and_report_plots(
        monkeypatch: pytest.MonkeyPatch) -> None:
    from cam_metrology.metrology import lift_error

    calls: list[str] = []
    real = lift_error.referenced_rows   # the kept rows of the referenced table

    def counting(table: object, feature: dict) -> object:
        calls.append(feature.get('kind', '?'))
        return real(table, feature)

    monkeypatch.setattr(lift_error, 'referenced_rows', counting)
    run = analyze_bag(str(CLEAN), plot_tables=True)
    lobes = [f for f in run.report['features'].values() if f.get('kind') == 'lobe']
    assert len(calls) == len(lobes) >= 2
    assert all('cam_card' in f for f in lobes if f.get('status') == 'ok')
    assert all(fid in run.tables for fid, f in run.report['features'].items()
               if f.get('kind') == 'lobe')


def test_plot_pngs_use_the_tables_referenced_once(monkeypatch: pytest.MonkeyPatch,
                                                  tmp_path: Path) -> None:
    """`analyze --plot` draws each lobe from the table the verdict referenced: one
    reference per lobe, none made again for the PNGs."""
    from cam_metrology.cli import main
    from cam_metrology.metrology import lift_error

    calls: list[str] = []
    rows, whole = lift_error.referenced_rows, lift_error.feature_referenced

    def counting_rows(table: object, feature: dict) -> object:
        calls.append('rows')
        return rows(table, feature)

    def counting_whole(table: object, feature: dict) -> object:
        calls.append('whole')
        return whole(table, feature)

    monkeypatch.setattr(lift_error, 'referenced_rows', counting_rows)
    monkeypatch.setattr(lift_error, 'feature_referenced', counting_whole)
    out = tmp_path / 'plots'
    assert main(['analyze', str(CLEAN), '--plot', str(out),
                 '--json', str(tmp_path / 'r.json')]) == 0
    import json
    report = json.loads((tmp_path / 'r.json').read_text())
    lobes = [f for f in report['features'].values() if f.get('kind') == 'lobe']
    assert calls.count('whole') == 0
    assert calls.count('rows') == len(lobes) >= 2
    pngs = sorted(p.name for p in out.glob('*.png'))
    assert len(pngs) >= len(lobes)
    assert all((out / p).stat().st_size > 10_000 for p in pngs)
