"""Parse and validate a scene file (docs/scene.md) into ``scene.Scene``.

``parse_scene(text, source)`` validates the whole document before it builds anything:
a bad value raises ``InputError`` whose key is the full path of the offending entry
(``lobes[1].lift.alpha[7]``), with the value and what was expected; nothing is
half-applied. Keys that the schema does not know are allowed: each gives a warning
(``Scene.warnings``, with its key path), never an error.

Schema: docs/scene.md plus the extra keys of architecture.md (``lobes[].follower_radius``,
``idle_timeout``, ``valve_train.seat.restitution``, ``valve_train.mdof``). All values SI.
Numbers written as strings that YAML 1.1 does not read as floats (``1e9``) are
accepted when they parse as finite floats.
"""
from __future__ import annotations

import importlib
import math
from contextlib import contextmanager
from contextvars import ContextVar
from pathlib import Path
from typing import Any, Callable, Iterator, Mapping

import numpy as np

from cam_design.errors import InputError, require_finite, require_length, require_positive
from cam_design.lift_laws import LiftLaw
from cam_design.lift_laws.base import check_design_table
from cam_metrology.inputs.files import read_text_file
from cam_metrology.scene.form_and_journals import (check_no_overlap, parse_axial_position,
                                                   parse_derivative_zones, zone_span)
from cam_metrology.scene.model import (COMPUTE_ITEMS, Band, Crank, DowelPin, Follower, Keyway,
                                       Lobe, Scene, Seat, ToleranceZone, Tolerances, ValveTrain)

__all__ = ['parse_scene', 'load_scene', 'lift_law_from_spec']

TOP_KEYS = ('camshaft_id', 'direction', 'probe', 'base_circle_radius', 'lobes',
            'dowel_pin', 'keyway', 'crank', 'compute', 'valve_train', 'idle_timeout',
            'tolerances', 'part_id', 'operator', 'trial', 'camshaft', 'form', 'journals',
            'rig', 'channels')
#: top-level keys of a gauge R&R study (carried into the report and the batch table)
STUDY_KEYS = ('part_id', 'operator', 'trial')
PROBE_KINDS = ('flat', 'roller', 'knife', 'ball')
FOLLOWER_KINDS = ('flat', 'roller', 'knife')
LOBE_KEYS = ('id', 'nominal_phase', 'follower', 'follower_radius', 'lift', 'lift_law',
             'width', 'tolerances', 'role', 'cylinder', 'nominal_file', 'axial_position')
#: tolerance keys of a lobe (units in the names); the top-level block adds datum_deg
TOL_BANDS = ('lift_error_um', 'centreline_deg', 'phase_deg', 'max_lift_um', 'duration_deg')
#: tolerance keys that are a maximum only (>= 0)
TOL_MAXIMA = ('runout_max_um', 'roundness_max_um', 'waviness_max_um', 'taper_max_um_per_mm',
              'twist_max_deg', 'velocity_error_max_mm_per_rad',
              'acceleration_error_max_mm_per_rad2')
TOL_KEYS = TOL_BANDS + ('lift_error_zones', 'checking_height_mm', 'derivative_error_zones') + \
    TOL_MAXIMA
PIN_KEYS = ('pin_radius', 'circle_radius', 'probe_radius', 'nominal_angle')
KEYWAY_KEYS = ('width', 'shaft_radius', 'probe_radius', 'depth', 'nominal_angle')
CRANK_KEYS = ('tdc_deg', 'cylinder_tdc_deg')
#: feature ids of the datums (no lobe may take them)
DATUM_IDS = ('dowel_pin', 'keyway')
VALVE_MODELS = ('sdof', 'mdof', 'hydraulic')
#: valve_train keys the hydraulic model does not use, with the value it takes
HYDRAULIC_UNUSED = {'rocker_ratio': 1.0, 'lash': 0.0, 'stiffness': 1.0e12, 'damping': 0.0}
SEAT_KEYS = ('stiffness', 'damping', 'restitution')
#: lift tables must end on the base circle within this [m] ("covering the whole lobe")
#: a scene this large is surely not a scene file [characters]
MAX_TEXT = 50_000_000

# key -> (required, check) for valve_train; check(key, value) -> validated value
_POS = require_positive


def _nonneg(key: str, value: Any) -> float:
    return require_positive(key, value, allow_zero=True)


#: largest plausible camshaft length [m] (radii, widths): more is a unit slip
GEOMETRY_MAX_M = 0.5
#: largest plausible valve lash [m]
LASH_MAX_M = 0.005


def _lash(key: str, value: Any) -> float:
    return require_length(key, value, LASH_MAX_M, allow_zero=True)


VALVE_KEYS: dict[str, tuple[bool, Callable[[str, Any], float]]] = {
    'rocker_ratio': (True, _POS),
    'lash': (True, _lash),
    'mass': (True, _POS),
    'stiffness': (True, _POS),
    'damping': (True, _nonneg),
    'spring_rate': (True, _nonneg),
    'spring_preload': (True, _nonneg),
    'valve_damping': (False, _nonneg),
}


