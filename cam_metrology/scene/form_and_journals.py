"""Scene keys of the form analysis and of the journals (validated, errors naming the key;
docs/scene.md): the ``form`` block (cut-off of the Gaussian filter and the waviness band
[UPR]), the ``journals`` list and ``probe.zero_radius``."""
from __future__ import annotations

from typing import Any, Callable, Mapping

from cam_design.errors import InputError, require_finite, require_length, require_positive
from cam_metrology.scene.model import DerivativeZone, FormSettings, Journal, Tolerances

#: highest cut-off or band edge a scene may ask for [UPR] (a 0.01 deg encoder resolves 18 000)
MAX_UPR = 18_000


def _upr(key: str, value: Any) -> int:
    """A whole number of UPR in [1, MAX_UPR]."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or \
            int(value) != value or not 1 <= value <= MAX_UPR:
        raise InputError(key, value, f'a whole number of undulations per revolution in '
                         f'[1, {MAX_UPR}]')
    return int(value)


def parse_form(block: Mapping[str, Any] | None) -> FormSettings:
    """FormSettings of the scene's ``form`` mapping (defaults when None)."""
    if block is None:
        return FormSettings()
    cutoff = _upr('form.cutoff_upr', block.get('cutoff_upr', FormSettings.cutoff_upr))
    derivs = block.get('derivative_errors', False)
    if not isinstance(derivs, bool):
        raise InputError('form.derivative_errors', derivs, 'true or false')
    band = block.get('waviness_band_upr')
    if band is None:
        return FormSettings(cutoff, None, derivs)
    if not isinstance(band, (list, tuple)) or len(band) != 2:
        raise InputError('form.waviness_band_upr', band, '[lo, hi] in UPR')
    lo = _upr('form.waviness_band_upr[0]', band[0])
    hi = _upr('form.waviness_band_upr[1]', band[1])
    if lo > hi:
        raise InputError('form.waviness_band_upr', list(band), '[lo, hi] with lo <= hi')
    return FormSettings(cutoff, (lo, hi), derivs)


JOURNAL_KEYS = ('id', 'radius', 'axial_position', 'tolerances')
#: tolerance keys a journal takes (µm): maxima, and the diameter band
JOURNAL_TOL_KEYS = ('runout_max_um', 'roundness_max_um', 'waviness_max_um', 'diameter_um')
#: largest plausible radius or axial position [m]
GEOMETRY_MAX_M = 2.0


def parse_journals(value: Any, mapping: Callable[[str, Any, tuple[str, ...]], Mapping],
                   taken: set[str], band: Callable[[str, Any], tuple[float, float]]
                   ) -> tuple[Journal, ...]:
    """Journals of the scene's ``journals`` list. ``mapping`` validates a mapping (unknown
    keys warned), ``taken`` holds the ids already used by other features, ``band`` parses
    a tolerance band."""
    if value is None:
        return ()
    if not isinstance(value, list):
        raise InputError('journals', value, 'a list of {id, radius, axial_position}')
    out: list[Journal] = []
    for i, item in enumerate(value):
        key = f'journals[{i}]'
        j = mapping(key, item, JOURNAL_KEYS)
        jid = str(j.get('id', '')).strip()
        if not jid or any(c.isspace() for c in jid) or '@' in jid:
            raise InputError(f'{key}.id', j.get('id'), 'a feature id without white space '
                             "or '@', such as journal_1")
        if jid in taken:
            raise InputError(f'{key}.id', jid, 'an id no other feature of the scene has')
        taken.add(jid)
        if j.get('radius') is None:
            raise InputError(f'{key}.radius', None, 'the nominal journal radius in m (> 0)')
        radius = require_length(f'{key}.radius', j['radius'], GEOMETRY_MAX_M)
        if j.get('axial_position') is None:
            raise InputError(f'{key}.axial_position', None, 'the axial position along the '
                             'shaft in m (the same origin for every feature)')
        z = parse_axial_position(f'{key}.axial_position', j['axial_position'])
        tol, diameter = _tolerances(f'{key}.tolerances', j.get('tolerances'), mapping, band)
        out.append(Journal(jid, radius, z, tol, diameter))
    return tuple(out)


def parse_axial_position(key: str, value: Any) -> float:
    """An axial position along the shaft [m] (journals and lobes, one origin)."""
    z = require_finite(key, value)
    if abs(z) > GEOMETRY_MAX_M:
        raise InputError(key, z, f'a position in m within +-{GEOMETRY_MAX_M:g} '
                         '(millimetres given?)')
    return z


