"""Gauge repeatability and reproducibility by the ANOVA method (crossed study).

p parts, o operators (or benches), r trials each; y[part, operator, trial]. Two-way
ANOVA with interaction: SS_P = o r Σ(ȳ_p − ȳ)², SS_O = p r Σ(ȳ_o − ȳ)²,
SS_PO = r Σ(ȳ_po − ȳ_p − ȳ_o + ȳ)², SS_E = Σ(y − ȳ_po)², mean squares by their degrees
of freedom (p−1, o−1, (p−1)(o−1), p o (r−1)). Variance components (negative estimates
set to zero): repeatability σ²_E = MS_E; interaction σ²_PO = (MS_PO − MS_E)/r; operator
σ²_O = (MS_O − MS_PO)/(p r); part σ²_P = (MS_P − MS_PO)/(o r). Reproducibility = σ²_O +
σ²_PO; GRR = repeatability + reproducibility; total = GRR + part. %GRR = 100 σ_GRR /
σ_total (share of the study variation); ndc = floor(1.41 σ_P / σ_GRR). When the
interaction is not significant (p-value > 0.25, the AIAG convention) it is pooled into
the error term.

Against a tolerance T (USL - LSL): %Tol = 100 · 6 σ / T for the GRR and each component
(study variation 6 σ). Acceptance bands of %GRR and %Tol (AIAG MSA): below 10 %
acceptable, 10–30 % conditionally acceptable (depending on the application), above 30 %
not acceptable; and ndc >= 5.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from cam_design.errors import InputError


@dataclass
class GaugeRR:
    """Result of a crossed gauge R&R study (variances in the unit of y, squared)."""

    anova: dict[str, dict[str, float]]
    repeatability: float
    operator: float
    interaction: float
    part: float
    interaction_pooled: bool

    @property
    def reproducibility(self) -> float:
        """σ²_O + σ²_PO."""
        return self.operator + self.interaction

    @property
    def grr(self) -> float:
        """σ²_GRR."""
        return self.repeatability + self.reproducibility

    @property
    def total(self) -> float:
        """σ²_total."""
        return self.grr + self.part

    @property
    def percent_grr(self) -> float:
        """100 σ_GRR / σ_total."""
        return 100.0 * math.sqrt(self.grr / self.total) if self.total > 0 else math.nan

    @property
    def ndc(self) -> int:
        """Number of distinct categories, floor(1.41 σ_P / σ_GRR)."""
        return int(math.floor(1.41 * math.sqrt(self.part / self.grr))) if self.grr > 0 else 0

    def percent_tolerance(self, tolerance: float) -> dict[str, float]:
        """100 · 6 σ / ``tolerance`` of the GRR and of each component."""
        if not (math.isfinite(tolerance) and tolerance > 0):
            raise InputError('tolerance', tolerance, 'the tolerance USL - LSL (> 0)')
        parts = {'grr': self.grr, 'repeatability': self.repeatability,
                 'reproducibility': self.reproducibility, 'part': self.part}
        return {k: 600.0 * math.sqrt(v) / tolerance for k, v in parts.items()}

    def as_dict(self, tolerance: float | None = None) -> dict[str, Any]:
        """JSON-ready; with ``tolerance`` (USL - LSL) also %Tol and its band."""
        out: dict[str, Any] = {'anova': self.anova, 'variance': {
            'repeatability': self.repeatability, 'operator': self.operator,
            'interaction': self.interaction, 'reproducibility': self.reproducibility,
            'grr': self.grr, 'part': self.part, 'total': self.total},
            'percent_grr': self.percent_grr, 'ndc': self.ndc,
            'interaction_pooled': self.interaction_pooled,
            'acceptance': {'percent_grr': acceptance_band(self.percent_grr),
                           'ndc': 'acceptable' if self.ndc >= NDC_MIN else
                           f'not acceptable (ndc < {NDC_MIN})'}}
        if tolerance is not None:
            tol = self.percent_tolerance(tolerance)
            out['tolerance'] = float(tolerance)
            out['percent_tolerance'] = tol
            out['acceptance']['percent_tolerance'] = acceptance_band(tol['grr'])
        return out


#: the fewest distinct categories an acceptable gauge resolves (AIAG MSA)
NDC_MIN = 5


def acceptance_band(percent: float) -> str:
    """AIAG MSA band of a %GRR or %Tol: < 10 acceptable, 10-30 conditionally acceptable,
    > 30 not acceptable."""
    if not math.isfinite(percent):
        return 'not evaluated'
    if percent < 10.0:
        return 'acceptable (< 10 %)'
    if percent <= 30.0:
        return 'conditionally acceptable (10-30 %)'
    return 'not acceptable (> 30 %)'


def gauge_rr(y: ArrayLike, *, pool_alpha: float = 0.25) -> GaugeRR:
    """The study of ``y`` with shape (parts, operators, trials)."""
    from scipy.stats import f as f_dist

    a = np.asarray(y, dtype=float)
    if a.ndim != 3 or min(a.shape) < 2 or not np.all(np.isfinite(a)):
        raise InputError('measurements', a.shape, 'a complete (parts, operators, trials) '
                         'array with at least 2 of each and no missing value')
    p, o, r = a.shape
    grand = a.mean()
    mp = a.mean(axis=(1, 2))
    mo = a.mean(axis=(0, 2))
    mpo = a.mean(axis=2)
    ss_p = o * r * np.sum((mp - grand) ** 2)
    ss_o = p * r * np.sum((mo - grand) ** 2)
    ss_po = r * np.sum((mpo - mp[:, None] - mo[None, :] + grand) ** 2)
    ss_e = np.sum((a - mpo[:, :, None]) ** 2)
    df = {'part': p - 1, 'operator': o - 1, 'interaction': (p - 1) * (o - 1),
          'error': p * o * (r - 1)}
    ss = {'part': ss_p, 'operator': ss_o, 'interaction': ss_po, 'error': ss_e}
    ms = {k: ss[k] / df[k] for k in ss}
    p_inter = float(f_dist.sf(ms['interaction'] / ms['error'], df['interaction'],
                              df['error'])) if ms['error'] > 0 else 0.0
    pooled = p_inter > pool_alpha
    anova = {k: {'df': float(df[k]), 'ss': float(ss[k]), 'ms': float(ms[k])} for k in ss}
    anova['interaction']['p_value'] = p_inter
    if pooled:
        ms_e = (ss_e + ss_po) / (df['error'] + df['interaction'])
        rep, inter = ms_e, 0.0
        oper = max((ms['operator'] - ms_e) / (p * r), 0.0)
        part = max((ms['part'] - ms_e) / (o * r), 0.0)
    else:
        rep = ms['error']
        inter = max((ms['interaction'] - ms['error']) / r, 0.0)
        oper = max((ms['operator'] - ms['interaction']) / (p * r), 0.0)
        part = max((ms['part'] - ms['interaction']) / (o * r), 0.0)
    return GaugeRR(anova=anova, repeatability=float(rep), operator=float(oper),
                   interaction=float(inter), part=float(part), interaction_pooled=pooled)
