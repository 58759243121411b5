"""Compare an ``analyze`` report with a golden (reference) report, within tolerances.

A golden report is the JSON report of a bag that a user has accepted once (written by
``cam-bench golden BAG OUT.json``). Later runs of the same bag, on another machine or a
newer cam-bench, must agree with it within stated tolerances: never bit for bit, since
the last bits of a float differ between CPUs and library builds.

Rules, per value of a feature (the key's unit suffix decides):

* ``*_deg`` angles: |difference| <= ``angle_tol_arcsec`` (wrapped to +-180 deg); the
  uncertainty keys (``*_std_deg``) within 10 % or the angle tolerance, whichever is
  larger;
* angles that only place a wave (the ``phase_deg`` of a harmonic, the ``at_deg`` and
  ``extent_deg`` of a waviness band: mappings with ``amplitude_um`` or
  ``max_amplitude_um``): within ``angle_tol_arcsec`` or the angle by which a wave of that
  amplitude moves by ``lift_tol_um`` (lift_tol / amplitude radians), whichever is larger.
  The phase of a harmonic at noise level is noise itself: a nanometre of difference in
  the lift error turns it by degrees, and no gauge reports it closer than that; a list of
  harmonics is compared harmonic by harmonic of the same ``upr`` (largest first, two of
  nearly equal amplitude may swap places);
* ``*_arcsec``: within ``angle_tol_arcsec``;
* ``*_um`` (also inside a mapping such as ``lift_error_um``) and ``*_mm``: within
  ``lift_tol_um`` (mm converted);
* booleans, strings and whole numbers (sample counts, status, verdict): equal;
* any other number: relative 1e-6 or absolute 1e-12.

Keys the golden report has must be present; keys only the new report has are allowed
(reports may gain keys, never lose them).
"""
from __future__ import annotations

import math
from typing import Any, Mapping

#: top-level keys that describe the run, not the part (never compared)
VOLATILE = frozenset({'provenance', 'generated', 'elapsed_s', 'host', 'cam_bench_version'})
#: per-feature keys that describe the solver's path, not the result (never compared)
SOLVER_KEYS = frozenset({'iterations'})


def golden_of(report: Mapping[str, Any]) -> dict[str, Any]:
    """The part of a report worth freezing: everything but the run's provenance."""
    return {k: v for k, v in report.items() if k not in VOLATILE}


def _angle_diff_deg(a: float, b: float) -> float:
    """a - b [deg] wrapped to [-180, 180)."""
    return (a - b + 180.0) % 360.0 - 180.0


def _compare_value(path: str, key: str, new: Any, old: Any, angle_tol_arcsec: float,
                   lift_tol_um: float, unit: str) -> list[str]:
    """Differences between one new and one golden value (``unit`` from the parent key)."""
    if isinstance(old, Mapping):
        if not isinstance(new, Mapping):
            return [f'{path}: expected a mapping like the golden report, got {new!r}']
        sub = key if key.endswith(('_um', '_mm', '_deg', '_arcsec')) else unit
        own = old.get('unit')   # a verdict check: value, limits and margin in its unit
        if own in ('um', 'mm', 'deg', 'arcsec'):
            sub = '_' + own
        out: list[str] = []
        angle_tol_arcsec = _wave_angle_tol(old, angle_tol_arcsec, lift_tol_um)
        for k, v in old.items():
            if k in SOLVER_KEYS:
                continue
            if k not in new:
                out.append(f'{path}.{k}: missing (golden {v!r})')
            else:
                out += _compare_value(f'{path}.{k}', k, new[k], v, angle_tol_arcsec,
                                      lift_tol_um, sub)
        return out
    if isinstance(old, list) and _keyed_by_upr(old) and isinstance(new, list) \
            and _keyed_by_upr(new):
        # a spectrum is listed largest first: harmonics of nearly equal amplitude may swap
        # places, so each is compared with the golden one of the same UPR
        by_upr = {int(h['upr']): h for h in new}
        out = []
        for o in old:
            k = int(o['upr'])
            if k not in by_upr:
                out.append(f'{path}[upr {k}]: missing (golden {o!r})')
            else:
                out += _compare_value(f'{path}[upr {k}]', key, by_upr[k], o,
                                      angle_tol_arcsec, lift_tol_um, unit)
        return out
    if isinstance(old, list):
        if not isinstance(new, list) or len(new) != len(old):
            return [f'{path}: got {new!r}, golden {old!r}']
        out = []
        for i, (n, o) in enumerate(zip(new, old)):
            out += _compare_value(f'{path}[{i}]', key, n, o, angle_tol_arcsec, lift_tol_um,
                                  unit)
        return out
    if old is None or isinstance(old, (bool, str)) or isinstance(new, (bool, str)) \
            or new is None:
        return [] if new == old else [f'{path}: got {new!r}, golden {old!r}']
    if isinstance(old, int) and isinstance(new, int):
        return [] if new == old else [f'{path}: got {new}, golden {old}']
    new_f, old_f = float(new), float(old)
    if math.isnan(old_f) or math.isnan(new_f):
        return [] if math.isnan(old_f) and math.isnan(new_f) else \
            [f'{path}: got {new_f!r}, golden {old_f!r}']
    suffix = key if key.endswith(('_um', '_mm', '_deg', '_arcsec')) else unit
    if key.endswith(('_mm_deg', '_m_rad')):   # an area under the lift: relative, not angle
        suffix = ''
    if suffix.endswith('_std_deg'):
        tol = max(0.1 * abs(old_f), angle_tol_arcsec / 3600.0)
        diff, shown = new_f - old_f, f'{(new_f - old_f) * 3600:.4g} arcsec'
    elif suffix.endswith('_deg'):
        tol = angle_tol_arcsec / 3600.0
        diff = _angle_diff_deg(new_f, old_f)
        shown = f'{diff * 3600:.4g} arcsec'
    elif suffix.endswith('_arcsec'):
        tol, diff = angle_tol_arcsec, new_f - old_f
        shown = f'{diff:.4g} arcsec'
    elif suffix.endswith('_um'):
        tol, diff = lift_tol_um, new_f - old_f
        shown = f'{diff:.4g} µm'
    elif suffix.endswith('_mm'):
        tol, diff = lift_tol_um * 1e-3, new_f - old_f
        shown = f'{diff * 1e3:.4g} µm'
    else:
        tol, diff = max(1e-6 * abs(old_f), 1e-12), new_f - old_f
        shown = f'{diff:.4g}'
    if abs(diff) <= tol:
        return []
    return [f'{path}: got {new_f!r}, golden {old_f!r} (off by {shown}; tolerance '
            f'{_tol_text(suffix, tol)})']


