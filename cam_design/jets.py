"""Truncated Taylor arithmetic ("jets") of order 3, vectorised over points.

A jet is an array of shape (4, n): the coefficients c0..c3 of
c0 + c1 e + c2 e^2 + c3 e^3 for a small increment e of a curve parameter. Composing
jets gives the exact derivatives up to order 3 of any smooth expression, with no finite
differences. The follower geometry, the grinding wheel path, the master cam and the
machining-error sensitivities all differentiate through these. Units are those of the
quantities carried; the parameter's unit divides the k-th coefficient k times.
"""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

#: highest power kept: jets carry value, slope, curvature term and jerk term.
JET_ORDER = 3


def jet_const(value: ArrayLike, n: int) -> NDArray[np.float64]:
    """Jet of a constant (shape (4, n)): value, then zero derivatives."""
    out = np.zeros((JET_ORDER + 1, n))
    out[0] = value
    return out


def jet_mul(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Jet of the product a b (Cauchy product truncated at order 3)."""
    out = np.zeros(np.broadcast_shapes(a.shape, b.shape))
    for k in range(JET_ORDER + 1):
        for j in range(k + 1):
            out[k] += a[j] * b[k - j]
    return out


def jet_div(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Jet of the quotient a / b (``b[0]`` non-zero)."""
    out = np.zeros(np.broadcast_shapes(a.shape, b.shape))
    for k in range(JET_ORDER + 1):
        acc = a[k].copy()
        for j in range(1, k + 1):
            acc -= b[j] * out[k - j]
        out[k] = acc / b[0]
    return out


def jet_sqrt(a: NDArray[np.float64]) -> NDArray[np.float64]:
    """Jet of sqrt(a) (``a[0]`` > 0)."""
    out = np.zeros(a.shape)
    out[0] = np.sqrt(a[0])
    for k in range(1, JET_ORDER + 1):
        acc = a[k].copy()
        for j in range(1, k):
            acc -= out[j] * out[k - j]
        out[k] = acc / (2.0 * out[0])
    return out


def jet_deriv(a: NDArray[np.float64]) -> NDArray[np.float64]:
    """Jet of the derivative (the order-3 coefficient becomes 0: a cubic's derivative)."""
    out = np.zeros(a.shape)
    for k in range(JET_ORDER):
        out[k] = (k + 1) * a[k + 1]
    return out


def jet_atan2(y: NDArray[np.float64], x: NDArray[np.float64]) -> NDArray[np.float64]:
    """Jet of atan2(y, x): value from np.arctan2, higher terms from (y'x - yx')/(x^2+y^2)."""
    rate = jet_div(jet_mul(jet_deriv(y), x) - jet_mul(y, jet_deriv(x)),
                   jet_mul(x, x) + jet_mul(y, y))
    out = np.zeros(rate.shape)
    out[0] = np.arctan2(y[0], x[0])
    for k in range(1, JET_ORDER + 1):
        out[k] = rate[k - 1] / k
    return out


def jet_inverse_compose(angle: NDArray[np.float64],
                        value: NDArray[np.float64]) -> NDArray[np.float64]:
    """Derivatives d^k value / d angle^k (k = 0..3), shape (4, n), by series reversion.

    ``angle`` and ``value`` are jets in the same parameter; ``angle[1]`` must be non-zero.
    """
    a1, a2, a3 = angle[1], angle[2], angle[3]
    b1 = 1.0 / a1
    b2 = -a2 * b1 ** 3
    b3 = (2.0 * a2 * a2 - a1 * a3) * b1 ** 5
    q0, q1, q2, q3 = value
    return np.stack([q0, q1 * b1, 2.0 * (q1 * b2 + q2 * b1 * b1),
                     6.0 * (q1 * b3 + 2.0 * q2 * b1 * b2 + q3 * b1 ** 3)])