class _Ctx:
    """Collects warnings while a document is validated."""

    def __init__(self, base_dir: Path | None = None) -> None:
        self.warnings: list[str] = []
        self.base_dir = base_dir   # folder of the scene file: relative nominal_file paths

    def mapping(self, key: str, value: Any, known: tuple[str, ...]) -> Mapping[str, Any]:
        """``value`` as a mapping; unknown keys become warnings."""
        if not isinstance(value, Mapping):
            raise InputError(key, value, 'a mapping (key: value)')
        for k in value:
            if not isinstance(k, str):
                raise InputError(f'{key}', k, 'string keys')
            if k not in known:
                path = f'{key}.{k}' if key else k
                self.warnings.append(f'{path}: unknown key ignored (known: '
                                     f'{", ".join(known)})')
        return value


#: text, source, base dir -> Scene of the texts parsed inside ``shared_parses()``
_SHARED: ContextVar[dict[tuple[str, str, str], Scene] | None] = ContextVar(
    'shared_scene_parses', default=None)


@contextmanager
def shared_parses() -> Iterator[None]:
    """Within the block, each scene text is parsed once: later ``parse_scene`` calls of
    the same text (same source and base dir) get the same frozen ``Scene``. The offline
    analysis wraps its bag checks and replay in it, so the bag's scene check and every
    core share one parse; outside the block nothing is kept (a nominal file read again)."""
    token = _SHARED.set({})
    try:
        yield
    finally:
        _SHARED.reset(token)


def parse_scene(text: str, source: str = '<scene>', base_dir: str | Path | None = None
                ) -> Scene:
    """Validate a scene YAML document and return the Scene (InputError if invalid).

    ``source`` names the document in YAML syntax errors (a file name); ``base_dir`` is
    the folder relative ``lobes[i].nominal_file`` paths start from (default: the
    working directory). Inside ``shared_parses()`` a text already parsed is not parsed
    again.
    """
    memo = _SHARED.get()
    if memo is None:
        return _parse_document(text, source, base_dir)
    key = (text, source, '' if base_dir is None else str(base_dir))
    if key not in memo:
        memo[key] = _parse_document(text, source, base_dir)
    return memo[key]


def _parse_document(text: str, source: str, base_dir: str | Path | None) -> Scene:
    """``parse_scene`` without the sharing: the validation itself."""
    import yaml

    if not isinstance(text, str):
        raise InputError('scene', type(text).__name__, 'YAML text (str)')
    if len(text) > MAX_TEXT:
        raise InputError('scene', f'{len(text)} characters',
                         f'a scene file of at most {MAX_TEXT} characters')
    try:
        from cam_metrology.inputs.yaml_input import load_yaml, syntax_error_text
        doc = load_yaml(text, 'scene', getattr(yaml, 'CSafeLoader', yaml.SafeLoader))
    except yaml.YAMLError as exc:
        raise InputError('scene', source, f'valid YAML ({syntax_error_text(exc, text)})') \
            from None
    if doc is None:
        raise InputError('scene', source, 'a YAML mapping with the scene keys (file is empty)')
    ctx = _Ctx(None if base_dir is None else Path(base_dir))
    top = ctx.mapping('', doc, TOP_KEYS) if isinstance(doc, Mapping) else None
    if top is None:
        raise InputError('scene', type(doc).__name__,
                         'a YAML mapping with the keys of docs/scene.md at the top level')
    camshaft_id = _text('camshaft_id', top.get('camshaft_id', ''), allow_empty=True)
    direction = _direction(top.get('direction', 1))
    if 'probe' not in top:
        raise InputError('probe', None, 'a probe mapping {kind, radius}')
    probe = _probe(ctx, top['probe'])
    if 'base_circle_radius' not in top:
        raise InputError('base_circle_radius', None, 'the base circle radius in m (> 0)')
    base = require_length('base_circle_radius', top['base_circle_radius'], GEOMETRY_MAX_M)
    defaults = _tolerance_block(ctx, 'tolerances', top.get('tolerances'), TOL_KEYS +
                                ('datum_deg',))
    lobes = _lobes(ctx, top.get('lobes', []), base, defaults)
    pin = _dowel_pin(ctx, top['dowel_pin']) if top.get('dowel_pin') is not None else None
    keyway = _keyway(ctx, top['keyway']) if top.get('keyway') is not None else None
    if pin is not None and keyway is not None:
        raise InputError('keyway', 'given with a dowel_pin',
                         'one angular datum: either dowel_pin or keyway, not both')
    datum = _datum_tolerance(defaults, pin or keyway)
    if not lobes and pin is None and keyway is None and not top.get('journals'):
        raise InputError('lobes', top.get('lobes', []),
                         'at least one lobe (or a dowel_pin or keyway): nothing to measure')
    crank = _crank(ctx, top.get('crank'), pin or keyway, lobes)
    compute = _compute(top.get('compute'))
    valve = _valve_train(ctx, top['valve_train']) \
        if top.get('valve_train') is not None else None
    idle = require_positive('idle_timeout', top.get('idle_timeout', 1.0))
    shaft = _camshaft(top.get('camshaft'), lobes)
    _check_conversions(ctx, lobes, base, probe)
    if pin is None and keyway is None and any(lobe.nominal_phase is not None
                                              for lobe in lobes):
        ctx.warnings.append('lobes[].nominal_phase: given but the scene has no dowel_pin or '
                            'keyway; phases cannot be measured')
    study = {k: _text(k, top[k]) for k in STUDY_KEYS if top.get(k) is not None}
    from cam_metrology.scene.form_and_journals import parse_form
    form = parse_form(ctx.mapping('form', top['form'], ('cutoff_upr', 'waviness_band_upr',
                                                        'derivative_errors'))
                      if top.get('form') is not None else None)
    from cam_metrology.scene.form_and_journals import parse_journals, parse_zero_radius
    journals = parse_journals(top.get('journals'), ctx.mapping,
                              {lobe.id for lobe in lobes} | set(DATUM_IDS), _band)
    zero_radius = parse_zero_radius(top['probe'].get('zero_radius'))
    from cam_metrology.scene.channels import parse_channels
    channels = parse_channels(top.get('channels'), ctx.mapping)
    return Scene(camshaft_id=camshaft_id, direction=direction, probe=probe,
                 base_circle_radius=base, lobes=tuple(lobes), dowel_pin=pin,
                 compute=compute, valve_train=valve, idle_timeout=idle, text=text,
                 datum_tolerance_deg=datum, warnings=tuple(ctx.warnings), keyway=keyway,
                 crank=crank, study=study, camshaft=shaft, form=form, journals=journals,
                 probe_zero_radius=zero_radius, channels=channels)


