"""Lift-table files: reading CSV and gauge files, with unit handling.

Two inputs end up as one ``LiftTable`` (alpha [rad] from the lobe centreline, lift
[m] above the base circle, optional design lift [m] for the same follower):

* a CSV file with a header naming the columns; the unit is part of each name
  (``alpha_rad`` | ``alpha_deg``; ``lift_m`` | ``lift_mm`` | ``lift_um``; optional
  ``design_lift_<unit>``);
* a nominal-profile file in the common gauge layout: line 1 the probe radius, line 2
  the number of angle steps, then one row per step ``angle lift [marker]`` (fields
  separated by blanks, commas, semicolons or tabs; decimal commas are read where they
  cannot be separators: ``12,5``, ``0,5;8,0000``). Gauges write degrees and
  millimetres: those are the defaults, overridable (``angle_unit``, ``length_unit``);

The rows, their cleaning and the checks on their values are
``cam_design.lift_table.samples``.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from cam_design.errors import InputError
from cam_design.lift_table.samples import (ANGLE_UNITS, CRANK_PER_CAM, HEADER_UNITS,
                                           LENGTH_UNITS, LiftTable, check_angle_magnitude,
                                           check_lift_magnitude)
from cam_metrology.inputs.files import read_text_file

_SPLIT = re.compile(r'[\s,;]+')
#: the accepted table layouts, for error messages
TABLE_FORMATS = ('a CSV whose first line names the columns alpha_deg|alpha_rad|crank_deg '
                 'and lift_mm|lift_um|lift_m|lift_in|h_mm (e.g. alpha_deg,lift_mm), or a '
                 'gauge profile file whose first line is the probe radius (one number)')

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
_BRACKET = re.compile(r'^(?P<name>.*?)\s*[\[(](?P<unit>[^\])]*)[\])]\s*$')
_SUFFIX = re.compile(r'^(?P<name>.+?)[_ ](?P<unit>[a-zµμ°]+)$')


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
