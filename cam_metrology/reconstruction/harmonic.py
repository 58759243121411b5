"""N-harmonic (finite Fourier) approximation of a measured lift (docs/reconstruction.md, RECON).

Two bases, both on the rebound-cleaned samples (outliers removed by ``spline.
rebound_fairing``):

* ``full`` (methods option A): the table is resampled uniformly over the whole
  revolution at the data's own step (natural cubic spline through the samples;
  outside a table that ends on the base circle, h = 0), transformed with
  ``np.fft.rfft`` and truncated at order N. Derivatives are analytic: order j scales
  by (i j)^n. The series is periodic, so a lobe pays with truncation ripple on the
  base circle; that ripple is checked and reported.
* ``section`` (option B): least squares on the working section |alpha| <= Phi with
  cos(j pi alpha / Phi), j = 0..N (plus sin(j pi alpha / Phi) when the table is
  asymmetric), constrained so that h, h', h'' and h''' vanish at +-Phi (the lobe
  joins the base circle with continuous jerk); h = 0 outside. Phi comes from the data
  (where the lift leaves the base circle, plus a margin) or from the caller.

N is chosen automatically (overridable): ``cp`` (Mallows' Cp with the noise
estimate: the noise-floor rule; default), ``bic`` (no noise estimate needed),
``risk`` (full basis only: estimated acceleration error with weights j^4), or
``residual`` (Shang's rule: the smallest N with max |residual| <= ``tol``).
Orders beyond the Nyquist limit of the data are capped with a warning.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.interpolate import CubicSpline
from scipy.linalg import LinAlgError, cho_factor, solve_triangular

from cam_design.errors import InputError, require_positive
from cam_design.lift_table.blas import single_thread_blas
from cam_design.lift_table.result import Reconstruction, output_grid
from cam_design.lift_table.samples import CleanSamples
from cam_design.lift_table.rebound import Fairing, rebound_fairing

BASES = ('section', 'full')
CRITERIA = ('noise', 'cp', 'bic', 'risk', 'residual')
#: residual level [fraction of the lift range] below which a noise-free table counts as
#: fitted (8 nm on an 8 mm lobe)
NOISE_FLOOR_REL = 1e-6
NOISE_SLACK = 1.25
#: smallest order a caller may set: N = 0 is a constant and N = 1 a single cosine (an
#: eccentric circle); neither can represent a lobe
MIN_ORDER = 2
ORDER_EXPECTED = (f'an integer >= {MIN_ORDER} (N = 0 is a constant, N = 1 a single '
                  'cosine: neither represents a lobe); omit it for the automatic order')
#: a caller-set order whose rms residual exceeds this many noise sigmas (and 1e-4 of the
#: lift range) under-fits the lobe: the result says so
UNDERFIT_SIGMAS = 5.0


@dataclass(frozen=True)
class HarmonicOptions:
    """Options of ``reconstruct_harmonic`` (see the module docstring)."""

    basis: str = 'section'             # 'section' | 'full'
    order: int | None = None           # N; None: automatic
    # criterion: 'cp' | 'bic' | 'risk' (full) | 'residual'; None: 'bic' (section), 'cp' (full)
    criterion: str | None = None
    tol: float | None = None           # residual target [m] for 'residual'
    half_angle: float | None = None    # Phi [rad] for 'section'; None: from the data
    asymmetric: bool | None = None     # add sines; None: decided from the data
    max_order: int = 150               # search limit
    step: float | None = None          # output grid step [rad]; None: data step
    sigma: float | None = None         # noise [m]; None: estimated (rebound)
    continuity: int = 1                # section: h..h^(continuity) = 0 at +-Phi (-1: none)
    expected_sign_changes: int | None = 2   # of h'' (None: no shape check)


def check_harmonic_options(opt: HarmonicOptions) -> HarmonicOptions:
    if opt.criterion is None:
        opt = replace(opt, criterion='bic' if opt.basis == 'section' else 'cp')
    if opt.basis not in BASES:
        raise InputError('harmonic.basis', opt.basis, ' | '.join(BASES))
    if opt.criterion not in CRITERIA:
        raise InputError('harmonic.criterion', opt.criterion, ' | '.join(CRITERIA))
    if opt.order is not None and (isinstance(opt.order, bool) or int(opt.order) != opt.order
                                  or opt.order < MIN_ORDER):
        raise InputError('harmonic.order', opt.order, ORDER_EXPECTED)
    if opt.criterion == 'residual' and opt.order is None:
        if opt.tol is None:
            raise InputError('harmonic.tol', None, "a residual target [m] for 'residual'")
        require_positive('harmonic.tol', opt.tol)
    if opt.criterion == 'risk' and opt.basis != 'full':
        raise InputError('harmonic.criterion', 'risk', "cp | bic | residual for 'section'")
    return opt


def _cap_order(requested: int, nyquist: int, warnings: list[str]) -> int:
    if requested > nyquist:
        warnings.append(f'order {requested} is beyond the Nyquist limit {nyquist} of the '
                        f'data: capped to {nyquist}')
        return nyquist
    return requested


def reconstruct_harmonic(data: CleanSamples, options: HarmonicOptions | None = None,
                         fairing: Fairing | None = None) -> Reconstruction:
    """N-harmonic reconstruction of cleaned samples (alpha [rad], lift [m])."""
    with single_thread_blas():
        return _reconstruct(data, options or HarmonicOptions(), fairing)


def _reconstruct(data: CleanSamples, opt: HarmonicOptions,
                 fairing: Fairing | None) -> Reconstruction:
    opt = check_harmonic_options(opt)
    fair = fairing or rebound_fairing(data.alpha, data.lift, sigma=opt.sigma)
    kept = ~fair.outlier
    x, y = data.alpha[kept], fair.lift[kept]
    y_raw = data.lift[kept]
    if opt.basis == 'full':
        rec = _full(x, y, y_raw, data.step, fair.sigma, opt)
    else:
        rec = _section(x, y, y_raw, data.step, fair.sigma, opt)
    rec.outliers_alpha = data.alpha[fair.outlier]
    rec.notes = list(data.notes) + rec.notes
    if np.count_nonzero(fair.outlier):
        rec.notes.append(f'rebound: {int(np.count_nonzero(fair.outlier))} outlier(s) removed')
    rec.check_residuals(tol=opt.tol or 0.0)
    _check_underfit(rec, y_raw, opt.order is not None)
    _check_limit(rec, opt)
    rec.check_shape(opt.expected_sign_changes)
    rec.check_finite()
    return rec


def _check_underfit(rec: Reconstruction, y: NDArray[np.float64], manual: bool) -> None:
    """Warn when the order is too low for the lobe. Set by the caller: rms residual above
    ``UNDERFIT_SIGMAS`` noise sigmas and above 1e-4 of the lift range [m]; automatic:
    rms residual above 1.5 noise sigmas and 1e-5 of the lift range."""
    span = float(np.max(y) - np.min(y)) if y.size else 0.0
    order = rec.parameter.get('order')
    rms = rec.rms_residual
    if manual:
        if rms > max(UNDERFIT_SIGMAS * rec.sigma, 1e-4 * span):
            rec.warnings.append(
                f'the order set by the caller (N = {order}) is too low for this lobe: rms '
                f'residual {rms * 1e6:.3f} um against noise sigma {rec.sigma * 1e6:.3g} um; '
                'raise N or omit it for the automatic order')
    elif rms > max(1.5 * rec.sigma, 1e-5 * span, 1e-300):
        rec.warnings.append(
            f'under-fitted: the automatic order N = {order} leaves an rms residual of '
            f'{rms * 1e6:.3f} um against noise sigma {rec.sigma * 1e6:.3g} um (the series '
            'cannot follow this table; compare with the spline)')


def _check_limit(rec: Reconstruction, opt: HarmonicOptions) -> None:
    """Warn when the automatic order sits at the search limit (max_order or the Nyquist
    limit of the data): the series may not have converged."""
    order = rec.parameter.get('order')
    limit = min(int(rec.parameter.get('nyquist_order', opt.max_order)), opt.max_order)
    if opt.order is None and order is not None and order >= limit:
        rec.warnings.append(
            f'the automatic order N = {order} sits at the search limit ({limit}: '
            f'{"the Nyquist limit of the data" if limit < opt.max_order else "max_order"}); '
            'the series may not have converged')


def _gap_warning(x: NDArray[np.float64], step: float, period: float,
                 warnings: list[str]) -> None:
    gaps = np.diff(x)
    if gaps.size and float(gaps.max()) > max(3.0 * step, 0.5 * period):
        g = int(np.argmax(gaps))
        warnings.append(f'gap of {math.degrees(float(gaps[g])):.3g} deg at '
                        f'{math.degrees(float(x[g])):.4g} deg is wider than half the period '
                        'of the highest order or 3 steps: the series there is unconstrained'
                        if float(gaps.max()) > 0.5 * period else
                        f'gap of {math.degrees(float(gaps[g])):.3g} deg at '
                        f'{math.degrees(float(x[g])):.4g} deg: interpolated')


def _base_tolerance(y: NDArray[np.float64], sigma: float) -> float:
    return max(5.0 * sigma, 2e-4 * float(np.ptp(y)), 1e-300)


def _full(x: NDArray[np.float64], y: NDArray[np.float64], y_raw: NDArray[np.float64],
          step: float, sigma: float, opt: HarmonicOptions) -> Reconstruction:
    warnings: list[str] = []
    notes: list[str] = []
    m_pts = int(round(2.0 * np.pi / step))
    m_pts += m_pts % 2
    grid = 2.0 * np.pi * np.arange(m_pts) / m_pts
    wrapped = np.pi - np.mod(np.pi - grid, 2.0 * np.pi)
    covered = (x[-1] - x[0]) >= 2.0 * np.pi - 1.5 * step
    base_tol = _base_tolerance(y, sigma)
    slack = 1e-9 * step
    inside = (wrapped >= x[0] - slack) & (wrapped <= x[-1] + slack)
    if covered:
        inside[:] = True          # the few nodes across +-pi: short extrapolation
    if not covered:
        # end rule: the first and the last row must be on the base circle (within the
        # noise); the lift is then 0 over the rest of the revolution
        first, last = float(y[0]), float(y[-1])
        if abs(first) > base_tol or abs(last) > base_tol:
            raise InputError('harmonic.basis', 'full',
                             'a table covering the whole revolution, or whose first and '
                             'last rows are on the base circle (lift within '
                             f'{base_tol * 1e3:.3g} mm of 0; here {first * 1e3:.4g} and '
                             f"{last * 1e3:.4g} mm); else use --basis section")
        notes.append(f'full basis end rule: the table covers '
                     f'{math.degrees(float(x[-1] - x[0])):.1f} deg and its end rows are on '
                     f'the base circle ({first * 1e3:.3g} and {last * 1e3:.3g} mm): h = 0 '
                     'assumed over the rest of the revolution')
    values = np.zeros(m_pts)
    values[inside] = CubicSpline(x, y, bc_type='natural')(wrapped[inside])
    coef = np.fft.rfft(values) / m_pts
    coef[1:] *= 2.0
    if m_pts % 2 == 0:
        coef[-1] /= 2.0
    nyquist = m_pts // 2 - 1
    _gap_warning(x, step, 2.0 * np.pi / max(nyquist, 1), [])
    n_meas = int(np.count_nonzero(inside))
    var = 4.0 * n_meas * sigma ** 2 / m_pts ** 2          # E|c_j|^2 from the noise
    j = np.arange(coef.size, dtype=float)
    search = min(nyquist, opt.max_order)
    if opt.order is not None:
        order = _cap_order(int(opt.order), nyquist, warnings)
        why = f'set by the caller: N = {order}'
    else:
        order, why = _choose_full(coef[:search + 1], j[:search + 1], var, x, y_raw,
                                  opt, max(n_meas, 2))
    _gap_warning(x, step, 2.0 * np.pi / max(order, 1), warnings)
    c = coef[:order + 1]
    jj = j[:order + 1]

    def evaluate(a: Any, nu: int = 0) -> NDArray[np.float64]:
        a = np.asarray(a, dtype=float)
        e = np.exp(1j * np.outer(a.reshape(-1), jj))
        return np.real(e @ (c * (1j * jj) ** nu)).reshape(a.shape)

    out = output_grid(x[0], x[-1], opt.step or step)
    e = np.exp(1j * np.outer(out, jj))
    derivs = [np.real(e @ (c * (1j * jj) ** nu)) for nu in range(4)]
    fit = evaluate(x)
    base = np.abs(y) <= base_tol
    if np.any(base) and order > 0:
        ripple = float(np.max(np.abs(fit[base])))
        if ripple > max(4.0 * sigma, opt.tol or 0.0, base_tol):
            warnings.append(f'truncation ripple of {ripple:.3g} m on the base circle '
                            f'(N = {order})')
    parameter = {'order': order, 'basis': 'full', 'criterion':
                 'manual' if opt.order is not None else opt.criterion,
                 'nyquist_order': nyquist, 'samples_per_rev': m_pts}
    return Reconstruction(
        'harmonic', out, derivs[0], derivs[1], derivs[2], derivs[3], x, y_raw - fit,
        parameter, why, sigma, evaluate, warnings=warnings, notes=notes,
        spectrum=(j[:search + 1].copy(), np.abs(coef[:search + 1])))


def _choose_full(coef: NDArray[np.complex128], j: NDArray[np.float64], var: float,
                 x: NDArray[np.float64], y: NDArray[np.float64],
                 opt: HarmonicOptions, n_meas: int) -> tuple[int, str]:
    """Order N of the truncated rFFT series by the option's criterion."""
    p2 = np.abs(coef) ** 2
    if opt.criterion == 'residual':
        for n in range(j.size):
            c = coef[:n + 1]
            fit = np.real(np.exp(1j * np.outer(x, j[:n + 1])) @ c)
            if float(np.max(np.abs(y - fit))) <= opt.tol:
                return n, f'smallest N with max |residual| <= {opt.tol:.3g} m'
        return int(j[-1]), (f'residual target {opt.tol:.3g} m not reached up to the '
                            f'search limit N = {int(j[-1])}')
    weight = j ** 4 if opt.criterion == 'risk' else np.ones_like(j)
    if opt.criterion == 'bic':
        # lift residual energy ~ sum of dropped |c_j|^2 / 2; 2 parameters per order
        # residual energy of order N: the dropped |c_j|^2 / 2 per sample (Parseval) plus
        # the noise beyond the search limit; 2 parameters per order; n measured samples
        tail = np.concatenate([np.cumsum((p2 / 2)[::-1])[::-1][1:], [0.0]])
        tail = tail + 0.5 * var * max(n_meas / 2.0 - j[-1], 1.0)
        score = n_meas * np.log(np.maximum(tail, 1e-300)) + 2.0 * j * np.log(n_meas)
        n = int(np.argmin(score))
        return n, f'BIC minimum at N = {n}'
    gain = weight * (p2 - 2.0 * var)       # risk reduction of including order j
    score = -np.cumsum(gain)
    n = int(np.argmin(score))
    label = 'estimated acceleration error (weights j^4)' if opt.criterion == 'risk' \
        else 'Cp / noise-floor rule (orders above 2x the noise power)'
    return n, (f'{label}: N = {n}, noise floor {math.sqrt(var):.3g} m per order')


