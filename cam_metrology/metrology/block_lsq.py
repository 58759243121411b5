"""Linear least squares over samples taken block by block (no rclpy).

A feature of millions of samples must not need its whole design matrix in memory (a
4-column Jacobian of 2 M samples is 64 MB, and ``numpy.linalg.lstsq`` copies it). The
blocks of rows of ``[A | y]`` are reduced one after the other by Householder QR
(a tall-skinny QR: the triangular factor of the rows so far is stacked on the next
block and factorised again). The final ``(p+1) x (p+1)`` triangle ``[[R, z], [0, rho]]``
holds everything the least-squares problem needs: ``A = Q R`` with the same singular
values and right singular vectors as ``A``, ``z = Q^T y`` and ``rho^2`` the residual
sum of squares. The solution is that of the whole matrix up to rounding (orthogonal
transformations, no normal equations: the conditioning is that of ``A``, not its
square). Memory: one block of rows.
"""
from __future__ import annotations

from typing import Iterable

import numpy as np
from numpy.typing import NDArray

from cam_metrology.metrology.spill import blank, release, seal, walk

#: rows of a block (65 536 rows of 5 columns: 2.6 MB)
BLOCK_ROWS = 1 << 16


def triangle(blocks: Iterable[tuple[NDArray[np.float64], NDArray[np.float64]]],
             ) -> tuple[NDArray[np.float64], int]:
    """The upper triangle ``T`` (``(p+1) x (p+1)``) of the QR factorisation of ``[A | y]``
    given as blocks of rows ``(A_k (m_k x p), y_k (m_k))``, and the number of rows.
    Blocks with no rows are skipped; ``T`` is zero-padded when there are fewer than
    ``p + 1`` rows in all."""
    tri: NDArray[np.float64] | None = None
    rows = 0
    width = 0
    for a, y in blocks:
        if a.shape[0] == 0:
            width = a.shape[1] + 1
            continue
        stacked = np.column_stack([a, y])
        if tri is not None:
            stacked = np.vstack([tri, stacked])
        tri = np.asarray(np.linalg.qr(stacked, mode='r'), dtype=np.float64)
        rows += a.shape[0]
        width = stacked.shape[1]
    if tri is None:
        return np.zeros((width, width)), 0
    if tri.shape[0] < tri.shape[1]:
        tri = np.vstack([tri, np.zeros((tri.shape[1] - tri.shape[0], tri.shape[1]))])
    return tri, rows


def solve(tri: NDArray[np.float64], rows: int) -> NDArray[np.float64]:
    """Least-squares solution of ``A x = y`` from the triangle of ``triangle``: what
    ``numpy.linalg.lstsq(A, y, rcond=None)`` gives (singular values below
    ``eps * max(rows, p)`` times the largest treated as zero, as it does)."""
    p = tri.shape[1] - 1
    rcond = np.finfo(float).eps * max(rows, p)
    return np.asarray(np.linalg.lstsq(tri[:p, :p], tri[:p, p], rcond=rcond)[0],
                      dtype=np.float64)


def inverse_normal(tri: NDArray[np.float64]) -> tuple[NDArray[np.float64],
                                                      NDArray[np.float64]]:
    """``((A^T A)^-1, singular values of A)`` from the triangle of ``triangle``, through
    the SVD of ``R`` (its singular values and right vectors are those of ``A``)."""
    p = tri.shape[1] - 1
    _, sv, vt = np.linalg.svd(tri[:p, :p])
    with np.errstate(divide='ignore', invalid='ignore'):
        return (vt.T / sv**2) @ vt, sv


def lstsq(a: NDArray[np.float64], y: NDArray[np.float64],
          block_rows: int = BLOCK_ROWS) -> NDArray[np.float64]:
    """``numpy.linalg.lstsq(a, y, rcond=None)[0]`` for a design matrix ``a`` that is
    already in memory, without its copies (a block at a time)."""
    n = a.shape[0]
    tri, rows = triangle((a[k:k + block_rows], y[k:k + block_rows])
                         for k in range(0, n, block_rows))
    return solve(tri, rows)


def harmonic_lstsq(theta: NDArray[np.float64], y: NDArray[np.float64],
                   mask: NDArray[np.bool_] | None = None,
                   block_rows: int = BLOCK_ROWS, offset: float = 0.0) -> NDArray[np.float64]:
    """Coefficients ``(c, a, b)`` of ``y - offset ~ c + a cos(theta) + b sin(theta)``
    [units of y] by least squares over the samples of ``mask`` (all when None), built a
    block at a time (the 3-column matrix of every sample is never formed)."""
    def blocks() -> Iterable[tuple[NDArray[np.float64], NDArray[np.float64]]]:
        for k in range(0, theta.size, block_rows):
            t, v = theta[k:k + block_rows], y[k:k + block_rows]
            if mask is not None:
                m = mask[k:k + block_rows]
                t, v = t[m], v[m]
            yield t, (v - offset if offset else v)
            release(theta, y)   # spilled columns (``spill``): one block resident

    return harmonic_fit(blocks())


def harmonic_fit(blocks: Iterable[tuple[NDArray[np.float64], NDArray[np.float64]]],
                 ) -> NDArray[np.float64]:
    """``harmonic_lstsq`` of samples handed out as blocks ``(theta [rad], y)``."""
    return solve(*triangle((np.column_stack([np.ones_like(t), np.cos(t), np.sin(t)]), v)
                           for t, v in blocks))


def first_harmonic(theta: NDArray[np.float64], c: float, a: float,
                   b: float) -> NDArray[np.float64]:
    """The model of ``harmonic_lstsq``, c + a cos(theta) + b sin(theta) [units of c, a,
    b], at the angles ``theta`` [rad], built in place (two columns alive at most, not
    the four temporaries of the expression: memory for millions of samples)."""
    out = np.cos(theta)
    out *= a
    part = np.sin(theta)
    part *= b
    out += part
    del part
    out += c
    return out


def minus_harmonic(theta: NDArray[np.float64], s: NDArray[np.float64], a: float,
                   b: float) -> NDArray[np.float64]:
    """``s - (a cos theta + b sin theta)`` [units of s, a, b] (readings with a fitted
    run-out removed), built a block at a time into a new column (a temporary file when
    long: ``spill.blank``): the same values as the whole-column expression."""
    out = blank((s.size,))
    for lo, hi in walk(s.size, theta, s, out):
        out[lo:hi] = s[lo:hi] - first_harmonic(theta[lo:hi], 0.0, a, b)
    return seal(out)
