"""Measurement of one feature (lobe or dowel pin) from its cleaned samples.

Pipeline of a lobe: design lift as seen by the probe (``convert_lift`` when the
design follower differs from the probe) -> coarse nose by circular correlation ->
flank coverage check (a flank with too little data fails the feature with the
reason) -> full-flank least squares (primary angle, std) -> sensitive-point method
(secondary angle, validity) -> top point / false asymmetry -> lift error and
base-circle run-out. The dowel pin is measured the same way with Liu's
geometry (absolute lift), excluding the samples near the tangent points and the
probe-stop samples outside contact.

Frames: ``x = wrap(direction * theta - x0)`` [rad] relative to the coarse nose x0;
estimators return shifts ``d`` in this frame; the encoder angle of the nose is
``direction * (x0 + d)`` wrapped to [0, 2 pi).
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cam_design.dowel_pin import DowelPinGeometry
from cam_design.errors import InputError
from cam_design.keyway import KeywayGeometry
from cam_metrology.metrology import block_lsq
from cam_metrology.metrology.asymmetry import lift_spline, lobe_spline_of_table, top_point
from cam_metrology.metrology.features import FeatureSamples, unwrapped_blocks
from cam_metrology.metrology.lift_error import (error_stats, error_stats_blocks,
                                                local_deviation,
                                                referenced_error_stats)
from cam_metrology.metrology.lobe_columns import (column_median, column_of, lift_table,
                                                  mask_of, masked, masked_median, selected,
                                                  short_lift_table)
from cam_metrology.metrology.flank_fit import (HermiteLift, Lift, coarse_align, fit_shift,
                                               wrap_pi)
from cam_metrology.metrology.long_columns import angle_order
from cam_metrology.metrology.sensitive_point import sensitive_point_shift, sensitive_points
from cam_metrology.metrology.spill import blank, is_long, release, seal, walk

DEG = np.pi / 180.0
UM = 1e6


class FeatureFailed(Exception):
    """A feature that cannot be measured; the message is the reason."""


@dataclass(frozen=True)
class Settings:
    """Numerical settings of the metrology node (see ``core.MetrologyCore.PARAMETERS``)."""

    fit_runout: bool = True
    min_flank_samples: int = 20
    max_flank_gap_deg: float = 2.0
    sp_half_window_deg: float = 1.0
    sp_fit_order: int = 1
    sp_pairs: int = 0
    sp_pair_spacing_deg: float = 0.5
    pin_edge_margin_deg: float = 0.5
    validity_tol_um: float = 1.0
    asymmetry_knot_deg: float = 0.5
    max_shift_deg: float = 5.0
    outlier_sigma: float = 5.0
    max_residual_rms_um: float = 50.0

    def __post_init__(self) -> None:
        if not 0 <= self.sp_fit_order <= 3:
            raise InputError('metrology.sp_fit_order', self.sp_fit_order, 'an order 0..3')
        for name in ('sp_half_window_deg', 'max_flank_gap_deg', 'asymmetry_knot_deg',
                     'max_shift_deg', 'min_flank_samples', 'max_residual_rms_um'):
            if not getattr(self, name) > 0:
                raise InputError(f'metrology.{name}', getattr(self, name), 'a value > 0')

    @classmethod
    def from_params(cls, params: dict[str, Any]) -> Settings:
        """Settings from a parameter dict (unknown keys ignored; types checked)."""
        kwargs = {}
        for name, default in cls.__dataclass_fields__.items():
            if name in params:
                kwargs[name] = _typed(name, params[name], type(getattr(cls, name)))
        return cls(**kwargs)


_KIND_WORDS = {int: 'an integer', float: 'a number'}


def _typed(name: str, value: Any, kind: type) -> Any:
    """``value`` converted to ``kind`` (bool, int, float) or InputError."""
    if kind is bool:
        if isinstance(value, bool):
            return value
        raise InputError(f'metrology.{name}', value, 'true or false')
    try:
        out = kind(value)
    except (TypeError, ValueError):
        raise InputError(f'metrology.{name}', value, _KIND_WORDS[kind]) from None
    if isinstance(value, bool) or not np.isfinite(out) or out < 0:
        raise InputError(f'metrology.{name}', value, f'{_KIND_WORDS[kind]} >= 0 (finite)')
    return out


@dataclass
class FeatureResult:
    """Report fields of one feature (JSON-ready), its lift table, and the internal
    encoder angle [rad] used for phases."""

    feature_id: str
    kind: str
    values: dict[str, Any]
    table: NDArray[np.float64] | None = None
    angle_rad: float | None = None
    failed: str | None = None
    skipped: list[tuple[str, str]] = field(default_factory=list)


def same_follower(a: Any, b: Any) -> bool:
    """True if two followers see the same lift (flat ignores the radius)."""
    if a.kind != b.kind:
        return False
    return a.kind == 'flat' or abs(a.radius - b.radius) <= 1e-12


def seen_lift(lobe: Any, probe: Any, base_radius: float, *,
              tabulate_step: float | None = 0.01 * DEG) -> Lift:
    """The design lift of ``lobe`` as the probe sees it (``convert_lift`` if needed),
    tabulated once as a quintic Hermite interpolant with ``tabulate_step`` [rad]
    (exact node derivatives, < 1e-11 m off on smooth parts) so that the estimators
    evaluate it cheaply; ``tabulate_step=None`` returns the law itself."""
    if same_follower(lobe.follower, probe):
        law = lobe.lift
    else:
        try:
            from cam_design.follower import convert_lift
        except ImportError:
            raise FeatureFailed(
                f'design follower {lobe.follower.kind} differs from the probe {probe.kind} '
                'and cam_design.follower.convert_lift is not available') from None
        law = convert_lift(lobe.lift, base_radius, lobe.follower, probe)
    if tabulate_step is None:
        return law
    return HermiteLift(law, law.support, tabulate_step)


def is_symmetric(law: Lift, lo: float, hi: float, tol: float = 1e-9) -> bool:
    """True if law(a) == law(-a) within ``tol`` [m] over the support."""
    a = np.linspace(0.0, max(-lo, hi), 2001)
    return bool(np.max(np.abs(law(a, 0) - law(-a, 0))) <= tol)


def _zone_check(x: NDArray[np.float64], zone: tuple[float, float], flank: str,
                settings: Settings) -> None:
    """Fail the feature when a flank's sensitive zone has too few samples or a gap."""
    inside = np.sort(selected(x, mask_of(x.size, lambda a, b: (x[a:b] >= zone[0]) &
                                         (x[a:b] <= zone[1]), x)))
    lo, hi = np.degrees(zone[0]), np.degrees(zone[1])
    need = settings.min_flank_samples
    if inside.size < need:
        raise FeatureFailed(f'{flank} flank: {inside.size} samples in its sensitive zone '
                            f'[{lo:.2f}, {hi:.2f}] deg (need >= {need})')
    edges = np.concatenate(([zone[0]], inside, [zone[1]]))
    gap = float(np.degrees(np.max(np.diff(edges))))
    if gap > settings.max_flank_gap_deg:
        raise FeatureFailed(f'{flank} flank: a gap of {gap:.2f} deg in its sensitive zone '
                            f'[{lo:.2f}, {hi:.2f}] deg (max_flank_gap_deg '
                            f'{settings.max_flank_gap_deg:g})')