def _camshaft(block: Any, lobes: list[Lobe]) -> Any:
    """``camshaft:`` (``cam_design.camshaft.spec``): every lobe needs its nominal phase,
    which places it on the shaft."""
    if block is None:
        return None
    from cam_design.camshaft.spec import camshaft_from_mapping

    for i, lobe in enumerate(lobes):
        if lobe.nominal_phase is None:
            raise InputError(f'lobes[{i}].nominal_phase', None, 'a nominal phase [rad] for '
                             'every lobe on the camshaft (it places the lobe on the shaft)')
    return camshaft_from_mapping(block, [lobe.id for lobe in lobes])


def load_scene(path: str | Path) -> Scene:
    """Read and validate the scene file at ``path`` (see ``parse_scene``)."""
    return parse_scene(read_text_file(path, 'scene file'), source=str(path),
                       base_dir=Path(path).parent)


# ------------------------------------------------------------------------- scalars

def _text(key: str, value: Any, *, allow_empty: bool = False) -> str:
    """A free-text scalar (numbers are accepted and turned into text)."""
    if isinstance(value, bool) or not isinstance(value, (str, int, float)):
        raise InputError(key, value, 'a text string')
    out = str(value).strip()
    if not out and not allow_empty:
        raise InputError(key, value, 'a non-empty text string')
    return out


def _direction(value: Any) -> int:
    if isinstance(value, bool) or value not in (1, -1, 1.0, -1.0):
        raise InputError('direction', value, '+1 or -1')
    return int(value)


def _optional_angle(key: str, value: Any) -> float | None:
    if value is None:
        return None
    angle = require_finite(key, value)
    if abs(angle) > 2 * math.pi:
        raise InputError(key, value, 'an angle in rad within [-2 pi, 2 pi] (degrees given?)')
    return angle


def _follower(kind_key: str, radius_key: str, kind: Any, radius: Any,
              kinds: tuple[str, ...]) -> Follower:
    """A Follower from a kind and a radius [m] (ball = roller; radius ignored if flat)."""
    if kind not in kinds:
        raise InputError(kind_key, kind, ' | '.join(kinds))
    if kind == 'ball':
        kind = 'roller'
    r = require_length(radius_key, radius if radius is not None else 0.0, GEOMETRY_MAX_M,
                       allow_zero=True)
    if kind == 'roller' and r == 0.0:
        raise InputError(radius_key, radius,
                         'a roller/ball radius > 0 in m (kind knife for a point)')
    return Follower(kind, r if kind == 'roller' else 0.0)


def _probe(ctx: _Ctx, value: Any) -> Follower:
    probe = ctx.mapping('probe', value, ('kind', 'radius', 'zero_radius'))
    if 'kind' not in probe:
        raise InputError('probe.kind', None, ' | '.join(PROBE_KINDS))
    return _follower('probe.kind', 'probe.radius', probe['kind'], probe.get('radius'),
                     PROBE_KINDS)


# -------------------------------------------------------------------------- lobes

