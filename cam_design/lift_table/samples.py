"""Lift-table rows as numbers: the ``LiftTable`` and ``CleanSamples`` records, row
cleaning, and the checks and warnings read from the rows themselves.

A ``LiftTable`` holds alpha [rad] from the lobe centreline, lift [m] above the base
circle and optionally the design lift [m] for the same follower. ``clean_samples``
drops non-finite rows (counted), wraps angles to (-pi, pi], sorts them and merges
repeated angles (several turns of the shaft) into their mean. The magnitude checks
(``check_lift_magnitude``, ``check_angle_magnitude``) tell a wrong unit from the values;
``find_steps`` and the ``*_warning`` functions say what the rows could not tell.
Reading the rows from files and messages is the reader's business, not this module's.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cam_design.errors import InputError

ANGLE_UNITS = {'rad': 1.0, 'deg': math.pi / 180.0}
LENGTH_UNITS = {'m': 1.0, 'mm': 1.0e-3, 'um': 1.0e-6}


@dataclass(frozen=True)
class LiftTable:
    """A measured (or nominal) lift table of one feature, SI units.

    ``alpha`` [rad] from the lobe centreline, ``lift`` [m] above the base circle, as
    seen by ``follower`` (kind, radius [m]) when known; ``design`` [m] the design lift
    for the same follower at the same angles, or None.
    """

    feature: str
    alpha: NDArray[np.float64]
    lift: NDArray[np.float64]
    design: NDArray[np.float64] | None = None
    follower: tuple[str, float] | None = None
    source: str = ''
    notes: tuple[str, ...] = ()


@dataclass(frozen=True)
class CleanSamples:
    """Samples ready for fitting: strictly increasing ``alpha`` [rad], ``lift`` [m]
    (means over repeated angles), ``count`` samples merged into each point."""

    alpha: NDArray[np.float64]
    lift: NDArray[np.float64]
    count: NDArray[np.int64]
    dropped_nonfinite: int = 0
    merged_repeats: int = 0
    wrapped: int = 0
    notes: tuple[str, ...] = field(default_factory=tuple)

    @property
    def step(self) -> float:
        """Median angular spacing [rad] of the samples."""
        return float(np.median(np.diff(self.alpha)))


def wrap_pi(alpha: ArrayLike) -> NDArray[np.float64]:
    """Angles [rad] wrapped to (-pi, pi]."""
    a = np.asarray(alpha, dtype=float)
    out = np.pi - np.mod(np.pi - a, 2.0 * np.pi)
    return out


def wrap_from(alpha: ArrayLike, start: float) -> NDArray[np.float64]:
    """Angles [rad] wrapped to the turn (start, start + 2 pi] (``wrap_pi``: start -pi)."""
    a = np.asarray(alpha, dtype=float)
    top = start + 2.0 * np.pi
    return top - np.mod(top - a, 2.0 * np.pi)


def clean_samples(alpha: ArrayLike, lift: ArrayLike, *, key: str = 'table',
                  min_points: int = 8) -> CleanSamples:
    """Drop non-finite rows, wrap to (-pi, pi], sort, merge repeated angles.

    Angles closer than 1e-9 rad are treated as repeats and averaged. Raises
    InputError if fewer than ``min_points`` distinct finite angles remain.
    """
    a = np.asarray(alpha, dtype=float).reshape(-1)
    h = np.asarray(lift, dtype=float).reshape(-1)
    if a.size != h.size:
        raise InputError(f'{key}.lift', f'{h.size} values', f'as many as alpha ({a.size})')
    finite = np.isfinite(a) & np.isfinite(h)
    dropped = int(a.size - np.count_nonzero(finite))
    bad = np.flatnonzero(~finite)
    where = ''
    if bad.size:   # name the first: its place in the input and its angle when it has one
        j = int(bad[0])
        where = (f' (the first: sample {j + 1}'
                 + (f' at {math.degrees(float(a[j])):.6g} deg' if np.isfinite(a[j]) else '')
                 + ')')
    a, h = a[finite], h[finite]
    notes = []
    if dropped:
        notes.append(f'dropped {dropped} non-finite sample(s){where}')
    outside = (a <= -np.pi) | (a > np.pi)
    wrapped = int(np.count_nonzero(outside))
    if wrapped:
        a = wrap_pi(a)
        notes.append(f'wrapped {wrapped} angle(s) to (-180, 180] deg')
    order = np.argsort(a, kind='stable')
    a, h = a[order], h[order]
    if a.size:
        new = np.concatenate([[True], np.diff(a) > 1e-9])
        groups = np.cumsum(new) - 1
        count = np.bincount(groups)
        a_u = np.bincount(groups, weights=a) / count
        h_u = np.bincount(groups, weights=h) / count
    else:
        count, a_u, h_u = np.zeros(0, dtype=np.int64), a, h
    merged = int(a.size - a_u.size)
    if merged:
        spread = (np.maximum.reduceat(h, np.flatnonzero(new))
                  - np.minimum.reduceat(h, np.flatnonzero(new)))
        # among the merged angles only (an angle of one sample has spread 0 too)
        worst = int(np.argmax(np.where(count > 1, spread, -1.0)))
        notes.append(f'merged {merged} sample(s) at repeated angles into their mean (largest '
                     f'spread {spread[worst] * 1e3:.4g} mm at '
                     f'{math.degrees(float(a_u[worst])):.3f} deg)')
    if a_u.size < min_points:
        raise InputError(f'{key}.alpha', f'{a_u.size} distinct finite angles',
                         f'at least {min_points}')
    return CleanSamples(a_u, h_u, count.astype(np.int64), dropped, merged, wrapped,
                        tuple(notes))


HEADER_UNITS = {'m': 1.0, 'mm': 1.0e-3, 'um': 1.0e-6, 'in': 0.0254}
#: the crank shaft of a four-stroke engine turns twice per cam turn
CRANK_PER_CAM = 2.0
#: plausible cam lift range [m] (largest |lift| of a table): 20 um .. 250 mm
LIFT_PLAUSIBLE = (20e-6, 0.25)


def check_lift_magnitude(raw: NDArray[np.float64], scale: float, key: str, what: str,
                         fix: Any) -> None:
    """InputError when the lift, read as ``raw`` x ``scale`` [m], is implausible for a
    cam (largest |lift| outside ``LIFT_PLAUSIBLE``) while another length unit makes it
    plausible; the message names that unit (``fix(unit)`` says how to select it)."""
    v = np.abs(raw[np.isfinite(raw)])
    if v.size == 0:
        return
    top = float(np.max(v))
    lo, hi = LIFT_PLAUSIBLE
    if lo <= top * scale <= hi or top == 0:
        return
    likely = [u for u, f in HEADER_UNITS.items() if u != 'in' and lo <= top * f <= hi
              and f != scale]
    if top * scale > hi or likely:
        guess = min(likely, key=lambda u: abs(math.log10(top * HEADER_UNITS[u] / 8e-3))) \
            if likely else None
        hint = (f'the values look like {_UNIT_WORDS[guess]}: {fix(guess)}' if guess else
                'a cam lift below 250 mm')
        raise InputError(key, f'a largest lift of {top:g} {what} = {_si(top * scale)}',
                         f'a plausible cam lift (0.02 to 250 mm); {hint}')


_UNIT_WORDS = {'m': 'metres', 'mm': 'millimetres', 'um': 'micrometres', 'deg': 'degrees',
               'rad': 'radians'}


def _si(length: float) -> str:
    return f'{length:.4g} m' if length >= 1 else f'{length * 1e3:.4g} mm'


def check_angle_magnitude(raw: NDArray[np.float64], lift: NDArray[np.float64], unit: str,
                          role: str, key: str, what: str, fix: Any) -> None:
    """InputError when the angles read in ``unit`` cannot be right: degrees spanning
    less than 2 pi (radians, then), or more than one turn whose turns disagree
    (degrees read as radians, or crank degrees read as cam degrees). ``fix(unit,
    role)`` says how to select the likely reading."""
    ok = np.isfinite(raw) & np.isfinite(lift)
    a, h = raw[ok], lift[ok]
    if a.size < 8:
        return
    span = float(np.ptp(a))
    if unit == 'deg' and role == 'cam' and span <= 2.0 * math.pi + 1e-6 and \
            float(np.max(np.abs(a))) <= 2.0 * math.pi + 1e-6:
        raise InputError(key, f'angles spanning {span:.4g} {what}',
                         f'a lobe table over tens of degrees; the values look like radians: '
                         f'{fix("rad", "cam")}')
    scale = ANGLE_UNITS[unit] / (CRANK_PER_CAM if role == 'crank' else 1.0)
    if span * scale <= 2.0 * math.pi * (1.0 + 1e-3) + 1e-9 or _turns_agree(a * scale, h):
        return
    if unit == 'rad':
        hint = f'the values look like degrees: {fix("deg", "cam")}'
    elif role == 'cam' and span <= 2.0 * 360.0 * (1.0 + 1e-3):
        hint = f'the values look like crank degrees: {fix("deg", "crank")}'
    else:
        hint = 'one turn, or several turns that repeat the same lift'
    raise InputError(key, f'angles spanning {span:.4g} {what} ({span * scale / (2 * math.pi):.3g} '
                     'cam turns) whose turns disagree', f'angles within one cam turn; {hint}')


def _turns_agree(alpha: NDArray[np.float64], lift: NDArray[np.float64]) -> bool:
    """Do the turns of a table spanning more than one turn repeat the same lift (rms
    difference below 5 % of the lift range where they overlap)?"""
    order = np.argsort(alpha)
    a, h = alpha[order], lift[order]
    turn = np.floor((a - a[0]) / (2.0 * math.pi)).astype(int)
    first = turn == 0
    if np.count_nonzero(first) < 4:
        return False
    a0, h0 = a[first], h[first]
    rng = float(np.ptp(h)) or 1.0
    diffs = []
    for k in range(1, int(turn.max()) + 1):
        sel = turn == k
        w = a[sel] - 2.0 * math.pi * k
        inside = (w >= a0[0]) & (w <= a0[-1])
        if np.any(inside):
            diffs.append(h[sel][inside] - np.interp(w[inside], a0, h0))
    if not diffs:
        return True
    d = np.concatenate(diffs)
    return float(np.sqrt(np.mean(d ** 2))) <= 0.05 * rng


def centre_on_nose(table: LiftTable) -> tuple[LiftTable, float]:
    """Shift the table's angles so that alpha = 0 is the lobe's symmetry axis.

    The axis is the mean midpoint of the rise/fall crossings of lift levels at 20..80 %
    of the maximum (the flank form of docs/metrology.md; linear interpolation, adequate
    because |h'| is large there). Returns the shifted table and the shift [rad] that
    was subtracted. Raises InputError if the lift has no clear single maximum.
    """
    data = clean_samples(table.alpha, table.lift, key=table.feature)
    a, h = data.alpha, data.lift
    top = int(np.argmax(h))
    peak = float(h[top])
    base = float(np.percentile(h, 5))
    rng = peak - base
    if not rng > 0:
        raise InputError(f'{table.feature}.lift', 'a constant table', 'a lobe to centre')
    # put the maximum in the middle so that both flanks are contiguous
    a = wrap_pi(a - a[top])
    order = np.argsort(a)
    a, h = a[order], h[order]
    i0 = int(np.argmin(np.abs(a)))
    mids = []
    for level in base + rng * np.linspace(0.2, 0.8, 13):
        left = np.nonzero(h[:i0 + 1] <= level)[0]
        right = np.nonzero(h[i0:] <= level)[0]
        if left.size == 0 or right.size == 0:
            continue
        j, k = int(left[-1]), i0 + int(right[0])
        al = a[j] + (level - h[j]) * (a[j + 1] - a[j]) / (h[j + 1] - h[j])
        ar = a[k - 1] + (level - h[k - 1]) * (a[k] - a[k - 1]) / (h[k] - h[k - 1])
        mids.append(0.5 * (al + ar))
    if not mids:
        raise InputError(f'{table.feature}.lift', 'no flank crossings',
                         'a single lobe rising from and returning to the base circle')
    shift = float(wrap_pi(data.alpha[top] + np.mean(mids)))
    note = f'angles re-centred on the lobe axis: shifted by {math.degrees(shift):.4f} deg'
    design = table.design
    return (LiftTable(table.feature, wrap_pi(table.alpha - shift), table.lift, design,
                      table.follower, table.source, table.notes + (note,)), shift)


#: a step: one row-to-row change this many times the changes (per angle) next to it
STEP_RATIO = 4.0


def find_steps(alpha: NDArray[np.float64], lift: NDArray[np.float64], sigma: float
               ) -> list[tuple[int, float, float, float, float]]:
    """Steps of a lift table: (row index k, alpha_k, alpha_k+1 [rad], jump [m], largest
    neighbour change [m]) for each pair of consecutive rows whose slope is ``STEP_RATIO`` times
    the slopes on both sides and whose change exceeds 10 noise sigmas and 1 % of the
    lift range (a ramp cut off: 0 -> 0.5 mm between two rows), or that leaves the base
    circle (flat row before) by more than 5 % of the range and at least half the next
    row's slope. A spike changes by +d then -d and is not a step."""
    a = np.asarray(alpha, dtype=float)
    h = np.asarray(lift, dtype=float)
    if a.size < 4:
        return []
    dh = np.diff(h)
    slope = dh / np.diff(a)
    rng = float(np.ptp(h))
    s, d = np.abs(slope), np.abs(dh)
    none = np.array([-np.inf])
    s_l, s_r = np.concatenate([none, s[:-1]]), np.concatenate([s[1:], none])
    d_l, d_r = np.concatenate([none, d[:-1]]), np.concatenate([d[1:], none])
    dh_l = np.concatenate([[0.0], dh[:-1]])
    dh_r = np.concatenate([dh[1:], [0.0]])
    near = np.maximum(d_l, d_r)
    jump = (s > STEP_RATIO * np.maximum(s_l, s_r)) & (d - near > max(10.0 * sigma, 0.01 * rng))
    # leaving (or reaching) the base circle in one row: a lift that starts with a
    # continuous velocity rises at most 1/3 as much in its first row as in the
    # next (1:3 for constant h''); a cut ramp rises about as much
    flat = max(10.0 * sigma, 0.002 * rng)
    big = d > max(10.0 * sigma, 0.05 * rng)
    inner = np.zeros(d.size, dtype=bool)
    inner[1:-1] = True
    from_left = inner & (d_l <= flat) & big & (dh * dh_r > 0) & (s >= 0.5 * s_r)
    from_right = inner & (d_r <= flat) & big & (dh * dh_l > 0) & (s >= 0.5 * s_l)
    out: list[tuple[int, float, float, float, float]] = []
    for kk in np.flatnonzero(jump | from_left | from_right):
        k = int(kk)
        neighbour = float(near[k] if jump[k] else (d_l[k] if from_left[k] else d_r[k]))
        out.append((k, float(a[k]), float(a[k + 1]), float(dh[k]), neighbour))
    return out


def step_warnings(steps: list[tuple[int, float, float, float, float]]) -> list[str]:
    """One warning per step found by ``find_steps`` (at most 5, then a count)."""
    out = [f'lift jumps by {jump * 1e3:.4g} mm between the rows at {math.degrees(a0):.3f} '
           f'and {math.degrees(a1):.3f} deg (the row on the base-circle side, or the rows '
           f'next to them, change by at most {near * 1e3:.3g} mm): a step, e.g. a ramp '
           'cut off; the reconstruction interpolates it, so velocity and acceleration '
           'there are not the cam\'s'
           for _, a0, a1, jump, near in steps[:5]]
    if len(steps) > 5:
        out.append(f'{len(steps) - 5} more step(s) in the table')
    return out


def other_lobes_warning(alpha: ArrayLike, lift: ArrayLike) -> str | None:
    """A warning when a table holds more than one lobe: runs of lift above 10 % of the
    largest, around the turn, separated by base circle (below 2 %). Names the angle [deg]
    and height of each further lobe's top (a dual-peak lobe, whose valley stays above
    the base circle, is one lobe)."""
    a = np.asarray(alpha, dtype=float)
    h = np.asarray(lift, dtype=float)
    ok = np.isfinite(a) & np.isfinite(h)
    order = np.argsort(wrap_pi(a[ok]))
    a, h = wrap_pi(a[ok])[order], h[ok][order]
    if a.size < 8 or not float(np.max(h)) > 0:
        return None
    top = float(np.max(h))
    base = h <= 0.02 * top
    if not np.any(base):
        return None
    start = int(np.flatnonzero(base)[0])    # walk the turn from a base-circle row
    a, h, base = np.roll(a, -start), np.roll(h, -start), np.roll(base, -start)
    lobes: list[int] = []
    # the runs off the base circle; a lobe: 3 rows or more (not a spike), above 10 %
    edges = np.diff(np.concatenate([[0], (~base).astype(np.int8), [0]]))
    for first, end in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)):
        best = int(first) + int(np.argmax(h[first:end]))
        if end - first >= 3 and h[best] > 0.1 * top:
            lobes.append(best)
    if len(lobes) < 2:
        return None
    main = max(lobes, key=lambda k: h[k])
    others = ', '.join(f'{math.degrees(float(a[k])):.1f} deg ({h[k] * 1e3:.4g} mm)'
                       for k in lobes if k != main)
    return (f'the table holds {len(lobes)} lobes (or a lobe with a secondary lift off the '
            'base circle, e.g. for EGR): the numbers are of the highest (top at '
            f'{math.degrees(float(a[main])):.1f} deg); the others top at {others}: give '
            'each lobe its own table (or cut the table) to read them')


