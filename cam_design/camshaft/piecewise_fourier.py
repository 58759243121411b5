"""Fourier coefficients of a periodic, piecewise-smooth function sampled on a uniform
grid, whose breakpoints (angles where it or a derivative jumps) are known
(docs/methods.md "Loads with kinks on the shaft").

The plain discrete Fourier transform of such samples is only O(step) (a jump) or
O(step^2) (a kink) accurate, wherever the breakpoints fall. Here the function is split,
f = S + sum_b sum_m J_bm B_m(alpha - b), into a part S that is smooth up to the
(``ORDER`` + 1)-th derivative and the kernels B_m: the 2 pi-periodic, zero-mean
functions whose m-th derivative rises by 1 at 0 and which are polynomials elsewhere
(B_m(x) = -(2 pi)^m / (m + 1)! Bern_{m+1}(x / 2 pi) on [0, 2 pi), Bernoulli polynomials),
with Fourier coefficients exactly 1 / (2 pi (i n)^(m + 1)) for n != 0. The jumps J_bm of
f and its first ``ORDER`` derivatives are estimated from the samples on either side of
each breakpoint (a polynomial through the nearest ``POINTS`` samples of that side,
extrapolated to the breakpoint); S is transformed by the FFT, the kernels exactly. The
coefficients of S decay as n^-(ORDER + 2), so the harmonics above the grid's Nyquist
order are those of the kernels alone (``tail``).

This is the singularity subtraction of Eckhoff (Math. Comp. 64, 1995) and Lyness
(Math. Comp. 28, 1974) with the jumps taken from the samples.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

#: highest derivative whose jump is estimated and removed
ORDER = 3
#: samples on each side of a breakpoint that its one-sided polynomial goes through
POINTS = 7
#: rad: a breakpoint this close to a node is taken as on it
ON_NODE = 1e-12
TWO_PI = 2.0 * math.pi


def kernel(x: NDArray[np.float64], m: int) -> NDArray[np.float64]:
    """B_m at ``x`` [rad] (module docstring): B_0 = (pi - x) / (2 pi) on (0, 2 pi),
    B_m' = B_{m-1}, zero mean; at x = 0 (mod 2 pi) the mean of the two one-sided
    values (B_0 jumps there)."""
    t = np.mod(np.asarray(x, dtype=float), TWO_PI) / TWO_PI
    if m == 0:
        out = 0.5 - t
        return np.where(t == 0.0, 0.0, out)
    bern = {1: t * t - t + 1.0 / 6.0,
            2: t ** 3 - 1.5 * t * t + 0.5 * t,
            3: t ** 4 - 2.0 * t ** 3 + t * t - 1.0 / 30.0}[m]
    return -(TWO_PI ** m) / math.factorial(m + 1) * bern


@dataclass(frozen=True)
class Breaks:
    """Breakpoints [rad] in [0, 2 pi), ascending, and the jumps (B, ORDER + 1) of the
    function and its derivatives there (right limit minus left limit, per rad^m)."""

    at: NDArray[np.float64]
    jumps: NDArray[np.float64]
    #: nodes on a breakpoint (grid index) and the mean of the function's two limits there
    on_node: tuple[tuple[int, float], ...] = ()


def _side(samples: NDArray[np.float64], idx: NDArray[np.int64], offsets: NDArray[np.float64],
          step: float) -> NDArray[np.float64]:
    """Value and derivatives 1..ORDER [per rad^m] at offset 0 of the polynomial through
    ``samples[idx]`` at ``offsets`` [rad] (least squares when more points than terms)."""
    out = np.zeros(ORDER + 1)
    if idx.size == 0:
        return out
    deg = min(idx.size - 1, POINTS - 1)
    s = offsets / step
    vand = s[:, None] ** np.arange(deg + 1)
    coef = np.linalg.lstsq(vand, samples[idx], rcond=None)[0]
    for m in range(min(deg, ORDER) + 1):
        out[m] = coef[m] * math.factorial(m) / step ** m
    return out


def find_jumps(samples: NDArray[np.float64], breaks: ArrayLike) -> Breaks:
    """Jumps of the periodic function sampled as ``samples`` (N points, alpha_k =
    2 pi k / N) at ``breaks`` [rad], each side from the samples between it and the
    neighbouring breakpoint (at most POINTS of them). Breakpoints with fewer than
    ``MIN_BETWEEN`` samples between them form a cluster that is left as it is (no
    jumps: the error there is that of the plain transform); it still bounds its
    neighbours' samples."""
    f = np.asarray(samples, dtype=float)
    N = f.size
    step = TWO_PI / N
    b = np.unique(np.mod(np.asarray(breaks, dtype=float).ravel(), TWO_PI))
    if b.size and TWO_PI - b[-1] < ON_NODE:
        b = np.unique(np.concatenate([[0.0], b[:-1]]))
    lo, hi = _clusters(b, step)
    if lo.size == 0:
        return Breaks(at=lo, jumps=np.zeros((0, ORDER + 1)))
    at = np.mod(0.5 * (lo + hi), TWO_PI)
    jumps = np.zeros((lo.size, ORDER + 1))
    on: list[tuple[int, float]] = []
    n = lo.size
    for i in range(n):
        if hi[i] - lo[i] > ON_NODE:
            continue                            # a cluster: left to the plain transform
        nxt = lo[(i + 1) % n] + (TWO_PI if i + 1 == n else 0.0)
        prv = hi[i - 1] - (TWO_PI if i == 0 else 0.0)
        k0 = math.floor(hi[i] / step + ON_NODE / step) + 1      # strictly right of hi
        kr = k0 + np.arange(POINTS)
        kr = kr[kr * step < nxt - ON_NODE]
        k1 = math.ceil(lo[i] / step - ON_NODE / step) - 1       # strictly left of lo
        kl = k1 - np.arange(POINTS)
        kl = kl[kl * step > prv + ON_NODE]
        ref = 0.5 * (lo[i] + hi[i])
        r = _side(f, kr % N, kr * step - ref, step)
        left = _side(f, kl % N, kl * step - ref, step)
        jumps[i] = r - left
        pos = ref / step
        if abs(pos - round(pos)) * step < ON_NODE and hi[i] - lo[i] < ON_NODE:
            on.append((int(round(pos)) % N, 0.5 * (r[0] + left[0])))
    return Breaks(at=at, jumps=jumps, on_node=tuple(on))


