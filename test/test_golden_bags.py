"""The fixture bags against their golden reports, through the same pytest plugin that
users run over their own bags (``cam_bench_analysis`` fixture, ``assert_report_matches``).

A golden file is rewritten with ``cam-bench golden bags/NAME bags/golden/NAME.json
--force`` when a change of the analysis is intended (say why in the commit). The
tolerances are far above the last-bit differences between CPUs and far below anything a
metrologist would notice: 0.01 arc-second and 1 nm.
"""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from cam_metrology.golden import assert_report_matches

BAGS = Path(__file__).resolve().parent.parent / 'bags'
NAMES = sorted(p.stem for p in (BAGS / 'golden').glob('*.json'))


def test_every_fixture_bag_has_a_golden_report() -> None:
    bags = sorted(p.parent.name for p in BAGS.glob('*/metadata.yaml'))
    assert bags == NAMES


@pytest.mark.parametrize('name', NAMES)
def test_fixture_matches_its_golden_report(name: str, cam_bench_analysis) -> None:
    golden = json.loads((BAGS / 'golden' / f'{name}.json').read_text(encoding='utf-8'))
    assert_report_matches(cam_bench_analysis(BAGS / name), golden,
                          angle_tol_arcsec=0.01, lift_tol_um=1e-3)
