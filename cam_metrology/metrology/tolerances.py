"""Acceptance of a measured camshaft against the scene's tolerances (docs/tolerances.md).

Pure numerics (no rclpy). ``judge_part(scene, features, tables, designs)`` adds a
``verdict`` to each feature of a metrology report and returns the part's verdict:

* a check compares one measured quantity with its band ``[lower, upper]``; limits are
  inclusive (a value at a limit, to ``LIMIT_RTOL`` for rounding, passes); ``margin``
  is the distance to the nearer limit (negative when outside); when the quantity has a
  standard uncertainty ``u`` and lies within ``2 u`` of a limit, the check says
  ``uncertain: true`` (the
  decision is still taken on the value: ISO 14253-1's conformance zone is not applied);
* lift errors, max lift and events come from the lift table re-referenced to the base
  circle alone (``base_referenced``), not from the fit's offset;
* a feature ``verdict.result`` is ``fail`` if any check fails, else ``not checked`` if a
  toleranced quantity could not be evaluated (or the feature has no tolerances), else
  ``pass``;
* the part is ``fail`` if any check fails, ``not checked`` if the scene has no
  tolerances or a toleranced quantity of any feature could not be evaluated (a failed
  feature, no dowel pin for a phase, ...), else ``pass``.
"""
from __future__ import annotations

import math
from typing import Any, Callable, Mapping

import numpy as np

from cam_metrology.metrology.lift_error import referenced_rows
from cam_metrology.metrology.lobe_columns import card_rows
from cam_metrology.metrology.spill import walk
from cam_metrology.scene.model import Band, Scene, Tolerances

__all__ = ['check', 'judge_lobe', 'judge_datum', 'judge_part', 'PASS', 'FAIL', 'NOT_CHECKED']

PASS, FAIL, NOT_CHECKED = 'pass', 'fail', 'not checked'
#: a value within this fraction of a limit's size (at least 1 unit) is at the limit: the
#: quantities come out of floating-point arithmetic (1e-9 um on a 1 um band is rounding)
LIMIT_RTOL = 1e-9
DEG = math.pi / 180.0


def check(quantity: str, value: float, band: tuple[float | None, float], unit: str,
          std: float | None = None) -> dict[str, Any]:
    """One check of ``value`` against ``band`` = (lower, upper), limits inclusive;
    ``lower`` None: a maximum only (run-out)."""
    lo, hi = band
    eps = LIMIT_RTOL * max(abs(hi), abs(lo or 0.0), 1.0)   # floating-point rounding only
    ok = (lo is None or lo - eps <= value) and value <= hi + eps
    margin = hi - value if lo is None else min(value - lo, hi - value)
    out: dict[str, Any] = {'quantity': quantity, 'value': float(value), 'lower': lo,
                           'upper': hi, 'unit': unit, 'result': PASS if ok else FAIL,
                           'margin': float(margin)}
    if not ok:
        out['limit'] = lo if lo is not None and value < lo else hi
    if std is not None and math.isfinite(std):
        out['std'] = float(std)
        out['uncertain'] = bool(abs(margin) < 2.0 * std)
    return out


def _not(quantity: str, why: str) -> dict[str, str]:
    return {'quantity': quantity, 'why': why}


def _verdict(checks: list[dict[str, Any]], missing: list[dict[str, str]]) -> dict[str, Any]:
    failed = [{k: c[k] for k in ('quantity', 'value', 'limit', 'unit')}
              for c in checks if c['result'] == FAIL]
    result = FAIL if failed else (NOT_CHECKED if missing or not checks else PASS)
    return {'result': result, 'checks': checks, 'failed': failed, 'not_checked': missing}


#: base-circle samples are those at least this far [rad] outside the design's lobe


