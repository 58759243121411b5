"""A fine table of a smooth lobe rounded by the gauge (0.01 or 0.001 mm): the rounding is
noise of sigma q/sqrt(12), but in the spectrum of a smooth lobe sampled finely it looks
smaller, and the acceleration-risk smoothing the lobe law once used then nearly
interpolated the rounding steps (a floor of q/sqrt(12) mended it). The lobe law now
smooths by GCV and gives the engine the rounding as the known noise; these bounds hold
for both. Truth: the analytic law the table was made from (h'' RMS over the lobe; an
eccentric's h'' is -e cos at every angle)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from cam_design.lift_laws.registry import from_spec
from cam_design.lift_table.lobe_table import lobe_law

DEG = math.pi / 180.0


@pytest.mark.parametrize('q, limit', [(1e-6, 0.02), (1e-5, 0.03)])
def test_rounded_one_degree_table_acceleration(q: float, limit: float) -> None:
    # without the floor: 0.033 and 0.057 of the largest |h''|
    law = from_spec({'family': 'preset', 'name': 'methods_example'})
    a = np.arange(-180.0, 180.0, 1.0) * DEG
    smooth = lobe_law(a, np.round(np.asarray(law(a, 0)) / q) * q, key='table')
    lo, hi = law.support
    x = np.linspace(lo + 0.01, hi - 0.01, 5000)
    err = np.asarray(smooth(x, 2)) - np.asarray(law(x, 2))
    assert math.sqrt(float(np.mean(err ** 2))) < limit * float(np.max(np.abs(law(x, 2))))


def test_rounded_two_degree_eccentric_acceleration() -> None:
    # without the floor the nose-to-base h'' was off by 41 % of e
    e = 4e-3
    a = np.arange(-180.0, 180.0, 2.0) * DEG
    h = np.round(e * (1.0 + np.cos(a)) / 1e-6) * 1e-6
    smooth = lobe_law(a, h, key='eccentric')
    x = np.radians(np.arange(-150.0, 150.0, 0.25))
    # measured 0.0052 e by GCV, 0.0035 e by the former risk criterion with the floor
    assert np.max(np.abs(np.asarray(smooth(x, 2)) + e * np.cos(x))) < 0.04 * e
    fit = smooth.lobe.fit   # smoothed, the rounding's q/sqrt(12) the known noise
    assert (fit.method, fit.criterion) == ('smoothed', 'gcv')
    assert fit.known == pytest.approx(1e-6 / math.sqrt(12.0), rel=1e-9)
    assert 'periodic (no base circle)' in smooth.lobe.note()


def _rounding_step_of_all_rows(v):
    """The rounding step the slow way: every candidate step tried on all rows."""
    top, span = float(np.max(np.abs(v))), float(np.ptp(v))
    for k in range(math.floor(math.log10(span / 20.0)), math.floor(math.log10(top)) - 13, -1):
        for m in (5.0, 2.0, 1.0):
            q = m * 10.0 ** k
            if q <= span / 20.0 and np.max(np.abs(v / q - np.rint(v / q))) <= 1e-6:
                return q
    return 0.0


def test_rounding_step_tried_on_the_first_rows_first_gives_the_same_step():
    """quantisation_step tries each step on the first rows before all of them: the same
    step [m] as trying every row, on lobes rounded to 0.01 mm, 1 um and 0.0001 in, not
    rounded, and rounded only in their first 100 rows (base-circle zeros first, which
    every step divides)."""
    from cam_design.lift_table.rebound import quantisation_step

    law = from_spec({'family': 'preset', 'name': 'methods_example'})
    alpha = np.radians(np.arange(-180.0, 180.0, 0.1))
    exact = np.asarray(law(alpha), dtype=float)
    noisy = exact + np.random.default_rng(3).normal(0.0, 0.5e-6, exact.size)
    head_only = noisy.copy()
    head_only[:100] = np.round(head_only[:100] / 1e-5) * 1e-5
    tables = [np.round(exact / q) * q for q in (1e-5, 1e-6, 2.54e-6)]
    tables += [noisy, head_only, np.concatenate([np.zeros(200), tables[0]])]
    steps = [quantisation_step(t) for t in tables]
    assert steps == [_rounding_step_of_all_rows(t) for t in tables]
    assert steps[0] == pytest.approx(1e-5, rel=1e-12)                      # m
    assert steps[3] == 0.0 and steps[4] == 0.0
