"""SPC and capability against hand-computed tables; gauge R&R (ANOVA) against an
independent least-squares decomposition and a synthetic study with known variances."""
from __future__ import annotations

import math

import numpy as np
import pytest

from cam_design.errors import InputError
from cam_metrology.quality.gauge_rr import gauge_rr
from cam_metrology.quality.spc import capability, individuals, run_rules, xbar_r

X = [10.0, 12.0, 11.0, 13.0, 12.0]


def test_individuals_chart_by_hand() -> None:
    """mean 11.6; moving ranges 2, 1, 2, 1 -> MR-bar 1.5; sigma = 1.5/1.128."""
    c = individuals(X)
    sigma = 1.5 / 1.128
    assert c.centre == pytest.approx(11.6)
    assert c.sigma_within == pytest.approx(sigma)
    assert c.ucl == pytest.approx(11.6 + 3 * sigma) and c.lcl == pytest.approx(11.6 - 3 * sigma)
    assert c.range_ucl == pytest.approx(3.267 * 1.5)
    assert c.violations == []


def test_xbar_r_chart_by_hand() -> None:
    c = xbar_r([[1, 2, 3], [2, 3, 4]])
    assert c.centre == pytest.approx(2.5) and c.range_centre == pytest.approx(2.0)
    assert c.ucl == pytest.approx(2.5 + 1.023 * 2) and c.range_ucl == pytest.approx(2.574 * 2)
    assert c.sigma_within == pytest.approx(2 / 1.693)


def test_capability_by_hand() -> None:
    """sigma_within 1.5/1.128; overall s = sqrt(5.2/4) = 1.140175."""
    cap = capability(X, 5.0, 18.0)
    sw, so = 1.5 / 1.128, math.sqrt(1.3)
    assert cap.cp == pytest.approx(13 / (6 * sw)) and cap.cpk == pytest.approx(6.4 / (3 * sw))
    assert cap.pp == pytest.approx(13 / (6 * so)) and cap.ppk == pytest.approx(6.4 / (3 * so))
    one_sided = capability(X, None, 18.0)
    assert one_sided.cp is None and one_sided.cpk == pytest.approx(6.4 / (3 * sw))


@pytest.mark.parametrize('series, rule', [
    ([0, 0, 0, 0, 4, 0], 'beyond 3 sigma'),
    ([0, 0, 2.5, 0, 2.5, 0], '2 of 3 beyond 2 sigma'),
    ([0, 1.5, 1.5, 0, 1.5, 1.5, 0], '4 of 5 beyond 1 sigma'),
    ([0.5, -0.2, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5], '8 in a row on one side'),
    ([0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6], 'trend of 6'),
])
def test_run_rules(series: list, rule: str) -> None:
    hits = run_rules(np.array(series, float), 0.0, 1.0)
    assert rule in {h['rule'] for h in hits}


def test_bad_input() -> None:
    with pytest.raises(InputError):
        individuals([1.0, math.nan, 2.0, 3.0])
    with pytest.raises(InputError):
        capability(X, 18.0, 5.0)
    with pytest.raises(InputError):
        xbar_r([[1.0] * 12, [2.0] * 12])
    with pytest.raises(InputError):
        gauge_rr(np.ones((1, 3, 3)))


def _lstsq_ss(y: np.ndarray) -> dict[str, float]:
    """Sequential sums of squares by least squares on dummy variables (an independent
    route to the balanced two-way ANOVA)."""
    p, o, r = y.shape
    v = y.ravel()
    part = np.repeat(np.arange(p), o * r)
    oper = np.tile(np.repeat(np.arange(o), r), p)
    cell = part * o + oper

    def rss(cols: list[np.ndarray]) -> float:
        x = np.column_stack([np.ones(v.size)] + cols)
        beta, *_ = np.linalg.lstsq(x, v, rcond=None)
        return float(np.sum((v - x @ beta) ** 2))

    dp = [(part == i).astype(float) for i in range(1, p)]
    do = [(oper == j).astype(float) for j in range(1, o)]
    dc = [(cell == k).astype(float) for k in range(1, p * o)]
    r0, rp, rpo, rfull = rss([]), rss(dp), rss(dp + do), rss(dc)
    return {'part': r0 - rp, 'operator': rp - rpo, 'interaction': rpo - rfull,
            'error': rfull}


def test_anova_sums_of_squares_match_least_squares() -> None:
    rng = np.random.default_rng(4)
    y = rng.normal(size=(6, 3, 2)) + rng.normal(size=(6, 1, 1)) * 2
    res = gauge_rr(y)
    ref = _lstsq_ss(y)
    for k, v in ref.items():
        assert res.anova[k]['ss'] == pytest.approx(v, rel=1e-10, abs=1e-12)