def _lift_error_checks(tol: Tolerances, table: Any, good: Any,
                       checks: list[dict[str, Any]], missing: list[dict[str, str]]) -> None:
    """Global band (lobe region, design > 0) and the angle->band zones, from the
    base-referenced table."""
    if tol.lift_error_um is None and not tol.lift_error_zones:
        return
    if table is None:
        missing.append(_not('lift_error_um', 'no lift table for this feature'))
        return
    if isinstance(table, np.memmap):   # a long table: a block of rows at a time
        _long_lift_error_checks(tol, table, good, checks, missing)
        return
    # masks over the whole table instead of copies of its good rows (memory: one
    # column of errors, and the angles in degrees only when there are zones)
    good = np.ones(table.shape[0], bool) if good is None else good
    err = table[:, 1] - table[:, 2]
    err *= 1e6
    in_zone = np.zeros(err.size, dtype=bool)
    alpha = np.degrees(table[:, 0]) if tol.lift_error_zones else None
    for z in tol.lift_error_zones:
        sel = (alpha >= z.from_deg) & (alpha <= z.to_deg) & good
        in_zone |= sel
        name = f'lift_error_um[{z.from_deg:g}..{z.to_deg:g} deg]'
        if not np.any(sel):
            missing.append(_not(name, 'no samples in this zone'))
            continue
        checks.append(check(f'{name}.max_plus', float(np.max(err[sel])), z.band_um, 'um'))
        checks.append(check(f'{name}.max_minus', float(np.min(err[sel])), z.band_um, 'um'))
    del alpha
    if tol.lift_error_um is not None:
        sel = (table[:, 2] > 0) & ~in_zone & good
        if np.any(sel):
            checks.append(check('lift_error_max_plus_um', float(np.max(err[sel])),
                                tol.lift_error_um, 'um'))
            checks.append(check('lift_error_max_minus_um', float(np.min(err[sel])),
                                tol.lift_error_um, 'um'))


def _widen(hi: Any, lo: Any, j: int, values: Any) -> None:
    """Extend the running extremes ``hi[j]``, ``lo[j]`` by ``values`` (if any)."""
    if values.size:
        hi[j], lo[j] = max(hi[j], float(np.max(values))), min(lo[j], float(np.min(values)))


def _long_lift_error_checks(tol: Tolerances, table: Any, good: Any,
                            checks: list[dict[str, Any]], missing: list[dict[str, str]]
                            ) -> None:
    """``_lift_error_checks`` of a spilled table, its extremes gathered a block of rows
    at a time (the same numbers)."""
    n = table.shape[0]
    zones = list(tol.lift_error_zones)
    hi = np.full(len(zones) + 1, -np.inf)   # per zone, then the lobe outside the zones
    lo = np.full(len(zones) + 1, np.inf)
    for a, b in walk(n, table):
        rows = table[a:b]
        err = rows[:, 1] - rows[:, 2]
        err *= 1e6
        ok = np.ones(b - a, bool) if good is None else good[a:b]
        in_zone = np.zeros(b - a, bool)
        deg = np.degrees(rows[:, 0]) if zones else None
        for j, z in enumerate(zones):
            sel = (deg >= z.from_deg) & (deg <= z.to_deg) & ok
            in_zone |= sel
            _widen(hi, lo, j, err[sel])
        _widen(hi, lo, -1, err[(rows[:, 2] > 0) & ~in_zone & ok])
    for j, z in enumerate(zones):
        name = f'lift_error_um[{z.from_deg:g}..{z.to_deg:g} deg]'
        if not np.isfinite(hi[j]):
            missing.append(_not(name, 'no samples in this zone'))
            continue
        checks.append(check(f'{name}.max_plus', float(hi[j]), z.band_um, 'um'))
        checks.append(check(f'{name}.max_minus', float(lo[j]), z.band_um, 'um'))
    if tol.lift_error_um is not None and np.isfinite(hi[-1]):
        checks.append(check('lift_error_max_plus_um', float(hi[-1]), tol.lift_error_um, 'um'))
        checks.append(check('lift_error_max_minus_um', float(lo[-1]), tol.lift_error_um, 'um'))