def _lobes(ctx: _Ctx, value: Any, base: float, defaults: dict[str, Any] | None = None
           ) -> list[Lobe]:
    if value is None:
        return []
    if not isinstance(value, list):
        raise InputError('lobes', value, 'a list of lobe mappings')
    lobes: list[Lobe] = []
    seen: dict[str, int] = {}
    for i, item in enumerate(value):
        key = f'lobes[{i}]'
        lobe = ctx.mapping(key, item, LOBE_KEYS)
        if 'id' not in lobe:
            raise InputError(f'{key}.id', None, 'a feature id such as lobe_1')
        lobe_id = _text(f'{key}.id', lobe['id'])
        if lobe_id in DATUM_IDS:
            raise InputError(f'{key}.id', lobe_id, 'a lobe id other than dowel_pin and '
                             'keyway (reserved for the datum features)')
        if any(c.isspace() for c in lobe_id):
            raise InputError(f'{key}.id', lobe_id, 'an id without white space')
        if lobe_id in seen:
            raise InputError(f'{key}.id', lobe_id,
                             f'a unique id (lobes[{seen[lobe_id]}] has it already)')
        seen[lobe_id] = i
        follower = _lobe_follower(key, lobe)
        phase = _optional_angle(f'{key}.nominal_phase', lobe.get('nominal_phase'))
        has_table = lobe.get('lift') is not None
        has_law = lobe.get('lift_law') is not None
        has_file = lobe.get('nominal_file') is not None
        if has_table + has_law + has_file != 1:
            raise InputError(f'{key}.lift', 'more than one' if has_table + has_law + has_file
                             else None, 'exactly one of lift (alpha/h table), lift_law or '
                             'nominal_file')
        nominal_path = None
        law: LiftLaw
        if has_file:
            law, follower, nominal_path = _nominal_file(ctx, key, lobe, follower)
            spec = None
        elif has_table:
            law = _lift_table(ctx, f'{key}.lift', lobe['lift'])
            spec = None
        else:
            if not isinstance(lobe['lift_law'], Mapping):
                raise InputError(f'{key}.lift_law', lobe['lift_law'],
                                 'a mapping {family: NAME, ...parameters}')
            spec = dict(lobe['lift_law'])   # the registry rejects unknown parameters
            law = lift_law_from_spec(spec, f'{key}.lift_law')
        _check_law(f'{key}.lift_law' if spec is not None else
                   f'{key}.nominal_file' if has_file else f'{key}.lift', law)
        width = lobe.get('width')
        if width is not None:
            width = require_length(f'{key}.width', width, GEOMETRY_MAX_M)
        z = lobe.get('axial_position')
        if z is not None:
            z = parse_axial_position(f'{key}.axial_position', z)
        tol = _lobe_tolerances(ctx, key, lobe.get('tolerances'), defaults or {}, law, phase)
        role = lobe.get('role')
        if role is not None and role not in ('intake', 'exhaust'):
            raise InputError(f'{key}.role', role, 'intake | exhaust')
        cylinder = _text(f'{key}.cylinder', lobe.get('cylinder', 1))
        lobes.append(Lobe(id=lobe_id, follower=follower, lift=law, nominal_phase=phase,
                          lift_spec=spec, width=width, tolerances=tol, role=role,
                          cylinder=cylinder, nominal_file=nominal_path, axial_position=z))
    return lobes


def _nominal_file(ctx: _Ctx, key: str, lobe: Mapping[str, Any], follower: Follower
                  ) -> tuple[LiftLaw, Follower, str]:
    """The design lift of a gauge nominal-profile file (docs/cam_card.md: probe radius,
    steps, rows ``angle_deg lift_mm``) and the follower it is written for (a roller of
    the file's probe radius, a knife for 0); a lobe ``follower`` that differs is an
    error. Relative paths start from the scene file's folder."""
    from cam_design.lift_table.samples import check_angle_magnitude, check_lift_magnitude
    from cam_metrology.inputs.lift_tables import read_gauge_file

    raw = _text(f'{key}.nominal_file', lobe['nominal_file'])
    path = Path(raw).expanduser()
    if not path.is_absolute() and ctx.base_dir is not None:
        path = ctx.base_dir / path
    if not path.is_file():
        raise InputError(f'{key}.nominal_file', raw, f'an existing gauge nominal-profile file '
                         f'(looked for {path}; relative paths start from the scene file\'s '
                         'folder, or the working directory for a scene from a bag)')
    table = read_gauge_file(path, feature=_text(f'{key}.id', lobe['id']))
    fix = 'a nominal file is in deg and mm: convert the file'
    check_lift_magnitude(table.lift * 1e3, 1e-3, f'{key}.nominal_file', 'mm',
                         lambda u: fix)
    check_angle_magnitude(np.degrees(table.alpha), table.lift, 'deg', 'cam',
                          f'{key}.nominal_file', 'deg', lambda u, r: fix)
    kind, radius = table.follower or ('knife', 0.0)
    own = Follower(kind, radius)
    if 'follower' in lobe and (follower.kind != own.kind or
                               abs(follower.radius - own.radius) > 1e-12):
        raise InputError(f'{key}.follower', lobe['follower'],
                         f'no follower, or the file\'s ({kind}, radius {radius:g} m): the '
                         'nominal file says which follower its lift is for')
    # a gauge may write 0..360 deg (the nose at 0 and 360) or -180..180: the lobe law
    # takes the whole turn (wrapped, the repeated closing angle merged) and finds the
    # lobe where it rises off the base circle
    if not float(np.max(table.lift)) > 0:
        raise InputError(f'{key}.nominal_file', raw, 'a lift profile (every lift is 0)')
    return _table_law(ctx, f'{key}.nominal_file', table.alpha, table.lift,
                      design=False), own, str(path)


def _lobe_follower(key: str, lobe: Mapping[str, Any]) -> Follower:
    raw = lobe.get('follower', 'flat')
    if isinstance(raw, Mapping):   # {kind: roller, radius: r} accepted too
        return _follower(f'{key}.follower.kind', f'{key}.follower.radius', raw.get('kind'),
                         raw.get('radius', lobe.get('follower_radius')), FOLLOWER_KINDS)
    return _follower(f'{key}.follower', f'{key}.follower_radius', raw,
                     lobe.get('follower_radius'), FOLLOWER_KINDS)


def _number_list(key: str, value: Any) -> np.ndarray:
    """A list of finite numbers as float array; the error names the first bad entry."""
    if not isinstance(value, (list, tuple)):
        raise InputError(key, value, 'a list of numbers')
    for j, v in enumerate(value):
        if isinstance(v, bool) or isinstance(v, (list, dict)):
            raise InputError(f'{key}[{j}]', v, 'a finite number')
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        arr = None
    if arr is None or not np.all(np.isfinite(arr)):
        for j, v in enumerate(value):
            require_finite(f'{key}[{j}]', v)
    return np.asarray(arr, dtype=float)


