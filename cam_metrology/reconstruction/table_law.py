"""A coarse or noisy lift table as a lift law: the reconstruction's smoothing spline
(rebound fairing + quintic smoothing spline, smoothing chosen by the estimated
acceleration error, rounding to a step q counted as noise q/sqrt(12)), evaluated with
h, h', h'', h''' on a 0.1 deg grid as a ``JetTableLift`` (rad, m). Used for scene lobe
tables whose own interpolant cannot be trusted and for tables given to the dynamics.
"""
from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from cam_design.errors import InputError
from cam_design.valve_train.cam_input import JetTableLift

#: output step of a table's spline evaluation [deg]
GRID_DEG = 0.1


def spline_law(alpha: NDArray[np.float64], h: NDArray[np.float64],
               key: str) -> tuple[JetTableLift, str]:
    """(law, note) of a lift table [rad, m] smoothed by the reconstruction spline."""
    from cam_metrology.reconstruction.profile import reconstruct_table
    from cam_metrology.reconstruction.samples import LiftTable
    from cam_metrology.reconstruction.spline import SplineOptions, quantisation_step

    a = np.asarray(alpha, dtype=float)
    v = np.asarray(h, dtype=float)
    q = quantisation_step(v) or None   # a gauge's rounding: noise of sigma q/sqrt(12)
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
    # what a replica of the table needs (dynamics.tables.jump_uncertainty): the rows,
    # the gauge step q (None: not quantised) and the noise the spline assumed [m]
    law.table = (a.copy(), v.copy(), q, float(rec.sigma))
    step = float(np.median(np.diff(a)))
    note = (f'table of {a.size} points every {math.degrees(step):.3g} deg smoothed by the '
            f'reconstruction spline ({rec.why}; rms residual {rec.rms_residual:.3g} m'
            + (f', lifts quantised to {q * 1e3:g} mm' if q else '') + ')')
    return law, note