def judge_lobe(tol: Tolerances | None, feature: Mapping[str, Any], table: Any = None,
               design: Callable[..., Any] | None = None, phase_std_deg: float | None = None
               ) -> dict[str, Any]:
    """The verdict of one lobe. ``feature``: its report entry; ``table``: its
    /metrology/lift table (columns alpha [rad] from the fitted nose, measured and design
    lift [m]); ``design``: the design lift as seen by the probe (a law);
    ``phase_std_deg``: standard uncertainty of the phase (lobe and pin combined)."""
    if tol is None or not tol.any():
        return {'result': NOT_CHECKED, 'checks': [], 'failed': [],
                'not_checked': [_not('*', 'no tolerances for this feature')]}
    if feature.get('status') != 'ok':
        why = f"feature {feature.get('status', 'missing')}: {feature.get('reason', '')}"
        names = [n for n in ('lift_error_um', 'centreline_deg', 'phase_deg', 'max_lift_um',
                             'runout_max_um', 'duration_deg', 'roundness_max_um',
                             'waviness_max_um', 'velocity_error_max_mm_per_rad',
                             'acceleration_error_max_mm_per_rad2', 'lift_error_zones',
                             'derivative_error_zones')
                 if getattr(tol, n) not in (None, ())]
        return _verdict([], [_not(n, why.strip().rstrip(':')) for n in names] or
                        [_not('*', why.strip().rstrip(':'))])
    checks: list[dict[str, Any]] = []
    missing: list[dict[str, str]] = []
    good = None
    if table is not None:
        table = referenced_rows(table, feature)   # the rows kept: good = all
    _lift_error_checks(tol, table, good, checks, missing)
    if tol.phase_deg is not None:
        value = feature.get('phase_error_deg')
        if value is None:
            missing.append(_not('phase_error_deg', 'no phase (no dowel-pin angle or no '
                                'nominal_phase)'))
        else:
            checks.append(check('phase_error_deg', value, tol.phase_deg, 'deg',
                                phase_std_deg))
    if tol.runout_max_um is not None:
        value = feature.get('base_circle_runout_um')
        if value is None:
            missing.append(_not('base_circle_runout_um', 'too few base-circle samples'))
        else:
            checks.append(check('base_circle_runout_um', value, (None, tol.runout_max_um),
                                'um'))
    _form_checks(tol, feature, checks, missing)
    _derivative_checks(tol, feature, checks, missing)
    needs_table = (tol.max_lift_um, tol.duration_deg, tol.centreline_deg)
    if any(v is not None for v in needs_table):
        if table is None or design is None:
            for n, v in zip(('max_lift_um', 'duration_deg', 'centreline_deg'), needs_table):
                if v is not None:
                    missing.append(_not(n, 'no lift table or design for this feature'))
        else:
            # the two columns the checks read (not a copy of the whole table: memory; of
            # a long table only the rows around the peak and the events they fit)
            heights = () if tol.duration_deg is None and tol.centreline_deg is None \
                else (tol.checking_height_mm * 1e-3,)
            alpha, lift = card_rows(table, design, heights)
            del table
            _table_checks(tol, alpha, lift, design, checks, missing)
    return _verdict(checks, missing)


def _form_checks(tol: Tolerances, feature: Mapping[str, Any], checks: list[dict[str, Any]],
                 missing: list[dict[str, str]]) -> None:
    """Base-circle roundness and the waviness band's largest harmonic, maxima only."""
    why = feature.get('form_error') or 'no form analysis for this feature'
    if tol.roundness_max_um is not None:
        value = feature.get('roundness_um')
        if value is None:
            missing.append(_not('roundness_um', why))
        else:
            checks.append(check('roundness_um', value, (None, tol.roundness_max_um), 'um'))
    if tol.waviness_max_um is not None:
        value = (feature.get('waviness') or {}).get('max_amplitude_um')
        if value is None:
            missing.append(_not('waviness_max_amplitude_um', why))
        else:
            checks.append(check('waviness_max_amplitude_um', value,
                                (None, tol.waviness_max_um), 'um'))


