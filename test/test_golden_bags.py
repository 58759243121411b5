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

from cam_metrology.report.golden import assert_report_matches

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


@pytest.mark.parametrize('core', ['Prescott', 'Haswell'])
def test_golden_holds_on_other_blas_kernels(core: str, tmp_path: Path) -> None:
    """Another CPU runs other BLAS kernels (summation orders differ in the last bits):
    the irregular bag (encoder-grid samples at exactly a margin from the lobe, where a
    last bit once moved the cam card by 0.5 arc-second) analysed with OpenBLAS forced
    to the SSE3-only and the AVX2 kernels still matches its golden report."""
    import os
    import subprocess
    import sys

    out = tmp_path / 'r.json'
    env = dict(os.environ, OPENBLAS_CORETYPE=core)
    run = subprocess.run([sys.executable, '-m', 'cam_metrology', 'analyze',
                          str(BAGS / 'irregular'), '--json', str(out)],
                         env=env, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    golden = json.loads((BAGS / 'golden' / 'irregular.json').read_text(encoding='utf-8'))
    assert_report_matches(json.loads(out.read_text(encoding='utf-8')), golden,
                          angle_tol_arcsec=0.01, lift_tol_um=1e-3)
