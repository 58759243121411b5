"""Reconstruct one feature with the requested methods; errors against the design lift;
conversion to the engine's follower; JSON-ready summaries.

The design lift, when known, is compared *as seen by the probe*: either a LiftLaw
already converted to the probe (``design``), or the metrology table's
``design_lift_m`` column, interpolated by ``TabulatedLift`` (quintic, exact
derivatives of the interpolant). When the scene's design follower differs from the
probe, each reconstruction is also converted back to the design follower with
``cam_design.follower.convert_lift`` applied to the reconstructed lift as a
``TabulatedLift``.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np
from numpy.typing import NDArray

from cam_design.errors import InputError
from cam_design.lift_table.result import Reconstruction, output_grid, per_second
from cam_design.lift_table.samples import (CleanSamples, LiftTable,
                                           clean_samples, find_steps, nose_warning,
                                           other_lobes_warning, step_warnings, wrap_from,
                                           wrap_pi)
from cam_design.lift_table.rebound import rebound_fairing
from cam_design.lift_table.spline import SplineOptions, reconstruct_spline
from cam_metrology.reconstruction.harmonic import HarmonicOptions, reconstruct_harmonic

METHODS = ('spline', 'harmonic')
Law = Callable[..., NDArray[np.float64]]


@dataclass(frozen=True)
class Conversion:
    """Probe and design follower (``cam_design.follower.Follower``) and the cam's base
    radius [m], for converting a reconstruction back to the design follower."""

    probe: Any
    design: Any
    base_radius: float
    design_law: Any = None          # the design lift for ``design`` (for engine errors)


@dataclass
class MethodOutcome:
    """One method on one feature: the reconstruction (None if it failed, with
    ``error``), its errors against the design, and the engine-follower version."""

    method: str
    reconstruction: Reconstruction | None = None
    error: str = ''
    design_errors: dict[str, float] = field(default_factory=dict)
    engine: NDArray[np.float64] | None = None      # (4, n) for the design follower
    engine_note: str = ''
    engine_errors: dict[str, float] = field(default_factory=dict)


def design_from_table(table: LiftTable) -> Law | None:
    """A LiftLaw-like callable from the table's design column (None if absent)."""
    from cam_design.lift_laws import TabulatedLift

    if table.design is None:
        return None
    ok = np.isfinite(table.alpha) & np.isfinite(table.design)
    if np.count_nonzero(ok) < 6:
        return None
    data = clean_samples(table.alpha[ok], table.design[ok], key='design', min_points=6)
    return TabulatedLift(data.alpha, data.lift, key=f'{table.feature}.design')


def design_errors(rec: Reconstruction, design: Law,
                  derivs: NDArray[np.float64] | None = None) -> dict[str, float]:
    """RMS and max |reconstruction - design| of lift [m], velocity [m/rad],
    acceleration [m/rad^2] and jerk [m/rad^3] on the output grid (``derivs``: other
    (4, n) values on the same grid, e.g. the engine-follower version)."""
    out: dict[str, float] = {}
    names = ('lift_m', 'velocity_m_per_rad', 'acceleration_m_per_rad2', 'jerk_m_per_rad3')
    values_all = rec.derivatives() if derivs is None else derivs
    for nu, (name, values) in enumerate(zip(names, values_all)):
        diff = values - np.asarray(design(wrap_pi(rec.alpha), nu), dtype=float)
        out[f'rms_error_{name}'] = float(np.sqrt(np.mean(diff ** 2)))
        out[f'max_error_{name}'] = float(np.max(np.abs(diff)))
    return out


LOBE_MARGIN_RAD = math.radians(2.0)   # base circle kept unchanged, tapered, zero
LOBE_MARGIN_POINTS = (24, 12)         # at least this many zero / taper points (ringing)


def _taper(t: NDArray[np.float64]) -> NDArray[np.float64]:
    """C3 step from 0 (t <= 0) to 1 (t >= 1): 35t^4 - 84t^5 + 70t^6 - 20t^7."""
    t = np.clip(t, 0.0, 1.0)
    return t ** 4 * (35.0 - 84.0 * t + 70.0 * t ** 2 - 20.0 * t ** 3)