def _derivative_checks(tol: Tolerances, feature: Mapping[str, Any],
                       checks: list[dict[str, Any]], missing: list[dict[str, str]]) -> None:
    """Largest |velocity| and |acceleration| error (maxima only): in each angle zone that
    limits it against the zone's maximum, and on the rest of the lobe (the whole lobe
    without such zones) against the lobe's own."""
    from cam_metrology.metrology.derivative_error import ZONE_LIMITS

    why = feature.get('derivative_error') or 'no velocity/acceleration error computed'
    zone_stats = feature.get('derivative_error_zones') or []
    outside = feature.get('derivative_error_outside_zones') or {}
    for name, limit, unit in (('velocity_error_mm_per_rad', tol.velocity_error_max_mm_per_rad,
                               'mm/rad'),
                              ('acceleration_error_mm_per_rad2',
                               tol.acceleration_error_max_mm_per_rad2, 'mm/rad2')):
        zoned = False
        for z in tol.derivative_error_zones:
            zmax = getattr(z, ZONE_LIMITS[name])
            if zmax is None:
                continue
            zoned = True
            label = f'{name}[{z.from_deg:g}..{z.to_deg:g} deg]'
            stats = next((s.get(name) for s in zone_stats
                          if (s['from_deg'], s['to_deg']) == (z.from_deg, z.to_deg)), None)
            if stats is None:
                missing.append(_not(label, why if 'derivative_error' in feature or
                                    not zone_stats else 'no samples in this zone'))
            else:
                checks.append(check(label, stats['max_abs'], (None, zmax), unit))
        if limit is None:
            continue
        value = ((outside.get(name) if zoned else feature.get(name)) or {}).get('max_abs')
        if value is None and zoned and name in outside:
            continue   # the zones cover the whole lobe: nothing left for the lobe's maximum
        if value is None:
            missing.append(_not(name, why))
        else:
            checks.append(check(name, value, (None, limit), unit))


def _table_checks(tol: Tolerances, alpha: Any, lift: Any, design: Callable[..., Any],
                  checks: list[dict[str, Any]], missing: list[dict[str, str]]) -> None:
    """Max lift, duration and centreline checks of the measured ``lift`` [m] against
    ``alpha`` [rad] (the good samples of the table, in angle order)."""
    from cam_design.cam_card import (law_events, law_peak, table_events, table_events_std,
                                     table_peak, table_peak_std)
    from cam_design.errors import InputError

    if tol.max_lift_um is not None:
        try:
            at, measured = table_peak(alpha, lift, design)
            _, nominal = law_peak(design)
            std = table_peak_std(alpha, lift, design, at) * 1e6
            checks.append(check('max_lift_error_um', (measured - nominal) * 1e6,
                                tol.max_lift_um, 'um', std))
        except InputError as exc:
            missing.append(_not('max_lift_um', str(exc)))
    if tol.duration_deg is None and tol.centreline_deg is None:
        return
    y = tol.checking_height_mm * 1e-3
    try:
        o, c = table_events(alpha, lift, y, design, key='checking_height_mm')
        o0, c0 = law_events(design, y, 'checking_height_mm')
    except InputError as exc:
        for n in ('duration_deg', 'centreline_deg'):
            if getattr(tol, n) is not None:
                missing.append(_not(n, str(exc)))
        return
    so, sc = table_events_std(alpha, lift, y, (o, c), design)
    at = f'@{tol.checking_height_mm:g}mm'
    if tol.duration_deg is not None:
        checks.append(check(f'duration_error_deg{at}', math.degrees((c - o) - (c0 - o0)),
                            tol.duration_deg, 'deg', math.degrees(math.hypot(so, sc))))
    if tol.centreline_deg is not None:
        checks.append(check(f'centreline_error_deg{at}',
                            math.degrees(0.5 * (o + c) - 0.5 * (o0 + c0)),
                            tol.centreline_deg, 'deg', math.degrees(0.5 * math.hypot(so, sc))))


