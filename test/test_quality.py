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


def test_summary_figures_match_a_published_crossed_study() -> None:
    """Minitab's crossed gage R&R example (10 parts, 3 operators, 3 trials, interaction
    pooled) publishes variance contributions of 7.76 % (total gage R&R) and 92.24 %
    (part to part), a study variation of 27.86 % and 4 distinct categories. From those
    variance shares our definitions must give the same %GRR and ndc (the raw data of
    that study is not available here, so its ANOVA itself is not re-run)."""
    from cam_metrology.quality.gauge_rr import GaugeRR

    study = GaugeRR(anova={}, repeatability=0.0600, operator=0.0176, interaction=0.0,
                    part=0.9224, interaction_pooled=True)
    assert study.grr == pytest.approx(0.0776, abs=1e-12)
    assert study.percent_grr == pytest.approx(27.86, abs=0.005)
    assert study.ndc == 4
