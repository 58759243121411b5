"""Measured lift tables: reading, unit handling and cleaning.

Three inputs end up as one ``LiftTable`` (alpha [rad] from the lobe centreline, lift
[m] above the base circle, optional design lift [m] for the same follower):

* a CSV file with a header naming the columns; the unit is part of each name
  (``alpha_rad`` | ``alpha_deg``; ``lift_m`` | ``lift_mm`` | ``lift_um``; optional
  ``design_lift_<unit>``);
* a nominal-profile file in the common gauge layout: line 1 the probe radius, line 2
  the number of angle steps, then one row per step ``angle lift [marker]`` (fields
  separated by blanks, commas, semicolons or tabs; decimal commas are read where they
  cannot be separators: ``12,5``, ``0,5;8,0000``). Gauges write degrees and
  millimetres: those are the defaults, overridable (``angle_unit``, ``length_unit``);
* a /metrology/lift table (Float64MultiArray with columns
  ``alpha_rad,lift_m,design_lift_m``).

``clean_samples`` then drops non-finite rows (counted), wraps angles to (-pi, pi],
sorts them and merges repeated angles (several turns of the shaft) into their mean.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cam_design.errors import InputError
from cam_metrology.inputs.files import read_text_file
from cam_metrology.wire.layouts import table_from_msg
from cam_metrology.wire.topics import METROLOGY_LIFT

ANGLE_UNITS = {'rad': 1.0, 'deg': math.pi / 180.0}
LENGTH_UNITS = {'m': 1.0, 'mm': 1.0e-3, 'um': 1.0e-6}
_SPLIT = re.compile(r'[\s,;]+')
#: the accepted table layouts, for error messages
TABLE_FORMATS = ('a CSV whose first line names the columns alpha_deg|alpha_rad|crank_deg '
                 'and lift_mm|lift_um|lift_m|lift_in|h_mm (e.g. alpha_deg,lift_mm), or a '
                 'gauge profile file whose first line is the probe radius (one number)')


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
    a, h = a[finite], h[finite]
    notes = []
    if dropped:
        notes.append(f'dropped {dropped} non-finite sample(s)')
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
        worst = int(np.argmax(spread))
        notes.append(f'merged {merged} sample(s) at repeated angles into their mean (largest '
                     f'spread {spread[worst] * 1e3:.4g} mm at '
                     f'{math.degrees(float(a_u[worst])):.3f} deg)')
    if a_u.size < min_points:
        raise InputError(f'{key}.alpha', f'{a_u.size} distinct finite angles',
                         f'at least {min_points}')
    return CleanSamples(a_u, h_u, count.astype(np.int64), dropped, merged, wrapped,
                        tuple(notes))


#: column names (lower case, unit removed) of the angle, crank angle and lift columns
ANGLE_NAMES = ('alpha', 'angle', 'cam', 'cam_angle', 'camangle', 'cam angle', 'theta')
CRANK_NAMES = ('crank', 'crank_angle', 'crankangle', 'crank angle')
LIFT_NAMES = ('lift', 'h', 'cam_lift', 'cam lift', 'valve_lift', 'valve lift',
              'follower_lift', 'follower lift', 'tappet_lift', 'tappet lift')
#: unit spellings accepted in headers
ANGLE_SPELLING = {'rad': 'rad', 'radian': 'rad', 'radians': 'rad', 'deg': 'deg',
                  'degree': 'deg', 'degrees': 'deg', '°': 'deg'}
LENGTH_SPELLING = {'m': 'm', 'mm': 'mm', 'um': 'um', 'µm': 'um', 'μm': 'um',
                   'micron': 'um', 'microns': 'um', 'in': 'in', 'inch': 'in'}
HEADER_UNITS = {'m': 1.0, 'mm': 1.0e-3, 'um': 1.0e-6, 'in': 0.0254}
#: the crank shaft of a four-stroke engine turns twice per cam turn
CRANK_PER_CAM = 2.0
_BRACKET = re.compile(r'^(?P<name>.*?)\s*[\[(](?P<unit>[^\])]*)[\])]\s*$')
_SUFFIX = re.compile(r'^(?P<name>.+?)[_ ](?P<unit>[a-zµμ°]+)$')
#: plausible cam lift range [m] (largest |lift| of a table): 20 um .. 250 mm
LIFT_PLAUSIBLE = (20e-6, 0.25)


def _split_header(name: str) -> tuple[str, str]:
    """(name, unit) of a header field: ``lift_mm``, ``lift [mm]``, ``Lift (mm)``."""
    text = name.strip().strip('"\'').strip().lower()
    m = _BRACKET.match(text)
    if m:
        return m.group('name').strip(), m.group('unit').strip()
    m = _SUFFIX.match(text)
    if m:
        return m.group('name').strip(), m.group('unit')
    return text, ''


@dataclass(frozen=True)
class _Column:
    index: int
    header: str
    role: str          # 'cam' | 'crank' | 'lift' | 'design'
    unit: str
    scale: float


def _classify(header: list[str], key: str) -> list[_Column]:
    """The angle, lift and design columns of a CSV header (others are ignored)."""
    cols = []
    for i, field_ in enumerate(header):
        name, unit = _split_header(field_)
        design = name.startswith(('design_', 'design '))
        base = name[7:] if design else name
        if base in ANGLE_NAMES or base in CRANK_NAMES:
            if unit not in ANGLE_SPELLING:
                raise InputError(key, field_, f'an angle column with a unit ({base}_deg or '
                                 f'{base}_rad): {TABLE_FORMATS}')
            role = 'crank' if base in CRANK_NAMES else 'cam'
            unit = ANGLE_SPELLING[unit]
            cols.append(_Column(i, field_, role, unit, ANGLE_UNITS[unit]))
        elif base in LIFT_NAMES:
            if unit not in LENGTH_SPELLING:
                raise InputError(key, field_, f'a lift column with a unit ({base}_mm, '
                                 f'{base}_um, {base}_m or {base}_in): {TABLE_FORMATS}')
            unit = LENGTH_SPELLING[unit]
            cols.append(_Column(i, field_, 'design' if design else 'lift', unit,
                                HEADER_UNITS[unit]))
    return cols


def read_csv_table(path: str | Path, *, feature: str | None = None) -> LiftTable:
    """Read a CSV lift table whose header names the columns with their units.

    Angle: ``alpha_deg|alpha_rad`` (also ``angle``, ``cam``, ``theta``; ``crank_deg`` is
    a crank angle, divided by 2 for the cam); lift: ``lift_mm|lift_um|lift_m|lift_in``
    (also ``h_mm``, as ``cam-bench design law --csv`` writes); optional
    ``design_lift_<unit>``. Units may also be written ``lift [mm]`` or ``Lift (mm)``.
    Separators: comma, semicolon or tab (with either of the last two a decimal comma is
    accepted), or the one a spreadsheet's first line ``sep=;`` names. Other columns are
    ignored (not read: they may hold text or nothing); the units may stand on the line
    under the names (``Angle;Lift`` then ``[deg];[mm]``); an empty cell in a used column
    is a missing reading (NaN, counted). Trailing empty fields are ignored, as are a
    UTF-8 byte-order mark and a repetition of the header line (files exported in parts;
    counted in the notes). Empty lines and ``#`` comments are skipped; a malformed line
    raises InputError naming ``FILE:LINE``.
    """
    p = Path(path)
    lines = _read_text(p).splitlines()
    header: list[str] | None = None
    cols: list[_Column] = []
    sep, sep_given = ',', False
    used: list[int] = []
    values: list[float] = []   # the used columns of every row, flat (a 1e6-row file)
    rows = repeats = empty = 0
    skip = units_line = 0
    for number, raw in enumerate(lines, start=1):
        line = raw.split('#', 1)[0].strip()
        if not line:
            continue
        if header is None:
            if _EXCEL_SEP.match(line):   # a spreadsheet's "sep=;" line names the separator
                sep, sep_given = line[4], True
                continue
            if not sep_given:
                sep = ';' if ';' in line else ('\t' if '\t' in line else ',')
            header = _trim([f.strip() for f in line.split(sep)])
            units = _unit_row(lines, number, sep)
            if units is not None:   # names on one line, units on the next (alpha / deg)
                header = [f'{n}_{u}' if u and n and not _split_header(n)[1] else n for n, u in
                          zip(header, units + [''] * (len(header) - len(units)))]
                skip = units_line = _next_content(lines, number)
            cols = _classify(header, f'{p.name}:header')
            _one_each(cols, header, p.name)
            used = [c.index for c in cols]
            continue
        if number == skip:
            continue
        parts = [f.strip() for f in line.split(sep)]
        fields = _trim(parts)
        if [f.strip('"\'').lower() for f in fields] == \
                [f.strip('"\'').lower() for f in header]:
            repeats += 1     # files exported in parts repeat the header
            continue
        if not (max(used) < len(parts) and len(fields) <= len(header)):
            raise InputError(f'{p.name}:{number}', raw.strip(),
                             f'{len(header)} values separated by {sep!r} '
                             f'({",".join(header)})')
        empty += sum(1 for i in used if not parts[i])
        try:   # only the columns used are read; a decimal comma unless commas separate;
            # an empty cell is a missing reading (NaN: the row is dropped and counted)
            values.extend(float((parts[i].replace(',', '.') if sep != ',' else parts[i])
                                or 'nan') for i in used)
        except ValueError:
            raise InputError(f'{p.name}:{number}', raw.strip(),
                             'numbers in the columns ' + ', '.join(header[i] for i in used)
                             + (' (a decimal point or comma)' if sep != ',' else
                                ' (a decimal point)')) from None
        rows += 1
    if header is None:
        raise InputError(p.name, 'an empty file', 'a header alpha_rad,lift_m and rows')
    if not rows:
        raise InputError(p.name, '0 data rows', f'rows of numbers under the header '
                         f'{",".join(header)}')
    angles = [c for c in cols if c.role in ('cam', 'crank')]
    lifts = [c for c in cols if c.role == 'lift']
    designs = [c for c in cols if c.role == 'design']
    data = np.asarray(values, dtype=float).reshape(-1, len(used))
    ang, lift_col = angles[0], lifts[0]
    raw_alpha = data[:, used.index(ang.index)]
    raw_lift = data[:, used.index(lift_col.index)]
    notes = [f'columns: angle {ang.header!r} in {ang.unit}, lift {lift_col.header!r} in '
             f'{lift_col.unit}']
    if repeats:
        notes.append(f'skipped {repeats} repeated header line(s)')
    if units_line:
        notes.append(f'units read from line {units_line} under the column names')
    if empty:
        notes.append(f'{empty} empty cell(s) read as missing readings (rows dropped)')
    alpha = raw_alpha * ang.scale
    if ang.role == 'crank':
        alpha = alpha / CRANK_PER_CAM
        notes.append(f'angles: crank angle / {CRANK_PER_CAM:g} (four-stroke: the camshaft '
                     'turns once per two crank turns)')
    key = f'{p.name}:{lift_col.header}'
    check_lift_magnitude(raw_lift, lift_col.scale, key, lift_col.header,
                         lambda u: f'name the column {_renamed(lift_col.header, u)}')
    check_angle_magnitude(raw_alpha, raw_lift, ang.unit, ang.role,
                          f'{p.name}:{ang.header}', ang.header,
                          lambda u, r: f'name the column {_renamed(ang.header, u, r)}')
    lift = raw_lift * lift_col.scale
    design = None
    if designs:
        design = data[:, used.index(designs[0].index)] * designs[0].scale
    return LiftTable(feature or p.stem, alpha, lift, design, None, str(p), tuple(notes))


_EXCEL_SEP = re.compile(r'^sep=[,;\t]$', re.IGNORECASE)


def _one_each(cols: list[_Column], header: list[str], name: str) -> None:
    """InputError unless the header has one angle, one lift and at most one design column."""
    roles = [c.role for c in cols]
    angles = roles.count('cam') + roles.count('crank')
    if angles != 1 or roles.count('lift') != 1 or roles.count('design') > 1:
        read = {c.index for c in cols}
        unread = [h for i, h in enumerate(header) if i not in read and h]
        missing = [w for w, n in (('angle', angles), ('lift', roles.count('lift'))) if n == 0]
        said = (f'; no {" and no ".join(missing)} column among them, and '
                + ', '.join(repr(h) for h in unread) + ' could not be read as one'
                if missing and unread else '')
        raise InputError(f'{name}:header', ','.join(header),
                         'one angle column (alpha_deg, alpha_rad or crank_deg, e.g. '
                         '"Crank Angle [deg]") and one lift column (lift_mm, lift_um, '
                         'lift_m, lift_in or h_mm, e.g. "Valve Lift [mm]")' + said)


def _next_content(lines: list[str], number: int) -> int:
    """The 1-based number of the first non-empty, non-comment line after ``number``
    (0 if none)."""
    for n in range(number, len(lines)):
        if lines[n].split('#', 1)[0].strip():
            return n + 1
    return 0


def _unit_row(lines: list[str], number: int, sep: str) -> list[str] | None:
    """The units of a line under the header holding only unit words (``deg,mm``,
    ``[deg];[mm]``; empty cells allowed), or None when that line is not one."""
    nxt = _next_content(lines, number)
    if not nxt:
        return None
    cells = _trim([f.strip().strip('"\'').strip('[]()').strip().lower()
                   for f in lines[nxt - 1].split('#', 1)[0].strip().split(sep)])
    known = set(ANGLE_SPELLING) | set(LENGTH_SPELLING)
    if not any(cells) or any(c and c not in known for c in cells):
        return None
    return cells


def _trim(fields: list[str]) -> list[str]:
    """``fields`` without the empty ones at the end (a spreadsheet's trailing separators)."""
    while fields and not fields[-1]:
        fields = fields[:-1]
    return fields


def _renamed(header: str, unit: str, role: str | None = None) -> str:
    """The header with another unit (and for angles another role: crank)."""
    name, _ = _split_header(header)
    if role == 'crank':
        name = 'crank'
    elif role == 'cam' and name in CRANK_NAMES:
        name = 'alpha'
    return f'{name.replace(" ", "_")}_{unit}'


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


def read_gauge_file(path: str | Path, *, angle_unit: str = 'deg', length_unit: str = 'mm',
                    feature: str | None = None) -> LiftTable:
    """Read a nominal-profile file in the common gauge layout.

    Line 1: probe radius; line 2: number of angle steps N; then N (or N + 1, when the
    closing angle is repeated) rows ``angle lift [marker]``. Angles in ``angle_unit``
    (deg by default), lengths in ``length_unit`` (mm by default). Lines starting with
    ``#`` and blank lines are ignored. Errors name ``FILE:LINE``.
    """
    if angle_unit not in ANGLE_UNITS:
        raise InputError('angle_unit', angle_unit, ' | '.join(ANGLE_UNITS))
    if length_unit not in LENGTH_UNITS:
        raise InputError('length_unit', length_unit, ' | '.join(LENGTH_UNITS))
    p = Path(path)
    content = [(n, raw.strip()) for n, raw in
               enumerate(_read_text(p).splitlines(), start=1)]
    content = [(n, s) for n, s in content if s and not s.startswith('#')]
    if len(content) < 2:
        raise InputError(p.name, f'{len(content)} non-empty line(s)',
                         'probe radius, number of steps, then the rows')
    (n1, l1), (n2, l2) = content[0], content[1]
    radius = _gauge_number(p.name, n1, l1, 'the probe radius (one number >= 0)')
    if radius < 0:
        raise InputError(f'{p.name}:{n1}', l1, 'the probe radius (one number >= 0)')
    steps = _gauge_number(p.name, n2, l2, 'the number of angle steps (an integer > 0)')
    if steps != int(steps) or steps <= 0:
        raise InputError(f'{p.name}:{n2}', l2, 'the number of angle steps (an integer > 0)')
    body = content[2:]
    if len(body) not in (int(steps), int(steps) + 1):
        where = body[-1][0] if body else n2
        raise InputError(f'{p.name}:{where}', f'{len(body)} rows',
                         f'{int(steps)} rows (or {int(steps) + 1} with the closing angle)')
    alpha = np.empty(len(body))
    lift = np.empty(len(body))
    for i, (number, line) in enumerate(body):
        fields = _gauge_fields(line)
        if len(fields) not in (2, 3):
            raise InputError(f'{p.name}:{number}', line, 'angle, lift[, marker]')
        try:
            alpha[i] = float(fields[0])
            lift[i] = float(fields[1])
        except ValueError:
            raise InputError(f'{p.name}:{number}', line,
                             'two numbers (angle, lift) and an optional marker') from None
        if not (math.isfinite(alpha[i]) and math.isfinite(lift[i])):
            raise InputError(f'{p.name}:{number}', line, 'finite angle and lift')
    alpha *= ANGLE_UNITS[angle_unit]
    lift *= LENGTH_UNITS[length_unit]
    r = radius * LENGTH_UNITS[length_unit]
    follower = ('roller', r) if r > 0 else ('knife', 0.0)
    note = (f'gauge file: angles in {angle_unit}, lengths in {length_unit}, '
            f'probe radius {r:.6g} m')
    return LiftTable(feature or p.stem, alpha, lift, None, follower, str(p), (note,))


def _gauge_fields(line: str) -> list[str]:
    """The fields of a gauge-file line. Commas separate fields, except in a line without
    a decimal point whose fields are already separated by blanks, semicolons or tabs:
    there they are decimal commas (European gauges: ``12,5`` or ``0,5;8,0000``)."""
    if ',' in line and '.' not in line:
        parts = [f for f in re.split(r'[\s;]+', line) if f]
        if len(parts) > 1 and not any(f.startswith(',') or f.endswith(',') for f in parts):
            return [f.replace(',', '.') for f in parts]
    return [f for f in _SPLIT.split(line) if f]


def _gauge_number(name: str, number: int, line: str, expected: str) -> float:
    fields = _gauge_fields(line)
    if len(fields) == 2 and '.' not in line and re.fullmatch(r'[+-]?\d+,\d+', line):
        fields = [line.replace(',', '.')]    # one number with a decimal comma: 12,5
    try:
        if len(fields) != 1:
            raise ValueError
        value = float(fields[0])
    except ValueError:
        raise InputError(f'{name}:{number}', line, expected) from None
    if not math.isfinite(value):
        raise InputError(f'{name}:{number}', line, expected)
    return value


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


def read_table_file(path: str | Path, *, angle_unit: str = 'deg',
                    length_unit: str = 'mm') -> LiftTable:
    """A CSV table (first line names an ``alpha_`` column) or a gauge file."""
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f'no such table file: {p}')
    first, number = '', 0
    for number, raw in enumerate(_read_text(p).splitlines(), start=1):
        if raw.strip() and not raw.strip().startswith('#') and \
                not _EXCEL_SEP.match(raw.strip()):
            first = raw.strip()
            break
    if _names_an_angle(first):
        return read_csv_table(p)
    try:
        _gauge_number(p.name, number, first, 'one number')
    except InputError:
        shown = first if len(first) <= 80 else first[:77] + '...'
        raise InputError(f'{p.name}:{number}' if first else p.name,
                         shown if first else 'an empty file', TABLE_FORMATS) from None
    table = read_gauge_file(p, angle_unit=angle_unit, length_unit=length_unit)
    check_lift_magnitude(table.lift / LENGTH_UNITS[length_unit], LENGTH_UNITS[length_unit],
                         '--length-unit', length_unit, lambda u: f'use --length-unit {u}')
    check_angle_magnitude(table.alpha / ANGLE_UNITS[angle_unit], table.lift, angle_unit,
                          'cam', '--angle-unit', angle_unit,
                          lambda u, r: f'use --angle-unit {u}' + (
                              ' and halve the angles (crank degrees)' if r == 'crank' else ''))
    return table


