"""The discrete quintic smoother's banded system: I + lam_d P with P = D3'D3, the
penalty on third differences with free ends (a quadratic costs it nothing), on a
uniform table of n nodes. Its banded Cholesky factors (the whole table, cached by level,
and the Toeplitz interior block of any length, whose rows all carry the full stencil),
the banded solves with them, the smoother's trace from the reflective spectrum, and the
deflation that takes the quadratics out of a solve's result. Lengths in nodes.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import lapack


def third_difference_gram(m: int) -> NDArray[np.float64]:
    """D3^T D3 (free ends) for m >= 4 unknowns in upper banded storage (4 x m)."""
    c = np.array([-1.0, 3.0, -3.0, 1.0])
    ab = np.zeros((4, m))
    for o in range(4):
        diag = np.convolve(np.ones(m - 3), c[:4 - o] * c[o:])     # length m - o
        ab[3 - o, o:] = diag[:m - o]
    return ab


@lru_cache(maxsize=16)
def _penalty(m: int) -> NDArray[np.float64]:
    ab = third_difference_gram(m)
    ab.setflags(write=False)
    return ab


def _lower_band(upper: NDArray[np.float64], lam_d: float) -> NDArray[np.float64]:
    """I + lam_d P in lower banded storage (Fortran order) from P in upper storage."""
    m = upper.shape[1]
    low = np.zeros((4, m), order='F')
    for k in range(4):
        low[k, :m - k] = lam_d * upper[3 - k, k:]
    low[0] += 1.0
    return low


def _cholesky(low: NDArray[np.float64]) -> NDArray[np.float64]:
    """Lower banded Cholesky factor (read-only). The lower storage: OpenBLAS's
    factorisation of it takes about 0.4 of the upper one's time at these sizes."""
    c, info = lapack.dpbtrf(low, lower=1, overwrite_ab=1)
    if info != 0:
        raise np.linalg.LinAlgError(f'banded Cholesky failed (info {info})')
    c.setflags(write=False)
    return c


@lru_cache(maxsize=32)
def whole_factor(n: int, lam_d: float) -> NDArray[np.float64]:
    """Banded Cholesky factor of I + lam_d D3'D3 (free ends, n nodes; cached: the
    search asks for the same level many times)."""
    return _cholesky(_lower_band(_penalty(n), lam_d))


@lru_cache(maxsize=16)
def interior_factor(m: int, lam_d: float) -> NDArray[np.float64]:
    """Banded Cholesky factor of the m x m block of I + lam_d D3'D3 away from both
    ends (every row the full stencil 20, -15, 6, -1; Toeplitz)."""
    return _cholesky(_lower_band(_toeplitz_penalty(m), lam_d))


@lru_cache(maxsize=4)
def _toeplitz_penalty(m: int) -> NDArray[np.float64]:
    """The rows of D3'D3 away from both ends, m columns in upper banded storage (every
    row the full stencil 20, -15, 6, -1; read-only)."""
    stencil = np.array([-1.0, 6.0, -15.0, 20.0])
    out = np.repeat(stencil[:, None], m, axis=1)
    out.setflags(write=False)
    return out


def banded_solve(factor: NDArray[np.float64], rhs: NDArray[np.float64]) -> NDArray[np.float64]:
    """(L L')^-1 rhs for a lower banded factor whose first rhs.shape[0] columns are
    used (the leading block's factor is the leading part of the whole one)."""
    m = rhs.shape[0]
    x, info = lapack.dpbtrs(factor[:, :m], rhs, lower=1)
    if info != 0:
        raise np.linalg.LinAlgError(f'banded solve failed (info {info})')
    return np.asarray(x, dtype=np.float64)


def apply_smoother(rhs: NDArray[np.float64], lam_d: float) -> NDArray[np.float64]:
    """(I + lam_d D3'D3)^-1 rhs (rhs (n,) or (n, k))."""
    return banded_solve(whole_factor(rhs.shape[0], float(lam_d)), rhs)


@lru_cache(maxsize=16)
def _cubed_spectrum(n: int) -> NDArray[np.float64]:
    """mu_k^3 of the reflective second difference, modes 1 .. n - 3 (read-only)."""
    mu = 2.0 - 2.0 * np.cos(np.pi * np.arange(1, n - 2) / n)
    m3 = mu ** 3
    m3.setflags(write=False)
    return m3


def trace_smoother(n: int, lam_d: float) -> float:
    """tr (I + lam_d D3'D3)^-1: the three unpenalised quadratics plus the reflective
    spectrum mu_k^3 of the other modes (boundary terms of order one left out)."""
    return 3.0 + float(np.sum(1.0 / (1.0 + lam_d * _cubed_spectrum(n))))


@lru_cache(maxsize=64)
def quadratics(n: int) -> NDArray[np.float64]:
    """Orthonormal basis (n, 3) of the quadratics on n nodes (read-only, cached): the Q
    of the QR factorisation of [1, x, x^2], x = linspace(-1, 1, n), by LAPACK's
    Householder QR (numpy's ``linalg.qr`` makes the same two calls, with more overhead
    than the work of 3 columns)."""
    x = np.linspace(-1.0, 1.0, n)
    qr, tau, _, info = lapack.dgeqrf(np.column_stack([np.ones(n), x, x * x]))
    q, _, info2 = lapack.dorgqr(qr, tau)
    if info != 0 or info2 != 0:
        raise np.linalg.LinAlgError(f'QR of the quadratics failed (info {info}, {info2})')
    out = np.ascontiguousarray(q, dtype=np.float64)     # in numpy's layout (row-major)
    out.setflags(write=False)
    return out


def deflate(r: NDArray[np.float64]) -> NDArray[np.float64]:
    """r without its quadratic part. R r is orthogonal to the quadratics (the free
    ends reproduce them); the banded solve's rounding, amplified by the condition
    number, is not, and a long hinge would sum it up."""
    q = quadratics(r.shape[0])
    return r - q @ (q.T @ r)


#: the stencil of the third difference
THIRD_DIFFERENCE = np.array([-1.0, 3.0, -3.0, 1.0])


def penalty_of(g: NDArray[np.float64]) -> NDArray[np.float64]:
    """P g = D3'D3 g (free ends of ``g``'s own rows)."""
    d3 = np.diff(g, 3, axis=0)
    if g.ndim == 1:
        return np.convolve(d3, THIRD_DIFFERENCE)
    return np.column_stack([np.convolve(d3[:, k], THIRD_DIFFERENCE)
                            for k in range(g.shape[1])])