def judge_tracks(tol: Tolerances | None, lobe_id: str,
                 features: Mapping[str, Mapping[str, Any]]) -> dict[str, Any]:
    """Taper and twist of a lobe measured on tracks (``tracks.taper_and_twist``) against
    ``taper_max_um_per_mm`` and ``twist_max_deg`` (maxima of the magnitudes)."""
    from cam_metrology.metrology.tracks import taper_and_twist

    checks: list[dict[str, Any]] = []
    missing: list[dict[str, str]] = []
    if tol is None or (tol.taper_max_um_per_mm is None and tol.twist_max_deg is None):
        return _verdict(checks, missing)
    tracks = taper_and_twist({f: e for f, e in features.items()
                              if e.get('track_of') == lobe_id}) or {}
    for name, limit, field in (('taper_um_per_mm', tol.taper_max_um_per_mm, 'taper_um_per_mm'),
                               ('nose_angle_difference_deg', tol.twist_max_deg,
                                'nose_angle_difference_deg')):
        if limit is None:
            continue
        if tracks.get(field) is None:
            missing.append(_not(name, 'fewer than 2 tracks of this lobe measured '
                                      '(frame_id <lobe>@<z mm>)'))
        else:
            checks.append(check(name, abs(tracks[field]), (None, limit),
                                'um/mm' if field.startswith('taper') else 'deg'))
    return _verdict(checks, missing)


class _Track:
    """A track of a lobe as the verdict sees it: its own id, the lobe's tolerances."""

    def __init__(self, track_id: str, lobe: Any) -> None:
        self.id, self.lobe_id, self.tolerances = track_id, lobe.id, lobe.tolerances


def judge_journal(journal: Any, feature: Mapping[str, Any]) -> dict[str, Any]:
    """The verdict of a journal: run-out TIR, roundness, waviness (maxima) and the
    diameter deviation band."""
    tol = journal.tolerances or Tolerances()
    if not tol.any() and journal.diameter_um is None:
        return {'result': NOT_CHECKED, 'checks': [], 'failed': [],
                'not_checked': [_not('*', 'no tolerances for this feature')]}
    if feature.get('status') != 'ok':
        return _verdict([], [_not('*', f"feature {feature.get('status')}: "
                                       f"{feature.get('reason', '')}")])
    checks: list[dict[str, Any]] = []
    missing: list[dict[str, str]] = []
    if tol.runout_max_um is not None:
        checks.append(check('runout_um', feature['runout_um'], (None, tol.runout_max_um), 'um'))
    _form_checks(tol, feature, checks, missing)
    if journal.diameter_um is not None:
        value = feature.get('diameter_deviation_um')
        if value is None:
            missing.append(_not('diameter_deviation_um', 'no probe.zero_radius in the scene'))
        else:
            checks.append(check('diameter_deviation_um', value, journal.diameter_um, 'um'))
    return _verdict(checks, missing)


def judge_datum(band: Band | None, feature: Mapping[str, Any] | None,
                nominal_angle_rad: float | None, name: str = 'dowel pin') -> dict[str, Any]:
    """The verdict of the datum (dowel pin or keyway, ``name``): its centre angle minus
    ``nominal_angle`` [deg], wrapped to (-180, 180]."""
    if band is None or nominal_angle_rad is None:
        return {'result': NOT_CHECKED, 'checks': [], 'failed': [],
                'not_checked': [_not('*', 'no datum tolerance')]}
    if not feature or feature.get('status') != 'ok' or feature.get('angle_deg') is None:
        why = f'{name} not measured' if not feature else \
            f"{name} {feature.get('status')}: {feature.get('reason', '')}"
        return _verdict([], [_not('datum_error_deg', why)])
    err = (feature['angle_deg'] - math.degrees(nominal_angle_rad) + 180.0) % 360.0 - 180.0
    if err == -180.0:
        err = 180.0
    return _verdict([check('datum_error_deg', err, band, 'deg',
                           feature.get('angle_std_deg'))], [])