def _names_an_angle(line: str) -> bool:
    """Is ``line`` a CSV header with an angle column (alpha_deg, crank_deg, ...)?"""
    for field_ in re.split(r'[,;\t]', line):
        name, _ = _split_header(field_)
        name = name[7:] if name.startswith(('design_', 'design ')) else name
        if name in ANGLE_NAMES or name in CRANK_NAMES:
            return True
    return False


def _read_text(path: Path) -> str:
    """The file's UTF-8 text; InputError (naming the file) for binary data, a directory
    or an unreadable file, listing the accepted table layouts."""
    return read_text_file(path, 'text table: ' + TABLE_FORMATS, key=path.name)


def lift_table_from_message(msg: Any) -> LiftTable:
    """A /metrology/lift table as a LiftTable (feature = the label)."""
    label, columns, data = table_from_msg(msg)
    index = {c: i for i, c in enumerate(columns)}
    for need in ('alpha_rad', 'lift_m'):
        if need not in index:
            raise InputError(f'{label}.columns', ','.join(columns), 'alpha_rad,lift_m[,...]')
    design = data[:, index['design_lift_m']].copy() if 'design_lift_m' in index else None
    return LiftTable(label, data[:, index['alpha_rad']].copy(),
                     data[:, index['lift_m']].copy(), design, None, METROLOGY_LIFT)


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