def _slope_zone(law: Lift, alpha: float, lo: float, hi: float) -> tuple[float, float]:
    """Interval [rad] around ``alpha`` where |h'| >= half its value at ``alpha``."""
    grid = np.linspace(lo, hi, 4001)
    slope = np.abs(law(grid, 1))
    peak = abs(float(law(np.array(alpha), 1)))
    good = slope >= 0.5 * peak
    k = int(np.argmin(np.abs(grid - alpha)))
    a = k
    while a > 0 and good[a - 1]:
        a -= 1
    b = k
    while b < grid.size - 1 and good[b + 1]:
        b += 1
    return float(grid[a]), float(grid[b])


def _common(fs: FeatureSamples) -> dict[str, Any]:
    return {'samples_received': fs.received, 'samples_used': int(fs.theta.size),
            'samples_nan_dropped': fs.nan_dropped,
            'samples_duplicate_dropped': fs.duplicates_dropped,
            'revolutions': round(fs.revolutions, 4)}


def _encoder_deg(direction: int, x0: float, d: float) -> float:
    return float(np.degrees(np.mod(direction * (x0 + d), 2 * np.pi)))


def _sp_values(sp: Any, direction: int, x0: float, d_lsq: float) -> dict[str, Any]:
    """Report fields of the sensitive-point result (None fields when it failed: the
    reason is in ``sp``, a str)."""
    if isinstance(sp, str):
        return {'sensitive_point_angle_deg': None, 'sensitive_point_angle_std_deg': None,
                'sensitive_point_minus_lsq_deg': None, 'sensitive_point_error': sp}
    return {'sensitive_point_angle_deg': _encoder_deg(direction, x0, sp.d),
            'sensitive_point_angle_std_deg': float(np.degrees(sp.d_std)),
            'sensitive_point_minus_lsq_deg': float(np.degrees(direction * (sp.d - d_lsq))),
            'sensitive_points_alpha_deg': [float(np.degrees(sp.alpha_m)),
                                           float(np.degrees(sp.alpha_n))],
            'sensitive_point_levels_mm': [sp.level_m * 1e3, sp.level_n * 1e3],
            'validity': {'h_m_minus_design_um': sp.validity_dev_m * UM,
                         'h_n_minus_design_um': sp.validity_dev_n * UM,
                         'valid': sp.valid}}


#: floor [m] of the robust noise scale: deviations below 5 x 0.1 um are never outliers
#: (noise-free or very quiet data keep small systematic differences between revolutions)
OUTLIER_SCALE_FLOOR = 1e-7
#: outliers are rare by definition: above this fraction nothing is rejected
OUTLIER_MAX_FRACTION = 0.05


