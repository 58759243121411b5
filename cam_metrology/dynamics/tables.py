"""Lift tables into the dynamics: measured or nominal tables, reconstruct JSON, and the
valve train from a scene or a small YAML (docs/dynamics.md "Tables").

* ``spline_law(alpha, h, key)``: a coarse or noisy lift table through the
  reconstruction's smoothing spline (rebound fairing + quintic smoothing spline; the
  smoothing chosen by the estimated acceleration error, with the noise taken as the
  quantisation step / sqrt(12) when the lifts are on a quantisation grid), evaluated
  with h, h', h'', h''' on a 0.1 deg grid and used as a ``JetTableLift``. Returns the
  law and a sentence saying what was done (reported with the run).
* ``table_input(path, ...)``: (feature, law, source, note) from a CSV / gauge file
  (``cam_metrology.reconstruction.samples.read_table_file``) or the JSON that
  ``cam-bench reconstruct`` writes.
* ``valve_train_file(path)``: the ``valve_train`` block of a scene, or a YAML holding
  only that block (with or without the ``valve_train:`` key).
"""
from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cam_design.errors import InputError
from cam_design.valve_train.cam_input import JetTableLift

#: output step of a table's spline evaluation [deg]
GRID_DEG = 0.1
_QUANTA = (1e-7, 1e-6, 1e-5, 1e-4)


def quantisation(h: NDArray[np.float64]) -> float | None:
    """The largest step q in 0.1 um .. 0.1 mm with every lift a multiple of q (to 1e-3
    q), or None: a gauge's resolution, whose rounding is noise of sigma q / sqrt(12)."""
    best = None
    for q in _QUANTA:
        r = h / q
        if np.max(np.abs(r - np.round(r))) < 1e-3 and np.unique(np.round(r)).size > 3:
            best = q
    return best


def spline_law(alpha: NDArray[np.float64], h: NDArray[np.float64],
               key: str) -> tuple[JetTableLift, str]:
    """(law, note) of a lift table [rad, m] smoothed by the reconstruction spline."""
    from cam_metrology.reconstruction.profile import reconstruct_table
    from cam_metrology.reconstruction.samples import LiftTable
    from cam_metrology.reconstruction.spline import SplineOptions

    a = np.asarray(alpha, dtype=float)
    v = np.asarray(h, dtype=float)
    q = quantisation(v)
    opts = SplineOptions(criterion='risk', sigma=q / math.sqrt(12.0) if q else None)
    out = reconstruct_table(LiftTable(key, a, v), methods=('spline',), spline=opts)['spline']
    rec = out.reconstruction
    if rec is None:
        raise InputError(key, f'{a.size} points',
                         f'a lift table the reconstruction spline can fit ({out.error})')
    limit = max(5.0 * (q or 0.0) / math.sqrt(12.0), 1e-3 * float(np.max(v)))
    steps = [w for w in (rec.warnings or []) if w.startswith('lift jumps')]
    if steps:   # a velocity step or a cut-off ramp: the dynamics would see an impulse
        raise InputError(key, f'{a.size} points',
                         'a table without steps (' + steps[0].split(':')[0] + '; a '
                         'velocity step is an impact the dynamics cannot take from a '
                         'smoothed table): tabulate the ramp finer or give the lift law')
    if rec.rms_residual > limit:
        raise InputError(key, f'{a.size} points',
                         'a table fine enough to define the lobe: neither its quintic '
                         'interpolant nor the reconstruction spline follows it (rms '
                         f'residual {rec.rms_residual:.3g} m > {limit:.3g} m); tabulate '
                         'more points')
    n = max(4, int(math.ceil(math.degrees(rec.alpha[-1] - rec.alpha[0]) / GRID_DEG)) + 1)
    grid = np.linspace(rec.alpha[0], rec.alpha[-1], n)
    jets = np.stack([np.asarray(rec.evaluate(grid, nu), dtype=float) for nu in range(4)])
    law = JetTableLift(grid, jets, key=key)
    step = float(np.median(np.diff(a)))
    note = (f'table of {a.size} points every {math.degrees(step):.3g} deg smoothed by the '
            f'reconstruction spline ({rec.why}; rms residual {rec.rms_residual:.3g} m'
            + (f', lifts quantised to {q * 1e3:g} mm' if q else '') + ')')
    return law, note


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


def valve_train_file(path: Path) -> tuple[Any, Any]:
    """(ValveTrain, Scene or None) from a scene YAML or a YAML of the valve_train block."""
    from cam_metrology.scene_parse import _Ctx, _valve_train, load_scene
    from cam_metrology.yaml_input import load_yaml

    if not path.is_file():
        raise FileNotFoundError(f'no such valve-train file: {path}')
    try:
        text = path.read_text(encoding='utf-8')
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError('--valve-train', str(path), f'a readable YAML file ({exc})') from None
    doc = load_yaml(text, '--valve-train')
    if isinstance(doc, dict) and 'lobes' in doc:
        scene = load_scene(path)
        if scene.valve_train is None:
            raise InputError('--valve-train', str(path), 'a scene with a valve_train block')
        return scene.valve_train, scene
    if isinstance(doc, dict) and 'valve_train' in doc:
        doc = doc['valve_train']
    if not isinstance(doc, dict):
        raise InputError('--valve-train', str(path),
                         'a YAML mapping with the valve_train keys (docs/scene.md)')
    return _valve_train(_Ctx(), doc), None
