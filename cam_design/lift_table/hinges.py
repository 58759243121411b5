"""The hinges of a junction, the columns the partial spline adds to let h'' (and h''')
change at a point: g2 = u_+^2 / 2, a unit step of h''; g3 = u_+^3 / 6, a unit step of
h''' tapered to zero over ``taper_nodes`` (C5 there); and ``ramp_hinge``, a unit change
of h'' spread linearly over a width (the 5 deg hedge). Positions and lengths in nodes
(grid rows), u measured into the side the hinge opens to (``side_of``).
"""
from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
from numpy.polynomial import Polynomial
from numpy.typing import NDArray


def _smoothstep() -> Polynomial:
    """S(v) = v^6 sum_k C(5 + k, k) (1 - v)^k: 0 at 0, 1 at 1, flat to 5th order."""
    v = Polynomial([0.0, 1.0])
    return v ** 6 * sum(math.comb(5 + k, k) * Polynomial([1.0, -1.0]) ** k
                        for k in range(6))


def side_of(tau: float, n: int) -> int:
    """+1: the junction at node ``tau`` opens to the right (its longer side), else -1."""
    return 1 if tau <= 0.5 * (n - 1) else -1


def taper_nodes(n: int) -> float:
    """Length [nodes] of a junction's cubic hinge (long beside the smoother's
    bandwidth, short enough to keep its values, and the rounding of R g, small)."""
    return max(min(0.25 * (n - 1), 60.0 + 0.02 * n), 4.0)


@lru_cache(maxsize=64)
def _hinges_on(length: float) -> tuple[Polynomial, Polynomial]:
    """g2 = u^2/2 on u > 0 (no taper: the free ends do not penalise a quadratic) and
    g3 = u^3/6 w(u) on [0, L], w = 1 - S(u / L), 0 beyond (C5 there, 1 + O(u^6) at
    0): unit steps of the second and third derivatives at 0, in node units."""
    taper = 1.0 - _smoothstep()(Polynomial([0.0, 1.0 / length]))
    return Polynomial([0.0, 0.0, 0.5]), Polynomial([0.0, 0.0, 0.0, 1.0 / 6.0]) * taper


@lru_cache(maxsize=64)
def hinge_coefficients(length: float, nu: int) -> tuple[NDArray[np.float64], ...]:
    """Power-series coefficients of the nu-th derivatives of g2 and g3."""
    return tuple(np.asarray(p.deriv(nu).coef, dtype=np.float64) for p in _hinges_on(length))


def horner(x: NDArray[np.float64], coef: NDArray[np.float64]) -> NDArray[np.float64]:
    """sum_k coef[k] x^k by Horner's rule (numpy's polyval without its checks)."""
    acc = np.full(x.shape, coef[-1])
    for c in coef[-2::-1]:
        acc *= x            # in place: the same operations, no temporaries
        acc += c
    return acc


def hinge_values(u: NDArray[np.float64], length: float, nu: int = 0) -> NDArray[np.float64]:
    """(len(u), 2): nu-th u-derivatives of g2 and g3 (node units), ``u`` nodes from a
    junction that opens to the right."""
    return hinge_block(np.asarray(u, dtype=float).reshape(-1, 1), length, nu)


def hinge_block(u: NDArray[np.float64], length: float, nu: int = 0) -> NDArray[np.float64]:
    """(m, 2k): ``hinge_values`` of each column of ``u`` (m, k) side by side (g2 and g3
    of column j in columns 2j, 2j + 1), all in one pass of Horner's rule."""
    out = np.zeros((u.shape[0], 2 * u.shape[1]))
    quad, cubic = hinge_coefficients(float(length), nu)
    pos = u > 0
    g2, g3 = out[:, 0::2], out[:, 1::2]         # views
    g2[pos] = horner(u[pos], quad)              # 0 where the hinge is closed
    near = pos & (u < length)
    g3[near] = horner(u[near], cubic)
    return out


def _truncated_power(x: NDArray[np.float64], k: int) -> NDArray[np.float64]:
    """x_+^k / k! (k >= 0; k = 0: the unit step at x > 0)."""
    if k == 0:
        return np.asarray(x > 0.0, dtype=np.float64)
    return np.asarray(np.maximum(x, 0.0) ** k / math.factorial(k), dtype=np.float64)


def ramp_hinge(u: NDArray[np.float64], width: float, nu: int = 0) -> NDArray[np.float64]:
    """nu-th u-derivative of a unit change of h'' at u = 0 (node units, opening to
    positive u): the step u_+^2 / 2 (``width`` 0) or a linear change of h'' over
    ``width`` nodes centred on 0, ((u + w/2)_+^3 - (u - w/2)_+^3) / (6 w), which beyond
    the ramp is the step's u^2 / 2 plus the constant w^2 / 24. Derivatives of order
    above 2 (step) or 3 (ramp) are 0 (the delta functions left out)."""
    u = np.asarray(u, dtype=float)
    if width <= 0.0:
        return _truncated_power(u, 2 - nu) if nu <= 2 else np.zeros(u.shape)
    if nu > 3:
        return np.zeros(u.shape)
    return np.asarray((_truncated_power(u + 0.5 * width, 3 - nu)
                       - _truncated_power(u - 0.5 * width, 3 - nu)) / width,
                      dtype=np.float64)
