"""Statistical process control of a measured quantity over parts, and capability.

Individuals chart (one value per part, in measurement order): centre x̄, moving ranges
MR_i = |x_i − x_{i−1}|, sigma_within = MR̄ / d2(2) (d2 = 1.128), limits x̄ ± 3 sigma_within
(= x̄ ± 2.66 MR̄); moving-range chart UCL = D4(2) MR̄ = 3.267 MR̄. X̄–R chart for subgroups
of n = 2..10: limits X̄̄ ± A2 R̄, R chart D3 R̄ .. D4 R̄, sigma_within = R̄ / d2(n).
Capability against a tolerance [LSL, USL]: Cp = (USL − LSL)/(6 sigma_within),
Cpk = min(USL − x̄, x̄ − LSL)/(3 sigma_within); Pp, Ppk the same with the overall sample
standard deviation. Run rules (Western Electric): 1 a point beyond 3 sigma; 2 two of
three consecutive points beyond 2 sigma on the same side; 3 four of five beyond 1 sigma
on the same side; 4 eight in a row on one side of the centre; plus a trend of six
points steadily rising or falling.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cam_design.errors import InputError

#: control-chart constants by subgroup size n: (A2, D3, D4, d2) (ASTM/AIAG tables)
CONSTANTS: dict[int, tuple[float, float, float, float]] = {
    2: (1.880, 0.0, 3.267, 1.128), 3: (1.023, 0.0, 2.574, 1.693),
    4: (0.729, 0.0, 2.282, 2.059), 5: (0.577, 0.0, 2.114, 2.326),
    6: (0.483, 0.0, 2.004, 2.534), 7: (0.419, 0.076, 1.924, 2.704),
    8: (0.373, 0.136, 1.864, 2.847), 9: (0.337, 0.184, 1.816, 2.970),
    10: (0.308, 0.223, 1.777, 3.078)}


@dataclass
class Chart:
    """Limits of a control chart and the points that break a rule."""

    centre: float
    lcl: float
    ucl: float
    sigma_within: float
    range_centre: float
    range_ucl: float
    range_lcl: float = 0.0
    violations: list[dict[str, Any]] = field(default_factory=list)

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready."""
        return dict(self.__dict__)


def _values(x: ArrayLike, key: str, minimum: int) -> NDArray[np.float64]:
    a = np.asarray(x, dtype=float)
    if a.ndim != 1 or a.size < minimum or not np.all(np.isfinite(a)):
        raise InputError(key, f'{a.size} values', f'at least {minimum} finite values')
    return a


def individuals(x: ArrayLike, key: str = 'values') -> Chart:
    """Individuals and moving-range chart of ``x`` (in measurement order)."""
    a = _values(x, key, 3)
    mr = np.abs(np.diff(a))
    mr_bar = float(mr.mean())
    sigma = mr_bar / CONSTANTS[2][3]
    centre = float(a.mean())
    chart = Chart(centre=centre, lcl=centre - 3 * sigma, ucl=centre + 3 * sigma,
                  sigma_within=sigma, range_centre=mr_bar, range_ucl=CONSTANTS[2][2] * mr_bar)
    chart.violations = run_rules(a, centre, sigma)
    return chart


def xbar_r(subgroups: ArrayLike, key: str = 'subgroups') -> Chart:
    """X̄–R chart of a (k, n) array: k subgroups of n = 2..10 values."""
    s = np.asarray(subgroups, dtype=float)
    if s.ndim != 2 or s.shape[1] not in CONSTANTS or s.shape[0] < 2 or not np.all(
            np.isfinite(s)):
        raise InputError(key, s.shape, 'a (subgroups, n) array with n in 2..10 and at least '
                         'two subgroups of finite values')
    a2, d3, d4, d2 = CONSTANTS[s.shape[1]]
    means = s.mean(axis=1)
    ranges = s.max(axis=1) - s.min(axis=1)
    r_bar = float(ranges.mean())
    centre = float(means.mean())
    chart = Chart(centre=centre, lcl=centre - a2 * r_bar, ucl=centre + a2 * r_bar,
                  sigma_within=r_bar / d2, range_centre=r_bar, range_ucl=d4 * r_bar,
                  range_lcl=d3 * r_bar)
    chart.violations = run_rules(means, centre, r_bar / d2 / math.sqrt(s.shape[1]))
    return chart


def run_rules(x: NDArray[np.float64], centre: float, sigma: float) -> list[dict[str, Any]]:
    """Points breaking the Western Electric rules (index = the point that completes the
    pattern)."""
    out: list[dict[str, Any]] = []
    if sigma <= 0:
        return out
    z = (x - centre) / sigma
    for i, zi in enumerate(z):
        if abs(zi) > 3:
            out.append({'index': i, 'rule': 'beyond 3 sigma'})
        for side in (1, -1):
            if i >= 2 and np.sum(side * z[i - 2:i + 1] > 2) >= 2 and side * zi > 2:
                out.append({'index': i, 'rule': '2 of 3 beyond 2 sigma'})
            if i >= 4 and np.sum(side * z[i - 4:i + 1] > 1) >= 4 and side * zi > 1:
                out.append({'index': i, 'rule': '4 of 5 beyond 1 sigma'})
            if i >= 7 and np.all(side * z[i - 7:i + 1] > 0):
                out.append({'index': i, 'rule': '8 in a row on one side'})
        if i >= 5:
            d = np.diff(x[i - 5:i + 1])
            if np.all(d > 0) or np.all(d < 0):
                out.append({'index': i, 'rule': 'trend of 6'})
    return out


@dataclass
class Capability:
    """Process capability against a tolerance."""

    cp: float | None
    cpk: float
    pp: float | None
    ppk: float
    mean: float
    sigma_within: float
    sigma_overall: float

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready."""
        return dict(self.__dict__)


def capability(x: ArrayLike, lsl: float | None, usl: float | None,
               sigma_within: float | None = None, key: str = 'values') -> Capability:
    """Cp/Cpk (within: MR̄/d2 of the individuals unless given) and Pp/Ppk (overall sample
    std) against [lsl, usl]; a one-sided tolerance gives Cpk/Ppk only."""
    a = _values(x, key, 3)
    if lsl is None and usl is None:
        raise InputError('tolerance', None, 'a lower or an upper limit')
    if lsl is not None and usl is not None and not lsl < usl:
        raise InputError('tolerance', (lsl, usl), 'lower limit < upper limit')
    sw = individuals(a).sigma_within if sigma_within is None else float(sigma_within)
    so = float(a.std(ddof=1))
    m = float(a.mean())

    def k_index(sigma: float) -> float:
        sides = [(usl - m) if usl is not None else math.inf,
                 (m - lsl) if lsl is not None else math.inf]
        return min(sides) / (3 * sigma) if sigma > 0 else math.inf

    both = lsl is not None and usl is not None
    return Capability(cp=(usl - lsl) / (6 * sw) if both and sw > 0 else None,
                      cpk=k_index(sw), pp=(usl - lsl) / (6 * so) if both and so > 0 else None,
                      ppk=k_index(so), mean=m, sigma_within=sw, sigma_overall=so)
