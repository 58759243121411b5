"""One lift table -> one lobe law: the component every route that reads a lift table
uses (a table file, a scene lobe table, a gauge nominal file, a reconstruction's
profile, the measured table of the metrology node).

``lobe_law(alpha, lift, key=...)`` returns a ``TableLobe``: a lift law (rad -> m,
callable as ``law(alpha, nu)`` for nu = 0..3, continuous up to h''' everywhere) in the
table's own angle frame, with a ``LobeInfo`` (``law.lobe``) saying what was done and
what the rows could not tell. The rules (docs/methods.md, "One table, one lobe"):

* **frame**: a table over the whole turn is turned so that the seam (+-180 deg) lies
  in the middle of its longest base-circle run (a lobe across +-180 deg is not cut);
  one with no base-circle run (an eccentric) is periodic, its lowest row at the seam.
  Angles of the law are those of the table (the turn is undone), continuous across the
  lobe, in the turn of the table's first row (``lobe_frame``): the lobe's middle
  (halfway between where it passes half its max lift) lies in [first row, first row +
  360 deg), one within ``SEAM_TOL_STEPS`` row steps below the end of that turn at the
  first row. So a -180..180 deg table with its nose at 180 deg has the nose at -180
  deg and its events on both sides of it (-219 .. -141 deg), a 0..360 deg table with
  its nose at 0/360 deg the nose at 0 deg, one with its nose at 200 deg the nose at 200
  deg, on every route that reads a table (card, dynamics, reconstruct's lobe law); a
  scene's lobe is told from its centreline, in (-180, 180] (``turn_from``).
* **smoothing**: the rows are interpolated (quintic spline through every row) when
  their scatter about a smooth curve is no more than their rounding explains and the
  rounding, carried through the interpolant, stays below ``ROUNDING_ACC_SHARE`` of the
  lobe's peak h''; otherwise they are smoothed by the reconstruction spline by
  ``LEVEL_CRITERION`` (modified GCV; known noise: the rounding's q/sqrt(12), or none).
  ``LobeInfo.fit`` keeps what was done: a replica (``fit=``) is fitted the same way.
* **lobe ends**: the lobe is the run of the curve above the base-circle level
  ``tau`` around the highest row; at each end it is joined to the base circle by a
  degree-7 Hermite segment from (h, h', h'', h''') = 0 to the curve's values (never a
  lift step), over the angle 2 h/h' a constant-velocity ramp would take.
* a table that starts or ends mid-lobe (no base-circle row before or after the lobe)
  is joined the same way, with a warning; above ``MID_LOBE_LIMIT`` of the max lift it
  is refused. Several lobes: the highest is taken, the others named in a warning.
* results no cam can have are refused: a max lift above every row by more than the
  noise, a peak acceleration far above what the lobe's lift and duration allow
  (``lobe_checks``, which also gives the law's warnings).

The engine (``reconstruction.spline``) is called through its public entry points only.
This module belongs with the engine; both should move to a pure-numerics package of
cam_design together.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cam_design.errors import InputError
from cam_design.lift_laws.base import LiftLaw
from cam_design.lift_laws.jet_table import JetTableLift
from cam_design.lift_table.lobe_checks import law_checks
from cam_design.lift_table.lobe_joins import JOIN_MIN_DEG, Curve, join, lobe_edge
from cam_design.lift_table.lobe_frame import (BASE_MIN_DEG, BASE_OFFSET_M, TWO_PI, base_level,
                                              lobe_middle, lobe_turn, part_turn_centre,
                                              seam_frame)
from cam_design.lift_table.noise import BaseNoise, base_circle_noise
from cam_design.lift_table.samples import clean_samples, wrap_pi
from cam_design.lift_table.table_fit import LEVEL_CRITERION, TableFit

if TYPE_CHECKING:
    from cam_design.lift_table.rebound import Fairing

#: largest step [deg] of the grid on which the lobe's jets are tabulated for the
#: degree-7 Hermite law (a divisor of the table step, so that every row is a node)
GRID_DEG = 0.1
#: lifts below this share of the lift range are base circle even in exact rows
BASE_LEVEL_REL = 1e-9
#: fewer rows than this are interpolated: noise cannot be told from shape
JUDGE_ROWS = 24
#: rows scatter at most this many times the rounding's q/sqrt(12): "only rounded"
SCATTER_RATIO = 1.5
#: rows scattering less than this share of the lift range are exact (8 nm on 8 mm)
EXACT_SCATTER_REL = 1e-6
#: interpolate a rounded table only while its rounding carried into h'' (ROUNDING_GAIN
#: q/sqrt(12)/step^2) stays below this share of the lobe's peak |h''|
ROUNDING_ACC_SHARE = 0.02
#: std of the quintic interpolant's h'' at unit white noise on unit steps (measured on
#: 1e4 rows of unit noise: 9.7 at the rows, up to 11 between; the larger is used)
ROUNDING_GAIN = 11.0
#: the misfit of a smooth shape grows at least this much when the step doubles (the
#: engine's estimate on exact tables of ramped, cycloidal and harmonic lobes at
#: 0.5-5 deg: 14 to 1e9; on noisy tables 0.7 to 1.7)
SHAPE_GROWTH = 8.0
#: repeated rows differing by more than this share of the lift range are refused
REPEAT_SPREAD = 0.01
#: a table starting / ending above this share of its max lift is refused
MID_LOBE_LIMIT = 0.5
#: a mid-lobe join longer than this share of the lobe between the joins is refused (the
#: table ends on a flat stretch off 0, where no join from the base circle fits)
MID_JOIN_MAX = 1.0
#: inch gauges round to 0.0001 in: a quantum in inches [m per in]
INCH = 0.0254


@dataclass
class LobeInfo:
    """What ``lobe_law`` did with a table. Angles [rad], lengths [m].

    ``method``: 'interpolated' or 'smoothed'; ``why``: the sentence behind it;
    ``sigma``: the noise the rows carry (rounding or estimate); ``quantum``: the
    rounding step q (0: not rounded); ``offset``: the turn applied to the rows (frame:
    lobe-frame angle + offset = table angle, in (-pi, pi]); ``shift``: the whole turns
    [rad] added to that so that the lobe lies in the turn of the table's first row
    ``first`` [rad] (``lobe_turn``; ``law_offset`` = offset + shift); ``middle``: the
    lobe's middle in the law's angles [rad] (``lobe_middle``);
    ``periodic``: no base circle (an eccentric); ``joins``: (start, end) of the join
    before and after the lobe (None: the lobe runs out to the table's own rows);
    ``mid_lobe``: 'start' / 'end' where the table has no base-circle row;
    ``rows``: the rows as given (alpha, lift) for replicas; ``rec``: the engine's
    Reconstruction when smoothed; ``base_noise``: the base circle's noise when it is
    correlated row to row (its spread is then the noise the rows were smoothed with);
    ``base``: the base circle's lift in the rows [m], taken off them (0: at zero);
    ``fit``: how the law was fitted (``TableFit``), what a replica repeats."""

    key: str
    method: str
    why: str
    sigma: float
    quantum: float
    step: float
    offset: float
    periodic: bool
    level: float
    joins: list[tuple[float, float] | None] = field(default_factory=list)
    mid_lobe: tuple[str, ...] = ()
    warnings: list[str] = field(default_factory=list)
    rows: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None
    rec: object = None
    steps: list[str] = field(default_factory=list)
    first: float | None = None
    shift: float = 0.0
    middle: float | None = None
    base_noise: BaseNoise | None = None
    base: float = 0.0
    fit: TableFit = TableFit('interpolated')

    @property
    def law_offset(self) -> float:
        """Lobe-frame angle + this = the law's angle [rad] (the turn off the seam and
        the whole turns that put the lobe in the table's turn)."""
        return self.offset + self.shift

    def note(self) -> str:
        """One sentence for a route's output: how the table became the lobe."""
        return (f'{self.key}: lobe law from a table every {math.degrees(self.step):.3g} deg, '
                f'{self.method} ({self.why})'
                + (f'; lifts quantised to {self.quantum * 1e3:g} mm' if self.quantum else '')
                + ('; periodic (no base circle)' if self.periodic else
                   '; runs out to the table\'s base-circle rows' if not any(self.joins) else
                   '; joined to the base circle with zero lift, velocity, acceleration and '
                   'jerk at ' + ', '.join(
                       f'{math.degrees(j[0] + self.law_offset):.2f}..'
                       f'{math.degrees(j[1] + self.law_offset):.2f} deg'
                       for j in self.joins if j))
                + (f'; rows turned by {math.degrees(self.offset):.1f} deg to keep the lobe '
                   'off the +-180 deg seam (angles reported in the table frame, the lobe '
                   'in the turn of the first row)'
                   if self.offset else '')
                + ''.join(f'; {s}: lifts, velocities and events near it are the law\'s '
                          'bridge over the step, not the cam' for s in self.steps))


class TableLobe(LiftLaw):
    """The lobe law of a table (``lobe_law``): pieces (lo, hi, f) in the lobe frame
    [rad] (the joins to the base circle and, between them, the curve through or near
    the rows: the quintic interpolant or the engine's smoothing spline, evaluated as
    they are), C3 everywhere; angles of the table = lobe frame + ``offset``. A periodic
    law (an eccentric) is one piece over the turn, its lift measured from ``floor``.
    ``lobe`` (LobeInfo) says what was done, ``table`` (rows, q, sigma) and
    ``lobe.fit`` what a replica of the table needs."""

    continuity_order = 3
    lobe: LobeInfo
    table: tuple

    def __init__(self, pieces: list, offset: float, floor: float = 0.0) -> None:
        self._pieces = pieces
        self._offset = offset
        self._floor = floor

    @property
    def support(self) -> tuple[float, float]:
        return (self._pieces[0][0] + self._offset, self._pieces[-1][1] + self._offset)

    def _evaluate(self, alpha: NDArray[np.float64], nu: int) -> NDArray[np.float64]:
        x = alpha - self._offset
        out = np.zeros_like(x)
        for k, (lo, hi, f) in enumerate(self._pieces):
            last = k == len(self._pieces) - 1
            sel = (x >= lo) & ((x <= hi) if last else (x < hi))
            if np.any(sel):
                out[sel] = np.asarray(f(x[sel], nu), dtype=float)
        if nu == 0 and self._floor:
            out -= self._floor
        return out


def table_quantum(lift: ArrayLike) -> float:
    """The rounding step q [m] of lifts [m] rounded in mm or in inches (0: not rounded)."""
    from cam_design.lift_table.rebound import quantisation_step

    v = np.asarray(lift, dtype=float)
    # both: an inch quantum in m is also a (much finer) whole multiple of 1e-8 m
    return float(max(quantisation_step(v), INCH * quantisation_step(v / INCH)))


def _interpolant(b: NDArray[np.float64], h: NDArray[np.float64], periodic: bool) -> Any:
    """Quintic interpolating spline of the rows (periodic over the turn if asked)."""
    from scipy.interpolate import make_interp_spline

    if periodic:
        x = np.append(b, b[0] + TWO_PI)
        y = np.append(h, h[0])
        return make_interp_spline(x, y, k=5, bc_type='periodic')
    return make_interp_spline(b, h, k=5)


def _scatter(b: NDArray[np.float64], h: NDArray[np.float64]) -> tuple[float, Fairing]:
    """The scatter [m] of the rows about a smooth curve: the engine's noise estimate
    less the part of it that is the lobe's shape. The shape's share is judged from the
    estimate of every second row: noise per row does not grow with the step, the misfit
    of a smooth shape grows as a power of it (at least ``SHAPE_GROWTH`` times when the
    step doubles, on every lobe tried), so scatter^2 = full^2 - (half/SHAPE_GROWTH)^2.
    Returns (scatter, the engine's fairing of all the rows, for the engine to reuse)."""
    from cam_design.lift_table.rebound import rebound_fairing, rebound_noise

    fairing = rebound_fairing(b, h)
    full = float(fairing.sigma)
    if b.size < 24 or full <= 0.0:
        return max(full, 0.0), fairing
    # of the halves only the noise estimate is needed, not their fairing
    half = min(float(rebound_noise(b[0::2], h[0::2])), float(rebound_noise(b[1::2], h[1::2])))
    return math.sqrt(max(full ** 2 - (half / SHAPE_GROWTH) ** 2, 0.0)), fairing


def _grid_step(step: float) -> float:
    g = math.radians(GRID_DEG)
    return step / max(1, math.ceil(step / g - 1e-9))


def lobe_law(alpha: ArrayLike, lift: ArrayLike, *, key: str = 'table',
             allow_steps: bool = False, noise: float | None = None,
             turn_from: float | None = None, fit: TableFit | None = None) -> TableLobe:
    """The lobe law of a lift table, ``alpha`` [rad] (any frame), ``lift`` [m] (module
    doc for the rules). InputError naming ``key`` when the rows cannot define a lobe.

    A lift step between two rows (a ramp cut off, a velocity step at the base circle) is
    an impact no lobe law drawn through the rows can give: refused unless
    ``allow_steps`` (a cam card, whose events away from the step are still right; the
    note then names the step). ``noise`` [m]: the rows' noise when the caller knows it
    (a replica of a table with a drawn noise), instead of the estimate. ``turn_from``
    [rad]: the start of the turn the lobe is told in (``lobe_frame.lobe_turn``), when not
    the table's first row (a scene's lobe: -pi, its angles from the lobe centreline
    wrapped to (-180, 180] deg, whatever turn a nominal file is written in). ``fit``:
    the ``TableFit`` of the table this is a replica of: the rows are fitted as it was,
    not judged again."""
    from cam_design.lift_table.samples import find_steps, step_warnings
    from cam_design.lift_table.spline import SplineOptions, reconstruct_spline

    raw_a = np.asarray(alpha, dtype=float).reshape(-1)
    raw_h = np.asarray(lift, dtype=float).reshape(-1)
    ok = np.isfinite(raw_a)
    lo_a, hi_a = (float(np.min(raw_a[ok])), float(np.max(raw_a[ok]))) if ok.any() else (0, 0)
    centre = part_turn_centre(raw_a)
    clean = (raw_a.size >= 6 and bool(np.all(np.isfinite(raw_a)))
             and bool(np.all(np.isfinite(raw_h))) and bool(np.all(np.diff(raw_a) > 1e-9))
             and -math.pi - 1e-12 <= lo_a and hi_a <= math.pi + 1e-12)
    if clean:   # rows as given (a design table over [-pi, pi] keeps both end rows)
        notes: list[str] = []
        a0, h = raw_a.copy(), raw_h.copy()
    else:
        data = clean_samples(raw_a - centre, raw_h, key=key, min_points=6)
        notes = [n for n in data.notes if not n.startswith('wrapped')]
        _check_repeats(raw_a - centre, raw_h, notes, key)
        a0, h = data.alpha + centre, data.lift
    top_row = float(np.max(h))
    if not top_row > 0:
        raise InputError(f'{key}.lift', f'largest lift {top_row:g} m',
                         'a lobe: lifts above the base circle (0)')
    step = float(np.median(np.diff(a0)))
    q = table_quantum(h)
    sigma_q = q / math.sqrt(12.0)
    span = float(np.ptp(h))
    fairing: Fairing | None = None
    base_noise = None   # the base circle's noise, when correlated row to row
    if noise is None:
        scatter, fairing = _scatter(a0, h)
        found = base_circle_noise(h, q)
        if found is not None and found.correlated and found.sigma > scatter:
            # neighbouring rows cannot see a noise they share: the base circle's spread
            # is the rows' noise (else a noisy base circle is no base circle at all)
            base_noise, scatter, fairing = found, found.sigma, None
        noise = scatter
    else:
        scatter = noise = float(noise)
    whole = a0[-1] - a0[0] >= TWO_PI - 1.5 * step
    offset, periodic = seam_frame(a0, h, step, max(2.0 * q, 8.0 * noise, 1e-4 * span, 1e-6))
    if (offset or periodic) and a0[-1] - a0[0] >= TWO_PI - 1e-9:
        # a closed turn (-180..180, 0..360 deg): its last row is its first row again,
        # which the turn would put on the same angle: one row, their mean
        _check_repeats(a0, h, notes, key)
        notes.append(f'merged the row at {math.degrees(a0[-1]):g} deg into the one at '
                     f'{math.degrees(a0[0]):g} deg (the same angle; lifts '
                     f'{h[0] * 1e3:.4g} and {h[-1] * 1e3:.4g} mm, their mean kept)')
        h = np.concatenate([[0.5 * (h[0] + h[-1])], h[1:-1]])
        a0 = a0[:-1]
    b = wrap_pi(a0 - offset) if offset else a0
    if periodic:   # the turn [-pi, pi) from the lowest row
        b = np.mod(a0 - offset + math.pi, TWO_PI) - math.pi
    if offset or periodic:
        order = np.argsort(b, kind='stable')
        b, h = b[order], h[order]
    said: list[str] = []
    base = 0.0
    if periodic:   # lift from the lowest row: the base circle of an eccentric
        h = h - float(np.min(h))
    elif whole and (bottom := base_level(h, step)) is not None and \
            abs(bottom[0]) > max(3.0 * max(noise, sigma_q), 0.5 * q, BASE_OFFSET_M):
        # lift is measured from the base circle (a probe zeroed elsewhere, a drifted
        # trace): the lobe, its joins, every height and the dynamics' lash are there
        base = bottom[0]
        h = h - base
        said.append(f'the base circle is at {base * 1e3:+.4f} mm, not 0 (median of the '
                    f'{bottom[1]} rows at the bottom of the table: the probe zeroed '
                    'elsewhere?): lifts are measured from the base circle, max lift above '
                    f'it {float(np.max(h)) * 1e3:.4f} mm, and the checking heights and the '
                    "valve train's lash are taken from it")
    floor = max(SCATTER_RATIO * sigma_q, EXACT_SCATTER_REL * span)
    steps = [w.split(':')[0] for w in
             step_warnings(find_steps(b, h, max(noise, sigma_q, 1e-9 * span)))]
    if steps and not allow_steps:
        raise InputError(key, f'{b.size} points',
                         f'a table without steps ({steps[0]}; a velocity step is an impact '
                         'the dynamics cannot take from a table): tabulate the ramp finer '
                         'or give the lift law')
    method = 'interpolated' if fit is None else fit.method
    if fit is not None:
        why = f'fitted as its table was ({fit.text()})'
    elif b.size < JUDGE_ROWS:
        why = (f'{b.size} rows, too few to tell noise from shape (at least {JUDGE_ROWS}): '
               'quintic interpolant through every row')
    elif scatter > floor:
        why = (f'rows scatter {scatter * 1e6:.3g} um about a smooth curve, more than their '
               f'rounding explains ({floor * 1e6:.3g} um)')
        method = 'smoothed'
    # the rows' quintic interpolant: built only for a table that may keep it (a smoothed
    # table gets the smoothing spline below)
    curve: Curve | None = _interpolant(b, h, periodic) if method == 'interpolated' else None
    if curve is not None and b.size >= JUDGE_ROWS and fit is None:
        dense = np.linspace(b[0], b[-1] + (TWO_PI - (b[-1] - b[0]) if periodic else 0.0),
                            4001)
        peak_acc = float(np.max(np.abs(curve(dense, 2))))
        carried = ROUNDING_GAIN * sigma_q / step ** 2
        if carried > ROUNDING_ACC_SHARE * peak_acc:
            why = (f'rounding to {q * 1e3:g} mm at a {math.degrees(step):.3g} deg step would '
                   f'carry {carried:.3g} m/rad^2 into h\'\' ({carried / peak_acc * 100:.0f} % '
                   f'of the peak; at most {ROUNDING_ACC_SHARE * 100:g} % interpolated)')
            method = 'smoothed'
        else:
            why = ('exact rows' if not q else f'rows only rounded (to {q * 1e3:g} mm)') + \
                ': quintic interpolant through every row'
    rec = None
    sigma = sigma_q if method == 'interpolated' else max(scatter, sigma_q)
    known: float | None = None
    if method == 'smoothed':
        known = ((base_noise.sigma if base_noise else sigma_q if scatter <= floor else None)
                 if fit is None else fit.known)
        # GCV takes noise the rows share for shape (it needs independent errors): such
        # rows go by the acceleration risk with the base circle's spread as their noise
        correlated = base_noise is not None if fit is None else fit.correlated
        criterion = (fit.criterion if fit is not None else None) or (
            'risk' if correlated else LEVEL_CRITERION)

        def smooth(how: str) -> tuple[Any, Curve]:
            """(Reconstruction, curve) of the rows smoothed by the criterion ``how``."""
            if periodic:
                return _periodic_smooth(b, h, known, how)
            # the engine works in (-pi, pi]: a part-turn table beyond it (118..242 deg)
            # is fitted about its own middle and moved back
            mid = 0.5 * (float(b[0]) + float(b[-1]))
            rows = clean_samples(b - mid, h, key=key, min_points=6)
            # the fairing the scatter estimate made is the engine's own when the engine
            # gets the same rows (none merged or re-ordered) with the estimated noise
            # (not after a turn: the fairing was made of the rows in their first order)
            same = (fairing is not None and known is None and not offset
                    and rows.alpha.size == b.size and bool(np.all(rows.lift == h)))
            fitted = reconstruct_spline(rows, options=SplineOptions(
                criterion=how, sigma=known, correlated_noise=correlated),
                fairing=fairing if same else None)
            return fitted, _Evaluated(fitted.evaluate, mid)
        rec, curve = smooth(criterion)
        limit = max(5.0 * sigma_q, 1e-3 * span, 5.0 * noise)
        if rec.rms_residual > limit and fit is None and criterion != 'risk':
            # GCV's level misses the rows by more than their noise allows (a coarse
            # table of a sharp lobe, 37 rows of a narrow peak): the level of the least
            # estimated acceleration error with that noise, which keeps to the rows
            missed = float(rec.rms_residual)
            rec, curve = smooth('risk')
            criterion = 'risk'
            why += (f'; {LEVEL_CRITERION} missed the rows by {missed:.3g} m rms, more than '
                    f'their noise allows ({limit:.3g} m): level by the acceleration risk')
        sigma = max(float(rec.sigma), sigma_q)
        why += f'; smoothed by the reconstruction spline ({rec.why})'
        if rec.rms_residual > limit:
            raise InputError(key, f'{b.size} points',
                             'a table fine enough to define the lobe: the reconstruction '
                             f'spline misses its rows by {rec.rms_residual:.3g} m rms (more '
                             f'than {limit:.3g} m' + (f'; {"; ".join(notes)}' if notes else '')
                             + '): tabulate more points')
    tau = max(3.0 * sigma, 0.5 * q, BASE_LEVEL_REL * span)
    info = LobeInfo(key=key, method=method, why=why, sigma=sigma, quantum=q, step=step,
                    offset=offset, periodic=periodic, level=tau, rec=rec,
                    rows=(raw_a.copy(), raw_h.copy()), steps=steps,
                    first=lo_a if turn_from is None else float(turn_from),
                    base_noise=base_noise, base=base,
                    fit=TableFit('smoothed', criterion, known, correlated) if rec is not None
                    else TableFit('interpolated'))
    assert curve is not None        # the interpolant, or the smoothing spline above
    law = _build(curve, b, h, info)
    info.warnings.extend(said + notes_warning(notes))
    return law


def lobe_from_jets(alpha: ArrayLike, jets: ArrayLike, *, key: str = 'profile') -> TableLobe:
    """The lobe law of a reconstructed profile: ``jets`` (4, n) of the lift and its
    first three derivatives [m, m/rad^k] on ``alpha`` [rad] (a reconstruction's grid:
    already smooth), by the same frame and lobe-end rules as ``lobe_law``; the
    base-circle level is 3 x the ripple of its base circle (the rows within 1 % of
    the lift range of the lowest whose slope is below 0.1 % of the largest, when they
    span ``BASE_MIN_DEG``)."""
    a = np.asarray(alpha, dtype=float).reshape(-1)
    j = np.asarray(jets, dtype=float)
    curve = JetTableLift(a, j, key=key, trim=-1.0)
    h = j[0]
    step = float(np.median(np.diff(a)))
    offset, periodic = seam_frame(a, h, step, max(1e-4 * float(np.ptp(h)), 1e-6))
    if offset or periodic:
        # a lobe across the seam of the profile's grid: its lift rows, re-framed
        return lobe_law(a, h, key=key)
    span = float(np.ptp(h))
    # the base circle, if the grid has one: low and flat (a ramp is low, not flat)
    low = (h <= 0.01 * span + float(np.min(h))) & (np.abs(j[1]) <= 1e-3 * np.max(np.abs(j[1])))
    ripple = (float(np.std(h[low])) if np.count_nonzero(low) * step >= math.radians(
        BASE_MIN_DEG) else 0.0)
    info = LobeInfo(key=key, method='reconstructed', why="a reconstruction's jets",
                    sigma=ripple, quantum=0.0, step=step, offset=0.0, periodic=False,
                    level=max(3.0 * ripple, EXACT_SCATTER_REL * span), first=float(a[0]))
    return _build(_Evaluated(curve), a, h, info)


def _build(curve: Curve, b: NDArray[np.float64], h: NDArray[np.float64], info: LobeInfo
           ) -> TableLobe:
    """The TableLobe of ``curve`` (callable (x, nu)) fitted to rows ``b`` [rad], ``h``
    [m] in the lobe frame, by the lobe-end rule; checks filled into ``info``."""
    if info.periodic:
        x = np.linspace(b[0], b[0] + TWO_PI, 7201)
        floor = float(np.min(np.asarray(curve(x, 0), dtype=float)))
        law = TableLobe([(float(b[0]), float(b[0]) + TWO_PI, curve)], info.offset, floor)
    else:
        law = TableLobe(_lobe_pieces(curve, b, h, info.level, info.step,
                                     _grid_step(info.step), info), info.offset)
    # the one frame of every route: the lobe in the turn of the table's first row
    grid = np.linspace(*law.support, 8001)
    lift = law(grid, 0)
    middle = lobe_middle(grid, lift)
    if info.first is not None:
        info.shift = lobe_turn(middle, info.first, info.step)
        law._offset = info.law_offset
    info.middle = middle + info.shift
    law.lobe = info
    rows = info.rows or (b, h)
    law.table = (rows[0], rows[1], info.quantum or None, info.sigma)
    info.warnings.extend(law_checks(law, b, h, info, (grid + info.shift, lift)))
    return law


def notes_warning(notes: list[str]) -> list[str]:
    """What the row cleaning did, as one warning (or none)."""
    return ['rows: ' + '; '.join(notes)] if notes else []


def _check_repeats(a: NDArray[np.float64], h: NDArray[np.float64], notes: list[str],
                   key: str) -> None:
    """Refuse rows repeated at one angle whose lifts differ by more than
    ``REPEAT_SPREAD`` of the lift range (and 20 um): a row pasted from elsewhere, which
    averaging would hide."""
    ok = np.isfinite(a) & np.isfinite(h)
    w = np.asarray(wrap_pi(a[ok]), dtype=float)
    v = h[ok]
    order = np.argsort(w, kind='stable')
    w, v = w[order], v[order]
    same = np.flatnonzero(np.diff(w) <= 1e-9)
    if same.size == 0:
        return
    gap = np.abs(v[same + 1] - v[same])
    worst = int(np.argmax(gap))
    if gap[worst] > max(REPEAT_SPREAD * float(np.ptp(v)), 20e-6):
        raise InputError(key, f'rows at {math.degrees(float(w[same[worst]])):.3f} deg with '
                         f'lifts {v[same[worst]] * 1e3:.4g} and '
                         f'{v[same[worst] + 1] * 1e3:.4g} mm',
                         'one lift per angle (' + '; '.join(notes) + '): mend the '
                         'repeated rows')


#: a periodic table is smoothed over 1 + 2 x this share of a turn, compressed by
#: PERIODIC_SCALE into the engine's (-pi, pi]; the middle turn is kept
PERIODIC_PAD = 0.25
PERIODIC_SCALE = 0.6


def _periodic_smooth(b: NDArray[np.float64], h: NDArray[np.float64], sigma: float | None,
                     criterion: str) -> tuple[Any, Curve]:
    """(Reconstruction, curve) of a whole-turn table without a base circle: the rows
    repeated a quarter turn beyond each end (so the fit has no free end on the turn)
    and smoothed (by ``criterion``, known noise ``sigma`` [m] or None) in the variable
    s = PERIODIC_SCALE x alpha; the curve undoes the change of variable
    (d^nu/dalpha^nu = PERIODIC_SCALE^nu d^nu/ds^nu)."""
    from cam_design.lift_table.spline import SplineOptions, reconstruct_spline

    pad = PERIODIC_PAD * TWO_PI
    x = np.concatenate([b[b >= b[-1] - pad] - TWO_PI, b, b[b <= b[0] + pad] + TWO_PI])
    y = np.concatenate([h[b >= b[-1] - pad], h, h[b <= b[0] + pad]])
    centre = 0.5 * (x[0] + x[-1])
    k = PERIODIC_SCALE
    rec = reconstruct_spline(k * (x - centre), y,
                             SplineOptions(criterion=criterion, sigma=sigma,
                                           expected_sign_changes=None))

    def curve(a: ArrayLike, nu: int = 0) -> NDArray[np.float64]:
        s = k * (np.asarray(a, dtype=float) - centre)
        return np.asarray(rec.evaluate(s, nu), dtype=float) * k ** nu

    return rec, curve


class _Evaluated:
    """A Reconstruction's ``evaluate`` (fitted in angles less ``shift`` [rad]) as
    ``curve(x, nu)`` in the table's angles."""

    def __init__(self, evaluate: Curve, shift: float = 0.0) -> None:
        self._f = evaluate
        self._shift = shift

    def __call__(self, x: ArrayLike, nu: int = 0) -> NDArray[np.float64]:
        return np.asarray(self._f(np.asarray(x, dtype=float) - self._shift, nu), dtype=float)


def _lobe_pieces(curve: Curve, b: NDArray[np.float64], h: NDArray[np.float64], tau: float,
                 step: float, g: float, info: LobeInfo) -> list:
    """The pieces (lo, hi, f) of the lobe: the join before it, the curve, the join
    after it (the grid of step ``g`` [rad] serves to find the edges)."""
    x = np.arange(int(math.floor((b[-1] - b[0]) / g + 1e-9)) + 1) * g + b[0]
    x = np.unique(np.concatenate([x[x < b[-1]], b[-1:]]))   # the last row is a node
    y = np.asarray(curve(x, 0), dtype=float)
    top = int(np.argmax(y))
    min_width = max(0.5 * step, math.radians(JOIN_MIN_DEG))
    lo, w_lo, mid_lo = lobe_edge(curve, x, y, b, top, tau, -1, min_width)
    hi, w_hi, mid_hi = lobe_edge(curve, x, y, b, top, tau, +1, min_width)
    peak = float(y[top])
    mids = []
    for name, at, width, mid in (('start', lo, w_lo, mid_lo), ('end', hi, w_hi, mid_hi)):
        level = float(curve(at, 0))
        if mid:
            mids.append(name)
        if level > MID_LOBE_LIMIT * peak or not math.isfinite(width):
            raise InputError(info.key, f'a table that {name}s at {level * 1e3:.4g} mm '
                             f'({level / peak * 100:.0f} % of its max lift)',
                             f'rows down to the base circle at its {name} (or below '
                             f'{MID_LOBE_LIMIT * 100:.0f} % of the lift, joined to it): '
                             'give the whole lobe')
        if mid and width > MID_JOIN_MAX * (hi - lo):
            # a flat stretch off 0 at the table's end (h' about 0: the join to the base
            # circle would span more than the lobe itself)
            raise InputError(info.key, f'a table that {name}s on a flat stretch at '
                             f'{level * 1e3:.4g} mm',
                             'rows down to the base circle, or lifts measured from it (a '
                             'base circle off 0 is taken off only on a whole-turn table): '
                             'subtract the base-circle level or give the whole turn')
    info.mid_lobe = tuple(mids)
    ends = np.stack([np.asarray(curve(np.array([lo, hi]), nu), dtype=float)
                     for nu in range(4)])
    # rows interpolated down to their own base-circle rows: the lobe runs out to the
    # table's end rows (the interpolant through zeros is the base circle); else (and at
    # a mid-lobe end) the join
    run_lo = info.method == 'interpolated' and not mid_lo
    run_hi = info.method == 'interpolated' and not mid_hi
    # the base-circle rows next to the lobe (not the table's ends: another lobe may lie
    # beyond them)
    before, after = b[(b <= lo) & (h <= tau)], b[(b >= hi) & (h <= tau)]
    run_lo, run_hi = run_lo and before.size > 0, run_hi and after.size > 0
    info.joins[:] = [None if run_lo else (lo - w_lo, lo), None if run_hi else (hi, hi + w_hi)]
    start = float(before[-1]) if run_lo else lo
    stop = float(after[0]) if run_hi else hi
    pieces = [] if run_lo else [(lo - w_lo, lo, join(lo, w_lo, ends[:, 0], -1))]
    pieces.append((start, stop, curve))
    if not run_hi:
        pieces.append((hi, hi + w_hi, join(hi, w_hi, ends[:, 1], 1)))
    return pieces