def lobe_section(alpha: NDArray[np.float64], lift: NDArray[np.float64],
                 sigma: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The part of a reconstructed lift [m] on ``alpha`` [rad] to hand to convert_lift.

    h = 0 on the base circle by definition, but a reconstruction is 0 there only
    within noise, and a smoothing spline over the revolution is not periodic: its end
    slopes differ by noise, which convert_lift reads as a corner at the +-180 deg seam.
    So only the lobe is converted: the span where |h| exceeds the noise (5 sigma, at
    least 1 nm) plus a margin of base circle on each side: from the lobe outwards,
    ``LOBE_MARGIN_RAD`` of the lift itself, then a C3 taper from the lift (within
    noise of 0 there) to 0, then exact zeros (each at least ``LOBE_MARGIN_RAD`` and the
    ``LOBE_MARGIN_POINTS``, so that the quintic interpolant's ringing has died out at
    the table ends: h' there below 1e-9 m/rad). So the lift is unchanged wherever it is
    above the noise and for 2 deg around. A table whose lift does
    not come down to the noise before its ends (a margin would not fit) only has its
    noise-level end offsets removed (linearly), as before; a table cut on the flanks
    is passed as it is (convert_lift then refuses it with the reason).
    """
    n = lift.size
    peak = float(np.max(np.abs(lift))) if n else 0.0
    noise = max(5.0 * sigma, 1e-9)
    above = np.nonzero(np.abs(lift) > noise)[0]
    if n >= 2 and above.size:
        step = float(alpha[-1] - alpha[0]) / (n - 1)
        keep = int(math.ceil(LOBE_MARGIN_RAD / step - 1e-9)) if step > 0 else n
        zero, taper = (max(p, keep) for p in LOBE_MARGIN_POINTS)
        m = zero + taper + keep
        lo, hi = int(above[0]) - m, int(above[-1]) + m
        if lo >= 0 and hi <= n - 1:
            a = alpha[lo:hi + 1]
            h = lift[lo:hi + 1].copy()
            k = np.arange(h.size, dtype=float)
            w = (_taper((k - zero + 1) / (taper + 1))
                 * _taper((h.size - k - zero) / (taper + 1)))
            return a, h * w
    small = max(5.0 * sigma, 1e-4 * peak)
    if n >= 2 and abs(lift[0]) <= small and abs(lift[-1]) <= small:
        ramp = np.linspace(0.0, 1.0, n)
        lift = lift - (lift[0] * (1.0 - ramp) + lift[-1] * ramp)
    return alpha, lift


def _engine(rec: Reconstruction, conv: Conversion, at: NDArray[np.float64] | None = None
            ) -> tuple[NDArray[np.float64] | None, str]:
    """(4, n) lift and derivatives for the design follower at ``at`` [rad] (default: the
    fit's grid), converted from the probe's ``rec``, or None and why not."""
    from cam_design.lift_laws import TabulatedLift

    try:
        from cam_design.follower import convert_lift
    except ImportError:
        return None, ('convert_lift not available: the profile is for the probe, not for '
                      f'the design follower ({conv.design.kind})')
    alpha, lift = lobe_section(rec.alpha, rec.lift, rec.sigma)
    try:
        tab = TabulatedLift(alpha, lift, key=f'{rec.method}.lift')
        law = convert_lift(tab, conv.base_radius, conv.probe, conv.design,
                           key=f'{rec.method}.lift')
        derivs = law.derivatives(rec.alpha if at is None else at)
    except InputError as exc:
        return None, f'conversion to the design follower failed: {exc}'
    if not np.all(np.isfinite(derivs)):
        return None, 'conversion to the design follower gave non-finite values'
    probe = f'{conv.probe.kind} r = {conv.probe.radius:.6g} m'
    return derivs, f'converted from the probe ({probe}) to the design follower ' \
                   f'({conv.design.kind})'


def turned_rows(data: CleanSamples, turn: float) -> tuple[CleanSamples, NDArray[np.intp]]:
    """The rows in the fit frame b = wrap(alpha - ``turn``) [rad], sorted, and the order
    ``perm`` of the table's rows in it (fit row j is table row perm[j])."""
    b = wrap_pi(data.alpha - turn)
    perm = np.argsort(b, kind='stable')
    return dataclasses.replace(data, alpha=b[perm], lift=data.lift[perm],
                               count=data.count[perm]), perm


def table_frame_grid(rec: Reconstruction, turn: float, span: tuple[float, float],
                     window: float | None) -> NDArray[np.float64]:
    """The output grid [rad] in the table's angles for a fit made in the frame turned by
    ``turn`` over the rows' ``span`` (fit frame, rad): the multiples of the fit's grid
    step whose fit-frame angle lies in that span, in the turn (window, window + 2 pi]
    for a whole turn (``lobe_routes.fit_window``: (-pi, pi] unless the lobe lies
    outside it), in the table's own contiguous angles for a table over part of the turn
    (``window`` None). No angle outside the rows' range is given a value."""
    n = rec.alpha.size
    step = float(rec.alpha[-1] - rec.alpha[0]) / (n - 1) if n > 1 else 2.0 * math.pi
    if window is None:
        return output_grid(span[0] + turn, span[1] + turn, step)
    grid = output_grid(window + 0.5 * step, window + 2.0 * math.pi, step)
    b = wrap_pi(grid - turn)
    return grid[(b >= span[0] - 1e-12) & (b <= span[1] + 1e-12)]


def in_table_frame(rec: Reconstruction, turn: float, grid: NDArray[np.float64],
                   perm: NDArray[np.intp], window: float | None) -> Reconstruction:
    """``rec``, fitted to the rows turned by ``turn`` [rad] (``turned_rows``), back in the
    table's angles on ``grid`` (``table_frame_grid``; ``window`` as there). Values are the
    fit's own, at b = wrap(alpha - turn); the fit's seam lies where its rows end (the
    middle of the base circle, or the gap of a partial table)."""
    def back(b: NDArray[np.float64]) -> NDArray[np.float64]:
        a = np.asarray(b, dtype=float) + turn
        return a if window is None else wrap_from(a, window)

    def evaluate(a: NDArray[np.float64], nu: int = 0) -> NDArray[np.float64]:
        return np.asarray(rec.evaluate(wrap_pi(np.asarray(a, dtype=float) - turn), nu),
                          dtype=float)

    d = [evaluate(grid, nu) for nu in range(4)]
    data_alpha = back(rec.data_alpha)
    order = np.argsort(data_alpha, kind='stable')
    parameter = dict(rec.parameter)
    if 'junctions_deg' in parameter:
        parameter['junctions_deg'] = [math.degrees(float(back(np.radians(v))))
                                      for v in parameter['junctions_deg']]
    mask = None
    if rec.outlier_mask is not None:
        mask = np.zeros(perm.size, dtype=bool)
        mask[perm] = rec.outlier_mask
    deg = math.degrees(turn)
    why = ('the lobe crosses +-180 deg' if window is not None else
           'the table covers part of the turn: its rows kept contiguous')
    over = ('' if window is None or window == -math.pi else
            f' over {math.degrees(window):.0f}..{math.degrees(window) + 360.0:.0f} deg (the '
            'turn centred on the lobe, where the card and the dynamics put it)')
    note = (f'fitted to the rows turned by {deg:.1f} deg ({why}), so that no fit is cut '
            'inside the lobe or bridges a gap; results are in the table\'s angles' + over
            + ', angles named in this fit\'s other notes and warnings in the turned frame '
            f'(table angle = that + {deg:.1f} deg)') if turn else (
        'results are in the table\'s angles' + over)
    return dataclasses.replace(
        rec, alpha=grid, lift=d[0], velocity=d[1], acceleration=d[2], jerk=d[3],
        data_alpha=data_alpha[order], residual=rec.residual[order],
        outliers_alpha=np.sort(back(rec.outliers_alpha)), evaluate=evaluate,
        parameter=parameter, outlier_mask=mask, notes=[note] + list(rec.notes),
        warnings=list(rec.warnings))


def reconstruct_table(table: LiftTable, *, methods: tuple[str, ...] = METHODS,
                      spline: SplineOptions | None = None,
                      harmonic: HarmonicOptions | None = None,
                      design: Law | None = None,
                      conversion: Conversion | None = None) -> dict[str, MethodOutcome]:
    """Run ``methods`` on one table. A method that cannot run (bad data for it) is
    reported with its error; bad *options* raise InputError."""
    for m in methods:
        if m not in METHODS:
            raise InputError('method', m, ' | '.join(METHODS))
    sopt = spline or SplineOptions()
    check_options(sopt, harmonic)
    data = clean_samples(table.alpha, table.lift, key=table.feature)
    design = design or design_from_table(table)
    if design is not None and sopt.expected_sign_changes is not None:
        # the design says how many sign changes of h'' the lobe really has (a
        # dual-peak EGR cam has more than the single lobe's two)
        from dataclasses import replace

        from cam_design.lift_table.result import sign_changes
        grid = np.linspace(data.alpha[0], data.alpha[-1], 4001)
        acc = np.asarray(design(grid, 2), dtype=float)
        lift = np.asarray(design(grid, 0), dtype=float)
        if np.all(np.isfinite(acc)) and np.any(acc):
            sopt = replace(sopt, expected_sign_changes=max(sign_changes(acc, lift=lift),
                                                           sopt.expected_sign_changes))
    if harmonic is not None or 'harmonic' in methods:
        from dataclasses import replace as _replace
        harmonic = _replace(harmonic or HarmonicOptions(),
                            expected_sign_changes=sopt.expected_sign_changes)
    outcomes: dict[str, MethodOutcome] = {}
    # what the lobe law of the same rows says of them (every route's warnings: mid-lobe
    # ends, crank degrees, steps, results no cam can have), with or without a design
    from cam_design.lift_table.lobe_routes import fit_turn, fit_window, lobe_warnings
    lobe, said = lobe_warnings(table.alpha, table.lift, key=table.feature,
                               design_known=design is not None)
    if lobe is not None and lobe.lobe.base:
        # the lobe law's base circle is the fits' zero too (its warning says where)
        data = dataclasses.replace(data, lift=data.lift - lobe.lobe.base)
    if lobe is not None and lobe.lobe.fit.correlated and sopt.sigma is None \
            and sopt.smoothing is None:
        # noise the rows share (its warning says so): GCV would take it for the lobe;
        # the spline is smoothed as the lobe law was (its criterion and known noise)
        law_fit = lobe.lobe.fit
        sopt = dataclasses.replace(sopt, criterion=law_fit.criterion or sopt.criterion,
                                   sigma=law_fit.known, correlated_noise=True)
    # the fits run in the lobe law's frame: rows turned so that their seam lies in the
    # base circle (a lobe across +-180 deg) or in the gap of a partial table
    turn = fit_turn(table.alpha, lobe)
    # a whole turn: results over (-pi, pi], or the turn centred on a lobe outside it
    window = fit_window(table.alpha, lobe)
    fit, perm = turned_rows(data, turn) if turn else (data, np.arange(data.alpha.size))
    fairing = rebound_fairing(fit.alpha, fit.lift, threshold=sopt.threshold,
                              gain=sopt.gain, cap=sopt.cap, sigma=sopt.sigma)
    steps = find_steps(data.alpha, data.lift, fairing.sigma)
    fit_steps = find_steps(fit.alpha, fit.lift, fairing.sigma) if turn else steps
    table_warnings = step_warnings(steps)
    # (with a design the table is aligned on it; a dual-peak lobe may have a valley at 0)
    off_centre = (nose_warning(data, None if lobe is None else lobe.lobe.middle)
                  if design is None else None)
    if off_centre:
        table_warnings.append(off_centre)
    other = None if design is not None else other_lobes_warning(data.alpha, data.lift)
    if other:   # (a design says how many lobes there are)
        table_warnings.append(other)
    table_warnings += [w for w in said if w not in table_warnings
                       and not w.startswith('the table holds')]
    table_notes = []
    if fit_steps and np.any(fairing.outlier):
        # the rebound of a step rings over its neighbours: they are not outliers
        near = np.zeros(fit.alpha.size, dtype=bool)
        for k, *_ in fit_steps:
            near[max(k - 3, 0):k + 5] = True
        restore = fairing.outlier & near
        if np.any(restore):
            fairing = dataclasses.replace(
                fairing, lift=np.where(restore, fit.lift, fairing.lift),
                outlier=fairing.outlier & ~restore)
            table_notes.append(f'{int(np.count_nonzero(restore))} point(s) next to a step '
                               'kept (not outliers)')
    if fairing.quantum > 0:
        table_notes.append(f'rounded to {fairing.quantum * 1e3:.3g} mm: rounding noise '
                           f'{fairing.quantum / math.sqrt(12.0) * 1e6:.3g} um (step/sqrt(12)) '
                           'included in the noise sigma')
    for m in methods:
        outcome = MethodOutcome(m)
        try:
            if m == 'spline':
                rec = reconstruct_spline(fit, None, sopt, fairing)
                mask = rec.outlier_mask
                if mask is not None and not np.array_equal(mask, fairing.outlier):
                    # the spline's second look corrected the outliers: the series too
                    fairing = dataclasses.replace(
                        fairing, outlier=mask,
                        lift=np.where(mask | fairing.outlier, fairing.lift, fit.lift))
            else:
                rec = reconstruct_harmonic(fit, harmonic, fairing)
        except InputError as exc:
            outcome.error = str(exc)
            outcomes[m] = outcome
            continue
        except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
            # a numerical failure on odd data fails this method, not the node
            outcome.error = f'{m}: numerical failure ({type(exc).__name__}: {exc})'
            outcomes[m] = outcome
            continue
        engine = None   # the design follower's lift, converted in the fit's frame
        if turn or (window is not None and window != -math.pi):
            grid = table_frame_grid(rec, turn, (fit.alpha[0], fit.alpha[-1]), window)
            if conversion is not None:
                engine = _engine(rec, conversion, wrap_pi(grid - turn))
            rec = in_table_frame(rec, turn, grid, perm, window)
        rec.notes = list(table.notes) + rec.notes + table_notes
        rec.warnings = table_warnings + rec.warnings
        if lobe is not None:
            from cam_design.lift_table.lobe_routes import beyond_rows
            gap = beyond_rows(lobe, rec.lift, data.lift)
            if gap:
                rec.warnings.append(gap)
        outcome.reconstruction = rec
        if design is not None:
            outcome.design_errors = design_errors(rec, design)
        if conversion is not None:
            outcome.engine, outcome.engine_note = engine or _engine(rec, conversion)
            if outcome.engine is not None and conversion.design_law is not None:
                outcome.engine_errors = design_errors(rec, conversion.design_law,
                                                      outcome.engine)
        outcomes[m] = outcome
    return outcomes


def check_options(spline: SplineOptions, harmonic: HarmonicOptions | None) -> None:
    """Raise InputError for bad options before any data is touched."""
    from cam_design.errors import require_positive
    from cam_metrology.reconstruction.harmonic import check_harmonic_options
    from cam_design.lift_table.spline import CRITERIA

    if spline.criterion not in CRITERIA:
        raise InputError('smoothing_criterion', spline.criterion, ' | '.join(CRITERIA))
    if spline.smoothing is not None:
        require_positive('smoothing', spline.smoothing, allow_zero=True)
    require_positive('threshold', spline.threshold)
    require_positive('cap', spline.cap)
    if not 0.0 < spline.gain <= 1.0:
        raise InputError('gain', spline.gain, 'a fraction in (0, 1]')
    if spline.step is not None:
        require_positive('step', spline.step)
    if harmonic is not None:
        check_harmonic_options(harmonic)


def summary(outcome: MethodOutcome, *, rpm: float | None = None,
            arrays: bool = True) -> dict[str, Any]:
    """JSON-ready dict of one method's outcome (arrays as lists when ``arrays``)."""
    if outcome.reconstruction is None:
        return {'ok': False, 'error': outcome.error}
    rec = outcome.reconstruction
    out: dict[str, Any] = {'ok': True, 'method': rec.method}
    key = 'order' if rec.method == 'harmonic' else 'smoothing'
    out[key] = rec.parameter[key]
    out['why'] = rec.why
    out['parameters'] = {k: v for k, v in rec.parameter.items() if k != key}
    out['rms_residual_m'] = rec.rms_residual
    out['max_residual_m'] = rec.max_residual
    out['noise_sigma_m'] = rec.sigma
    out['outliers_deg'] = [math.degrees(float(a)) for a in rec.outliers_alpha]
    out['warnings'] = list(rec.warnings)
    out['notes'] = list(rec.notes)
    if outcome.design_errors:
        out['design_errors'] = outcome.design_errors
    if outcome.engine_note:
        out['engine_follower'] = outcome.engine_note
    if outcome.engine_errors:
        out['engine_design_errors'] = outcome.engine_errors
    if arrays:
        out['alpha_rad'] = rec.alpha.tolist()
        derivs = rec.derivatives()
        for name, values in zip(('lift_m', 'velocity_m_per_rad', 'acceleration_m_per_rad2',
                                 'jerk_m_per_rad3'), derivs):
            out[name] = values.tolist()
        out['residual_alpha_rad'] = rec.data_alpha.tolist()
        out['residual_m'] = rec.residual.tolist()
        if rpm:
            out['cam_speed_rpm'] = rpm
            out.update({k: v.tolist() for k, v in per_second(derivs, rpm).items()})
        if outcome.engine is not None:
            out['engine'] = {name: values.tolist() for name, values in zip(
                ('lift_m', 'velocity_m_per_rad', 'acceleration_m_per_rad2',
                 'jerk_m_per_rad3'), outcome.engine)}
        if rec.spectrum is not None:
            out['spectrum'] = {'order': rec.spectrum[0].astype(int).tolist(),
                               'amplitude_m': rec.spectrum[1].tolist()}
    return out
