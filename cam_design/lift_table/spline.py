"""Smoothing spline with the rebound method 回弹法 (docs/reconstruction.md, a reconstruction).

Pipeline (``reconstruct_spline``):

1. **Rebound** and 2. **fairing** of the rows (``rebound.rebound_fairing``): each row's
   rebound in closed form, spikes faired or taken out as outliers.
3. **Quintic smoothing**: the faired values on a uniform grid are smoothed with the
   discrete quintic smoothing spline (penalty on third differences, the discrete
   form of the integral of h'''^2; reflective ends, or free end nodes for a table
   that ends on a flank), which the DCT-II diagonalises: eigenvalues mu_k^3 with
   mu_k = 2 - 2 cos(pi k / n). The smoothing level is chosen automatically by GCV
   (default) or by minimising an unbiased estimate of the *acceleration* error
   (SURE, noise from the upper half of the spectrum), or set by the caller. Missing
   grid nodes (gaps, outliers) get zero weight in an exact banded solve
   (``smooth_grid``). A quintic (k = 5) interpolating spline through the smoothed
   values gives h..h''' with h''' continuous. Uneven samples are fitted directly by
   a quintic P-spline on uniform knots (``_pspline``).
4. **Sign pattern** of h'' (docs/reconstruction.md step 3): significant sign changes above
   the expected count (2 for a single lobe, or the design's) raise the smoothing (x4,
   at most 5 times) while the fit still follows the data; otherwise a warning.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.fft import dct, idct
from scipy.interpolate import make_interp_spline

from cam_design.errors import InputError, require_positive
from cam_design.lift_table.blas import single_thread_blas
from cam_design.lift_table.coarse import coarse_junctions
from cam_design.lift_table.junction_widths import with_widths
from cam_design.lift_table.junctions import (JunctionSpline, find_junctions,
                                             lattice_minimum, refit)
from cam_design.lift_table.lobe_ends import KinkedLobe, coarse_lobe
from cam_design.lift_table.noise import EXACT_NOISE_REL
from cam_design.lift_table.rebound import VERY_COARSE_RAD, Fairing, rebound_fairing
from cam_design.lift_table.result import Reconstruction, output_grid, sign_changes
from cam_design.lift_table.samples import CleanSamples, clean_samples

CRITERIA = ('risk', 'gcv')
#: a point the rebound kept is an outlier after all when it is this many noise sigmas
#: (and the rebound tolerance) off the smooth fit, and the largest miss near it
SECOND_LOOK_SIGMAS = 6.0
GCV_GAMMA = 1.4
#: the sign-pattern rule leaves out a dwell: where |h'| is below this many standard
#: deviations of the fitted h' that the noise alone gives (derivative_noise)
SIGN_NOISE_SIGMAS = 4.0
MAD_TO_SIGMA = 1.482602218505602

#: table step [rad] above which the junctions kept are fitted as short ramps of h''
COARSE_RAD = VERY_COARSE_RAD
#: table step [rad] above which junctions get the soft-change test and a fit without
#: junctions the coarse-table level rule and the lobe-end knots (2.5 deg tables: ramped
#: C1 at 0.1 um 1.40 -> 0.93 x scipy, the flat-tappet preset 4.7 -> 0.78)
COARSE_LEVEL_RAD = math.radians(2.25)


@dataclass(frozen=True)
class SmoothingChoice:
    """The discrete smoothing level ``lam_d`` (penalty on third differences), the
    equivalent continuous level ``lam`` [rad^5] (penalty on the integral of h'''^2),
    effective degrees of freedom ``edf``, the noise ``sigma`` [m] used, and ``why``."""

    lam_d: float
    lam: float
    edf: float
    sigma: float
    why: str


def derivative_noise(sigma: float, step: float, lam_d: float, n: int, nu: int) -> float:
    """Standard deviation [m/rad^nu] of the smoothed h' (``nu`` = 1) or h'' (2) at a row
    from white noise of ``sigma`` [m] on ``n`` uniform rows ``step`` [rad] apart at the
    discrete level ``lam_d``: sigma / step^nu sqrt(mean_k mu_k^nu g_k^2), g_k =
    1 / (1 + lam_d mu_k^3) the smoother's DCT gains; mu_k^nu is the energy gain of the
    first (nu = 1) and second difference (reflective second difference: eigenvalues
    -mu_k)."""
    mu = _spectrum(n)
    gain = 1.0 / (1.0 + lam_d * mu ** 3)
    return sigma / step ** nu * math.sqrt(float(np.mean(mu ** nu * gain ** 2)))


def grid_edf(lam_d: float, n: int) -> float:
    """Effective degrees of freedom of the smoother of ``n`` uniform values at the
    discrete level ``lam_d``: the sum of its DCT gains 1 / (1 + lam_d mu_k^3)."""
    return float(np.sum(1.0 / (1.0 + lam_d * _spectrum(n) ** 3)))


def _spectrum(n: int) -> NDArray[np.float64]:
    """Eigenvalues mu_k = 2 - 2 cos(pi k / n) of the reflective second difference."""
    return 2.0 - 2.0 * np.cos(np.pi * np.arange(n) / n)


class _Criterion:
    """GCV score or estimated acceleration risk as a function of log10(lam_d)."""

    def __init__(self, coef: NDArray[np.float64], mu: NDArray[np.float64], sigma: float,
                 criterion: str, gamma: float = 1.0) -> None:
        self.m3 = mu ** 3
        self.gamma = gamma
        self.gcv = criterion == 'gcv'
        self.n = coef.size
        if self.gcv:
            self.c2 = coef ** 2
        else:
            w = mu ** 2
            self.wc2 = w * (coef ** 2 - sigma ** 2)
            self.ws2 = w * sigma ** 2

    def __call__(self, log_lam: float) -> float:
        hk = 1.0 / (1.0 + 10.0 ** log_lam * self.m3)
        g = 1.0 - hk
        if self.gcv:
            rss = float(np.dot(g * g, self.c2))
            return self.n * rss / max(self.n - self.gamma * float(hk.sum()), 1e-9) ** 2
        return float(np.dot(g * g, self.wc2) + np.dot(hk * hk, self.ws2))


def choose_smoothing(values: NDArray[np.float64], step: float, *, criterion: str = 'risk',
                     sigma: float | None = None, gamma: float = 1.0,
                     sigma_floor: float = 0.0) -> SmoothingChoice:
    """Automatic smoothing level for uniform samples ``values`` [m] at ``step`` [rad].

    ``risk``: minimise the unbiased estimate of the summed squared error of the second
    difference (acceleration) given the noise sigma [m] (from the upper half of the
    DCT spectrum when None, but at least ``sigma_floor``: a known noise such as the
    rounding of a table, which the spectrum of a smooth lobe rounded at a fine step
    underestimates). ``gcv``: generalised cross-validation.
    """
    if criterion not in CRITERIA:
        raise InputError('criterion', criterion, ' | '.join(CRITERIA))
    n = values.size
    coef = dct(values, norm='ortho')
    mu = _spectrum(n)
    if sigma is None:
        sigma = max(MAD_TO_SIGMA * float(np.median(np.abs(coef[n // 2:]))), sigma_floor)
    score = _Criterion(coef, mu, sigma, criterion, gamma)
    grid = np.arange(-6.0, 18.01, 1.0)
    log_lam, i = lattice_minimum(score, grid, 22)
    lam_d = 10.0 ** log_lam
    edf = float(np.sum(1.0 / (1.0 + lam_d * score.m3)))
    what = ('minimum of the estimated acceleration error (SURE)' if criterion == 'risk'
            else 'GCV minimum' if gamma == 1.0 else f'modified GCV minimum (gamma {gamma:g})')
    edge = ' (at the edge of the search range)' if i in (0, grid.size - 1) else ''
    why = f'{what}{edge}: lam_d = {lam_d:.4g}, edf = {edf:.1f} of {n}'
    if criterion == 'risk':
        # the noise of the (binned) grid values, not the table's noise sigma
        why += f', grid noise {sigma:.3g} m'
    return SmoothingChoice(lam_d, lam_d * step ** 5, edf, float(sigma), why)


@lru_cache(maxsize=8)
def _neumann_cube_banded(n: int) -> NDArray[np.float64]:
    """L^3 in upper banded storage (4 x n), L the reflective second difference
    (diag 1, 2, ..., 2, 1; off-diagonal -1): the penalty the DCT-II diagonalises.
    Interior rows are the stencil (-1, 6, -15, 20, -15, 6, -1); the corner blocks come
    from a small dense product. The result is read-only (cached)."""
    m = min(n, 10)
    main = np.full(m, 2.0)
    main[0] = main[-1] = 1.0
    lap = np.diag(main) - np.eye(m, k=1) - np.eye(m, k=-1)
    dense = lap @ lap @ lap
    ab = np.zeros((4, n))
    for offset, value in zip(range(4), (20.0, -15.0, 6.0, -1.0)):
        ab[3 - offset, offset:] = value
    if n <= 10:
        for offset in range(4):
            ab[3 - offset, offset:] = np.diag(dense, offset)
    else:
        for offset in range(4):
            head = np.diag(dense, offset)[:4]
            ab[3 - offset, offset:offset + 4] = head
        for i in range(n - 4, n):
            for offset in range(4):
                j = i + offset
                if j < n:
                    ab[3 - offset, j] = dense[m - n + i, m - n + j]
    ab.setflags(write=False)
    return ab


def smooth_grid(values: NDArray[np.float64], missing: NDArray[np.bool_],
                lam_d: float) -> NDArray[np.float64]:
    """Discrete quintic smoothing of uniform ``values`` [m]: minimise
    sum_observed (y - z)^2 + lam_d z^T L^3 z, L the reflective second difference.

    With no ``missing`` node this is one DCT filter. Otherwise the values given at
    missing nodes (any fill) are first smoothed by the DCT filter (z0), and the exact
    weighted solution is z0 + d with (W + lam_d L^3) d = W (y - z0) - (y - z0): the
    right-hand side uses lam_d L^3 z0 = y - z0, so nothing of size lam_d * |z| is ever
    formed (banded Cholesky, O(n), well conditioned in d)."""
    from scipy.linalg import solveh_banded

    n = values.size
    hk = 1.0 / (1.0 + lam_d * _spectrum(n) ** 3)
    z0 = idct(hk * dct(values, norm='ortho'), norm='ortho')
    if not np.any(missing):
        return z0
    w = (~missing).astype(float)
    resid = values - z0
    rhs = w * resid - resid
    ab = lam_d * _neumann_cube_banded(n)
    ab[3] += w
    d = solveh_banded(ab, rhs, check_finite=False)
    return z0 + d


def _knot_grid(x: NDArray[np.float64], span: float) -> NDArray[np.float64]:
    """Uniform knots over [x0, x0 + span]: the finest step (from span / (n - 1) up to
    4 times it) at which at least 90 % of the nodes have a sample nearby, so that
    interleaved turns or near-duplicate angles do not leave every other bin empty."""
    base = span / max(x.size - 1, 1)
    grid = np.array([x[0], x[0] + span])
    for factor in (1.0, 1.25, 1.5, 2.0, 2.5, 3.0, 4.0):
        n = max(int(round(span / (base * factor))) + 1, 8)
        grid = np.linspace(x[0], x[0] + span, n)
        idx = np.clip(np.rint((x - grid[0]) / (grid[1] - grid[0])).astype(int), 0, n - 1)
        if np.unique(idx).size >= 0.9 * n:
            break
    return grid


def _bin_means(x: NDArray[np.float64], y: NDArray[np.float64], count: NDArray[np.int64],
               grid: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Count-weighted means of the samples nearest to each uniform grid node; empty
    nodes are missing and filled by linear interpolation."""
    step = float(grid[1] - grid[0])
    idx = np.clip(np.rint((x - grid[0]) / step).astype(int), 0, grid.size - 1)
    w = np.bincount(idx, weights=count, minlength=grid.size)
    missing = w <= 0

    def means(shifted: NDArray[np.float64]) -> NDArray[np.float64]:
        sums = np.bincount(idx, weights=count * shifted, minlength=grid.size)
        out = np.zeros(grid.size)
        out[~missing] = sums[~missing] / w[~missing]
        if np.any(missing):
            out[missing] = np.interp(grid[missing], grid[~missing], out[~missing])
        return out

    # first-order binning bias: move each sample to its node along the slope of the
    # (lightly smoothed) first-pass bin means
    first = means(y)
    slope = np.gradient(np.convolve(first, np.ones(5) / 5, mode='same'), grid)
    values = means(y + slope[idx] * (grid[idx] - x))
    return values, missing


def _third_difference_banded(m: int) -> NDArray[np.float64]:
    """D3^T D3 (free ends) for m coefficients in upper banded storage (6 x m)."""
    c = np.array([-1.0, 3.0, -3.0, 1.0])
    ab = np.zeros((6, m))
    for o in range(4):
        prod = c[:4 - o] * c[o:]
        diag = np.convolve(np.ones(m - 3), prod)        # length m - o
        ab[5 - o, o:] = diag[:m - o]
    return ab


def _pspline(x: NDArray[np.float64], y: NDArray[np.float64], count: NDArray[np.int64],
             grid: NDArray[np.float64], lam: float) -> Any:
    """Quintic penalised regression spline on uniform knots ``grid`` (extended by five
    steps each side): min sum count (y - f)^2 + lam |D3 c|^2, banded O(n)."""
    from scipy.interpolate import BSpline
    from scipy.linalg import solveh_banded

    step = float(grid[1] - grid[0])
    knots = grid[0] + step * np.arange(-5, grid.size + 5)
    basis = BSpline.design_matrix(np.clip(x, knots[5], knots[-6]), knots, 5)
    m = basis.shape[1]
    weighted = basis.multiply(count.astype(float)[:, None]).tocsr()
    gram = (basis.T @ weighted).todia()
    ab = lam * _third_difference_banded(m)
    for offset, data in zip(gram.offsets, gram.data):
        if 0 <= offset <= 5:
            ab[5 - offset, offset:] += data[offset:]
    rhs = weighted.T @ y
    coef = solveh_banded(ab, rhs, check_finite=False)
    return BSpline(knots, coef, 5, extrapolate=True)


def _pad_flank_ends(grid: NDArray[np.float64], values: NDArray[np.float64],
                    missing: NDArray[np.bool_], x: NDArray[np.float64],
                    y: NDArray[np.float64], kept: NDArray[np.bool_], sigma: float
                    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_], int]:
    """Extend a table that does not cover the revolution and ends off the base circle
    by free (zero-weight) nodes, so that the reflective ends of the DCT smoother do
    not force h' = 0 at the data ends. Returns (grid, values, missing, pad)."""
    step = float(grid[1] - grid[0])
    covered = float(x[-1] - x[0]) >= 2.0 * np.pi - 1.5 * step
    tol = max(5.0 * sigma, 2e-4 * float(np.ptp(y)))
    yk = y[kept]
    if covered or (abs(float(np.mean(yk[:5]))) <= tol and abs(float(np.mean(yk[-5:]))) <= tol):
        return grid, values, missing, 0
    pad = int(min(max(grid.size // 2, 16), 400))
    k = min(20, grid.size)
    t = np.arange(1, pad + 1) * step
    head = np.polyfit(grid[:k] - grid[0], values[:k], 1)
    tail = np.polyfit(grid[-k:] - grid[-1], values[-k:], 1)
    grid = np.concatenate([grid[0] - t[::-1], grid, grid[-1] + t])
    values = np.concatenate([np.polyval(head, -t[::-1]), values, np.polyval(tail, t)])
    missing = np.concatenate([np.ones(pad, dtype=bool), missing, np.ones(pad, dtype=bool)])
    return grid, values, missing, pad


@dataclass(frozen=True)
class SplineOptions:
    """Options of ``reconstruct_spline`` (see the module docstring)."""

    smoothing: float | None = None          # continuous lam [rad^5]; None: automatic
    criterion: str = 'gcv'                  # 'gcv' | 'risk'
    threshold: float = 4.5                  # rebound tolerance, robust std of r
    gain: float = 1.0                       # lambda of the rebound move
    cap: float = 3.0                        # cumulative move cap, noise std
    sigma: float | None = None              # instrument noise [m]; None: estimated
    expected_sign_changes: int | None = 2   # of h'' (None: no check)
    step: float | None = None               # output grid step [rad]; None: data step
    junctions: bool = True                  # find h'' jumps and fit them (junctions.py)
    # also on tables coarser than COARSE_RAD (opt-in), each junction tested against a
    # soft change of h'' and fitted as a short ramp of h'' (coarse.py): a step cannot be
    # told there from a rise within one row. Off by default: a single spike on such a
    # table can make a false junction, and the fit's model choice biases a jump speed
    # beyond its stated uncertainty (docs/limits.md)
    coarse_junctions: bool = False
    # the rows' noise is correlated row to row (a filtered trace, found on the base
    # circle by the lobe law): the sign rule's noise band, built for independent rows,
    # cannot tell the lobe's own sign changes of h'' from the noise's; none are kept
    correlated_noise: bool = False


def reconstruct_spline(alpha: ArrayLike | CleanSamples, lift: ArrayLike | None = None,
                       options: SplineOptions | None = None,
                       fairing: Fairing | None = None) -> Reconstruction:
    """Rebound fairing + quintic smoothing spline of a lift table (docs/reconstruction.md).

    ``alpha`` [rad], ``lift`` [m] (or a ``CleanSamples``). Returns a Reconstruction on
    a uniform grid of ``options.step`` (default: the data's median spacing).
    ``fairing``: a rebound result for the same samples, to share between methods.
    """
    with single_thread_blas():
        return _reconstruct(alpha, lift, options or SplineOptions(), fairing)


def _reconstruct(alpha: ArrayLike | CleanSamples, lift: ArrayLike | None,
                 opt: SplineOptions, fairing: Fairing | None) -> Reconstruction:
    if isinstance(alpha, CleanSamples):
        data = alpha
    elif lift is None:
        raise InputError('lift', 'missing', 'lifts [m] beside the angles')
    else:
        data = clean_samples(alpha, lift)
    x, y0 = data.alpha, data.lift
    warnings: list[str] = []
    notes: list[str] = list(data.notes)
    fair = fairing or rebound_fairing(x, y0, threshold=opt.threshold, gain=opt.gain,
                                      cap=opt.cap, sigma=opt.sigma)
    kept = ~fair.outlier
    if np.count_nonzero(fair.outlier):
        notes.append(f'rebound: {int(np.count_nonzero(fair.outlier))} outlier(s) removed '
                     f'(|r| > {fair.tolerance:.3g} m), {fair.sweeps} sweep(s)')
    moved = np.count_nonzero(fair.correction)
    if moved:
        notes.append(f'rebound: {moved} point(s) faired by at most '
                     f'{float(np.max(np.abs(fair.correction))):.3g} m')
    step = data.step
    span = x[-1] - x[0]
    n_grid = int(round(span / step)) + 1
    uniform = (n_grid == x.size and
               float(np.max(np.abs(x - (x[0] + step * np.arange(x.size))))) < 1e-6 * step)
    density = 1.0
    if uniform:
        grid, values, missing = x, fair.lift.copy(), fair.outlier.copy()
        grid, values, missing, pad = _pad_flank_ends(grid, values, missing, x, y0, kept,
                                                     fair.sigma)
        if pad:
            notes.append(f'table ends on a flank: {pad} free nodes added at each end '
                         '(natural instead of reflective ends)')
    else:
        # uneven, interleaved or gappy samples: a quintic P-spline on uniform knots fits
        # the samples themselves (weights = merged counts); bin means on the knot grid
        # only serve to choose the smoothing level
        grid = _knot_grid(x[kept], span)
        n_grid = grid.size
        step = float(grid[1] - grid[0])
        values, missing = _bin_means(x[kept], fair.lift[kept], data.count[kept], grid)
        density = float(np.sum(data.count[kept])) / n_grid
        notes.append(f'uneven sampling: quintic P-spline on {n_grid} uniform knots '
                     f'({np.count_nonzero(missing)} without samples)')
    gaps = np.diff(x)
    if gaps.size and float(gaps.max()) > 3.0 * step:
        g = int(np.argmax(gaps))
        warnings.append(f'gap of {math.degrees(float(gaps[g])):.3g} deg at '
                        f'{math.degrees(float(x[g])):.4g} deg: the reconstruction '
                        'there is an interpolation')
    # GCV with gamma = 1.4 (Kim and Gu): plain GCV's flat minimum often under-smooths,
    # which the acceleration pays for; an exact (computed) table keeps plain GCV, whose
    # minimum is then the interpolant
    exact = fair.sigma <= EXACT_NOISE_REL * float(np.ptp(y0))
    gamma = 1.0 if exact else GCV_GAMMA
    # known noise per grid value: the caller's sigma or the rounding q/sqrt(12), over the
    # square root of the samples per node
    known = opt.sigma if opt.sigma is not None else fair.quantum / math.sqrt(12.0)
    floor = known / math.sqrt(max(density, 1.0))
    if opt.smoothing is None:
        choice = choose_smoothing(values, step, criterion=opt.criterion, gamma=gamma,
                                  sigma_floor=floor)
        gap_nodes = bool(np.any(missing[:-2] & missing[1:-1] & missing[2:]))
        for _ in range(3 if gap_nodes or not uniform else 0):
            # filled nodes are not data: refill them with the weighted solution and
            # choose again, so that the fill looks like the smooth fit, not like an
            # interpolant through the noisy samples at the gap ends
            values = np.where(missing, smooth_grid(values, missing, choice.lam_d), values)
            choice = choose_smoothing(values, step, criterion=opt.criterion, gamma=gamma,
                                      sigma_floor=floor)
    else:
        lam = require_positive('smoothing', opt.smoothing, allow_zero=True)
        lam_d = lam / step ** 5
        choice = SmoothingChoice(lam_d, lam, grid_edf(lam_d, grid.size),
                                 fair.sigma, f'set by the caller: lam = {lam:.4g} rad^5')
    why = choice.why
    lam_d = choice.lam_d
    found = None
    spiked = np.zeros(x.size, dtype=bool)     # rows that explain a junction (coarse.py)
    # coarse tables (coarse.py): a few rows per segment cannot tell a step of h'' from a
    # steep smooth change by GCV alone, so above COARSE_LEVEL_RAD each junction is also
    # tested against a soft change, and above COARSE_RAD the junctions kept are fitted
    # as short ramps of h'' (none sought if opt.coarse_junctions is False); without
    # junctions the level is checked against the base circle's noise
    coarse = step > COARSE_RAD
    if (opt.junctions and uniform and not exact and opt.smoothing is None
            and (opt.coarse_junctions or not coarse)):
        # the search compares GCV scores: it starts from the plain GCV level
        start = choice if opt.criterion == 'gcv' else choose_smoothing(
            values, step, criterion='gcv', gamma=gamma, sigma_floor=floor)
        hedge = ''
        if step > COARSE_LEVEL_RAD:
            outcome = coarse_junctions(grid, values, missing, start.lam_d, gamma=gamma,
                                       sigma_floor=floor)
            found = outcome.found
            hedge = outcome.why
            spiked[[k - pad for k in outcome.rows if 0 <= k - pad < x.size]] = True
            if not step > VERY_COARSE_RAD:      # taken out (kept and named above it)
                missing[pad:pad + x.size] |= spiked
            if np.any(spiked):
                notes.append('coarse table: rows at ' + ', '.join(
                    f'{math.degrees(v):.1f}' for v in x[spiked]) + ' deg explain a step '
                    'of h\'\' beside them better as spikes'
                    + ('' if step > VERY_COARSE_RAD else ': taken out'))
            if outcome.refused:
                notes.append('coarse table: no step of h\'\' at ' + ', '.join(
                    f'{math.degrees(t):.1f}' for t in outcome.refused)
                    + ' deg (a change of h\'\' over 2-4 rows, or spikes, fit the rows '
                    'better)')
        else:
            found = find_junctions(grid, values, start.lam_d, gamma=gamma,
                                   sigma_floor=floor)
            if found is not None:
                found = with_widths(grid, values, found, gamma)
                ramps = [w for w in found.widths if w > 0.0]
                if ramps:
                    hedge = (f'; {len(ramps)} of them a change of h\'\' over '
                             + ', '.join(f'{w:g}' for w in ramps) + ' rows (GCV: the rows '
                             'rise there rather than step)')
        if found is not None:
            lam_d = found.lam_d
            why += (f'; {len(found.angles)} junction(s) where h\'\' jumps, smoothing '
                    f'chosen again with them: lam_d = {lam_d:.4g}' + hedge)
    knots, kinked = None, None   # the coarse rules (lobe_ends.coarse_lobe)
    if (step > COARSE_LEVEL_RAD and uniform and found is None and not exact
            and opt.smoothing is None):
        lobe = coarse_lobe(grid, values, smooth_grid(values, missing, lam_d), missing, fair,
                           floor, lam_d, gamma, opt.criterion == 'gcv')
        lam_d, why, knots, kinked = lobe.lam_d, why + lobe.why, lobe.knots, lobe.plan
    kinked_fit: list[KinkedLobe] = []
    ylift = fair.lift.copy()

    def fit_spline(lam: float) -> Any:
        if uniform and found is not None:
            fit = refit(grid, values, missing, found, lam)
            return JunctionSpline(make_interp_spline(grid, fit.smooth, k=5), fit)
        if uniform:
            kinked_fit[:] = [kinked.fit(values, missing, lam)] if kinked is not None else []
            smooth = kinked_fit[0].values if kinked_fit else smooth_grid(values, missing, lam)
            if knots is not None:
                try:
                    return make_interp_spline(grid, smooth, k=5, t=knots)
                except (ValueError, np.linalg.LinAlgError):
                    pass
            return make_interp_spline(grid, smooth, k=5)
        return _pspline(x[kept], ylift[kept], data.count[kept], grid, lam * density)

    spline = fit_spline(lam_d)
    # second look with the smooth fit: a spike the rebound missed (two spikes in
    # adjacent rows hide each other's rebound) stands out of the fit, a point flagged
    # next to it fits; refit once with the corrected set
    outlier = fair.outlier | (spiked & (step <= VERY_COARSE_RAD))
    kept = ~outlier
    at_rows = spline(x)
    resid = y0 - at_rows
    absr = np.abs(resid)
    absk = np.where(outlier, 0.0, absr)
    # isolated: 3 x the misses of the kept rows within +-3 (bias near a sharp feature
    # of the lift is spread over its neighbours)
    padded = np.concatenate([np.zeros(3), absk, np.zeros(3)])
    window = np.lib.stride_tricks.sliding_window_view(padded, 7).copy()
    window[:, 3] = 0.0
    new = ((absk > fair.tolerance) & (absk > SECOND_LOOK_SIGMAS * fair.sigma)
           & (absk > 1e-9 * float(np.max(np.abs(y0))))
           & (absk > 3.0 * window.max(axis=1)))
    if exact or step > VERY_COARSE_RAD:   # every row kept; say which stand out
        new |= spiked
        if np.any(new):
            listed = ', '.join(f'{math.degrees(v):.1f}' for v in x[new][:5])
            warnings.append(f'rows at {listed} deg stand out of the fit by up to '
                            f'{float(absk[new].max()) * 1e6:.3g} um; at a '
                            f'{math.degrees(step):.3g} deg step an outlier cannot be told '
                            'from the shape of the lobe, so they are kept: check them')
        new = np.zeros_like(new)
    back = outlier & (absr < 3.0 * fair.sigma)
    if np.any(new) or np.any(back):
        outlier = (outlier | new) & ~back
        kept = ~outlier
        ylift[back] = y0[back]
        if uniform:
            values[pad:pad + x.size] = np.where(back, y0, values[pad:pad + x.size])
            missing[pad:pad + x.size] = outlier
        spline = fit_spline(lam_d)
        at_rows = spline(x)
        notes.append(f'second look at the fit: {int(np.count_nonzero(new))} more '
                     f'outlier(s), {int(np.count_nonzero(back))} restored')
    out_step = opt.step or step
    out = output_grid(x[0], x[-1], out_step)
    node_sigma = fair.sigma / math.sqrt(max(density, 1.0))

    def dwell(fitted: Any, level: float, velocity: NDArray[np.float64] | None = None
              ) -> NDArray[np.bool_]:
        """A dwell on the output grid: h' = 0 over an interval within what the noise
        gives at this level, so h'' = 0 there too and the sign flicker of its noise
        is not a sign change of the lobe (``velocity``: h' of ``fitted`` on the output
        grid, when already evaluated)."""
        band = SIGN_NOISE_SIGMAS * derivative_noise(node_sigma, step, level, grid.size, 1)
        h1 = fitted(out, 1) if velocity is None else velocity
        return np.asarray(np.abs(h1) < band, dtype=bool)
    acc = spline(out, 2)
    lift_out = spline(out)
    expected = opt.expected_sign_changes
    # a junction fit explains the steps of h'' itself: its level is not raised for them
    real = False   # the fit's extra sign changes of h'' are the lobe's own
    if expected is not None and opt.smoothing is None and found is None:
        raised = 0
        # more smoothing is only accepted while the fit still follows the data (RMS
        # residual within 25 % of the noise): a real feature (a second lobe) stays
        rms_limit = 1.25 * max(fair.sigma, 1e-300)

        def evaluated(fitted: Any) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
            # (h'', lift) on the output grid; the spline at hand is already evaluated
            return (acc, lift_out) if fitted is spline else (fitted(out, 2), fitted(out))

        def significant_changes(fitted: Any, level: float) -> int:
            fit_acc, fit_lift = evaluated(fitted)
            count = sign_changes(fit_acc, lift=fit_lift)
            if count <= expected:
                return count
            return sign_changes(fit_acc, lift=fit_lift, still=dwell(fitted, level))

        def beyond_noise(fitted: Any, level: float) -> int:
            # sign changes where |h''| also exceeds SIGN_NOISE_SIGMAS times what the
            # noise gives at this level (the noise: the estimate, or the fit's RMS
            # residual when more: a spike the fairing kept wiggles h'' too)
            fit_acc, fit_lift = evaluated(fitted)
            left = float(np.sqrt(np.mean((ylift[kept] - fitted(x[kept])) ** 2)))
            band = SIGN_NOISE_SIGMAS * derivative_noise(max(node_sigma, left), step, level,
                                                        grid.size, 2)
            quiet = dwell(fitted, level) | (np.abs(fit_acc) < band)
            return sign_changes(fit_acc, lift=fit_lift, still=quiet)
        # the pattern to reach: the expected one, or the sign changes that stand above
        # the noise (the lobe's own: the S of a cosine ramp, a second lobe), which more
        # smoothing must not wipe out. Only a fit that smooths (edf at most half its
        # rows) tells the lobe's shape; one that nearly interpolates carries every
        # row's miss into h''.
        target = expected
        if not opt.correlated_noise and significant_changes(spline, lam_d) > expected and \
                grid_edf(lam_d, grid.size) <= 0.5 * np.count_nonzero(kept):
            target = max(expected, beyond_noise(spline, lam_d))
            real = target > expected
        if kinked_fit and significant_changes(spline, lam_d) > target:
            kinked, kinked_fit[:] = None, []    # only with the sign pattern (LobeEndFit)
            spline = fit_spline(lam_d)
            acc, lift_out, at_rows = spline(out, 2), spline(out), spline(x)
        while significant_changes(spline, lam_d) > target and raised < 5:
            trial = fit_spline(lam_d * 4.0)
            if float(np.sqrt(np.mean((ylift[kept] - trial(x[kept])) ** 2))) > rms_limit:
                break
            if real and beyond_noise(trial, lam_d * 4.0) < target:
                break
            lam_d *= 4.0
            raised += 1
            spline = trial
            acc = spline(out, 2)
            lift_out = spline(out)
            at_rows = spline(x)
        if real:
            why += (f"; h'' has {target} sign changes above its noise (the lobe's own, "
                    f'{expected} expected): kept')
        if raised:
            why += (f'; raised x{4 ** raised} to lam_d = {lam_d:.4g} for the sign '
                    f"pattern of h'' ({target} sign changes expected)")
    fit = at_rows[kept]
    edf = grid_edf(lam_d, grid.size)
    parameter: dict[str, Any] = {
        'smoothing': lam_d * step ** 5, 'smoothing_discrete': lam_d, 'edf': edf,
        'criterion': opt.criterion if opt.smoothing is None else 'manual',
        'grid_step_rad': step, 'outliers': int(np.count_nonzero(outlier)),
        'rebound_tolerance_m': fair.tolerance, 'rebound_sweeps': fair.sweeps,
        'max_rebound_m': float(np.max(np.abs(fair.rebound0[1:-1]))),
        'median_rebound_m': float(np.median(np.abs(fair.rebound0[1:-1]))),
    }
    if kinked is not None and kinked_fit:
        parameter['edf'] = kinked_fit[0].edf
        why += kinked.why(grid, kinked_fit[0])
    if isinstance(spline, JunctionSpline):
        parameter['edf'] = spline.junctions.edf
        parameter['junctions_deg'] = [math.degrees(t) for t in spline.junctions.angles]
        parameter['acceleration_jumps_m_per_rad2'] = list(spline.junctions.jumps)
        widths = [spline.junctions.width(k) * math.degrees(step)
                  for k in range(len(spline.junctions.angles))]
        parameter['junction_widths_deg'] = widths
        notes.append("h'' jumps at " + ', '.join(
            f'{math.degrees(t):.2f} deg ({j:+.3g} m/rad^2'
            + (f' over {w:.3g} deg)' if w > 0.0 else ')')
            for t, j, w in zip(spline.junctions.angles, spline.junctions.jumps, widths)))
    final = spline

    def evaluate(a: ArrayLike, nu: int = 0) -> NDArray[np.float64]:
        return np.asarray(final(np.asarray(a, dtype=float), nu), dtype=float)

    velocity = spline(out, 1)
    rec = Reconstruction(
        method='spline', alpha=out, lift=lift_out, velocity=velocity,
        acceleration=acc, jerk=spline(out, 3), data_alpha=x[kept],
        residual=y0[kept] - fit, parameter=parameter, why=why, sigma=fair.sigma,
        evaluate=evaluate,
        outliers_alpha=x[outlier], warnings=warnings, notes=notes)
    rec.outlier_mask = outlier
    rec.check_residuals()
    rec.check_shape(opt.expected_sign_changes, still=dwell(final, lam_d, velocity),
                    above_noise=real)
    rec.check_finite()
    return rec