def test_synthetic_study_recovers_known_variances() -> None:
    """sigma_part 1.0, operator 0.3, interaction 0.15, repeatability 0.2; 300 parts x 8
    operators x 4 trials: each estimate within 20 %. The operator term is compared with
    the variance of the 8 operator effects actually drawn (8 levels scatter +-50 % around
    0.09 by themselves)."""
    rng = np.random.default_rng(11)
    p, o, r = 300, 8, 4
    ops = rng.normal(0, 0.3, (1, o, 1))
    y = (rng.normal(0, 1.0, (p, 1, 1)) + ops
         + rng.normal(0, 0.15, (p, o, 1)) + rng.normal(0, 0.2, (p, o, r)))
    res = gauge_rr(y)
    assert not res.interaction_pooled
    assert res.part == pytest.approx(1.0, rel=0.2)
    assert res.repeatability == pytest.approx(0.04, rel=0.2)
    assert res.interaction == pytest.approx(0.0225, rel=0.2)
    realized = float(np.var(ops, ddof=1))
    assert res.operator == pytest.approx(realized, rel=0.2)
    grr = 0.04 + realized + 0.0225
    assert res.percent_grr == pytest.approx(100 * math.sqrt(grr / (grr + 1.0)), rel=0.15)
    assert res.ndc == math.floor(1.41 * math.sqrt(res.part / res.grr))


def test_insignificant_interaction_is_pooled() -> None:
    rng = np.random.default_rng(2)
    y = rng.normal(0, 1.0, (10, 1, 1)) + rng.normal(0, 0.1, (10, 3, 3))
    res = gauge_rr(y)
    assert res.anova['interaction']['p_value'] > 0.25 and res.interaction_pooled
    assert res.interaction == 0.0


#: AIAG MSA reference manual (4th ed.), appendix gauge study, as distributed by Minitab
#: (sample "gageaiag"): 10 parts (rows) x operators A, B, C x 3 trials each.
AIAG_STUDY = [
    [0.29, 0.41, 0.64, 0.08, 0.25, 0.07, 0.04, -0.11, -0.15],
    [-0.56, -0.68, -0.58, -0.47, -1.22, -0.68, -1.38, -1.13, -0.96],
    [1.34, 1.17, 1.27, 1.19, 0.94, 1.34, 0.88, 1.09, 0.67],
    [0.47, 0.50, 0.64, 0.01, 1.03, 0.20, 0.14, 0.20, 0.11],
    [-0.80, -0.92, -0.84, -0.56, -1.20, -1.28, -1.46, -1.07, -1.45],
    [0.02, -0.11, -0.21, -0.20, 0.22, 0.06, -0.29, -0.67, -0.49],
    [0.59, 0.75, 0.66, 0.47, 0.55, 0.83, 0.02, 0.01, 0.21],
    [-0.31, -0.20, -0.17, -0.63, 0.08, -0.34, -0.46, -0.56, -0.49],
    [2.26, 1.99, 2.01, 1.80, 2.12, 2.19, 1.77, 1.45, 1.87],
    [-1.36, -1.25, -1.31, -1.68, -1.62, -1.50, -1.49, -1.77, -2.16]]


def test_published_crossed_study_raw_data() -> None:
    """The AIAG MSA (4th ed.) crossed study, raw data, against the ANOVA table and the
    figures Minitab publishes for it: SS part 88.3619, operator 3.1673, interaction
    0.3590, repeatability 2.7589 (df 9, 2, 18, 60); interaction F 0.434, p 0.974, so it
    is pooled (alpha 0.25); variance components repeatability 0.03997, reproducibility
    0.05146, GRR 0.09143, part 1.0864; contribution 7.76 % (3.39 + 4.37); study
    variation 27.86 %; 4 distinct categories."""
    res = gauge_rr(np.array(AIAG_STUDY).reshape(10, 3, 3))
    ss = {k: v['ss'] for k, v in res.anova.items()}
    assert ss['part'] == pytest.approx(88.3619, abs=5e-5)
    assert ss['operator'] == pytest.approx(3.1673, abs=5e-5)
    assert ss['interaction'] == pytest.approx(0.3590, abs=5e-5)
    assert ss['error'] == pytest.approx(2.7589, abs=5e-5)
    assert [res.anova[k]['df'] for k in ('part', 'operator', 'interaction', 'error')] == [
        9, 2, 18, 60]
    inter = res.anova['interaction']
    assert inter['ms'] / res.anova['error']['ms'] == pytest.approx(0.434, abs=5e-4)
    assert inter['p_value'] == pytest.approx(0.974, abs=5e-4)
    assert res.interaction_pooled and res.interaction == 0.0
    assert res.repeatability == pytest.approx(0.03997, abs=5e-6)
    assert res.reproducibility == pytest.approx(0.05146, abs=5e-6)
    assert res.grr == pytest.approx(0.09143, abs=5e-6)
    assert res.part == pytest.approx(1.0864, abs=5e-5)
    assert 100 * res.grr / res.total == pytest.approx(7.76, abs=0.005)
    assert 100 * res.repeatability / res.total == pytest.approx(3.39, abs=0.005)
    assert 100 * res.reproducibility / res.total == pytest.approx(4.37, abs=0.005)
    assert res.percent_grr == pytest.approx(27.86, abs=0.005)
    assert res.ndc == 4
