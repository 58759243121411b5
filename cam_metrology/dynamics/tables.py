"""Lift tables into the dynamics: measured or nominal tables and reconstruct JSON
(docs/dynamics.md "Tables").

* tables go through ``cam_design.lift_table.lobe_table.lobe_law`` (the one lobe law of a
  table, with a sentence saying what was done and the table's warnings).
* ``table_input(path, ...)``: (feature, law, source, note) from a CSV / gauge file
  (``cam_metrology.inputs.lift_tables.read_table_file``) or the JSON that
  ``cam-bench reconstruct`` writes.
* the valve train comes from ``scene.parse.load_valve_train``.
* ``jump_uncertainty``: the jump speed's uncertainty that a table's noise or
  quantisation carries (replicas of the table with a fresh draw of that noise, each
  fitted as the table was: ``lobe_law(..., fit=law.lobe.fit)``).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from cam_design.errors import InputError
from cam_design.lift_laws.base import LiftLaw
from cam_design.lift_table.lobe_table import TableLobe, lobe_from_jets, lobe_law

#: replicas of a table for the jump-speed uncertainty
REPLICAS = 8
#: the level of confidence of the band: that of 3 standard deviations of a normal law
#: (99.73 %); with the standard deviation estimated from n replicas the coverage factor
#: is Student's t for n - 1 degrees of freedom at that level (GUM, JCGM 100:2008,
#: Annex G, Table G.2: 4.53 for 7), not 3 (docs/dynamics.md "Tables")
CONFIDENCE = 0.9973


def coverage_factor(replicas: int) -> float:
    """Student's t quantile (two-sided ``CONFIDENCE``) for ``replicas`` - 1 degrees of
    freedom: the factor on the replicas' standard deviation."""
    from scipy.stats import t

    return float(t.ppf(0.5 + 0.5 * CONFIDENCE, replicas - 1))


def table_input(path: Path, *, feature: str | None = None, angle_unit: str = 'deg',
                length_unit: str = 'mm') -> tuple[str, LiftLaw, str, str]:
    """(feature, law, source, note) of a TABLE given to ``cam-bench dynamics``."""
    if path.suffix.lower() == '.json':
        return _reconstruct_json(path, feature)
    from cam_metrology.inputs.lift_tables import read_table_file

    table = read_table_file(path, angle_unit=angle_unit, length_unit=length_unit)
    name = feature or table.feature or path.stem
    law = lobe_law(table.alpha, table.lift, key=path.name)
    note = law.lobe.note() + ''.join(f'; WARNING: {w}' for w in law.lobe.warnings)
    return name, law, f'table:{law.lobe.method}', note


def _reconstruct_json(path: Path, feature: str | None) -> tuple[str, LiftLaw, str, str]:
    try:
        doc = json.loads(path.read_text(encoding='utf-8'))
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise InputError(path.name, 'unreadable JSON', f'the JSON of cam-bench reconstruct '
                         f'({exc})') from None
    feats = doc.get('features') if isinstance(doc, dict) else None
    if not isinstance(feats, dict) or not feats:
        raise InputError(f'{path.name}: features', None,
                         'the JSON of cam-bench reconstruct (features.<id>.<method>)')
    if feature is None:
        feature = sorted(feats)[0]
    if feature not in feats:
        raise InputError('--feature', feature, 'one of ' + ', '.join(sorted(feats)))
    methods = dict(feats[feature])
    lobe = (doc.get('lobes') or {}).get(feature)
    if isinstance(lobe, dict):   # the rows' lobe law: what every table route reads
        methods['lobe'] = lobe
    names = [m for m in ('lobe', 'spline', 'harmonic') if isinstance(methods.get(m), dict)
             and methods[m].get('ok') and 'alpha_rad' in methods[m]]
    if not names:
        raise InputError(f'{path.name}: features.{feature}', 'no method with arrays',
                         'a reconstruction with alpha_rad, lift_m, velocity_m_per_rad, '
                         'acceleration_m_per_rad2, jerk_m_per_rad3 (reconstruct --json)')
    m = methods[names[0]]
    cols = ('lift_m', 'velocity_m_per_rad', 'acceleration_m_per_rad2', 'jerk_m_per_rad3')
    try:
        a = np.asarray(m['alpha_rad'], dtype=float)
        jets = np.stack([np.asarray(m[c], dtype=float) for c in cols])
    except (KeyError, TypeError, ValueError) as exc:
        raise InputError(f'{path.name}: features.{feature}.{names[0]}', str(exc),
                         'arrays ' + ', '.join(('alpha_rad',) + cols)) from None
    where = (f'lobes.{feature}' if names[0] == 'lobe' else f'features.{feature}.{names[0]}')
    law = lobe_from_jets(a, jets, key=f'{path.name}: {where}')
    return feature, law, f'reconstruct:{names[0]}', (
        f'reconstructed profile ({names[0]}) from {path.name}: ' + law.lobe.note()
        + ''.join(f'; WARNING: {w}' for w in law.lobe.warnings))


