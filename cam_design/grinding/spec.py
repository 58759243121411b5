"""The ``grinding:`` section of a YAML file (docs/grinding.md): checked into dataclasses.

Every bad value raises InputError naming ``grinding.<key>``.
"""
from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np

from cam_design.errors import (InputError, require_finite, require_length, require_mapping,
                               require_positive)
from cam_design.grinding.wheel_path import DESIGN_KINDS, Design

SECTION_KEYS = ('design', 'wheel_radius', 'step_deg', 'cradle', 'master_follower', 'errors')
DESIGN_KEYS = ('kind', 'radius', 'offset', 'centre_distance', 'arm_length', 'eta', 'delta')
CRADLE_KEYS = ('pivot_to_work', 'pivot_to_wheel', 'pivot_to_master',
               'pivot_to_master_follower', 'master_angle', 'side')
MASTER_KEYS = ('kind', 'radius')
ERROR_KEYS = ('wheel_radius', 'centre_distance', 'index', 'run_out_x', 'run_out_y',
              'master_follower_radius')


def section(doc: Any, key: str = 'grinding') -> Mapping[str, Any]:
    """The checked ``grinding:`` mapping of a YAML document (empty if absent)."""
    if not isinstance(doc, Mapping) or doc.get('grinding') is None:
        return {}
    return require_mapping(doc['grinding'], key, SECTION_KEYS)


def design(value: Any, key: str = 'grinding.design') -> Design:
    """A :class:`Design` from ``{kind, radius, offset, centre_distance, arm_length, eta,
    delta}`` (or just the kind as a string)."""
    if isinstance(value, str):
        value = {'kind': value}
    spec = require_mapping(value, key, DESIGN_KEYS)
    kind = spec.get('kind')
    if kind not in DESIGN_KINDS:
        raise InputError(f'{key}.kind', kind, ' | '.join(DESIGN_KINDS))
    args: dict[str, Any] = {'kind': kind}
    for name in ('radius', 'offset', 'centre_distance', 'arm_length'):
        if name in spec:
            args[name] = require_positive(f'{key}.{name}', spec[name], allow_zero=True)
    for name in ('eta', 'delta'):
        if name in spec:
            v = spec[name]
            if isinstance(v, bool) or v not in ((1, -1) if name == 'eta' else (1, -1, 0)):
                extra = ' (or 0)' if name == 'delta' else ''
                raise InputError(f'{key}.{name}', v, '+1 or -1' + extra)
            args[name] = int(v)
    if kind == 'rocker':
        for name in ('centre_distance', 'arm_length'):
            if not args.get(name):
                raise InputError(f'{key}.{name}', spec.get(name), 'a length > 0 [m] for a '
                                                                  'rocker design')
    return Design(**args)


#: largest plausible grinding-wheel radius [m] (wheels are up to about 0.4 m): a larger
#: value is almost always millimetres
WHEEL_RADIUS_MAX_M = 1.0


def wheel_radii(value: Any, key: str = 'grinding.wheel_radius') -> list[float]:
    """One radius or a list of radii [m], each > 0 and at most ``WHEEL_RADIUS_MAX_M``
    (200 given for 200 mm is refused, naming the unit it looks like)."""
    values = value if isinstance(value, (list, tuple)) else [value]
    if not values:
        raise InputError(key, value, 'a wheel radius [m] or a list of them')
    return [require_length(f'{key}[{i}]' if len(values) > 1 else key, v, WHEEL_RADIUS_MAX_M,
                           what='a wheel radius') for i, v in enumerate(values)]


def step_rad(value: Any, key: str = 'grinding.step_deg') -> float:
    """Angle step [deg] in [1e-3, 10] -> rad."""
    step = require_positive(key, value)
    if not 1e-3 <= step <= 10.0:
        raise InputError(key, value, 'an angle step in [0.001, 10] deg')
    return math.radians(step)


def floats(spec: Mapping[str, Any], key: str, names: tuple[str, ...],
           positive: tuple[str, ...] = ()) -> dict[str, float]:
    """The finite numbers of ``spec`` under ``names`` (those in ``positive`` > 0)."""
    out = {}
    for name in names:
        if name in spec:
            fn = require_positive if name in positive else require_finite
            out[name] = float(fn(f'{key}.{name}', spec[name]))
    return out


def as_array(value: Any, key: str) -> np.ndarray:
    """A finite 1-D float array (InputError naming ``key`` otherwise)."""
    try:
        arr = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise InputError(key, value, 'a list of numbers') from None
    if arr.size == 0 or not np.all(np.isfinite(arr)):
        raise InputError(key, value, 'a non-empty list of finite numbers')
    return arr