def _lift_table(ctx: _Ctx, key: str, value: Any) -> LiftLaw:
    table = ctx.mapping(key, value, ('alpha', 'h'))
    for part in ('alpha', 'h'):
        if part not in table:
            raise InputError(f'{key}.{part}', None, 'a list of numbers (alpha rad, h m)')
    alpha = _number_list(f'{key}.alpha', table['alpha'])
    h = _number_list(f'{key}.h', table['h'])
    if alpha.size != h.size:
        raise InputError(f'{key}.h', f'{h.size} values',
                         f'as many values as {key}.alpha ({alpha.size})')
    if alpha.size < 6:
        raise InputError(f'{key}.alpha', f'{alpha.size} points', 'at least 6 points')
    bad = np.nonzero(np.diff(alpha) <= 0)[0]
    if bad.size:
        j = int(bad[0]) + 1
        raise InputError(f'{key}.alpha[{j}]', float(alpha[j]),
                         f'strictly increasing angles in rad (previous is {alpha[j - 1]:g})')
    return _table_law(ctx, key, alpha, h)


def _table_law(ctx: _Ctx, key: str, alpha: np.ndarray, h: np.ndarray, *,
               design: bool = True) -> LiftLaw:
    """The lobe law of a design table (``cam_design.lift_table.lobe_table``: the same lobe as
    every other route reads from these rows; ``design``: first the rules of a scene
    table, ``check_design_table``); its warnings go to the scene's."""
    from cam_design.lift_table.lobe_table import lobe_law

    a, v = (check_design_table(alpha, h, key) if design else (alpha, h))
    # a scene's lobe is told from its centreline, in (-180, 180] deg (a nominal file
    # written 0..360 deg with its nose at 300 deg: a lobe at -60 deg, as the scene says)
    law = lobe_law(a, v, key=key, turn_from=-math.pi)
    if law.lobe.method != 'interpolated' or law.lobe.warnings:
        ctx.warnings.append(f'{key}: ' + law.lobe.note()
                            + ''.join(f'; {w}' for w in law.lobe.warnings))
    return law


def _registry() -> Any:
    """The lift-law registry module, or None while it is not written."""
    name = 'cam_design.lift_laws.registry'
    try:
        return importlib.import_module(name)
    except ModuleNotFoundError as exc:
        if exc.name != name:
            raise
        return None


def lift_law_from_spec(spec: Mapping[str, Any], key: str) -> LiftLaw:
    """Build a lift law from a scene ``lift_law`` mapping with the lift-law registry
    (``cam_design.lift_laws.from_spec``); InputError naming ``key`` on bad input."""
    registry = _registry()
    if registry is None:
        raise InputError(f'{key}.family', spec.get('family'),
                         'a lift-law family; lift_law: family not available in this '
                         'build (cam_design.lift_laws.registry missing); use a lift table')
    try:
        law = registry.from_spec(spec, key)   # family table: the table's lobe law
    except InputError:
        raise
    except (TypeError, ValueError, KeyError, ArithmeticError) as exc:
        raise InputError(key, dict(spec), f'valid lift-law parameters ({exc})') from None
    if not isinstance(law, LiftLaw):
        raise InputError(key, type(law).__name__, 'a LiftLaw from the registry')
    return law


def _check_law(key: str, law: LiftLaw) -> None:
    """The law must be a lobe: finite support within (-pi, pi], finite positive lift."""
    lo, hi = law.support
    if not (math.isfinite(lo) and math.isfinite(hi) and -math.pi - 1e-9 <= lo < hi
            and hi <= math.pi + 1e-9):
        raise InputError(key, (lo, hi), 'a lobe whose support lies within [-pi, pi] rad')
    grid = np.linspace(lo, hi, 2001)
    h = law(grid)
    if not np.all(np.isfinite(h)):
        raise InputError(key, 'non-finite lift', 'a lift law with finite values')
    if float(np.max(h)) <= 0.0:
        raise InputError(key, float(np.max(h)), 'a lobe with a positive lift in m')


def _check_conversions(ctx: _Ctx, lobes: list[Lobe], base: float, probe: Follower) -> None:
    """Warn when a lobe's design lift cannot be converted to the probe (undercut design
    profile, concave flank under a flat probe, roller probe too large): the analysis
    will then report the lobe as failed with the same reason."""
    from cam_design import follower as fol

    convert = getattr(fol, 'convert_lift', None)
    if convert is None:
        return
    for i, lobe in enumerate(lobes):
        key = f'lobes[{i}].lift_law' if lobe.lift_spec is not None else f'lobes[{i}].lift'
        try:
            law = convert(lobe.lift, base, lobe.follower, probe, key=key)
            lo, hi = law.support
            law(np.linspace(lo, hi, 721))
        except InputError as exc:
            ctx.warnings.append(f'{key}: the design lift cannot be seen by the '
                                f'{probe.kind} probe: {exc}')


# ----------------------------------------------------------------- pin, compute, valve

def _dowel_pin(ctx: _Ctx, value: Any) -> DowelPin:
    from cam_design.dowel_pin import DowelPinGeometry

    pin = ctx.mapping('dowel_pin', value, PIN_KEYS)
    for k in PIN_KEYS[:3]:
        if k not in pin:
            raise InputError(f'dowel_pin.{k}', None, 'a radius in m')
    radii = {k: require_length(f'dowel_pin.{k}', pin[k], GEOMETRY_MAX_M,
                               allow_zero=k == 'probe_radius')
             for k in PIN_KEYS[:3]}
    DowelPinGeometry(**radii)   # raises InputError('dowel_pin.circle_radius', ...)
    return DowelPin(nominal_angle=_optional_angle('dowel_pin.nominal_angle',
                                                  pin.get('nominal_angle')), **radii)