def jump_uncertainty(law: LiftLaw, params: object, jump_rpm: float, step_deg: float,
                     *, replicas: int = REPLICAS, seed: int = 0) -> tuple[float, str] | None:
    """(U [rpm], sentence) of the jump speed ``jump_rpm`` found on a table's spline law,
    or None when the law did not come from a table (``lobe_law``).

    The table's rows carry noise (a gauge step q: rounding, uniform of width q; else the
    noise sigma the spline estimated). ``replicas`` copies of the table with a fresh
    draw of that noise added to the lobe rows (h > 0) are each fitted as the table was
    (``law.lobe.fit``: interpolated, or smoothed by the same criterion with the same
    known noise or the noise re-estimated from the copy's rows) and the jump speed of
    each is bisected to 0.2 % near ``jump_rpm``; their spread is the spread of the
    original table's jump speed around the cam's own (the rows are one draw of the same
    noise). U = k x standard deviation + |mean - jump_rpm|, k = ``coverage_factor``
    (Student's t for the number of copies that gave a speed, minus one).
    """
    import math

    from cam_design.valve_train.sweep import CLEAN, runners

    if not isinstance(law, TableLobe) or not jump_rpm:
        return None
    a, h, q, sigma = law.table
    fit = law.lobe.fit
    rng = np.random.default_rng(seed)
    lobe = h > 0
    speeds = []
    for _ in range(replicas):
        if q:
            noise = rng.uniform(-0.5 * q, 0.5 * q, h.size)
        else:
            noise = rng.normal(0.0, sigma, h.size)
        rep = lobe_law(a, h + noise * lobe, key='replica',
                       noise=max(sigma, (q or 0.0) / math.sqrt(12.0)), fit=fit)
        run_at, _single = runners(rep, params, step_deg)

        def fails(rpm: float) -> bool:
            return run_at(rpm).status != CLEAN

        lo, hi = 0.97 * jump_rpm, 1.03 * jump_rpm
        tries = 0
        while fails(lo) and tries < 8:
            lo, hi, tries = 0.94 * lo, lo, tries + 1
        while not fails(hi) and tries < 8:
            lo, hi, tries = hi, 1.06 * hi, tries + 1
        if tries >= 8:
            continue
        while hi - lo > 2e-3 * jump_rpm:
            mid = 0.5 * (lo + hi)
            lo, hi = (lo, mid) if fails(mid) else (mid, hi)
        speeds.append(hi)
    if len(speeds) < 3:
        return None
    js = np.asarray(speeds)
    sd = float(np.std(js, ddof=1))
    k = coverage_factor(js.size)
    u = k * sd + abs(float(np.mean(js)) - jump_rpm)
    what = (f'gauge step {q * 1e3:g} mm' if q else f'noise {sigma * 1e6:.3g} um')
    text = (f'jump speed +-{u:.0f} rpm ({100 * u / jump_rpm:.1f} %) from the table\'s '
            f'{what}: {len(speeds)} copies of the table with a fresh draw of that noise, '
            f'each {fit.text()} as the table was, gave {js.min():.0f}..{js.max():.0f} rpm '
            f'(U = {k:.2f} standard deviations, Student\'s t for {js.size - 1} degrees of '
            f'freedom at {CONFIDENCE * 100:g} %, + the mean shift); the interpolation '
            'between rows of an exact table and the smoothing of a step of h\'\' are not '
            'included')
    if not math.isfinite(u):
        return None
    return u, text