#: samples that must lie between two breakpoints for each to be corrected on its own
MIN_BETWEEN = 3


def _clusters(b: NDArray[np.float64], step: float
              ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(first, last) breakpoint [rad] of each cluster: neighbours with fewer than
    MIN_BETWEEN grid nodes strictly between them are one cluster (across the
    revolution's end too: then the last cluster's end runs past 2 pi)."""
    if b.size == 0:
        return np.zeros(0), np.zeros(0)

    def between(x: float, y: float) -> int:
        return math.ceil(y / step - ON_NODE / step) - math.floor(x / step + ON_NODE / step) - 1

    lo, hi = [float(b[0])], [float(b[0])]
    for x in b[1:].tolist():
        if between(hi[-1], x) < MIN_BETWEEN:
            hi[-1] = x
        else:
            lo.append(x)
            hi.append(x)
    if len(lo) > 1 and between(hi[-1], lo[0] + TWO_PI) < MIN_BETWEEN:
        hi[-1] = hi[0] + TWO_PI                  # the first cluster joins the last
        lo, hi = lo[1:], hi[1:]
    if len(lo) == 1 and hi[0] - lo[0] > TWO_PI - (MIN_BETWEEN + 1) * step:
        return np.zeros(0), np.zeros(0)          # breakpoints all around: none kept
    return np.asarray(lo), np.asarray(hi)


def smooth_part(samples: NDArray[np.float64], br: Breaks) -> NDArray[np.float64]:
    """Samples of S = f - sum J B (module docstring); at a node on a breakpoint the mean
    of f's two limits minus the kernels' values there."""
    f = np.asarray(samples, dtype=float)
    N = f.size
    if br.at.size == 0:
        return f.copy()
    alpha = np.arange(N) * (TWO_PI / N)
    g = f.copy()
    for m in range(ORDER + 1):
        g -= kernel(alpha[None, :] - br.at[:, None], m).T @ br.jumps[:, m]
    for k, mean in br.on_node:
        # kernel(0, 0) is the mean of B_0's limits: the node takes f's mean as well
        g[k] += mean - f[k]
    return g


def kernel_coefficients(br: Breaks, n: NDArray[np.int64]) -> NDArray[np.complex128]:
    """Exact Fourier coefficients sum_bm J_bm exp(-i n b) / (2 pi (i n)^(m + 1)) of the
    kernel part at the harmonics ``n`` (>= 1)."""
    n = np.asarray(n, dtype=np.int64)
    if br.at.size == 0:
        return np.zeros(n.size, dtype=complex)
    phase = np.exp(-1j * np.outer(n, br.at))                     # (n, B)
    inv = 1.0 / (1j * n.astype(float))
    out: NDArray[np.complex128] = np.zeros(n.size, dtype=np.complex128)
    power = inv.copy()
    for m in range(ORDER + 1):
        out += (phase @ br.jumps[:, m]) * power
        power = power * inv
    return out / TWO_PI


def coefficients(samples: NDArray[np.float64], breaks: ArrayLike
                 ) -> tuple[NDArray[np.complex128], Breaks]:
    """rfft-scaled Fourier coefficients c_n (f = sum c_n exp(i n alpha), n = 0..N/2) of
    the sampled function with breakpoints ``breaks`` [rad], and the breakpoints with
    their jumps (for the harmonics above N/2: ``kernel_coefficients``). The Nyquist
    coefficient (N even) is that of S alone, to be used once; the kernels' own share at
    n >= N/2 is ``kernel_coefficients``."""
    f = np.asarray(samples, dtype=float)
    N = f.size
    br = find_jumps(f, breaks)
    c = np.fft.rfft(smooth_part(f, br)) / N
    if br.at.size:
        top = c.size - 1 if N % 2 == 0 else c.size
        c[1:top] += kernel_coefficients(br, np.arange(1, top))
    return c, br


def integral(samples: NDArray[np.float64], breaks: ArrayLike) -> float:
    """Integral over the revolution of the sampled function with breakpoints
    ``breaks`` [rad] (2 pi times the mean of S; the kernels have zero mean)."""
    f = np.asarray(samples, dtype=float)
    br = find_jumps(f, breaks)
    return float(np.mean(smooth_part(f, br)) * TWO_PI)