#: var(r - running median of 9) / var(r) for white Gaussian r (computed, 2e6 samples)
MEDIAN9_VARIANCE = 0.9435


def _check_fit(fit: Any, settings: Settings, what: str) -> None:
    """Fail the feature when the fit is not credible: it moved far from the coarse
    estimate, or the measured lift does not match the design lift."""
    if abs(fit.d) > settings.max_shift_deg * DEG:
        raise FeatureFailed(f'least squares moved the {what} by {np.degrees(fit.d):.3f} deg '
                            'from the coarse estimate (data do not match the design lift)')
    if fit.sigma * UM > settings.max_residual_rms_um:
        raise FeatureFailed(f'residual RMS {fit.sigma * UM:.1f} um after the fit exceeds '
                            f'max_residual_rms_um {settings.max_residual_rms_um:g}: the '
                            'measured lift does not match the design lift (wrong lobe or '
                            'scene?)')


def robust_fit(x: NDArray[np.float64], s: NDArray[np.float64], law: Lift,
               settings: Settings, *, theta: NDArray[np.float64] | None = None,
               used: NDArray[np.bool_] | None = None, d0: float = 0.0,
               c0: float | None = None) -> tuple[Any, NDArray[np.bool_], dict[str, float]]:
    """``fit_shift`` with rejection of outliers (spikes, dirt on the probe).

    Samples whose residual deviates from the running median (9 samples in angle
    order) of the residuals by more than ``outlier_sigma`` times the robust scale
    (1.4826 x the median of those deviations, floored at 0.1 um) are dropped and the
    fit repeated (at most 3 times), unless they would be more than 5 % of the
    samples. Isolated spikes are removed; a smooth real form error is not (it stays
    visible in the lift error). Then the residual variance
    model of ``_angle_noise_weighting``. Returns the fit, the mask of rejected
    samples (among ``used``) and the noise estimates.
    """
    cand = np.ones(x.size, bool) if used is None else used
    fit = fit_shift(x, s, law, theta=theta, d0=d0, c0=c0, used=cand)
    k = settings.outlier_sigma
    for _ in range(3 if k > 0 else 0):
        # the residuals' column becomes their local deviation (one column in memory)
        dev = local_deviation(_used(x, cand), _residuals(x, s, law, fit, theta, cand),
                              overwrite=True)
        for a, b in walk(dev.size, dev):
            np.abs(dev[a:b], out=dev[a:b])
        scale = max(1.4826 * column_median(dev), OUTLIER_SCALE_FLOOR)
        keep = cand.copy()
        keep[cand] = mask_of(dev.size, lambda a, b: dev[a:b] <= k * scale, dev)
        if np.count_nonzero(~keep[cand]) > OUTLIER_MAX_FRACTION * dev.size:
            keep = fit.used   # not isolated spikes: systematic, keep everything
        dev = None   # type: ignore[assignment]  # freed before the next fit
        if np.array_equal(keep, fit.used):
            break
        d, c = fit.d, fit.c
        fit = None   # type: ignore[assignment]  # its residuals freed before the next fit
        fit = fit_shift(x, s, law, theta=theta, d0=d, c0=c, used=keep)
    keep = None   # type: ignore[assignment]
    fit, noise = _angle_noise_weighting(x, s, law, fit, theta)
    return fit, cand & ~fit.used, noise


def _used(a: NDArray[np.float64], used: NDArray[np.bool_]) -> NDArray[np.float64]:
    """``a[used]``, without a copy when every sample is used (spilled when long)."""
    return a if used.all() else masked(a, used)


def _residuals(x: NDArray[np.float64], s: NDArray[np.float64], law: Lift, fit: Any,
               theta: NDArray[np.float64] | None, used: NDArray[np.bool_],
               ) -> NDArray[np.float64]:
    """Residuals [m] of the samples ``used`` under ``fit`` (offset, shift and run-out),
    computed a block at a time (no full-size temporaries)."""
    out = blank((int(np.count_nonzero(used)),))
    step, pos = block_lsq.BLOCK_ROWS, 0
    for k in range(0, x.size, step):
        m = used[k:k + step]
        xb, sb = x[k:k + step][m], s[k:k + step][m]
        rb = sb - fit.c - law(xb - fit.d, 0)
        if theta is not None:
            tb = theta[k:k + step][m]
            rb -= block_lsq.first_harmonic(tb, 0.0, *fit.runout)
        out[pos:pos + rb.size] = rb
        pos += rb.size
        release(x, s, theta, out)   # spilled samples: one block resident
    return out