def _section_basis(x: NDArray[np.float64], phi: float, order: int, asym: bool,
                   nu: int = 0) -> NDArray[np.float64]:
    """Columns [cos 0, cos 1, (sin 1), cos 2, (sin 2), ...] (nu-th derivative)."""
    k = np.arange(order + 1) * np.pi / phi
    arg = np.outer(x, k)
    c = np.cos(arg + nu * np.pi / 2.0) * k ** nu
    if not asym:
        return c
    s = np.sin(arg + nu * np.pi / 2.0) * k ** nu
    cols = [c[:, :1]]
    for i in range(1, order + 1):
        cols += [c[:, i:i + 1], s[:, i:i + 1]]
    return np.hstack(cols)


def _constraints(phi: float, order: int, asym: bool,
                 continuity: int = 3) -> NDArray[np.float64]:
    """Rows: h^(nu) = 0 at alpha = +Phi for nu <= continuity (the equations at -Phi
    are the same up to sign)."""
    if continuity < 0:
        return np.zeros((0, (2 * order + 1) if asym else order + 1))
    rows = [_section_basis(np.array([phi]), phi, order, asym, nu)[0]
            for nu in range(min(continuity, 3) + 1)]
    c = np.array(rows)
    keep = np.any(np.abs(c) > 1e-9 * np.max(np.abs(c), axis=1, keepdims=True), axis=1)
    return c[keep]


