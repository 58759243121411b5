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
from cam_metrology.reconstruction.samples import wrap_pi

#: output step of a table's spline evaluation [deg]
GRID_DEG = 0.1


def spline_law(alpha: NDArray[np.float64], h: NDArray[np.float64],
               key: str, *, allow_steps: bool = False) -> tuple[JetTableLift, str]:
    """(law, note) of a lift table [rad, m] smoothed by the reconstruction spline. A
    table with a lift step (a ramp cut off) is refused unless ``allow_steps`` (the cam
    card: its heights away from the step are still right); the note then says where."""
    from cam_metrology.reconstruction.profile import reconstruct_table
    from cam_metrology.reconstruction.samples import LiftTable, clean_samples
    from cam_metrology.reconstruction.spline import SplineOptions, quantisation_step

    a = np.asarray(alpha, dtype=float)
    alpha_in = a.copy()
    v = np.asarray(h, dtype=float)
    # what the cleaning did to the rows (non-finite dropped, repeats merged): said in the
    # note and in a refusal, since a merged repeat with two different lifts is a bad row
    said = '; '.join(clean_samples(a, v, key=key).notes)
    turn = seam_turn(a, v)
    if turn:   # the lobe crosses +-180 deg: fit it with its lowest point at the seam
        a = np.mod(a - turn + math.pi, 2.0 * math.pi) - math.pi
    q = quantisation_step(v) or None   # a gauge's rounding: noise of sigma q/sqrt(12)
    opts = SplineOptions(criterion='risk', sigma=q / math.sqrt(12.0) if q else None)
    out = reconstruct_table(LiftTable(key, a, v), methods=('spline',), spline=opts)['spline']
    rec = out.reconstruction
    if rec is None:
        raise InputError(key, f'{a.size} points',
                         f'a lift table the reconstruction spline can fit ({out.error})')
    limit = max(5.0 * (q or 0.0) / math.sqrt(12.0), 1e-3 * float(np.max(v)))
    steps = [w for w in (rec.warnings or []) if w.startswith('lift jumps')]
    if steps and not allow_steps:   # a velocity step or a cut-off ramp: an impulse
        raise InputError(key, f'{a.size} points',
                         'a table without steps (' + steps[0].split(':')[0] + '; a '
                         'velocity step is an impact the dynamics cannot take from a '
                         'smoothed table): tabulate the ramp finer or give the lift law')
    if rec.rms_residual > limit:
        raise InputError(key, f'{a.size} points',
                         'a table fine enough to define the lobe: neither its quintic '
                         'interpolant nor the reconstruction spline follows it (rms '
                         f'residual {rec.rms_residual:.3g} m > {limit:.3g} m'
                         + (f'; {said}' if said else '') + '); tabulate more points'
                         + (' or mend the repeated rows' if 'merged' in said else ''))
    step = float(np.median(np.diff(np.sort(a))))
    lo, hi = float(rec.alpha[0]), float(rec.alpha[-1])
    if turn:   # whole turn: keep clear of the spline's free ends, bridge the seam below
        if hi - lo < 2.0 * math.pi - 2.5 * step:
            raise InputError(key, f'a table over {math.degrees(hi - lo):.1f} deg',
                             'a table that ends on the base circle at both ends, or one '
                             'over the whole revolution (the lift at its ends is above '
                             'the base circle)')
        edge = max(2.0 * step, math.radians(2.0))
        lo, hi = -math.pi + edge, math.pi - edge
    n = max(4, int(math.ceil(math.degrees(hi - lo) / GRID_DEG)) + 1)
    grid = np.linspace(lo, hi, n)
    jets = np.stack([np.asarray(rec.evaluate(grid, nu), dtype=float) for nu in range(4)])
    if turn:   # periodic: the last interval is the Hermite bridge across the seam
        # lift from the base circle: 0 at the lowest point of the smoothed turn (the
        # smoothing leaves it a fraction of a um off, a seat contact the valve would feel)
        grid = np.append(grid, lo + 2.0 * math.pi)
        jets = np.concatenate([jets, jets[:, :1]], axis=1)
        ring = JetTableLift(grid, jets, key=key, trim=-1.0)
        # resampled on the turn that starts at the seam (the lowest point), so that the
        # revolution the dynamics integrate starts and ends on the base of the lobe
        seam = np.linspace(-math.pi, math.pi, n + 1)
        inner = np.where(seam < lo, seam + 2.0 * math.pi, seam)
        jets = np.asarray(ring.derivatives(inner), dtype=float)
        jets[0] -= float(np.min(jets[0]))
        law = JetTableLift(seam + turn, jets, key=key, trim=-1.0)
    else:
        law = JetTableLift(grid, jets, key=key)
    # what a replica of the table needs (dynamics.tables.jump_uncertainty): the rows,
    # the gauge step q (None: not quantised) and the noise the spline assumed [m]
    law.table = (alpha_in, v.copy(), q, float(rec.sigma))
    note = (f'table of {a.size} points every {math.degrees(step):.3g} deg smoothed by the '
            f'reconstruction spline ({rec.why}; rms residual {rec.rms_residual:.3g} m'
            + (f', lifts quantised to {q * 1e3:g} mm' if q else '') + ')'
            + (f'; rows: {said}' if said else '')
            + (f'; {steps[0].split(":")[0]}: lifts and events near it are the spline\'s '
               'bridge over the step, not the cam' if steps else '')
            + (f'; the lobe crosses +-180 deg: fitted on the turn from its lowest point '
               f'({math.degrees(float(wrap_pi(turn + math.pi))):.1f} deg), bridged there by the '
               'Hermite interpolant of the jets 2 steps either side' if turn else ''))
    return law, note


def seam_turn(alpha: NDArray[np.float64], h: NDArray[np.float64],
              trim: float = 1e-3) -> float:
    """0 when the lobe of a table [rad, m] lies inside (-pi, pi] with base circle at both
    ends; else the angle [rad] to subtract so that the table's lowest point lands on
    +-pi (a lobe across the seam, an eccentric: lift above ``trim`` x max at the ends)."""
    ok = np.isfinite(alpha) & np.isfinite(h)
    a = np.mod(alpha[ok] + math.pi, 2.0 * math.pi) - math.pi
    v = h[ok]
    if v.size < 2 or float(np.max(v)) <= 0:
        return 0.0
    order = np.argsort(a)
    ends = v[order][[0, -1]]
    if float(np.max(ends)) <= trim * float(np.max(v)):
        return 0.0
    return float(wrap_pi(float(a[int(np.argmin(v))]) + math.pi))
