"""Q-DAS AQDEF transfer files (DFQ) of measured camshafts, for any SPC package.

Input: the rows of ``batch.rows_of_report`` (one per bag and feature, nested report
fields as ``a.b`` columns), from one ``analyze`` or a whole ``batch``. Output: one DFQ
text in the coded (K-field) form:

* part: ``K0100`` (number of characteristics), ``K1001`` part number (the camshaft id),
  ``K1002`` part description;
* one characteristic per reported quantity of each feature (``CHARACTERISTICS``) that
  has a value in some row: ``K2001/i`` number, ``K2002/i`` description
  ``<feature> <field>`` (the report's field name, e.g. ``lobe_1 angle_deg``),
  ``K2142/i`` unit, and where the scene tolerances gave the verdict limits for it:
  ``K2101/i`` nominal 0 (the quantity is an error), ``K2110/i`` lower and ``K2111/i``
  upper limit (a maximum only: no lower limit);
* one value record per measured part (bag): ``K0001/i`` value, ``K0004/i`` date/time
  of the measurement (the bag's start, UTC, ``dd.mm.yyyy/hh:mm:ss``), ``K0008/i``
  operator and ``K0014/i`` part ident (the scene's ``operator`` and ``part_id``, else
  the camshaft id). A quantity a part does not have (a failed feature) gets no value
  record for that part.
"""
from __future__ import annotations

import json
import math
import time
from pathlib import Path
from typing import Any, Iterable

#: report field -> (unit, verdict check quantity giving its limits, or None)
CHARACTERISTICS: dict[str, tuple[str, str | None]] = {
    'angle_deg': ('deg', None),
    'phase_deg': ('deg', None),
    'phase_error_deg': ('deg', 'phase_error_deg'),
    'asymmetry_deg': ('deg', None),
    'lift_error_um.max_plus': ('um', 'lift_error_max_plus_um'),
    'lift_error_um.max_minus': ('um', 'lift_error_max_minus_um'),
    'lift_error_um.rms': ('um', None),
    'base_circle_runout_um': ('um', 'base_circle_runout_um'),
    'roundness_um': ('um', 'roundness_um'),
    'waviness.max_amplitude_um': ('um', 'waviness_max_amplitude_um'),
    'waviness.upr_at_max': ('UPR', None),
    'diameter_deviation_um': ('um', 'diameter_deviation_um'),
    'runout_um': ('um', 'runout_um'),
    'velocity_error_mm_per_rad.max_abs': ('mm/rad', 'velocity_error_mm_per_rad'),
    'acceleration_error_mm_per_rad2.max_abs': ('mm/rad2', 'acceleration_error_mm_per_rad2'),
}
#: check quantity -> how its angle zones' checks begin (tolerances.md)
ZONED = {'lift_error_max_plus_um': 'lift_error_um[', 'lift_error_max_minus_um': 'lift_error_um[',
         'velocity_error_mm_per_rad': 'velocity_error_mm_per_rad[',
         'acceleration_error_mm_per_rad2': 'acceleration_error_mm_per_rad2['}


def _number(value: Any) -> float | None:
    """A finite float, or None (missing, NaN, text)."""
    if isinstance(value, bool) or value is None:
        return None
    try:
        out = float(value)
    except (TypeError, ValueError):
        return None
    return out if math.isfinite(out) else None


def _limits(row: dict[str, Any], quantity: str | None) -> tuple[float | None, float | None]:
    """(lower, upper) the row's verdict checked ``quantity`` against ((None, None) when
    it was not checked, or when the quantity also has angle zones: the whole-lobe value
    the file carries then has no one limit, the check covering only the lobe outside
    the zones)."""
    if quantity is None:
        return None, None
    raw = row.get('verdict.checks')
    try:
        checks = json.loads(raw) if isinstance(raw, str) else (raw or [])
    except ValueError:
        return None, None
    zoned = ZONED.get(quantity)
    if zoned and any(isinstance(c, dict) and str(c.get('quantity', '')).startswith(zoned)
                     for c in checks):
        return None, None
    for c in checks:
        if isinstance(c, dict) and c.get('quantity') == quantity:
            return _number(c.get('lower')), _number(c.get('upper'))
    return None, None


