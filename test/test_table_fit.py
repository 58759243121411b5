"""A replica of a table (its rows with a fresh draw of their noise, as the jump-speed band
draws them) is fitted as its table was: ``lobe_law(..., fit=law.lobe.fit)``. Judged
afresh, a noisy copy of a rounded table is no longer rounded: the engine then estimates
its noise from the copy's rows (0.55 um here, where the rounding carries 2.89 um) and
the band measures another smoother than the one that gave the answer."""
from __future__ import annotations

import math

import numpy as np
import pytest

from cam_design.lift_table.lobe_table import lobe_law
from cam_design.lift_table.table_fit import LEVEL_CRITERION, TableFit
from cam_design.valve_train.examples import HarmonicLobe
from cam_metrology.dynamics.tables import coverage_factor

D = math.pi / 180.0
LOBE = HarmonicLobe(9e-3, 80 * D, 80 * D)


def _noisy_copy(h: np.ndarray, draw: np.ndarray) -> np.ndarray:
    """The rows with ``draw`` [m] added to the lobe rows (h > 0), as jump_uncertainty."""
    return h + draw * (h > 0)


def test_a_rounded_table_records_its_fit_and_its_copy_repeats_it() -> None:
    q = 1e-5                                # a 5 deg table rounded to 0.01 mm
    deg = np.arange(-177.5, 180.0, 5.0)
    h = np.round(LOBE(deg * D) / q) * q
    law = lobe_law(deg * D, h, key='lobe.csv')
    sigma_q = q / math.sqrt(12.0)
    assert law.lobe.fit == TableFit('smoothed', LEVEL_CRITERION, pytest.approx(sigma_q))
    rng = np.random.default_rng(1)
    rows = _noisy_copy(h, rng.uniform(-0.5 * q, 0.5 * q, h.size))
    judged = lobe_law(deg * D, rows, key='copy', noise=sigma_q)
    assert judged.lobe.fit.known is None              # judged afresh: noise estimated
    assert judged.lobe.rec.sigma < 0.5 * sigma_q       # measured 0.55 um against 2.89
    same = lobe_law(deg * D, rows, key='copy', noise=sigma_q, fit=law.lobe.fit)
    assert same.lobe.fit == law.lobe.fit
    assert same.lobe.rec.sigma == pytest.approx(sigma_q, rel=1e-9)
    assert same.lobe.rec.parameter['criterion'] == LEVEL_CRITERION
    assert 'fitted as its table was (smoothed by gcv, noise 2.89 um' in same.lobe.note()


def test_a_copy_of_an_interpolated_table_is_interpolated() -> None:
    deg = np.arange(-180.0, 180.0, 0.5)     # exact rows: interpolated
    h = LOBE(deg * D)
    law = lobe_law(deg * D, h, key='exact.csv')
    assert law.lobe.fit == TableFit('interpolated')
    rows = _noisy_copy(h, np.random.default_rng(2).normal(0.0, 1e-7, h.size))
    assert lobe_law(deg * D, rows, key='copy', noise=1e-7).lobe.method == 'smoothed'
    same = lobe_law(deg * D, rows, key='copy', noise=1e-7, fit=law.lobe.fit)
    assert same.lobe.method == 'interpolated'
    # the interpolant through the copy's rows: every row on the law (to 1 nm)
    on = (deg > -70.0) & (deg < 70.0)
    assert np.max(np.abs(same(deg[on] * D) - rows[on])) < 1e-9


@pytest.mark.parametrize('copies, gum', [(3, 19.21), (8, 4.53), (16, 3.59), (21, 3.42)])
def test_coverage_factor_is_the_gum_t_factor(copies: int, gum: float) -> None:
    """Student's t at 99.73 % for copies - 1 degrees of freedom: the values of GUM
    (JCGM 100:2008) Table G.2 for nu = 2, 7, 15 and 20, to its two decimals."""
    assert coverage_factor(copies) == pytest.approx(gum, abs=0.006)


def test_a_fine_noisy_table_is_smoothed_by_gcv_not_by_a_flat_risk_score() -> None:
    """C2 lobe of the accuracy families, 0.1 deg (3600 rows), 0.5 um noise, seed 3: the
    acceleration-risk score is flat over decades of level there, and it took edf 294
    (h'' RMS error 0.82 mm/rad^2 over the turn); GCV takes edf 97 (measured 0.076).
    Truth: the closed-form lobe."""
    from cam_design.lift_table.truth_lobes import DEG, families, measured_table

    c2 = next(f for f in families() if f.name == 'C2')
    a, h = measured_table(c2.law, 0.1 * DEG, sigma=0.5e-6, seed=3)
    law = lobe_law(a, h, key='c2.csv')
    assert law.lobe.fit == TableFit('smoothed', LEVEL_CRITERION, None)
    assert 60.0 < law.lobe.rec.parameter['edf'] < 150.0
    grid = np.arange(a[0], a[-1], 0.05 * DEG)
    err = float(np.sqrt(np.mean((law(grid, 2) - c2.law(grid, 2)) ** 2)))
    assert err < 0.15e-3    # m/rad^2
