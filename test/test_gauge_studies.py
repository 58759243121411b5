"""Gauge studies against published examples: the type-1 study (Cg, Cgk, bias t-test) and
the gauge R&R against the tolerance (%Tol, acceptance bands, ndc)."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from cam_design.errors import InputError
from cam_metrology.cli import main
from cam_metrology.quality.gauge_rr import acceptance_band, gauge_rr
from cam_metrology.quality.gauge_type1 import type1_study

#: a published type-1 study: gauge S-441-0, reference -4.0 um, resolution 0.1 um, tolerance
#: 15 um, 50 repeated measurements (13 Nov 2010), the data set JASP's quality-control module
#: ships with its type-1 gauge analysis (tests/testthat/Type1.csv of jasp-stats/
#: jaspQualityControl), with the figures it publishes for it: mean -3.946, s 0.420015,
#: bias 0.054, Cg 1.19, Cgk 1.15, %Var(repeatability) 16.8, %Var(repeatability and bias)
#: 17.43, t 0.909106 (49 df), p 0.367744
TYPE1_DATA = [-4.0, -4.1, -4.1, -4.1, -4.1, -3.9, -3.9, -3.9, -4.1, -4.2,
              -3.9, -4.2, -4.0, -3.8, -3.9, -3.9, -3.9, -3.9, -4.6, -4.3,
              -3.9, -3.7, -3.7, -3.9, -4.0, -5.0, -3.9, -3.8, -3.7, -3.8,
              -3.7, -3.8, -3.6, -3.5, -3.6, -3.6, -3.4, -5.1, -3.5, -4.0,
              -4.5, -3.5, -5.1, -5.0, -3.5, -3.5, -3.5, -3.6, -3.6, -3.5]


def test_type1_study_reproduces_the_published_example() -> None:
    res = type1_study(TYPE1_DATA, reference=-4.0, tolerance=15.0)
    assert res.n == 50
    assert res.mean == pytest.approx(-3.946, abs=5e-7)
    assert res.std == pytest.approx(0.420014577006512, abs=1e-9)
    assert res.bias == pytest.approx(0.054, abs=1e-9)
    assert res.cg == pytest.approx(1.19, abs=0.005)
    assert res.cgk == pytest.approx(1.15, abs=0.005)
    d = res.as_dict()
    assert d['percent_var_repeatability'] == pytest.approx(16.8, abs=0.005)
    assert d['percent_var_repeatability_and_bias'] == pytest.approx(17.43, abs=0.005)
    assert res.t == pytest.approx(0.909105737620188, abs=1e-9)
    assert res.p_value == pytest.approx(0.367744349288335, abs=1e-9)
    assert not res.bias_significant and not d['capable']   # Cg < 1.33
    assert 'Cg = 0.2 T / (6 s)' in d['convention']


def test_type1_study_flags_a_significant_bias() -> None:
    """The same data shifted by +0.5 (a gauge reading high): t = 0.554 / (s / sqrt 50)."""
    res = type1_study(np.array(TYPE1_DATA) + 0.5, reference=-4.0, tolerance=15.0)
    assert res.t == pytest.approx(0.554 / (0.420014577006512 / math.sqrt(50)), rel=1e-9)
    assert res.bias_significant and res.cgk == pytest.approx((1.5 - 0.554) / 1.26004, abs=1e-4)


def test_type1_bad_input_is_named() -> None:
    with pytest.raises(InputError, match='type1.tolerance'):
        type1_study(TYPE1_DATA, -4.0, 0.0)
    with pytest.raises(InputError, match='at least 10'):
        type1_study(TYPE1_DATA[:5], -4.0, 15.0)


def test_grr_against_the_tolerance_aiag_study() -> None:
    """The AIAG MSA (4th ed.) crossed study (test_quality.AIAG_STUDY: published GRR variance
    0.09143, part 1.0864, ndc 4): against a tolerance of 10, %Tol = 100 6 sqrt(0.09143) / 10
    = 18.14 % (conditionally acceptable), %GRR 27.86 % (conditionally acceptable), ndc 4 < 5
    (not acceptable)."""
    from test_quality import AIAG_STUDY

    res = gauge_rr(np.array(AIAG_STUDY).reshape(10, 3, 3))
    d = res.as_dict(10.0)
    assert d['percent_tolerance']['grr'] == pytest.approx(600 * math.sqrt(0.09143) / 10,
                                                          abs=0.005)
    assert d['percent_tolerance']['repeatability'] == pytest.approx(
        600 * math.sqrt(0.03997) / 10, abs=0.005)
    assert d['acceptance']['percent_tolerance'].startswith('conditionally acceptable')
    assert d['acceptance']['percent_grr'].startswith('conditionally acceptable')
    assert d['acceptance']['ndc'].startswith('not acceptable')
    assert acceptance_band(9.99).startswith('acceptable') and \
        acceptance_band(30.01).startswith('not acceptable')


def _write_csv(path: Path, header: list[str], rows: list[list]) -> None:
    path.write_text(','.join(header) + '\n' + '\n'.join(','.join(str(v) for v in r)
                                                        for r in rows) + '\n')


def test_spc_type1_and_grr_tolerance_from_the_command_line(tmp_path: Path, capsys) -> None:
    """`spc --type1 QUANTITY=REF --tolerance QUANTITY=LSL:USL` gives the published numbers
    from a batch-like table; `--grr` with a tolerance adds %Tol."""
    path = tmp_path / 't1.csv'
    _write_csv(path, ['bag', 'feature', 'status', 'bag_start_utc_ns', 'dm_um'],
               [[f'b{i}', 'journal_1', 'ok', i, v] for i, v in enumerate(TYPE1_DATA)])
    assert main(['spc', str(path), '--type1', 'dm_um=-4', '--tolerance', 'dm_um=-11.5:3.5',
                 '--json', '-']) == 0
    (t,) = json.loads(capsys.readouterr().out)['type1']
    assert t['cg'] == pytest.approx(1.19, abs=0.005)
    assert t['cgk'] == pytest.approx(1.15, abs=0.005)
    assert main(['spc', str(path), '--type1', 'dm_um=x']) == 2
    err = capsys.readouterr().err
    assert err.count('\n') == 1 and '--type1' in err
    assert main(['spc', str(path), '--type1', 'dm_um=-4']) == 2
    err = capsys.readouterr().err
    assert err.count('\n') == 1 and 'a tolerance of dm_um' in err