def _stamp(row: dict[str, Any]) -> str:
    """The measurement's date/time in AQDEF form (bag start, UTC; else the analysis)."""
    ns = row.get('bag_start_utc_ns')
    if ns is not None:
        return time.strftime('%d.%m.%Y/%H:%M:%S', time.gmtime(int(ns) / 1e9))
    raw = str(row.get('analyzed_utc') or '')
    try:
        return time.strftime('%d.%m.%Y/%H:%M:%S', time.strptime(raw, '%Y-%m-%dT%H:%M:%SZ'))
    except ValueError:
        return time.strftime('%d.%m.%Y/%H:%M:%S', time.gmtime())


def _text(value: Any) -> str:
    """A K-field text value on one line."""
    return ' '.join(str(value).split())


def characteristics(rows: Iterable[dict[str, Any]]) -> list[dict[str, Any]]:
    """The characteristics of the rows, in order of first appearance: ``feature``,
    ``field``, ``unit``, ``lower``, ``upper`` (from the last row that has limits)."""
    out: dict[tuple[str, str], dict[str, Any]] = {}
    for row in rows:
        if row.get('status') != 'ok' or not row.get('feature'):
            continue
        for field, (unit, quantity) in CHARACTERISTICS.items():
            if _number(row.get(field)) is None:
                continue
            key = (str(row['feature']), field)
            entry = out.setdefault(key, {'feature': key[0], 'field': field, 'unit': unit,
                                         'lower': None, 'upper': None})
            lo, hi = _limits(row, quantity)
            if lo is not None or hi is not None:
                entry['lower'], entry['upper'] = lo, hi
    return list(out.values())


def dfq_text(rows: list[dict[str, Any]]) -> str:
    """The DFQ file of ``rows`` (module doc)."""
    chars = characteristics(rows)
    ok = [r for r in rows if r.get('status') == 'ok' and r.get('feature')]
    part = next((str(r.get('camshaft_id')) for r in ok if r.get('camshaft_id')), 'camshaft')
    lines = [f'K0100 {len(chars)}', f'K1001 {_text(part)}',
             'K1002 camshaft (cam-bench metrology report)']
    for i, c in enumerate(chars, 1):
        lines += [f'K2001/{i} {i}', f"K2002/{i} {c['feature']} {c['field']}",
                  f"K2142/{i} {c['unit']}"]
        if c['lower'] is not None or c['upper'] is not None:
            lines.append(f'K2101/{i} 0')
        if c['lower'] is not None:
            lines.append(f"K2110/{i} {c['lower']!r}")
        if c['upper'] is not None:
            lines.append(f"K2111/{i} {c['upper']!r}")
    index = {(c['feature'], c['field']): i for i, c in enumerate(chars, 1)}
    bags: dict[str, list[dict[str, Any]]] = {}
    for r in ok:
        bags.setdefault(str(r.get('bag')), []).append(r)
    for feats in sorted(bags.values(), key=lambda fs: (fs[0].get('bag_start_utc_ns') or 0,
                                                       str(fs[0].get('bag')))):
        for r in feats:
            ident = r.get('part_id') or r.get('camshaft_id') or part
            for field in CHARACTERISTICS:
                value = _number(r.get(field))
                num = index.get((str(r['feature']), field))
                if value is None or num is None:
                    continue
                lines += [f'K0001/{num} {value!r}', f'K0004/{num} {_stamp(r)}']
                if r.get('operator'):
                    lines.append(f"K0008/{num} {_text(r['operator'])}")
                lines.append(f'K0014/{num} {_text(ident)}')
    return '\r\n'.join(lines) + '\r\n'


def write_dfq(path: str | Path, rows: list[dict[str, Any]], key: str = '--dfq') -> int:
    """Write the DFQ of ``rows`` to ``path`` atomically (temp file + rename: a path that
    cannot be written is one InputError naming ``key``, and an old file stays whole);
    returns the number of characteristics."""
    from cam_design.errors import InputError
    from cam_metrology.inputs.files import write_output

    if not any(r.get('status') == 'ok' for r in rows):
        raise InputError(key, str(path), 'at least one measured feature to write')
    write_output(path, dfq_text(rows).encode('utf-8'), key)
    return len(characteristics(rows))
