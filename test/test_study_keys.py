"""Gauge R&R from an archive: the scene keys part_id, operator and trial travel from the
scene to the report (`study`) and the batch table's columns, so `spc --grr` can read a
study measured on the bench (no columns added by hand)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from cam_design.errors import InputError
from cam_metrology.offline.batch import analyse_bag, rows_of_report
from cam_metrology.cli import main
from cam_metrology.cli.spc import grr_results
from cam_metrology.host.paths import default_scene_path
from cam_metrology.quality.gauge_rr import gauge_rr
from cam_metrology.scene.parse import parse_scene


def _scene_text(**study) -> str:
    doc = yaml.safe_load(Path(default_scene_path()).read_text(encoding='utf-8'))
    doc.update(study)
    return yaml.safe_dump(doc)


def test_study_keys_reach_the_batch_row(tmp_path: Path) -> None:
    scene = tmp_path / 'scene.yaml'
    scene.write_text(_scene_text(part_id='CB-0042', operator='bench 2', trial=3))
    assert parse_scene(scene.read_text()).study == {'part_id': 'CB-0042',
                                                    'operator': 'bench 2', 'trial': '3'}
    bag = tmp_path / 'bag'
    assert main(['simulate', str(bag), '--quiet', '--scene', str(scene),
                 '--samples-per-rev', '720']) == 0
    rows = analyse_bag(str(bag))
    assert rows and all(r['status'] == 'ok' for r in rows)
    assert {(r['part_id'], r['operator'], r['trial']) for r in rows} == {
        ('CB-0042', 'bench 2', '3')}


def test_study_key_must_be_text() -> None:
    with pytest.raises(InputError) as err:
        parse_scene(_scene_text(operator={'name': 'x'}))
    assert err.value.key == 'operator'


def test_grr_from_rows_of_reports_equals_the_direct_study() -> None:
    """3 parts x 2 operators x 2 trials as rows of reports: the same %GRR as gauge_rr on
    the array (the table adds nothing and loses nothing)."""
    rng = np.random.default_rng(3)
    y = rng.normal(0.0, 0.01, (3, 2, 2)) + np.array([0.0, 0.05, 0.1])[:, None, None]
    rows = []
    for p in range(3):
        for o in range(2):
            for t in range(2):
                report = {'camshaft_id': f'P{p}', 'study': {'part_id': f'P{p}',
                                                            'operator': f'O{o}',
                                                            'trial': str(t)},
                          'features': {'lobe_1': {'kind': 'lobe', 'status': 'ok',
                                                  'angle_deg': float(y[p, o, t])}}}
                rows += rows_of_report(f'bag{p}{o}{t}', 'sha', report, None)
    (entry,) = grr_results(rows, ['angle_deg'], None)
    assert entry['percent_grr'] == pytest.approx(gauge_rr(y).as_dict()['percent_grr'],
                                                 rel=1e-12)
    rows[0]['operator'] = None
    with pytest.raises(InputError) as err:
        grr_results(rows, ['angle_deg'], None)
    assert err.value.key == '--grr' and 'operator' in str(err.value.value)
