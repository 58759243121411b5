"""The scene's ``camshaft:`` block as typed values (docs/contract.md, docs/camshaft.md).

Stations along the shaft, in axial order: ``sprocket`` (exactly once), every lobe of
the scene (by its id) and any number of journals (other names). ``sections[i]`` joins
``stations[i]`` and ``stations[i + 1]``: a solid or hollow round bar of ``length`` and
``diameter`` (optional ``bore``) in m. SI units throughout; every refusal names the key.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from cam_design.errors import InputError, require_finite, require_mapping, require_positive

SPROCKET = 'sprocket'
DRIVE_KINDS = ('constant_speed', 'chain', 'belt', 'gear')
BLOCK_KEYS = ('stations', 'sections', 'material', 'inertias', 'lobe_inertia',
              'damping_ratio', 'drive', 'friction', 'journal_radius')
MATERIAL_KEYS = ('shear_modulus', 'density')
SECTION_KEYS = ('length', 'diameter', 'bore')
DRIVE_KEYS = ('kind', 'stiffness', 'damping', 'sprocket_inertia', 'phaser_deg')
FRICTION_KEYS = ('cam_follower', 'roller', 'bearing')
FLAT_KEYS = ('coefficient', 'boundary', 'fluid', 'roughness', 'k_film', 'k_film_rpm')
ROLLER_KEYS = ('rolling_resistance', 'traction', 'inertia', 'pin_radius', 'pin_coefficient')
BEARING_KEYS = ('coefficient',)
#: a friction coefficient above this is refused (dry steel on steel is about 0.8)
MU_MAX = 1.0


@dataclass(frozen=True)
class Section:
    """A round bar between two stations: length, outer diameter and bore [m]."""

    length: float
    diameter: float
    bore: float = 0.0


@dataclass(frozen=True)
class Drive:
    """How the sprocket turns: ``constant_speed`` (the sprocket follows the crank
    exactly) or a chain/belt/gear as a torsional spring ``stiffness`` [N m/rad] and
    damper ``damping`` [N m s/rad] to the crank, the sprocket's inertia [kg m^2] and a
    constant phaser advance [deg cam]."""

    kind: str = 'constant_speed'
    stiffness: float = 0.0
    damping: float = 0.0
    sprocket_inertia: float = 0.0
    phaser_deg: float = 0.0


@dataclass(frozen=True)
class FlatFriction:
    """Flat-tappet friction: a constant ``coefficient``, or the mixed-lubrication blend
    of ``boundary`` and ``fluid`` coefficients over the film parameter
    Lambda = h_min / ``roughness`` (h_min of the oil-film check with ``k_film`` [m/m]
    at ``k_film_rpm``, scaled with speed^0.7)."""

    coefficient: float | None = None
    boundary: float = 0.0
    fluid: float = 0.0
    roughness: float = 0.0
    k_film: float = 0.0
    k_film_rpm: float = 0.0


@dataclass(frozen=True)
class RollerFriction:
    """Roller follower: rolling-resistance coefficient [-] of the roller on the cam,
    traction coefficient [-] the contact can transmit, roller inertia [kg m^2] about
    its pin, pin radius [m] and pin friction coefficient [-]."""

    rolling_resistance: float = 0.0
    traction: float = 0.1
    inertia: float = 0.0
    pin_radius: float = 0.0
    pin_coefficient: float = 0.0


@dataclass(frozen=True)
class Friction:
    """Friction of the camshaft: cam-follower (flat or roller) and journal bearings
    (``bearing`` coefficient on the journal radius)."""

    flat: FlatFriction | None = None
    roller: RollerFriction | None = None
    bearing: float = 0.0


@dataclass(frozen=True)
class CamshaftSpec:
    """The validated ``camshaft:`` block."""

    stations: tuple[str, ...]
    sections: tuple[Section, ...]
    shear_modulus: float = 8.0e10
    density: float = 7850.0
    inertias: tuple[tuple[str, float], ...] = ()
    lobe_inertia: float = 0.0
    damping_ratio: float = 0.02
    drive: Drive = Drive()
    friction: Friction = Friction()
    journal_radius: float = 0.0

    def inertia_of(self, station: str) -> float:
        """Added inertia [kg m^2] at a station (``inertias``, else ``lobe_inertia`` for
        lobes)."""
        return dict(self.inertias).get(station, 0.0)


def _coefficient(block: Mapping[str, Any], key: str, name: str,
                 default: float | None) -> float:
    value = block.get(name, default)
    mu = require_finite(f'{key}.{name}', value)
    if not 0.0 <= mu <= MU_MAX:
        raise InputError(f'{key}.{name}', value, f'a friction coefficient in [0, {MU_MAX:g}]')
    return mu


def _positive(block: Mapping[str, Any], key: str, name: str, default: Any = None) -> float:
    value = block.get(name, default)
    if value is None:
        raise InputError(f'{key}.{name}', None, 'a value > 0')
    return require_positive(f'{key}.{name}', value)


def _non_negative(block: Mapping[str, Any], key: str, name: str, default: float) -> float:
    value = block.get(name, default)
    x = require_finite(f'{key}.{name}', value)
    if x < 0:
        raise InputError(f'{key}.{name}', value, 'a value >= 0')
    return x


def _sections(value: Any, n: int, key: str) -> tuple[Section, ...]:
    if not isinstance(value, Sequence) or isinstance(value, (str, bytes)) or len(value) != n:
        raise InputError(key, value, f'a list of {n} sections (one between each pair of '
                         'neighbouring stations)')
    out = []
    for i, s in enumerate(value):
        k = f'{key}[{i}]'
        s = require_mapping(s, k, SECTION_KEYS)
        d = _positive(s, k, 'diameter')
        bore = _non_negative(s, k, 'bore', 0.0)
        if bore >= d:
            raise InputError(f'{k}.bore', s['bore'], f'a bore below the diameter {d:g} m')
        out.append(Section(length=_positive(s, k, 'length'), diameter=d, bore=bore))
    return tuple(out)


def _drive(value: Any, key: str) -> Drive:
    d = require_mapping(value if value is not None else {}, key, DRIVE_KEYS)
    kind = d.get('kind', 'constant_speed')
    if kind not in DRIVE_KINDS:
        raise InputError(f'{key}.kind', kind, ' | '.join(DRIVE_KINDS))
    phaser = require_finite(f'{key}.phaser_deg', d.get('phaser_deg', 0.0))
    if kind == 'constant_speed':
        for k in ('stiffness', 'damping', 'sprocket_inertia'):
            if k in d:
                raise InputError(f'{key}.{k}', d[k], 'no value with kind constant_speed '
                                 '(the sprocket follows the crank exactly)')
        return Drive(phaser_deg=phaser)
    return Drive(kind=kind, stiffness=_positive(d, key, 'stiffness'),
                 damping=_non_negative(d, key, 'damping', 0.0),
                 sprocket_inertia=_non_negative(d, key, 'sprocket_inertia', 0.0),
                 phaser_deg=phaser)


def _friction(value: Any, key: str) -> Friction:
    if value is None:
        return Friction()
    f = require_mapping(value, key, FRICTION_KEYS)
    flat = roller = None
    if f.get('cam_follower') is not None:
        k = f'{key}.cam_follower'
        c = require_mapping(f['cam_follower'], k, FLAT_KEYS)
        if 'coefficient' in c:
            extra = [x for x in c if x != 'coefficient']
            if extra:
                raise InputError(f'{k}.{extra[0]}', c[extra[0]], 'no value with a constant '
                                 'coefficient (either coefficient or the mixed law)')
            flat = FlatFriction(coefficient=_coefficient(c, k, 'coefficient', 0.0))
        else:
            boundary = _coefficient(c, k, 'boundary', None)
            fluid = _coefficient(c, k, 'fluid', None)
            if fluid > boundary:
                raise InputError(f'{k}.fluid', c['fluid'], f'at most boundary ({boundary:g})')
            flat = FlatFriction(boundary=boundary, fluid=fluid,
                                roughness=_positive(c, k, 'roughness'),
                                k_film=_positive(c, k, 'k_film'),
                                k_film_rpm=_positive(c, k, 'k_film_rpm'))
    if f.get('roller') is not None:
        k = f'{key}.roller'
        r = require_mapping(f['roller'], k, ROLLER_KEYS)
        roller = RollerFriction(
            rolling_resistance=_coefficient(r, k, 'rolling_resistance', 0.0),
            traction=_coefficient(r, k, 'traction', 0.1),
            inertia=_non_negative(r, k, 'inertia', 0.0),
            pin_radius=_non_negative(r, k, 'pin_radius', 0.0),
            pin_coefficient=_coefficient(r, k, 'pin_coefficient', 0.0))
    bearing = 0.0
    if f.get('bearing') is not None:
        k = f'{key}.bearing'
        bearing = _coefficient(require_mapping(f['bearing'], k, BEARING_KEYS), k, 'coefficient',
                               0.0)
    return Friction(flat=flat, roller=roller, bearing=bearing)


def camshaft_from_mapping(block: Any, lobe_ids: Sequence[str],
                          key: str = 'camshaft') -> CamshaftSpec:
    """Validate the ``camshaft:`` block against the scene's lobe ids."""
    b = require_mapping(block, key, BLOCK_KEYS)
    stations = b.get('stations')
    if (not isinstance(stations, Sequence) or isinstance(stations, (str, bytes))
            or len(stations) < 2 or not all(isinstance(s, str) for s in stations)):
        raise InputError(f'{key}.stations', stations, 'a list of at least two station '
                         'names in axial order (sprocket, lobe ids, journals)')
    if len(set(stations)) != len(stations):
        dup = next(s for s in stations if stations.count(s) > 1)
        raise InputError(f'{key}.stations', dup, 'each station once')
    if stations.count(SPROCKET) != 1:
        raise InputError(f'{key}.stations', list(stations), f"one station named '{SPROCKET}'")
    for i, lobe in enumerate(lobe_ids):
        if lobe not in stations:
            raise InputError(f'{key}.stations', lobe, f'every lobe on the shaft: lobes[{i}] '
                             f'({lobe}) is carried by no section')
    sections = _sections(b.get('sections'), len(stations) - 1, f'{key}.sections')
    m = require_mapping(b.get('material', {}), f'{key}.material', MATERIAL_KEYS)
    inert = require_mapping(b.get('inertias', {}), f'{key}.inertias', stations)
    lobe_inertia = _non_negative(b, key, 'lobe_inertia', 0.0)
    inertias = {s: (lobe_inertia if s in lobe_ids else 0.0) for s in stations}
    inertias.update({s: _non_negative(inert, f'{key}.inertias', s, 0.0) for s in inert})
    zeta = _non_negative(b, key, 'damping_ratio', 0.02)
    if zeta >= 1.0:
        raise InputError(f'{key}.damping_ratio', b['damping_ratio'], 'a value in [0, 1)')
    friction = _friction(b.get('friction'), f'{key}.friction')
    journal_radius = _non_negative(b, key, 'journal_radius', 0.0)
    if friction.bearing > 0 and journal_radius <= 0:
        raise InputError(f'{key}.journal_radius', b.get('journal_radius'),
                         'a journal radius > 0 [m] with bearing friction')
    return CamshaftSpec(stations=tuple(stations), sections=sections,
                        shear_modulus=_positive(m, f'{key}.material', 'shear_modulus', 8.0e10),
                        density=_positive(m, f'{key}.material', 'density', 7850.0),
                        inertias=tuple(inertias.items()), lobe_inertia=lobe_inertia,
                        damping_ratio=zeta, drive=_drive(b.get('drive'), f'{key}.drive'),
                        friction=friction, journal_radius=journal_radius)