def nose_warning(data: CleanSamples, near: float | None = None) -> str | None:
    """A warning when alpha = 0 is not on the lobe (lift there below half the largest
    lift): the angles are not taken from the lobe centreline, which the section harmonic
    basis and every lobe-centred quantity assume. Names the lobe axis (flank
    midpoints; in the turn nearest ``near`` [rad], the lobe law's middle, when given:
    the frame every route states) and the option that re-centres a table file."""
    a, h = data.alpha, data.lift
    top = float(np.max(h))
    base = float(np.percentile(h, 5))
    if not top - base > 0:
        return None
    at_zero = float(np.interp(0.0, a, h)) if a[0] <= 0.0 <= a[-1] else base
    if at_zero - base >= 0.5 * (top - base):
        return None
    try:
        _, shift = centre_on_nose(LiftTable('table', a, h))
        if near is not None:
            shift += 2.0 * math.pi * round((near - shift) / (2.0 * math.pi))
        where = f'the lobe axis is at {math.degrees(shift):.2f} deg'
    except InputError:
        where = f'the largest lift is at {math.degrees(float(a[int(np.argmax(h))])):.2f} deg'
    return (f'alpha = 0 is not on the lobe ({where}; lift at 0 is '
            f'{(at_zero - base) / (top - base) * 100:.0f} % of the lobe height): the angles '
            'are not from the lobe centreline; re-centre the table (--center-nose, or '
            'shift the angles)')
