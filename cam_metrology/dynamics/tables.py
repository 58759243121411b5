"""Lift tables into the dynamics: measured or nominal tables and reconstruct JSON
(docs/dynamics.md "Tables").

* tables go through ``reconstruction.table_law.spline_law`` (the reconstruction's
  smoothing spline as a ``JetTableLift``, with a sentence saying what was done).
* ``table_input(path, ...)``: (feature, law, source, note) from a CSV / gauge file
  (``cam_metrology.reconstruction.samples.read_table_file``) or the JSON that
  ``cam-bench reconstruct`` writes.
* the valve train comes from ``scene_parse.load_valve_train``.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from cam_design.errors import InputError
from cam_design.valve_train.cam_input import JetTableLift
from cam_metrology.reconstruction.table_law import spline_law


def table_input(path: Path, *, feature: str | None = None, angle_unit: str = 'deg',
                length_unit: str = 'mm') -> tuple[str, JetTableLift, str, str]:
    """(feature, law, source, note) of a TABLE given to ``cam-bench dynamics``."""
    if path.suffix.lower() == '.json':
        return _reconstruct_json(path, feature)
    from cam_metrology.reconstruction.samples import read_table_file

    table = read_table_file(path, angle_unit=angle_unit, length_unit=length_unit)
    name = feature or table.feature or path.stem
    law, note = spline_law(table.alpha, table.lift, path.name)
    return name, law, 'table:spline', note


def _reconstruct_json(path: Path, feature: str | None) -> tuple[str, JetTableLift, str, str]:
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
    methods = feats[feature]
    names = [m for m in ('spline', 'harmonic') if isinstance(methods.get(m), dict)
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
    law = JetTableLift(a, jets, key=f'{path.name}: features.{feature}.{names[0]}')
    return feature, law, f'reconstruct:{names[0]}', (
        f'reconstructed profile ({names[0]}) from {path.name}')