def _angle_noise_weighting(x: NDArray[np.float64], s: NDArray[np.float64], law: Lift,
                           fit: Any, theta: NDArray[np.float64] | None,
                           ) -> tuple[Any, dict[str, float]]:
    """Residual variance model r^2 ~ sigma_s^2 + h'^2 sigma_theta^2 (probe noise plus
    encoder/angle noise, which matters on the steep flanks), fitted to the local
    deviations of the residuals (``local_deviation``). When the angle term is
    significant (> 3 standard errors and > 20 % of the variance at the steepest
    point), refit by weighted least squares with weights 1/(sigma_s^2 + h'^2
    sigma_theta^2), so the estimate stays efficient and its std honest. The fit's
    residuals are consumed (their column holds the local deviations: memory); the fit
    returned carries none."""
    used = fit.used
    xu = _used(x, used)
    # the noise part of the residuals only: a real form error must not pass for noise
    r2 = local_deviation(xu, fit.residuals, overwrite=True)
    fit = replace(fit, residuals=np.empty(0))
    step = block_lsq.BLOCK_ROWS

    def slope2(k: int) -> NDArray[np.float64]:
        """h'^2 of the used samples k .. k + step (a block at a time: no column)."""
        g = law(xu[k:k + step] - fit.d, 1)
        g **= 2
        return g

    for k, e in walk(r2.size, r2, step=step):
        r2[k:e] **= 2
        r2[k:e] /= MEDIAN9_VARIANCE
    # r2 ~ a + b gp2 by least squares, a block of rows at a time
    tri, rows = block_lsq.triangle(
        (np.column_stack([np.ones(g.size), g]), r2[k:k + step])
        for k, _ in walk(r2.size, xu, r2, step=step) for g in (slope2(k),))
    coef = block_lsq.solve(tri, rows)
    a, b = float(coef[0]), float(coef[1])
    rss, gmax = 0.0, -np.inf
    for k, _ in walk(r2.size, xu, r2, step=step):
        g = slope2(k)
        res = r2[k:k + step] - (coef[0] + coef[1] * g)
        rss += float(res @ res)
        gmax = max(gmax, float(np.max(g)))
    size = r2.size
    del r2
    normal = tri[:2, :2].T @ tri[:2, :2]   # design^T design = R^T R
    cov = rss / max(size - 2, 1) * np.linalg.pinv(normal)
    b_se = float(np.sqrt(max(cov[1, 1], 0.0)))
    noise = {'probe_noise_estimate_um': float(np.sqrt(max(a, 0.0))) * UM,
             'angle_noise_estimate_arcsec': float(np.degrees(np.sqrt(max(b, 0.0)))) * 3600}
    if a <= 0 or b <= 3 * b_se or b * gmax <= 0.2 * a:
        return fit, noise

    def weight(lo: int, hi: int) -> NDArray[np.float64]:
        """1 / (a + b h'^2) of the used samples lo .. hi, 1 elsewhere."""
        w = np.ones(hi - lo)
        m = used[lo:hi]
        g = law(x[lo:hi][m] - fit.d, 1)
        g **= 2
        g *= b
        g += a
        w[m] = np.reciprocal(g, out=g)
        return w

    weights = column_of(x.size, weight, x)
    refit = fit_shift(x, s, law, theta=theta, d0=fit.d, c0=fit.c, used=used,
                      weights=weights)
    return replace(refit, residuals=np.empty(0)), noise