def _keyway(ctx: _Ctx, value: Any) -> Keyway:
    from cam_design.keyway import KeywayGeometry

    kw = ctx.mapping('keyway', value, KEYWAY_KEYS)
    for k in KEYWAY_KEYS[:3]:
        if k not in kw:
            raise InputError(f'keyway.{k}', None, 'a length in m (> 0)')
    dims = {k: require_positive(f'keyway.{k}', kw[k]) for k in KEYWAY_KEYS[:3]}
    depth = None if kw.get('depth') is None else require_positive('keyway.depth', kw['depth'])
    KeywayGeometry(depth=depth, **dims)   # raises InputError('keyway.<key>', ...)
    return Keyway(depth=depth, nominal_angle=_optional_angle('keyway.nominal_angle',
                                                             kw.get('nominal_angle')), **dims)


def _crank(ctx: _Ctx, value: Any, datum: Any, lobes: list[Lobe]) -> Crank | None:
    """The crank datum: cylinder 1's TDC [cam deg from the datum, like a phase] and the
    other cylinders' TDC [crank deg after cylinder 1's]; needs a pin or keyway datum."""
    if value is None:
        if any(lobe.role for lobe in lobes):
            ctx.warnings.append('lobes[].role: given but the scene has no crank datum; '
                                'no crank-degree events')
        return None
    if datum is None:
        raise InputError('crank', 'given without a datum', 'a dowel_pin or keyway in the '
                         'scene: TDC is placed relative to it (or no crank block)')
    crank = ctx.mapping('crank', value, CRANK_KEYS)
    if 'tdc_deg' not in crank:
        raise InputError('crank.tdc_deg', None, 'the cam angle [deg] from the datum to '
                         'cylinder 1 TDC (of the overlap), measured like a phase')
    tdc = require_finite('crank.tdc_deg', crank['tdc_deg'])
    if abs(tdc) > 360.0:
        raise InputError('crank.tdc_deg', tdc, 'cam degrees within [-360, 360]')
    raw = crank.get('cylinder_tdc_deg', {1: 0.0})
    if not isinstance(raw, Mapping) or not raw:
        raise InputError('crank.cylinder_tdc_deg', raw, 'a mapping cylinder -> crank deg of '
                         "its TDC after cylinder 1's, e.g. {1: 0, 2: 360}")
    cyl = {str(k): require_finite(f'crank.cylinder_tdc_deg.{k}', v) for k, v in raw.items()}
    for lobe in lobes:
        if lobe.role and lobe.cylinder not in cyl:
            i = lobes.index(lobe)
            raise InputError(f'lobes[{i}].cylinder', lobe.cylinder,
                             'one of the cylinders of crank.cylinder_tdc_deg: '
                             + ', '.join(cyl))
    return Crank(tdc_deg=tdc, cylinder_tdc_deg=cyl)


def _compute(value: Any) -> frozenset[str] | None:
    if value is None:
        return None
    if isinstance(value, str):
        value = [value]
    if not isinstance(value, list):
        raise InputError('compute', value, 'a list of ' + ', '.join(COMPUTE_ITEMS))
    for j, item in enumerate(value):
        if item not in COMPUTE_ITEMS:
            raise InputError(f'compute[{j}]', item, 'one of ' + ', '.join(COMPUTE_ITEMS))
    return frozenset(value)


def _valve_train(ctx: _Ctx, value: Any) -> ValveTrain:
    known = ('model', 'seat', 'cam_speed_rpm', 'mdof', 'hydraulic', 'spring',
             'piston', 'gas', 'hla') + tuple(VALVE_KEYS)
    vt = ctx.mapping('valve_train', value, known)
    model = vt.get('model', 'sdof')
    if model not in VALVE_MODELS:
        raise InputError('valve_train.model', model, ' | '.join(VALVE_MODELS))
    hydraulic = model == 'hydraulic'
    params: dict[str, float] = {}
    for k, (required, check) in VALVE_KEYS.items():
        if k in vt:
            params[k] = check(f'valve_train.{k}', vt[k])
        elif hydraulic and k in HYDRAULIC_UNUSED:
            params[k] = HYDRAULIC_UNUSED[k]
        elif required:
            raise InputError(f'valve_train.{k}', None, 'a value (see docs/scene.md)')
    seat = _seat(ctx, vt.get('seat'))
    block = vt.get('hydraulic')
    if hydraulic or block is not None:
        from cam_design.hydraulic.run import hydraulic_params

        hydraulic_params(block, mass=params['mass'], spring_rate=params['spring_rate'],
                         spring_preload=params['spring_preload'],
                         valve_damping=params.get('valve_damping', 0.0),
                         restitution=seat.restitution)   # validated here, built per run
        if not hydraulic:
            ctx.warnings.append(f'valve_train.hydraulic: ignored by model {model} (set '
                                'valve_train.model: hydraulic to use it)')
    speeds = _speeds(vt.get('cam_speed_rpm', [1500.0]))
    mdof = vt.get('mdof')
    if mdof is not None and not isinstance(mdof, Mapping):
        raise InputError('valve_train.mdof', mdof, 'a mapping of the 4+N1+N2 model parameters')
    if model == 'mdof' and mdof is None:
        ctx.warnings.append('valve_train.mdof: model mdof without an mdof block; the '
                            'dynamics node uses its defaults')
    from cam_design.valve_train.physics import train_checks_from

    train_checks_from(vt.get('spring'), vt.get('piston'))     # validated here, named keys
    spring, piston = vt.get('spring'), vt.get('piston')
    gas = _gas(ctx, vt.get('gas'))
    hla = vt.get('hla')
    if hla is not None:
        from cam_design.hydraulic.hla_coupled import HLA_KEYS, hla_from_mapping

        hla = {k: v for k, v in ctx.mapping('valve_train.hla', hla, HLA_KEYS).items()
               if k in HLA_KEYS}
        hla_from_mapping(hla)                       # validated here, named keys
        if model == 'hydraulic':
            raise InputError('valve_train.hla', 'with model hydraulic',
                             'model sdof or mdof (the hydraulic gear has no lash adjuster)')
        if seat.restitution is not None:
            raise InputError('valve_train.hla', 'with a hard seat (seat.restitution)',
                             'the penalty seat (the coupled HLA uses it)')
    return ValveTrain(model=model, seat=seat, cam_speed_rpm=speeds, gas=gas, hla=hla,
                      mdof=dict(mdof) if mdof is not None else None,
                      hydraulic=dict(block) if block is not None else None,
                      spring=dict(spring) if spring is not None else None,
                      piston=dict(piston) if piston is not None else None, **params)