def _half_angle(x: NDArray[np.float64], y: NDArray[np.float64], step: float,
                sigma: float) -> float:
    """Working half-angle [rad]: walking out from the lobe centre, where a ~1 deg
    moving mean of the lift first drops to the base circle (5 standard errors), plus
    a margin of 2 deg."""
    w = max(5, int(round(math.radians(1.0) / step)))
    w = min(w, max(1, y.size // 4))
    mean = np.convolve(y, np.ones(w) / w, mode='same')
    thr = max(5.0 * sigma / math.sqrt(w), 1e-4 * float(np.ptp(y)))
    i0 = int(np.argmin(np.abs(x)))
    if mean[i0] <= thr:
        raise InputError('harmonic.half_angle', 'no lift above the base circle at alpha = 0',
                         'a lobe centred on alpha = 0 (re-centre a table file with '
                         '--center-nose, or set half_angle)')
    low = mean <= thr
    right = np.nonzero(low[i0:])[0]
    left = np.nonzero(low[:i0][::-1])[0]
    hi = x[i0 + right[0]] if right.size else x[-1]
    lo = x[i0 - 1 - left[0]] if left.size else x[0]
    return min(max(abs(float(hi)), abs(float(lo))) + math.radians(2.0),
               float(np.max(np.abs(x))))


def _is_asymmetric(x: NDArray[np.float64], y: NDArray[np.float64], phi: float,
                   sigma: float) -> bool:
    sel = (x > 0) & (x < phi) & (-x > x[0])
    if np.count_nonzero(sel) < 8:
        return False
    mirror = CubicSpline(x, y, bc_type='natural')(-x[sel])
    d = y[sel] - mirror
    n = d.size
    return float(np.mean(d ** 2)) > 2.0 * sigma ** 2 * (1.0 + 6.0 / math.sqrt(n)) + \
        (1e-5 * float(np.ptp(y))) ** 2


def _section(x: NDArray[np.float64], y: NDArray[np.float64], y_raw: NDArray[np.float64],
             step: float, sigma: float, opt: HarmonicOptions) -> Reconstruction:
    warnings: list[str] = []
    notes: list[str] = []
    if opt.half_angle is not None:
        phi = require_positive('harmonic.half_angle', opt.half_angle)
        phi_why = 'set by the caller'
    else:
        phi = _half_angle(x, y, step, sigma)
        phi_why = 'from the data'
    asym = (_is_asymmetric(x, y, phi, sigma) if opt.asymmetric is None
            else bool(opt.asymmetric))
    sec = np.abs(x) <= phi
    xs, ys = x[sec], y[sec]
    per_order = 2 if asym else 1
    nyquist = int(min(math.floor(phi / step), (xs.size - 5) // per_order))
    if nyquist < 2:
        raise InputError('harmonic.half_angle', phi, 'a working section with > 10 samples')
    search = min(nyquist, opt.max_order)
    if opt.order is not None:
        order = _cap_order(int(opt.order), nyquist, warnings)
        why = f'set by the caller: N = {order}'
    else:
        order, why = _choose_section(xs, ys, phi, search, asym, sigma, opt)
    a_mat = _section_basis(xs, phi, order, asym)
    cons = _constraints(phi, order, asym, opt.continuity)
    coef = _constrained_lstsq(a_mat, ys, cons)
    _gap_warning(xs, step, 2.0 * phi / max(order, 1), warnings)

    def evaluate(a: Any, nu: int = 0) -> NDArray[np.float64]:
        a = np.asarray(a, dtype=float)
        flat = a.reshape(-1)
        out = np.zeros(flat.size)
        inside = np.abs(flat) <= phi
        out[inside] = _section_basis(flat[inside], phi, order, asym, nu) @ coef
        return out.reshape(a.shape)

    grid = output_grid(x[0], x[-1], opt.step or step)
    derivs = [evaluate(grid, nu) for nu in range(4)]
    fit = evaluate(x)
    outside = ~sec
    if np.any(outside):
        worst = float(np.max(np.abs(y[outside])))
        if worst > _base_tolerance(y, sigma):
            warnings.append(f'lift of {worst:.3g} m measured outside the working section '
                            f'|alpha| <= {math.degrees(phi):.2f} deg (set half_angle)')
    amp = np.abs(coef[:1])
    if asym:
        pairs = coef[1:].reshape(-1, 2)
        amp = np.concatenate([amp, np.hypot(pairs[:, 0], pairs[:, 1])])
    else:
        amp = np.abs(coef)
    notes.append(f'working half-angle Phi = {math.degrees(phi):.3f} deg ({phi_why}); '
                 + ('cosines and sines (asymmetric)' if asym else 'cosines (symmetric)'))
    parameter = {'order': order, 'basis': 'section', 'half_angle_rad': phi,
                 'asymmetric': asym, 'nyquist_order': nyquist,
                 'criterion': 'manual' if opt.order is not None else opt.criterion}
    return Reconstruction(
        'harmonic', grid, derivs[0], derivs[1], derivs[2], derivs[3], x, y_raw - fit,
        parameter, why, sigma, evaluate, warnings=warnings, notes=notes,
        spectrum=(np.arange(order + 1, dtype=float), amp))


def _constrained_lstsq(a_mat: NDArray[np.float64], y: NDArray[np.float64],
                       cons: NDArray[np.float64]) -> NDArray[np.float64]:
    """min |A c - y| subject to C c = 0 (null-space method)."""
    if cons.shape[0] == 0:
        return np.linalg.lstsq(a_mat, y, rcond=None)[0]
    _, s, vt = np.linalg.svd(cons)
    rank = int(np.count_nonzero(s > 1e-12 * s[0]))
    null = vt[rank:].T
    z, *_ = np.linalg.lstsq(a_mat @ null, y, rcond=None)
    return null @ z


def _choose_section(x: NDArray[np.float64], y: NDArray[np.float64], phi: float,
                    search: int, asym: bool, sigma: float,
                    opt: HarmonicOptions) -> tuple[int, str]:
    """Order N by Cp/BIC on nested unconstrained fits (one Cholesky), or residual."""
    if opt.criterion == 'residual':
        for n in range(2, search + 1):
            a_mat = _section_basis(x, phi, n, asym)
            coef = _constrained_lstsq(a_mat, y, _constraints(phi, n, asym, opt.continuity))
            if float(np.max(np.abs(y - a_mat @ coef))) <= opt.tol:
                return n, f'smallest N with max |residual| <= {opt.tol:.3g} m'
        return search, (f'residual target {opt.tol:.3g} m not reached up to the search '
                        f'limit N = {search}')
    a_mat = _section_basis(x, phi, search, asym)
    gram = a_mat.T @ a_mat
    rhs = a_mat.T @ y
    try:
        upper, _ = cho_factor(gram, lower=False, check_finite=False)
        upper = np.triu(upper)
        z = solve_triangular(upper, rhs, trans='T', check_finite=False)
    except LinAlgError:
        # a (numerically) singular Gram matrix, e.g. at the Nyquist order: the same nested
        # projections z = Q^T y from a QR of the basis itself
        q_mat, _ = np.linalg.qr(a_mat)
        z = q_mat.T @ y
    per = 2 if asym else 1
    sizes = 1 + per * np.arange(search + 1)            # parameters at order n
    explained = np.cumsum(z ** 2)[sizes - 1]
    rss = np.maximum(float(y @ y) - explained, 0.0)
    n_pts = y.size
    orders = np.arange(search + 1)
    valid = orders >= 2
    # the noise rule: the smallest N whose residual variance is at the noise level
    dof = np.maximum(n_pts - sizes, 1)
    floor = max(sigma, NOISE_FLOOR_REL * float(np.ptp(y)), 1e-300) ** 2
    # (the robust sigma is itself uncertain by a few per cent: 25 % slack on the variance)
    fits = valid & (rss / dof <= floor * NOISE_SLACK * (1.0 + 2.0 * np.sqrt(2.0 / dof)))
    n_noise = int(np.argmax(fits)) if np.any(fits) else None
    noise_text = f'noise level {math.sqrt(floor):.3g} m'
    if opt.criterion == 'noise':
        if n_noise is not None:
            return n_noise, f'smallest N whose residual is at the noise level ({noise_text}): ' \
                            f'N = {n_noise}'
        return search, (f'residual above the noise ({noise_text}) up to the search limit: '
                        f'N = {search}')
    if opt.criterion == 'bic':
        score = n_pts * np.log(np.maximum(rss, 1e-300) / n_pts) + sizes * np.log(n_pts)
        label = 'BIC minimum'
    else:
        s2 = max(sigma, 1e-300) ** 2
        score = rss / s2 + 2.0 * sizes
        label = f'Cp minimum (noise sigma {sigma:.3g} m)'
    score = np.where(valid, score, np.inf)
    n = int(np.argmin(score))
    edge = ' (at the search limit)' if n == search else ''
    why = f'{label}{edge}: N = {n}'
    if n_noise is None:
        return n, why
    top = n_noise + max(5, n_noise // 2)
    if n < n_noise:
        return n_noise, (f'{why}, raised to N = {n_noise}: below it the residual exceeds '
                         f'the noise ({noise_text})')
    if n > top:
        return top, (f'{why}, capped to N = {top} (1.5 x the order N = {n_noise} that '
                     f'reaches the noise, {noise_text}): beyond it the series fits noise '
                     'or rounding')
    return n, why
