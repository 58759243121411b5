"""Type-1 gauge study: repeatability and bias of a gauge on one reference part.

n repeated measurements x_i of a reference part of known value x_m, tolerance T of the
characteristic (USL - LSL). Convention (the one of Minitab, JASP and the VDA 5 / Q-DAS
practice, with the defaults K = 20 % of the tolerance and a study variation of 6 s):

* mean x̄, standard deviation s (n - 1 in the denominator), bias = x̄ - x_m;
* Cg = (K/100) T / (6 s) = 0.2 T / (6 s);
* Cgk = ((K/200) T - |bias|) / (3 s) = (0.1 T - |bias|) / (3 s);
* %Var(repeatability) = 100 (6 s) / T = K / Cg; %Var(repeatability and bias) = K / Cgk;
* significance of the bias: t = bias / (s / sqrt(n)) with n - 1 degrees of freedom,
  two-sided p-value; the bias is significant when p < alpha (0.05).

A gauge is capable for the characteristic when Cg >= 1.33 and Cgk >= 1.33 (the usual
acceptance limit; some plants ask 1.67).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from cam_design.errors import InputError

#: share of the tolerance [%] the gauge's 6 s may take at Cg = 1 (the common default)
DEFAULT_K_PERCENT = 20.0
#: Cg and Cgk at or above this: the gauge is capable
CAPABLE = 1.33


@dataclass(frozen=True)
class Type1Study:
    """Result of a type-1 study (values in the unit of the measurements)."""

    n: int
    mean: float
    std: float
    reference: float
    tolerance: float
    bias: float
    cg: float
    cgk: float
    t: float
    p_value: float
    k_percent: float = DEFAULT_K_PERCENT

    @property
    def bias_significant(self) -> bool:
        """True if the bias differs from 0 at the 5 % level (two-sided t-test)."""
        return self.p_value < 0.05

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready, with the convention stated."""
        return {'n': self.n, 'mean': self.mean, 'std': self.std, 'reference': self.reference,
                'tolerance': self.tolerance, 'bias': self.bias,
                'bias_t': self.t, 'bias_p_value': self.p_value,
                'bias_significant': self.bias_significant, 'cg': self.cg, 'cgk': self.cgk,
                'percent_var_repeatability': self.k_percent / self.cg,
                'percent_var_repeatability_and_bias': (self.k_percent / self.cgk
                                                       if self.cgk > 0 else math.inf),
                'capable': bool(self.cg >= CAPABLE and self.cgk >= CAPABLE),
                'convention': f'Cg = {self.k_percent / 100:g} T / (6 s); Cgk = '
                              f'({self.k_percent / 200:g} T - |bias|) / (3 s); capable '
                              f'when both >= {CAPABLE}'}


def type1_study(values: ArrayLike, reference: float, tolerance: float, *,
                k_percent: float = DEFAULT_K_PERCENT, key: str = 'type1') -> Type1Study:
    """The type-1 study of repeated measurements ``values`` of a part of value
    ``reference`` against the tolerance ``tolerance`` (USL - LSL, same unit)."""
    from scipy.stats import t as t_dist

    x = np.asarray(values, dtype=float).ravel()
    if x.size < 10 or not np.all(np.isfinite(x)):
        raise InputError(f'{key}.values', f'{x.size} values', 'at least 10 finite repeated '
                         'measurements of the reference part (50 are usual)')
    if not (math.isfinite(tolerance) and tolerance > 0):
        raise InputError(f'{key}.tolerance', tolerance, 'the tolerance USL - LSL (> 0)')
    if not math.isfinite(reference):
        raise InputError(f'{key}.reference', reference, 'the reference value (finite)')
    s = float(np.std(x, ddof=1))
    if s == 0.0:
        raise InputError(f'{key}.values', 'all equal', 'measurements that vary (a gauge '
                         'resolution finer than its repeatability)')
    mean = float(np.mean(x))
    bias = mean - float(reference)
    t = bias / (s / math.sqrt(x.size))
    p = float(2.0 * t_dist.sf(abs(t), x.size - 1))
    k = k_percent / 100.0
    return Type1Study(n=int(x.size), mean=mean, std=s, reference=float(reference),
                      tolerance=float(tolerance), bias=bias, cg=k * tolerance / (6.0 * s),
                      cgk=(0.5 * k * tolerance - abs(bias)) / (3.0 * s), t=float(t),
                      p_value=p, k_percent=float(k_percent))