#: a base circle this far from 0 [m] (and 0.25 % of the lift range) is not the zero
BASE_OFFSET_M = 10e-6


def base_circle_warning(alpha: ArrayLike, lift: ArrayLike) -> str | None:
    """A warning when the table's base circle is not at lift 0 (a probe zeroed elsewhere,
    lifts from another datum): the median of the rows within 2 % of the lift range above
    the lowest, when they cover at least 60 deg, off 0 by more than ``BASE_OFFSET_M``
    and 0.25 % of the range. Lifts, max lift and checking heights are then from the
    table's zero, not from the base circle; the warning gives the max lift above it."""
    a = np.asarray(alpha, dtype=float)
    h = np.asarray(lift, dtype=float)
    ok = np.isfinite(a) & np.isfinite(h)
    a, h = a[ok], h[ok]
    if a.size < 8:
        return None
    rng = float(np.ptp(h))
    low = h <= float(np.min(h)) + 0.02 * rng
    step = float(np.median(np.diff(np.sort(a)))) if a.size > 1 else 0.0
    if not rng > 0 or np.count_nonzero(low) * step < math.radians(60.0):
        return None
    level = float(np.median(h[low]))
    if abs(level) <= max(BASE_OFFSET_M, 0.0025 * rng):
        return None
    return (f'the base circle is at {level * 1e3:+.4f} mm, not 0 (median of the '
            f'{int(np.count_nonzero(low))} rows at the bottom of the table): the lifts are '
            'not measured from the base circle (probe zeroed elsewhere?); max lift above '
            f'the base circle {(float(np.max(h)) - level) * 1e3:.4f} mm; lifts and checking '
            'heights here are from the table\'s zero: subtract the offset to use the base '
            'circle')


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


def nose_warning(data: CleanSamples) -> str | None:
    """A warning when alpha = 0 is not on the lobe (lift there below half the largest
    lift): the angles are not taken from the lobe centreline, which the section harmonic
    basis and every lobe-centred quantity assume. Names the lobe axis (flank
    midpoints) and the option that re-centres a table file."""
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
        where = f'the lobe axis is at {math.degrees(shift):.2f} deg'
    except InputError:
        where = f'the largest lift is at {math.degrees(float(a[int(np.argmax(h))])):.2f} deg'
    return (f'alpha = 0 is not on the lobe ({where}; lift at 0 is '
            f'{(at_zero - base) / (top - base) * 100:.0f} % of the lobe height): the angles '
            'are not from the lobe centreline; re-centre the table (--center-nose, or '
            'shift the angles)')