GAS_KEYS = ('crank_deg', 'pressure_pa', 'head_diameter', 'back_pressure_pa',
            'lobe_start_crank_deg')


def _gas(ctx: _Ctx, value: Any) -> dict[str, Any] | None:
    """``valve_train.gas``: cylinder pressure (gauge Pa) against crank angle [deg] over
    720 deg, valve head diameter [m], port back pressure [Pa], and the crank angle [deg]
    at which the lobe's lift starts (the timing)."""
    if value is None:
        return None
    from cam_design.hydraulic.gas import gas_force

    g = ctx.mapping('valve_train.gas', value, GAS_KEYS)
    for k in ('crank_deg', 'pressure_pa', 'head_diameter', 'lobe_start_crank_deg'):
        if k not in g:
            raise InputError(f'valve_train.gas.{k}', None, 'a value (docs/scene.md)')
    crank = _number_list('valve_train.gas.crank_deg', g['crank_deg'])
    pressure = _number_list('valve_train.gas.pressure_pa', g['pressure_pa'])
    if pressure.shape != crank.shape:
        raise InputError('valve_train.gas.pressure_pa', f'{pressure.size} values',
                         f'one pressure per crank angle ({crank.size})')
    if crank.size and (crank.min() < 0 or crank.max() > 720):
        raise InputError('valve_train.gas.crank_deg', f'[{crank.min():g}, {crank.max():g}]',
                         'crank angles within [0, 720] deg (one four-stroke cycle)')
    out = {'crank_deg': crank.tolist(), 'pressure_pa': pressure.tolist(),
           'head_diameter': require_positive('valve_train.gas.head_diameter',
                                             g['head_diameter']),
           'back_pressure_pa': require_finite('valve_train.gas.back_pressure_pa',
                                              g.get('back_pressure_pa', 0.0)),
           'lobe_start_crank_deg': require_finite('valve_train.gas.lobe_start_crank_deg',
                                                  g['lobe_start_crank_deg'])}
    gas_force(out['crank_deg'], out['pressure_pa'], out['head_diameter'],
              out['back_pressure_pa'])        # the table's own checks
    return out


def _seat(ctx: _Ctx, value: Any) -> Seat:
    if value is None:
        return Seat()
    seat = ctx.mapping('valve_train.seat', value, SEAT_KEYS)
    stiffness = require_positive('valve_train.seat.stiffness', seat.get('stiffness', 1.0e9))
    damping = require_positive('valve_train.seat.damping', seat.get('damping', 2000.0),
                               allow_zero=True)
    restitution = seat.get('restitution')
    if restitution is not None:
        restitution = require_finite('valve_train.seat.restitution', restitution)
        if not 0.0 <= restitution <= 1.0:
            raise InputError('valve_train.seat.restitution', restitution,
                             'a coefficient of restitution in [0, 1]')
    return Seat(stiffness=stiffness, damping=damping, restitution=restitution)


def _speeds(value: Any) -> tuple[float, ...]:
    if not isinstance(value, list):
        value = [value]
    if not value:
        raise InputError('valve_train.cam_speed_rpm', value, 'at least one camshaft speed')
    return tuple(require_positive(f'valve_train.cam_speed_rpm[{j}]', v)
                 for j, v in enumerate(value))


# --------------------------------------------------------------------- tolerances

def _band(key: str, value: Any) -> Band:
    """``t`` (>= 0) -> (-t, t); ``[lower, upper]`` with lower <= 0 <= upper, lower < upper."""
    if isinstance(value, (list, tuple)):
        if len(value) != 2:
            raise InputError(key, value, 'a band: one number t >= 0 (meaning +-t) or '
                             '[lower, upper]')
        lo = require_finite(f'{key}[0]', value[0])
        hi = require_finite(f'{key}[1]', value[1])
        if not lo < hi:
            raise InputError(key, value, '[lower, upper] with lower < upper (the limits '
                             'contradict each other)')
        if not lo <= 0.0 <= hi:
            raise InputError(key, value, '[lower, upper] with lower <= 0 <= upper (a band '
                             'the nominal part is inside)')
        return (lo, hi)
    t = require_positive(key, value)
    return (-t, t)