def analyze_lobe(fs: FeatureSamples, law: Lift, direction: int, settings: Settings,
                 *, asymmetry: bool = True) -> FeatureResult:
    """Measure a lobe: ``law`` is the design lift as seen by the probe."""
    if fs.theta.size < 4 * settings.min_flank_samples:
        raise FeatureFailed(f'{fs.theta.size} valid samples (need >= '
                            f'{4 * settings.min_flank_samples})')
    lo, hi = law.support if hasattr(law, 'support') else (-np.pi, np.pi)
    # spilled samples (``features``): every pass gives back the pages it read; the
    # angle column x is itself spilled when long (``lobe_columns``)
    theta = fs.theta
    x = blank((theta.size,))
    for a, b in walk(x.size, theta, x):   # one block of spilled angles resident
        np.multiply(direction, theta[a:b], out=x[a:b])
    x0 = coarse_align(x, fs.s, law)
    _release(fs)
    for a, b in walk(x.size, x):   # x = wrap(direction theta - x0), in place
        x[a:b] = wrap_pi(x[a:b] - x0)
    x = seal(x)
    alpha_m, alpha_n = sensitive_points(law, lo, hi)
    _zone_check(x, _slope_zone(law, alpha_m, lo, 0.0), 'rise', settings)
    _zone_check(x, _slope_zone(law, alpha_n, 0.0, hi), 'fall', settings)
    base = mask_of(x.size, lambda a, b: (x[a:b] < lo - 2 * DEG) | (x[a:b] > hi + 2 * DEG), x)
    c_base = masked_median(fs.s, base) if np.count_nonzero(base) >= 5 else None
    _release(fs)
    runout = settings.fit_runout and covers_circle(fs.theta)
    fit, outliers, noise = robust_fit(x, fs.s, law, settings, c0=c_base,
                                      theta=fs.theta if runout else None)
    _release(fs)
    good = ~outliers
    _check_fit(fit, settings, 'nose')
    ref = base_reference(fs.theta, fs.s, base & good, runout, (fit.c, fit.runout))
    for a, b in walk(ref.size, ref, fs.s):   # s - ref, in place
        ref[a:b] -= fs.s[a:b]
        ref[a:b] *= -1.0
    ref = seal(ref)
    _release(fs)
    try:
        sp = sensitive_point_shift(
            x, ref, law, alpha_m, alpha_n, used=good,
            half_window=settings.sp_half_window_deg * DEG,
            pairs=settings.sp_pairs, spacing=settings.sp_pair_spacing_deg * DEG,
            order=settings.sp_fit_order, validity_tol=settings.validity_tol_um / UM)
    except InputError as exc:   # the primary (LSQ) result stands; SP reported as skipped
        sp = f'sensitive-point method: {exc}'
    del ref
    values: dict[str, Any] = {'kind': 'lobe',
                              'angle_deg': _encoder_deg(direction, x0, fit.d),
                              'angle_std_deg': float(np.degrees(fit.d_std)),
                              **_sp_values(sp, direction, x0, fit.d),
                              'lift_offset_mm': fit.c * 1e3,
                              'residual_rms_um': fit.sigma * UM,
                              'samples_outliers_rejected': int(np.count_nonzero(outliers)),
                              **noise,
                              'iterations': fit.iterations}
    values.update(_per_revolution(fs, x, law, fit, good, settings,
                                  (_slope_zone(law, alpha_m, lo, 0.0),
                                   _slope_zone(law, alpha_n, 0.0, hi))))
    base &= good
    base_runout, base_centre = _runout_um(fs.theta, fs.s, base, fit.c)
    del base
    _release(fs)
    # the lift table (alpha, measured, design) in alpha order
    build = lift_table if is_long(x.size) else short_lift_table   # long: angle buckets
    table, good = build(x, fit.d, fs.theta, fs.s, fit.c, fit.runout, law, good)
    _release(fs)
    alpha, measured, design = table[:, 0], table[:, 1], table[:, 2]
    if isinstance(table, np.memmap):   # long: a block of rows at a time
        fit_error = error_stats_blocks(
            (table[a:b, 1] - table[a:b, 2], table[a:b, 2], good[a:b])
            for a, b in walk(table.shape[0], table))
    else:
        fit_error = error_stats(measured - design, design, good)
    release(table)
    if fit_error is not None:   # what the fit leaves; a smooth form error partly hides here
        values['fit_residual_um'] = fit_error
    values['base_circle_runout_um'] = base_runout
    values['base_circle_eccentricity_um'] = base_centre
    values['runout_fitted'] = runout
    if runout:
        values['fitted_runout_amplitude_um'] = float(np.hypot(*fit.runout)) * UM
    skipped = [('sensitive_point', sp)] if isinstance(sp, str) else []
    if settings.fit_runout and not runout:
        skipped.append(('runout_fit', 'the samples do not cover the revolution (need 30 '
                                      'of 36 sectors of 10 deg)'))
    if asymmetry:
        if is_symmetric(law, lo, hi):
            values.update(_asymmetry(alpha, measured, good, lo, hi, direction, settings))
            release(table)
            if 'asymmetry_deg' in values:
                values['top_point_deg'] = float(np.mod(values['angle_deg']
                                                       + values['asymmetry_deg'], 360.0))
            else:
                skipped.append(('asymmetry', values['asymmetry_error']))
        else:
            skipped.append(('asymmetry', 'design lift is asymmetric: no symmetry axis'))
    # the lift error a gauge reports: offset (and run-out) from the base circle alone
    stats = referenced_error_stats(table, runout, good)
    release(table)
    del good
    if stats is not None:
        values['lift_error_um'] = stats
        values['lift_error_reference'] = 'base circle'
    return FeatureResult(fs.feature_id, 'lobe', {**values, **_common(fs)}, table,
                         float(np.radians(values['angle_deg'])), skipped=skipped)


def _release(fs: FeatureSamples) -> None:
    """Give back the pages of spilled sample columns read so far (``spill.release``)."""
    release(fs.theta, fs.s, fs.stamp_ns)


def _per_revolution(fs: FeatureSamples, x: NDArray[np.float64], law: Lift, fit: Any,
                    good: NDArray[np.bool_], settings: Settings,
                    zones: tuple[tuple[float, float], ...]) -> dict[str, Any]:
    """Repeatability: the shift fitted on each revolution alone (revolutions counted
    on the stamp-ordered unwrapped angle; the readings with the fitted run-out
    removed), as deviations [arcsec] from the joint fit; revolutions whose flanks are
    not covered are left out."""
    if fs.revolutions < 1.9:
        return {}
    s = block_lsq.minus_harmonic(fs.theta, fs.s, *fit.runout)
    _release(fs)
    rev = np.empty(fs.theta.size, np.int32)
    pos, first = 0, None
    for turns in unwrapped_blocks(fs.theta):   # np.unwrap, a block at a time
        first = turns[0] if first is None else first
        rev[pos:pos + turns.size] = np.floor(np.abs(turns - first) / (2 * np.pi))
        pos += turns.size
    _release(fs)
    devs = []
    count = int(rev.max()) + 1
    # revolutions counted on the stamp-ordered angle are runs of rows: each is fitted on
    # its own slice (cost ~ its samples); a back-and-forth angle falls back to masks
    # (the searched values in rev's own type: int64 ones would convert a copy of rev)
    runs = np.searchsorted(rev, np.arange(count + 1, dtype=rev.dtype)) \
        if bool(np.all(rev[1:] >= rev[:-1])) else None
    for k in range(count):
        if runs is not None:
            part = slice(int(runs[k]), int(runs[k + 1]))
            xs, ss, sel = x[part], s[part], good[part]
        else:
            xs, ss, sel = x, s, (rev == k) & good
        try:
            for flank, zone in zip(('rise', 'fall'), zones):
                _zone_check(xs[sel], zone, flank, settings)
            one = fit_shift(xs, ss, law, d0=fit.d, c0=fit.c, used=sel)
        except (FeatureFailed, InputError):
            continue
        finally:
            release(s, x)   # one revolution's pages resident
        devs.append(float(np.degrees(one.d - fit.d) * 3600))
    if len(devs) < 2:
        return {}
    return {'per_revolution_deviation_arcsec': devs,
            'per_revolution_std_arcsec': float(np.std(devs, ddof=1))}


