"""Full-flank least-squares estimate of a feature's angle (primary estimator).

Model for a feature whose design lift (as seen by the probe) is ``g(alpha)``:

    s_i = c + g(x_i - d) [+ a cos(theta_i) + b sin(theta_i)] + noise,

with ``x_i = wrap(direction * theta_i - x0)`` the sample angle relative to a coarse
nose ``x0`` [rad], ``d`` the angular shift [rad] (nose = direction * (x0 + d)), ``c``
the lift offset (probe zero) [m] and optionally the first harmonic (a, b) [m] of a
base-circle run-out. Gauss-Newton with the analytic Jacobian ``-g'(x - d)``
(``law(alpha, 1)``); the linear parameters are exact after one step. The standard
uncertainty comes from the residual variance and (J^T J)^-1; with the true noise
instead of the residual variance the same formula is the Cramer-Rao bound
(``crb_shift_std``), which the estimator reaches for Gaussian noise.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from numpy.typing import NDArray

from cam_design.errors import InputError
from cam_metrology.metrology import block_lsq
from cam_metrology.metrology.long_columns import median
from cam_metrology.metrology.spill import blank, is_long, release, walk

TWO_PI = 2.0 * np.pi
Lift = Callable[[NDArray[np.float64], int], NDArray[np.float64]]


def wrap_pi(x: NDArray[np.float64] | float) -> NDArray[np.float64]:
    """Angles [rad] wrapped to (-pi, pi]."""
    y = np.mod(np.asarray(x, dtype=float) + np.pi, TWO_PI) - np.pi
    return np.where(y == -np.pi, np.pi, y)


@dataclass(frozen=True)
class ShiftFit:
    """Result of ``fit_shift``: shift ``d`` [rad], offset ``c`` [m], run-out (a, b) [m]
    (zeros when not fitted), standard uncertainties, residual RMS ``sigma`` [m],
    residuals [m] of the used samples, their mask, and the iteration count."""

    d: float
    c: float
    runout: tuple[float, float]
    d_std: float
    c_std: float
    sigma: float
    residuals: NDArray[np.float64]
    used: NDArray[np.bool_]
    iterations: int


def _design_matrix(gp: NDArray[np.float64], theta: NDArray[np.float64] | None,
                   ) -> NDArray[np.float64]:
    """Jacobian of the model with respect to (d, c[, a, b]) (rows: samples)."""
    cols = [-gp, np.ones_like(gp)]
    if theta is not None:
        cols += [np.cos(theta), np.sin(theta)]
    return np.column_stack(cols)


class _UsedRows:
    """The used samples of a fit, handed out a block of rows at a time: views of the
    arrays when every sample is used, else the used ones of each block (gathered once
    when they fit in one block). ``sw``: square roots of the normalised weights."""

    def __init__(self, x: NDArray[np.float64], s: NDArray[np.float64],
                 theta: NDArray[np.float64] | None, used: NDArray[np.bool_],
                 weights: NDArray[np.float64] | None, block_rows: int) -> None:
        self.count = int(np.count_nonzero(used))
        self.block_rows = block_rows
        if weights is not None and weights.dtype != np.float64:
            weights = np.asarray(weights, dtype=float)   # (a spilled column stays mapped)
        arrays = [x, s, theta, weights]
        self.mask: NDArray[np.bool_] | None = None if self.count == x.size else used
        if self.mask is not None and self.count <= block_rows:
            arrays = [None if a is None else a[used] for a in arrays]
            self.mask = None
        self.arrays = arrays
        first = arrays[0]          # x (masked or not): never None
        assert first is not None
        self.size = first.size
        self.wmean = 1.0
        if weights is not None:
            self.wmean = float(sum(np.sum(w) for _, _, _, w, _ in self._raw())) / self.count

    def _raw(self):   # type: ignore[no-untyped-def]
        """(x, s, theta, weights, slice of the used rows) per block."""
        pos = 0
        for k in range(0, self.size, self.block_rows):
            part = [None if a is None else a[k:k + self.block_rows] for a in self.arrays]
            if self.mask is not None:
                m = self.mask[k:k + self.block_rows]
                part = [None if a is None else a[m] for a in part]
            n = part[0].size
            yield (*part, slice(pos, pos + n))
            release(self.arrays)   # spilled samples (``spill``): one block resident
            pos += n

    def blocks(self):   # type: ignore[no-untyped-def]
        """(x, s, theta or None, sw or None, slice of the used rows) per block."""
        for xs, ss, th, w, where in self._raw():
            yield xs, ss, th, None if w is None else np.sqrt(w / self.wmean), where


def fit_shift(x: NDArray[np.float64], s: NDArray[np.float64], lift: Lift, *,
              theta: NDArray[np.float64] | None = None, d0: float = 0.0,
              c0: float | None = None, used: NDArray[np.bool_] | None = None,
              weights: NDArray[np.float64] | None = None,
              max_iter: int = 50, tol: float = 1e-13,
              block_rows: int = block_lsq.BLOCK_ROWS) -> ShiftFit:
    """Gauss-Newton fit of ``s = c + lift(x - d) [+ a cos theta + b sin theta]``.

    ``x`` [rad] sample angles relative to the coarse nose, ``s`` [m] readings,
    ``lift(alpha, nu)`` the design lift and its derivatives; ``theta`` [rad] enables
    the run-out harmonic. ``used`` selects the samples (default: all). ``weights``:
    relative inverse variances per sample (weighted least squares; normalised to a
    mean of 1, so ``sigma`` stays a typical residual [m]).

    The Jacobian is never formed whole: each Gauss-Newton step is the least-squares
    solution of its blocks of ``block_rows`` rows (``block_lsq``: the same step as
    from the whole matrix up to rounding), so memory is the residual vector and one
    block, whatever the number of samples.
    """
    if used is None:
        used = np.ones(x.size, bool)
    rows = _UsedRows(x, s, theta, used, weights, block_rows)
    fit_runout = theta is not None
    weighted = weights is not None
    npar = 2 if not fit_runout else 4
    n = rows.count
    if n < npar + 2:
        raise InputError('samples', n, f'at least {npar + 2} samples for the fit')
    d = float(d0)
    r = blank((n,))   # residual columns: temporary files for millions of samples
    r_new = blank((n,))
    if c0 is None:
        for xs, ss, _, _, where in rows.blocks():
            r[where] = ss - lift(xs - d, 0)
            release(r)
        c = median(lambda: (r[a:b] for a, b in walk(n, r)))
    else:
        c = float(c0)
    extra = np.zeros(2)
    mapped = isinstance(r, np.memmap)   # sums of squares a block at a time

    def resid(d_: float, c_: float, ab: NDArray[np.float64],
              out: NDArray[np.float64]) -> float:
        """Fill ``out`` with the residuals [m]; return their weighted sum of squares."""
        total = 0.0
        for xs, ss, th, sw, where in rows.blocks():
            rb = ss - c_ - lift(xs - d_, 0)
            if th is not None:
                rb -= block_lsq.first_harmonic(th, 0.0, float(ab[0]), float(ab[1]))
            out[where] = rb
            release(out)
            if sw is not None:
                rw = rb * sw
                total += float(rw @ rw)
            elif mapped:
                total += float(rb @ rb)
        return total if weighted or mapped else float(out @ out)

    def triangle(d_: float, res: NDArray[np.float64]) -> NDArray[np.float64]:
        """QR triangle of the weighted [Jacobian | residuals] at shift ``d_``."""
        def blocks():   # type: ignore[no-untyped-def]
            for xs, _, th, sw, where in rows.blocks():
                jac = _design_matrix(lift(xs - d_, 1), th)
                rb = np.array(res[where])
                release(res)
                yield (jac, rb) if sw is None else (jac * sw[:, None], rb * sw)
        return block_lsq.triangle(blocks())[0]

    rss = resid(d, c, extra, r)
    it = 0
    for it in range(1, max_iter + 1):
        step = block_lsq.solve(triangle(d, r), n)
        lam = 1.0
        while True:
            d_new, c_new = d + lam * step[0], c + lam * step[1]
            ab_new = extra + lam * step[2:4] if fit_runout else extra
            rss_new = resid(d_new, c_new, ab_new, r_new)
            if rss_new <= rss * (1 + 1e-12) or lam < 1e-6:
                break
            lam *= 0.5
        d, c, extra, rss = d_new, c_new, ab_new, rss_new
        r, r_new = r_new, r
        if abs(lam * step[0]) < tol:
            break
    del r_new
    dof = max(n - npar, 1)
    sigma2 = rss / dof
    cov = sigma2 * _inv_normal(triangle(d, r))
    return ShiftFit(d, c, (float(extra[0]), float(extra[1])), float(np.sqrt(cov[0, 0])),
                    float(np.sqrt(cov[1, 1])), float(np.sqrt(sigma2)), r, used, it)


def _inv_normal(tri: NDArray[np.float64]) -> NDArray[np.float64]:
    """(J^T J)^-1 from the QR triangle of J (``block_lsq.triangle``), through the SVD
    of its R (stable when a column is nearly degenerate)."""
    inv, sv = block_lsq.inverse_normal(tri)
    if sv[-1] <= sv[0] * 1e-13:
        raise InputError('fit', 'a singular Jacobian',
                         'samples on the flanks (the angle is not determined)')
    return inv


def crb_shift_std(x_true: NDArray[np.float64], lift: Lift, sigma: float,
                  theta: NDArray[np.float64] | None = None) -> float:
    """Cramer-Rao bound [rad] of the shift for Gaussian noise ``sigma`` [m], samples at
    true design angles ``x_true`` [rad], offset (and run-out if ``theta``) unknown."""
    jac = _design_matrix(lift(x_true, 1), theta)
    tri, _ = block_lsq.triangle([(jac, np.zeros(jac.shape[0]))])
    return float(sigma * np.sqrt(_inv_normal(tri)[0, 0]))


def coarse_align(x: NDArray[np.float64], s: NDArray[np.float64], template: Lift,
                 bins: int = 1440) -> float:
    """Coarse position x0 [rad] such that s(x) ~ c + template(x - x0).

    ``x`` [rad] any angles (taken mod 2 pi). Bin means of the samples are
    circularly cross-correlated with the template by FFT (mean removed on both, so
    the probe zero does not matter); empty bins are filled by circular
    interpolation; the peak is refined by a parabola. Resolution ~ 360/bins deg.
    """
    step = block_lsq.BLOCK_ROWS
    if is_long(x.size):   # long: counts and sums a block at a time, no index column
        cnt = np.zeros(bins, np.int64)
        tot = np.zeros(bins)
        for k, e in walk(x.size, x, s, step=step):
            i = _bin_of(x[k:e], bins)
            cnt += np.bincount(i, minlength=bins)
            # added in sample order onto the running sums: bincount's very sums (a
            # different rounding would move x0 by an ulp, and ties in the angle order
            # of the outlier test with it)
            np.add.at(tot, i, s[k:e])
    else:
        idx = np.empty(x.size, np.int64)   # a block at a time: no full-size temporaries
        for k in range(0, x.size, step):
            idx[k:k + step] = _bin_of(x[k:k + step], bins)
        cnt = np.bincount(idx, minlength=bins)
        tot = np.asarray(np.bincount(idx, weights=s, minlength=bins), dtype=float)
        release(x, s)
    filled = cnt > 0
    if np.count_nonzero(filled) < 8:
        raise InputError('samples', int(np.count_nonzero(filled)),
                         'samples spread over more than 8 angle bins')
    centres = (np.arange(bins) + 0.5) * TWO_PI / bins
    mean = np.interp(centres, centres[filled], tot[filled] / cnt[filled], period=TWO_PI)
    tmpl = template(wrap_pi(centres), 0)
    tmpl = np.where(np.isfinite(tmpl), tmpl, np.nanmin(tmpl))
    corr = np.fft.irfft(np.fft.rfft(mean - mean.mean()) *
                        np.conj(np.fft.rfft(tmpl - tmpl.mean())), n=bins)
    k = int(np.argmax(corr))
    y0, y1, y2 = corr[k - 1], corr[k], corr[(k + 1) % bins]
    den = y0 - 2 * y1 + y2
    frac = 0.5 * (y0 - y2) / den if den < 0 else 0.0
    return float(wrap_pi((k + frac) * TWO_PI / bins))


def _bin_of(x: NDArray[np.float64], bins: int) -> NDArray[np.int64]:
    """Bin number of angles [rad] (taken mod 2 pi) among ``bins`` equal bins."""
    xm = np.mod(x, TWO_PI)
    return np.minimum((xm / TWO_PI * bins).astype(np.int64), bins - 1)


_HERMITE = np.array([   # quintic Hermite basis in monomials t^0..t^5
    [1, 0, 0, -10, 15, -6],        # h(0)
    [0, 1, 0, -6, 8, -3],          # h'(0) * step
    [0, 0, .5, -1.5, 1.5, -.5],    # h''(0) * step^2
    [0, 0, 0, 10, -15, 6],         # h(1)
    [0, 0, 0, -4, 7, -3],          # h'(1) * step
    [0, 0, 0, .5, -1, .5],         # h''(1) * step^2
])


class HermiteLift:
    """A lift law tabulated once as a C2 piecewise quintic Hermite interpolant.

    Node values h, h', h'' come from the law itself (exact derivatives), so the
    interpolation error is O(step^6 h^(6)) on smooth parts and about
    |jump of h''| * step^2 / 100 in an interval holding a junction (step = 0.01 deg:
    < 1e-9 m). Evaluation is pure numpy (a few microseconds per thousand points),
    which matters for laws that are costly to evaluate (``convert_lift`` results).
    Callable like a LiftLaw: ``lift(alpha, nu)`` (nu = 0..3), zero outside ``support``.
    """

    def __init__(self, law: Lift, support: tuple[float, float], step: float) -> None:
        lo, hi = support
        n = max(int(np.ceil((hi - lo) / step)), 1)
        nodes = np.linspace(lo, hi, n + 1)
        self.support = (float(lo), float(hi))
        self.lo, self.step = float(lo), float((hi - lo) / n)
        vals = [law(nodes, nu) for nu in range(3)]
        s = self.step
        left = np.column_stack([vals[0][:-1], s * vals[1][:-1], s * s * vals[2][:-1]])
        right = np.column_stack([vals[0][1:], s * vals[1][1:], s * s * vals[2][1:]])
        coef = np.hstack([left, right]) @ _HERMITE   # (n, 6) monomial coefficients
        self.n = n
        # the six monomial columns once; a derivative scales them as it evaluates
        # (k!/(k - nu)!/step^nu), instead of keeping 18 scaled columns (memory)
        self._coef = [np.ascontiguousarray(coef[:, k]) for k in range(6)]
        self._scale = [[float(np.prod(np.arange(k - nu + 1, k + 1))) / s ** nu
                        for k in range(nu, 6)] for nu in range(4)]

    def __call__(self, alpha: NDArray[np.float64] | float, nu: int = 0) -> NDArray[np.float64]:
        a = np.asarray(alpha, dtype=float)
        flat = a.reshape(-1)
        if flat.size <= block_lsq.BLOCK_ROWS:
            return self._eval(flat, nu).reshape(a.shape)
        out = np.empty(flat.size)   # a block at a time: no full-size temporaries
        for k in range(0, flat.size, block_lsq.BLOCK_ROWS):
            out[k:k + block_lsq.BLOCK_ROWS] = self._eval(flat[k:k + block_lsq.BLOCK_ROWS], nu)
        return out.reshape(a.shape)

    def _eval(self, flat: NDArray[np.float64], nu: int) -> NDArray[np.float64]:
        """The interpolant (or its ``nu``-th derivative) at the angles ``flat`` [rad]."""
        u = (flat - self.lo) / self.step
        inside = (u >= 0) & (u <= self.n)
        idx = np.clip(u.astype(np.int64), 0, self.n - 1)
        t = u - idx
        cols, scale = self._coef[nu:], self._scale[nu]
        out = cols[-1][idx] * scale[-1]
        for col, f in zip(cols[-2::-1], scale[-2::-1]):   # Horner on the nu-th derivative
            out *= t
            out += col[idx] * f
        out[~inside] = 0.0
        return out