def judge_part(scene: Scene, features: dict[str, dict[str, Any]],
               tables: Mapping[str, Any] | None = None,
               designs: Mapping[str, Callable[..., Any]] | None = None) -> dict[str, Any]:
    """Add ``verdict`` to every entry of ``features`` (in place) and return the part's
    verdict ``{result, failed[{feature, quantity, value, limit, unit}],
    not_checked[{feature, quantity, why}], checks}``."""
    tables, designs = tables or {}, designs or {}
    failed: list[dict[str, Any]] = []
    missing: list[dict[str, Any]] = []
    toleranced = False
    n = 0
    datum = getattr(scene, 'datum_id', None) or 'dowel_pin'
    pin_std = (features.get(datum) or {}).get('angle_std_deg')

    def lobe_verdict(lobe: Any, feature: dict[str, Any]) -> dict[str, Any]:
        std = feature.get('angle_std_deg')
        phase_std = (math.hypot(std, pin_std) if std is not None and pin_std is not None
                     else None)
        return judge_lobe(lobe.tolerances, feature, tables.get(lobe.id),
                          designs.get(getattr(lobe, 'lobe_id', lobe.id)), phase_std)

    judged = [(lobe, 'lobe', lobe.tolerances is not None and lobe.tolerances.any(),
               lobe_verdict) for lobe in scene.lobes]
    for lobe in scene.lobes:   # tracks across the width (lobe_1@-4): the lobe's tolerances
        judged += [(_Track(fid, lobe), 'track', lobe.tolerances is not None and
                    lobe.tolerances.any(), lobe_verdict) for fid, f in features.items()
                   if f.get('track_of') == lobe.id]
    judged += [(j, 'journal', j.tolerances is not None or j.diameter_um is not None,
                judge_journal) for j in getattr(scene, 'journals', ())]
    for item, what, has, judge in judged:
        toleranced |= has
        feature = features.get(item.id)
        if feature is None:
            if has:
                missing.append({'feature': item.id, 'quantity': '*',
                                'why': f'{what} not measured (no samples)'})
            continue
        v = judge(item, feature)
        feature['verdict'] = v
        if has:
            n += len(v['checks'])
            failed += [{'feature': item.id, **f} for f in v['failed']]
            missing += [{'feature': item.id, **m} for m in v['not_checked']]
    for lobe in scene.lobes:
        v = judge_tracks(lobe.tolerances, lobe.id, features)
        n += len(v['checks'])
        failed += [{'feature': lobe.id, **f} for f in v['failed']]
        missing += [{'feature': lobe.id, **m} for m in v['not_checked']]
    pin = scene.dowel_pin if datum == 'dowel_pin' else getattr(scene, 'keyway', None)
    if scene.datum_tolerance_deg is not None:
        toleranced = True
        v = judge_datum(scene.datum_tolerance_deg, features.get(datum),
                        pin.nominal_angle if pin else None, datum.replace('_', ' '))
        n += len(v['checks'])
        failed += [{'feature': datum, **f} for f in v['failed']]
        missing += [{'feature': datum, **m} for m in v['not_checked']]
        if datum in features:
            features[datum]['verdict'] = v
    elif datum in features:
        features[datum]['verdict'] = judge_datum(None, None, None)
    if not toleranced:
        return {'result': NOT_CHECKED, 'failed': [], 'not_checked':
                [{'feature': '*', 'quantity': '*', 'why': 'the scene has no tolerances'}],
                'checks': 0}
    result = FAIL if failed else (NOT_CHECKED if missing else PASS)
    return {'result': result, 'failed': failed, 'not_checked': missing, 'checks': n}


def verdict_lines(report: Mapping[str, Any]) -> list[str]:
    """Human lines of a report's verdict: the part first, then each failure / gap."""
    v = report.get('verdict')
    if not isinstance(v, Mapping):
        return ['verdict: not checked (no verdict in the report)']
    words = {PASS: 'PASS (accepted)', FAIL: 'FAIL (rejected)',
             NOT_CHECKED: 'NOT CHECKED'}
    lines = [f"verdict: {words.get(v.get('result'), v.get('result'))}  "
             f"({v.get('checks', 0)} checks)"]
    for f in v.get('failed') or []:
        lines.append(f"  FAIL {f['feature']} {f['quantity']}: {f['value']:.4g} {f['unit']} "
                     f"(limit {f['limit']:g} {f['unit']})")
    for m in v.get('not_checked') or []:
        if m.get('feature') != '*':
            lines.append(f"  not checked {m['feature']} {m['quantity']}: {m['why']}")
        else:
            lines.append(f"  not checked: {m['why']}")
    return lines