def _zones(ctx: _Ctx, key: str, value: Any) -> tuple[ToleranceZone, ...]:
    if not isinstance(value, list) or not value:
        raise InputError(key, value, 'a list of {from_deg, to_deg, band_um}')
    zones = []
    for j, item in enumerate(value):
        zk = f'{key}[{j}]'
        z = ctx.mapping(zk, item, ('from_deg', 'to_deg', 'band_um'))
        expected = ('a value (from_deg < to_deg in cam deg from the lobe centreline, band_um '
                    't or [lower, upper])')
        if 'band_um' not in z and 'from_deg' in z and 'to_deg' in z:
            raise InputError(f'{zk}.band_um', None, expected)
        lo, hi = zone_span(zk, z, expected)
        zones.append(ToleranceZone(lo, hi, _band(f'{zk}.band_um', z['band_um'])))
    check_no_overlap(key, [(z.from_deg, z.to_deg) for z in zones])
    return tuple(sorted(zones, key=lambda zz: zz.from_deg))


def _tolerance_block(ctx: _Ctx, key: str, value: Any, known: tuple[str, ...]
                     ) -> dict[str, Any]:
    """The validated entries of one tolerances mapping (absent keys absent)."""
    if value is None:
        return {}
    block = ctx.mapping(key, value, known)
    out: dict[str, Any] = {}
    for k in TOL_BANDS + ('datum_deg',):
        if k in block and k in known:
            out[k] = _band(f'{key}.{k}', block[k])
    if 'lift_error_zones' in block:
        out['lift_error_zones'] = _zones(ctx, f'{key}.lift_error_zones',
                                         block['lift_error_zones'])
    if 'derivative_error_zones' in block:
        out['derivative_error_zones'] = parse_derivative_zones(
            f'{key}.derivative_error_zones', block['derivative_error_zones'], ctx.mapping)
    for k in TOL_MAXIMA:
        if k in block:
            out[k] = require_positive(f'{key}.{k}', block[k], allow_zero=True)
    if 'checking_height_mm' in block:
        out['checking_height_mm'] = require_positive(f'{key}.checking_height_mm',
                                                     block['checking_height_mm'])
    return out


def _lobe_tolerances(ctx: _Ctx, key: str, value: Any, defaults: dict[str, Any],
                     law: LiftLaw, phase: float | None) -> Tolerances | None:
    """Defaults overridden key by key by the lobe's own block; None if nothing is set."""
    own = _tolerance_block(ctx, f'{key}.tolerances', value, TOL_KEYS)
    merged = {k: v for k, v in defaults.items() if k != 'datum_deg'}
    merged.update(own)
    if not merged:
        return None
    tol = Tolerances(**merged)
    where = f'{key}.tolerances' if own else 'tolerances'
    if tol.phase_deg is not None and phase is None:
        raise InputError(f'{where}.phase_deg', tol.phase_deg, f'a {key}.nominal_phase to '
                         'check the phase against (or no phase tolerance for this lobe)')
    if tol.duration_deg is not None or tol.centreline_deg is not None:
        peak = law.max_lift() * 1e3
        if not tol.checking_height_mm < peak:
            hk = f'{key}.tolerances' if 'checking_height_mm' in own else 'tolerances'
            raise InputError(f'{hk}.checking_height_mm', tol.checking_height_mm,
                             f'a checking height below the max lift of {key} '
                             f'({peak:.4f} mm)')
    return tol


def _datum_tolerance(defaults: dict[str, Any], pin: DowelPin | Keyway | None
                     ) -> Band | None:
    band = defaults.get('datum_deg')
    if band is None:
        return None
    if pin is None or pin.nominal_angle is None:
        raise InputError('tolerances.datum_deg', band, 'a dowel_pin or keyway with a '
                         'nominal_angle to check the datum against (or no datum tolerance)')
    return band


def valve_train_from_mapping(value: Any, key: str = 'valve_train') -> ValveTrain:
    """A ``valve_train`` block (a mapping, e.g. a rig scene's ``rig.true_valve_train``)
    validated into a ValveTrain; refusals name the keys under ``key``."""
    try:
        return _valve_train(_Ctx(), value)
    except InputError as exc:
        if key == 'valve_train' or not exc.key.startswith('valve_train'):
            raise
        raise InputError(key + exc.key[len('valve_train'):], exc.value,
                         exc.expected) from None


def load_valve_train(path: Path) -> tuple[ValveTrain, Scene | None]:
    """(ValveTrain, Scene or None) from a scene YAML or a YAML holding only the
    ``valve_train`` block (with or without the ``valve_train:`` key): ``--valve-train``."""
    import yaml

    from cam_metrology.inputs.yaml_input import load_yaml, syntax_error_text

    if not path.is_file():
        raise FileNotFoundError(f'no such valve-train file: {path}')
    text = read_text_file(path, 'YAML file', key='--valve-train')
    try:
        doc = load_yaml(text, '--valve-train')
    except yaml.YAMLError as exc:
        raise InputError('--valve-train', str(path),
                         f'valid YAML ({syntax_error_text(exc, text)})') from None
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
