"""Writing gauge nominal-profile files (the layout ``inputs.lift_tables`` reads).

Layout: line 1 the probe radius [mm], line 2 the number of angle steps N, then N + 1
rows ``angle lift`` (deg from the lobe centreline, mm above the base circle) from -180
to +180 deg, the closing angle repeated; lines starting with ``#`` are comments (the
readers skip them). Values are written with 10 decimals (1e-13 m, 1e-10 deg), so a
read-back reproduces the lift to far better than 1e-9 m.
"""
from __future__ import annotations

import math
from typing import Any, Callable, Sequence

import numpy as np

from cam_design.errors import InputError

__all__ = ['gauge_text', 'law_gauge_text']


def gauge_text(alpha_deg: Sequence[float] | np.ndarray, lift_m: Sequence[float] | np.ndarray,
               probe_radius_m: float,
               comments: Sequence[str] = ()) -> str:
    """The file text of a table (angles [deg] strictly increasing, lifts [m])."""
    a = np.asarray(alpha_deg, dtype=float)
    h = np.asarray(lift_m, dtype=float)
    if a.size < 2 or a.shape != h.shape or not np.all(np.isfinite(a)) or \
            not np.all(np.isfinite(h)) or np.any(np.diff(a) <= 0):
        raise InputError('nominal table', f'{a.size} angles, {h.size} lifts',
                         'finite lifts at strictly increasing angles')
    if not (math.isfinite(probe_radius_m) and probe_radius_m >= 0):
        raise InputError('probe radius', probe_radius_m, 'a radius >= 0 in m')
    lines = [f'# {c}' for c in comments]
    lines += [f'{probe_radius_m * 1e3:.10f}', f'{a.size - 1}']
    lines += [f'{x:.10f} {y * 1e3:.10f}' for x, y in zip(a, h)]
    return '\n'.join(lines) + '\n'


def law_gauge_text(law: Callable[..., Any], step_deg: float, probe_radius_m: float,
                   comments: Sequence[str] = (), key: str = '--nominal-step-deg') -> str:
    """A law sampled every ``step_deg`` from -180 to 180 deg (360 / step must be whole)."""
    if not (math.isfinite(step_deg) and 1e-3 <= step_deg <= 10):
        raise InputError(key, step_deg, 'a step in [0.001, 10] deg')
    n = 360.0 / step_deg
    if abs(n - round(n)) > 1e-9 * n:
        raise InputError(key, step_deg, 'a step that divides 360 deg (e.g. 0.1, 0.25, 0.5, 1)')
    a = np.linspace(-180.0, 180.0, int(round(n)) + 1)
    return gauge_text(a, law(np.radians(a), 0), probe_radius_m, comments)