def _tolerances(key: str, value: Any, mapping: Callable[..., Mapping],
                band: Callable[[str, Any], tuple[float, float]]
                ) -> tuple[Tolerances | None, tuple[float, float] | None]:
    """(Tolerances of the maxima, diameter band) of a journal's ``tolerances``."""
    if value is None:
        return None, None
    block = mapping(key, value, JOURNAL_TOL_KEYS)

    def maximum(k: str) -> float | None:
        return require_positive(f'{key}.{k}', block[k], allow_zero=True) \
            if k in block else None

    tol = Tolerances(runout_max_um=maximum('runout_max_um'),
                     roundness_max_um=maximum('roundness_max_um'),
                     waviness_max_um=maximum('waviness_max_um'))
    diameter = band(f'{key}.diameter_um', block['diameter_um']) \
        if 'diameter_um' in block else None
    return (tol if tol.any() else None), diameter


def zone_span(key: str, zone: Mapping[str, Any], expected: str) -> tuple[float, float]:
    """(from_deg, to_deg) of one angle zone ``key``: both present (else InputError with
    ``expected``), finite, from < to within [-180, 180] cam deg."""
    for part in ('from_deg', 'to_deg'):
        if part not in zone:
            raise InputError(f'{key}.{part}', None, expected)
    lo = require_finite(f'{key}.from_deg', zone['from_deg'])
    hi = require_finite(f'{key}.to_deg', zone['to_deg'])
    if not -180.0 <= lo < hi <= 180.0:
        raise InputError(f'{key}.to_deg', hi, f'an angle > from_deg ({lo:g}) within '
                         '[-180, 180] deg')
    return lo, hi


def check_no_overlap(key: str, spans: list[tuple[float, float]]) -> None:
    """InputError naming ``key`` when two angle spans (from_deg, to_deg) overlap."""
    ordered = sorted(spans)
    for (a0, a1), (b0, b1) in zip(ordered, ordered[1:]):
        if b0 < a1:
            raise InputError(key, f'zones {a0:g}..{a1:g} and {b0:g}..{b1:g} deg overlap',
                             'zones that do not overlap (two limits for one angle '
                             'contradict each other)')


DERIVATIVE_ZONE_KEYS = ('from_deg', 'to_deg', 'velocity_max_mm_per_rad',
                        'acceleration_max_mm_per_rad2')


def parse_derivative_zones(key: str, value: Any,
                           mapping: Callable[[str, Any, tuple[str, ...]], Mapping]
                           ) -> tuple[DerivativeZone, ...]:
    """``tolerances.derivative_error_zones``: a list of {from_deg, to_deg,
    velocity_max_mm_per_rad, acceleration_max_mm_per_rad2} (at least one of the two
    maxima, >= 0), in cam deg from the lobe centreline within [-180, 180], not
    overlapping."""
    if not isinstance(value, list) or not value:
        raise InputError(key, value, 'a list of {from_deg, to_deg, velocity_max_mm_per_rad, '
                         'acceleration_max_mm_per_rad2}')
    zones = []
    for j, item in enumerate(value):
        zk = f'{key}[{j}]'
        z = mapping(zk, item, DERIVATIVE_ZONE_KEYS)
        lo, hi = zone_span(zk, z, 'a cam angle in deg from the lobe centreline (from_deg < '
                           'to_deg)')
        limits = [require_positive(f'{zk}.{k}', z[k], allow_zero=True) if k in z else None
                  for k in DERIVATIVE_ZONE_KEYS[2:]]
        if all(v is None for v in limits):
            raise InputError(f'{zk}.velocity_max_mm_per_rad', None, 'a velocity_max_mm_per_rad '
                             'or acceleration_max_mm_per_rad2 for this zone')
        zones.append(DerivativeZone(lo, hi, *limits))
    check_no_overlap(key, [(z.from_deg, z.to_deg) for z in zones])
    return tuple(sorted(zones, key=lambda zz: zz.from_deg))


def parse_zero_radius(value: Any) -> float | None:
    """``probe.zero_radius`` [m]: the radius at which the probe reads 0 (set on a master)."""
    if value is None:
        return None
    return require_length('probe.zero_radius', value, GEOMETRY_MAX_M, allow_zero=True)