def covers_circle(theta: NDArray[np.float64], need: int = 30,
                  mask: NDArray[np.bool_] | None = None) -> bool:
    """True if the angles [rad] (those of ``mask``, all when None) fall in at least
    ``need`` of 36 sectors of 10 deg (a first harmonic is then well determined)."""
    seen = np.zeros(36 + 1, bool)   # a block at a time: no full-size temporaries
    for a, b in walk(theta.size, theta):
        t = theta[a:b] if mask is None else theta[a:b][mask[a:b]]
        seen[(np.mod(t, 2 * np.pi) // (np.pi / 18)).astype(np.int64)] = True
    return bool(np.count_nonzero(seen) >= need)


def base_reference(theta: NDArray[np.float64], s: NDArray[np.float64],
                   base: NDArray[np.bool_], runout: bool,
                   fallback: tuple[float, tuple[float, float]]) -> NDArray[np.float64]:
    """Base-circle level [m] under every sample (a new array), from the base-circle
    samples alone: their median, or with ``runout`` (and base samples in >= 18 of 36
    sectors) the fitted circle c + a cos(theta) + b sin(theta); the LSQ level
    ``fallback`` = (c, (a, b)) [m], c + a cos(theta) + b sin(theta), when there are
    fewer than 10 base-circle samples."""
    n = theta.size
    if np.count_nonzero(base) < 10:
        c, (a, b) = fallback
        return column_of(n, lambda i, j: c + block_lsq.first_harmonic(theta[i:j], 0.0, a, b),
                         theta)
    if runout and covers_circle(theta, need=18, mask=base):
        coef = block_lsq.harmonic_lstsq(theta, s, base)
        c, a, b = float(coef[0]), float(coef[1]), float(coef[2])
        return column_of(n, lambda i, j: block_lsq.first_harmonic(theta[i:j], c, a, b),
                         theta)
    level = masked_median(s, base)
    return column_of(n, lambda i, j: np.full(j - i, level))


def _runout_um(theta: NDArray[np.float64], s: NDArray[np.float64], base: NDArray[np.bool_],
               c: float) -> tuple[float | None, list[float] | None]:
    """Total indicated run-out [um] of the base circle (2 x first-harmonic amplitude) and
    its centre's eccentricity vector ``[a, b]`` [um] from the datum axis (the reading
    ``c + a cos theta + b sin theta``, as a journal's) of the readings ``s - c`` [m] of
    the samples ``base``; (None, None) with fewer than 10 base-circle samples."""
    if np.count_nonzero(base) < 10:
        return None, None
    if is_long(theta.size):   # long: masked a block at a time, no gathered copies
        coef = block_lsq.harmonic_lstsq(theta, s, base, offset=c)
    else:
        coef = block_lsq.harmonic_lstsq(theta[base], s[base] - c)
    return (float(2.0 * np.hypot(coef[1], coef[2]) * UM),
            [float(coef[1]) * UM, float(coef[2]) * UM])


def _asymmetry(alpha: NDArray[np.float64], measured: NDArray[np.float64],
               good: NDArray[np.bool_], lo: float, hi: float, direction: int,
               settings: Settings) -> dict[str, Any]:
    """Top point by the symmetry axis of the measured lift (frame: LSQ nose = 0), from
    the ``good`` samples on the lobe (lo < alpha < hi): only those are copied."""
    knots = settings.asymmetry_knot_deg * DEG
    try:
        if isinstance(alpha, np.memmap):   # a long table: merged a block of rows at a time
            spline, a_lo, a_hi = lobe_spline_of_table(alpha, measured, good, lo, hi, knots)
        else:
            sel = good & (alpha > lo) & (alpha < hi)
            a, h = alpha[sel], measured[sel]
            del sel
            spline = lift_spline(a, h, knot_spacing=knots)
            a_lo, a_hi = float(a.min()), float(a.max())
        tp = top_point(spline, a_lo, a_hi)
    except (InputError, ValueError) as exc:
        return {'asymmetry_error': str(exc)}
    if not (np.isfinite(tp.d) and abs(tp.d) <= settings.max_shift_deg * DEG):
        return {'asymmetry_error': f'symmetry axis {np.degrees(tp.d):.3f} deg from the '
                                   'least-squares nose: no credible top point'}
    return {'asymmetry_deg': float(np.degrees(direction * tp.d)),
            'asymmetry_flank_deg': float(np.degrees(direction * tp.d_flank)),
            'flank_midpoint_scatter_deg': float(np.degrees(tp.flank_scatter)),
            'residual_asymmetry_um': {'rms': tp.residual_rms * UM, 'max': tp.residual_max * UM},
            'apparent_asymmetry_rms_um': tp.apparent_rms * UM}


def analyze_pin(fs: FeatureSamples, pin: DowelPinGeometry, direction: int,
                settings: Settings) -> FeatureResult:
    """Measure the dowel-pin centre angle (Liu's geometry, absolute lift)."""
    if fs.theta.size < 4 * settings.min_flank_samples:
        raise FeatureFailed(f'{fs.theta.size} valid samples (need >= '
                            f'{4 * settings.min_flank_samples})')
    amax = pin.contact_half_angle
    margin = settings.pin_edge_margin_deg * DEG
    half = settings.sp_half_window_deg * DEG
    inner = amax - margin
    if inner <= 2 * half:
        raise InputError('metrology.pin_edge_margin_deg', settings.pin_edge_margin_deg,
                         f'a margin well below the contact half-angle {np.degrees(amax):.3f}')

    def law(a: NDArray[np.float64], nu: int = 0) -> NDArray[np.float64]:
        return pin.lift(a, nu)

    xraw = direction * fs.theta
    x0 = coarse_align(xraw, fs.s, law)
    x = wrap_pi(xraw - x0)
    for flank, zone in (('rise', (-inner, -0.5 * inner)), ('fall', (0.5 * inner, inner))):
        _zone_check(x, zone, flank, settings)   # the steep half of each contact flank
    top = np.abs(x) < 3 * DEG
    if np.count_nonzero(top) < 3:
        raise FeatureFailed('fewer than 3 samples within 3 deg of the pin top')
    c0 = float(np.median(fs.s[top] - law(x[top])))
    d = 0.0
    fit = None
    outliers = np.zeros(x.size, bool)
    for _ in range(3):   # contact mask from the current estimate, then refit
        used = np.abs(x - d) < inner
        fit, outliers, noise = robust_fit(x, fs.s, law, settings, d0=d, used=used,
                                          c0=c0 if fit is None else fit.c)
        if abs(fit.d - d) < 1e-13:
            d = fit.d
            break
        d = fit.d
    good = ~outliers
    assert fit is not None
    _check_fit(fit, settings, 'pin centre')
    sp = None
    d_sp = 0.0
    try:
        for _ in range(3):   # top reference and crossings, re-centred on the SP result
            near = (np.abs(x - d_sp) < 3 * DEG) & good
            ref = float(np.median(fs.s[near] - law(x[near] - d_sp)))
            sp = sensitive_point_shift(
                x[good], fs.s[good] - ref, law, -(inner - half), inner - half, half_window=half,
                pairs=settings.sp_pairs, spacing=settings.sp_pair_spacing_deg * DEG,
                limits=(-inner, inner), order=settings.sp_fit_order, inward_only=True,
                validity_tol=settings.validity_tol_um / UM)
            if abs(sp.d - d_sp) < 1e-13:
                break
            d_sp = sp.d
    except InputError as exc:   # the primary (LSQ) result stands; SP reported as skipped
        sp = f'sensitive-point method: {exc}'
    values: dict[str, Any] = {'kind': 'dowel_pin',
                              'angle_deg': _encoder_deg(direction, x0, fit.d),
                              'angle_std_deg': float(np.degrees(fit.d_std)),
                              **_sp_values(sp, direction, x0, fit.d),
                              'contact_half_angle_deg': float(np.degrees(amax)),
                              'lift_offset_mm': fit.c * 1e3,
                              'residual_rms_um': fit.sigma * UM,
                              'samples_outliers_rejected': int(np.count_nonzero(outliers)),
                              **noise,
                              'iterations': fit.iterations}
    used = fit.used
    alpha = (x - fit.d)[used]
    measured = (fs.s - fit.c)[used]
    design = law(alpha)
    err = measured - design
    values['lift_error_um'] = {'max_plus': float(np.max(err)) * UM,
                               'max_minus': float(np.min(err)) * UM,
                               'rms': float(np.sqrt(np.mean(err ** 2))) * UM}
    order = angle_order(alpha)
    table = np.column_stack([alpha[order], measured[order], design[order]])
    return FeatureResult(fs.feature_id, 'dowel_pin', {**values, **_common(fs)}, table,
                         float(np.radians(values['angle_deg'])),
                         skipped=[('sensitive_point', sp)] if isinstance(sp, str) else [])


def keyway_used(geo: KeywayGeometry, alpha: NDArray[np.float64],
                margin: float) -> NDArray[np.bool_]:
    """Samples [alpha from the slot centre, rad] the keyway fit uses: the shaft, and the
    two edge arcs except within ``margin`` [rad] of their inner end (where the arcs meet,
    the ball drops to the bottom or leaves the edge with an infinite slope); the bottom
    and free fall are left out."""
    from cam_design.keyway import EDGE_MINUS, EDGE_PLUS, SHAFT

    which = geo.branch(alpha)
    inner = geo.edge_angle - geo.edge_span() + margin   # |alpha| above this on an arc
    edge = ((which == EDGE_PLUS) | (which == EDGE_MINUS)) & (np.abs(alpha) > inner)
    return (which == SHAFT) | edge


def analyze_keyway(fs: FeatureSamples, geo: KeywayGeometry, direction: int,
                   settings: Settings) -> FeatureResult:
    """Measure the keyway centre angle: least squares of ``s = c + h(x - d)`` (plus the
    run-out harmonic when the samples cover the revolution) with h the keyway lift of
    ``cam_design.keyway`` on the shaft and the two edge flanks (``keyway_used``)."""
    if fs.theta.size < 4 * settings.min_flank_samples:
        raise FeatureFailed(f'{fs.theta.size} valid samples (need >= '
                            f'{4 * settings.min_flank_samples})')
    margin = settings.pin_edge_margin_deg * DEG
    beta, span = geo.edge_angle, geo.edge_span()
    if span <= 2 * margin:
        raise InputError('metrology.pin_edge_margin_deg', settings.pin_edge_margin_deg,
                         f'a margin well below the edge flank width {np.degrees(span):.3f} deg')

    def law(a: NDArray[np.float64], nu: int = 0) -> NDArray[np.float64]:
        return geo.lift(a, nu)

    xraw = direction * fs.theta
    x0 = coarse_align(xraw, fs.s, law)
    x = wrap_pi(xraw - x0)
    for flank, zone in (('rise', (-beta, -beta + span - margin)),
                        ('fall', (beta - span + margin, beta))):
        _zone_check(x, zone, flank, settings)
    runout = settings.fit_runout and covers_circle(fs.theta)
    d, fit = 0.0, None
    outliers = np.zeros(x.size, bool)
    noise: dict[str, float] = {}
    for _ in range(4):   # mask from the current estimate, then refit
        used = keyway_used(geo, x - d, margin)
        fit, outliers, noise = robust_fit(x, fs.s, law, settings, d0=d, used=used,
                                          theta=fs.theta if runout else None,
                                          c0=None if fit is None else fit.c)
        done = abs(fit.d - d) < 1e-13
        d = fit.d
        if done:
            break
    assert fit is not None
    _check_fit(fit, settings, 'keyway centre')
    harmonic = block_lsq.first_harmonic(fs.theta, 0.0, *fit.runout)
    values: dict[str, Any] = {'kind': 'keyway',
                              'angle_deg': _encoder_deg(direction, x0, fit.d),
                              'angle_std_deg': float(np.degrees(fit.d_std)),
                              'edge_angle_deg': float(np.degrees(beta)),
                              'edge_flank_deg': float(np.degrees(span)),
                              'lift_offset_mm': fit.c * 1e3,
                              'residual_rms_um': fit.sigma * UM,
                              'samples_outliers_rejected': int(np.count_nonzero(outliers)),
                              'runout_fitted': runout,
                              **noise,
                              'iterations': fit.iterations}
    if runout:
        values['fitted_runout_amplitude_um'] = float(np.hypot(*fit.runout)) * UM
    used = fit.used
    alpha = (x - fit.d)[used]
    measured = (fs.s - fit.c - harmonic)[used]
    design = law(alpha)
    err = measured - design
    values['lift_error_um'] = {'max_plus': float(np.max(err)) * UM,
                               'max_minus': float(np.min(err)) * UM,
                               'rms': float(np.sqrt(np.mean(err ** 2))) * UM}
    # the table shows the slot (every sample within 5 deg of its edges, also those the
    # fit leaves out: the bottom, the drop), not the whole shaft
    a_all = x - fit.d
    near = (np.abs(a_all) < beta + 5 * DEG) & ~outliers
    d_all = law(a_all[near])
    keep = np.isfinite(d_all)
    a_near = a_all[near][keep]
    order = angle_order(a_near)
    table = np.column_stack([a_near[order], (fs.s - fit.c - harmonic)[near][keep][order],
                             d_all[keep][order]])
    skipped = [('sensitive_point', 'not applied to a keyway: its centre comes from the two '
                                   'edge flanks by least squares')]
    if settings.fit_runout and not runout:
        skipped.append(('runout_fit', 'the samples do not cover the revolution (need 30 '
                                      'of 36 sectors of 10 deg)'))
    return FeatureResult(fs.feature_id, 'keyway', {**values, **_common(fs)}, table,
                         float(np.radians(values['angle_deg'])), skipped=skipped)