def _keyed_by_upr(items: list[Any]) -> bool:
    """True for a non-empty list of harmonics (mappings with distinct ``upr``)."""
    if not items or not all(isinstance(h, Mapping) and isinstance(h.get('upr'), int)
                            for h in items):
        return False
    return len({h['upr'] for h in items}) == len(items)


#: keys of a mapping that describes a wave; its angles are tolerated by the wave's amplitude
WAVE_AMPLITUDE_KEYS = ('amplitude_um', 'max_amplitude_um')


def _wave_angle_tol(old: Mapping[str, Any], angle_tol_arcsec: float,
                    lift_tol_um: float) -> float:
    """The angle tolerance [arcsec] inside a mapping: for a wave (a harmonic, a waviness
    band) the angle by which a wave of its amplitude moves by ``lift_tol_um``."""
    for key in WAVE_AMPLITUDE_KEYS:
        amp = old.get(key)
        if isinstance(amp, (int, float)) and not isinstance(amp, bool) and amp > 0:
            return max(angle_tol_arcsec, math.degrees(lift_tol_um / float(amp)) * 3600.0)
    return angle_tol_arcsec


def _tol_text(suffix: str, tol: float) -> str:
    if suffix.endswith('_deg'):
        return f'{tol * 3600:.4g} arcsec'
    if suffix.endswith('_arcsec'):
        return f'{tol:.4g} arcsec'
    if suffix.endswith('_um'):
        return f'{tol:.4g} µm'
    if suffix.endswith('_mm'):
        return f'{tol * 1e3:.4g} µm'
    return f'{tol:.4g}'


def compare_reports(report: Mapping[str, Any], golden: Mapping[str, Any], *,
                    angle_tol_arcsec: float = 0.5, lift_tol_um: float = 0.05) -> list[str]:
    """Every difference of ``report`` from ``golden`` beyond the tolerances, one line each
    (an empty list when they agree). Tolerances: angles [arcsec], lifts [µm]."""
    if not (angle_tol_arcsec >= 0 and lift_tol_um >= 0):
        from cam_design.errors import InputError
        raise InputError('angle_tol_arcsec/lift_tol_um', (angle_tol_arcsec, lift_tol_um),
                         'tolerances >= 0')
    out: list[str] = []
    gold = golden_of(golden)
    for key, old in gold.items():
        if key not in report:
            out.append(f'{key}: missing (golden {old!r})')
        elif key == 'features':
            new_feats = report[key]
            for fid in old:
                if fid not in new_feats:
                    out.append(f'features.{fid}: missing (the golden report has it)')
            for fid in new_feats:
                if fid not in old:
                    out.append(f'features.{fid}: not in the golden report')
            for fid, feat in old.items():
                if fid in new_feats:
                    out += _compare_value(f'features.{fid}', fid, new_feats[fid], feat,
                                          angle_tol_arcsec, lift_tol_um, '')
        else:
            out += _compare_value(key, key, report[key], old, angle_tol_arcsec,
                                  lift_tol_um, '')
    return out


def assert_report_matches(report: Mapping[str, Any], golden: Mapping[str, Any], *,
                          angle_tol_arcsec: float = 0.5, lift_tol_um: float = 0.05) -> None:
    """Raise AssertionError listing every difference (see ``compare_reports``)."""
    diffs = compare_reports(report, golden, angle_tol_arcsec=angle_tol_arcsec,
                            lift_tol_um=lift_tol_um)
    if diffs:
        head = (f'report differs from the golden report in {len(diffs)} place(s) '
                f'(angles within {angle_tol_arcsec} arcsec, lifts within {lift_tol_um} µm):')
        raise AssertionError('\n'.join([head] + ['  ' + d for d in diffs]))
