"""``from_spec(spec, key)``: build any lift-law family from a scene ``lift_law`` mapping.

The mapping is ``{family: NAME, ...parameters}`` in SI units (m, rad, m/rad, kg, N/m);
every family and parameter is documented with an example in docs/lift_laws.md. Bad
parameters raise InputError naming ``key + '.' + param``. Unknown parameters are
rejected too (a typo must not silently fall back to a default).
"""
from __future__ import annotations

import importlib
import math
from typing import Any, Callable, Mapping

from cam_design.errors import InputError
from cam_design.lift_laws import params as P
from cam_design.lift_laws.base import LiftLaw

#: family name -> 'module:function' taking (spec, key) and returning a LiftLaw
FAMILIES: dict[str, str] = {
    'polynomial': 'cam_design.lift_laws.laws:polynomial_from_spec',
    'constant_acceleration': 'cam_design.lift_laws.composite:constant_acceleration_from_spec',
    'composite': 'cam_design.lift_laws.composite:composite_from_spec',
    'polydyne': 'cam_design.lift_laws.polydyne:polydyne_from_spec',
    'harmonic': 'cam_design.lift_laws.harmonic:harmonic_from_spec',
    'dual_peak': 'cam_design.lift_laws.dual_peak:dual_peak_from_spec',
    'table': 'cam_design.lift_table.lobe_routes:table_from_spec',
    'preset': 'cam_design.lift_laws.registry:preset_from_spec',
}

DEG = math.pi / 180.0

#: the §1.1 example ramp with a 25 deg angle (0.3 mm, 0.015 mm/deg)
_RAMP_25 = {'kind': 'constant_acceleration_velocity', 'height': 3.0e-4,
            'velocity': 0.015e-3 / DEG, 'angle': 25 * DEG}

#: Named lobes usable in a scene as ``{family: preset, name: NAME}``.
PRESETS: dict[str, dict[str, Any]] = {
    # Flat-tappet intake lobe for base_circle_radius 0.0165 m: S2 ramp (0.3 mm,
    # 0.015 mm/deg, 25 deg) + 2-10-18-26 polynomial, 8.2 mm base rise (8.5 mm total
    # lift), 65 deg half base section: 180 deg cam duration including the ramps,
    # minimum flat-tappet radius of curvature 4.32 mm (at +-27.9 deg), max |h'| 12.8 mm/rad
    # (tappet face radius > 13 mm). 2-6-10-14 would need a 70+ deg half base section
    # on this base circle (nose rho1 < 0 below ~66 deg).
    'flat_tappet_intake': {
        'family': 'polynomial',
        'ramp': _RAMP_25,
        'rise': 8.2e-3,
        'half_angle': 65 * DEG,
        'exponents': [2, 10, 18, 26],
    },
    # The worked example of docs/lift_laws.md (H = 8 mm, alpha2 = 100 deg) on the §1.1 ramp.
    'methods_example': {
        'family': 'polynomial',
        'ramp': dict(_RAMP_25, angle=30 * DEG),
        'rise': 8.0e-3,
        'half_angle': 50 * DEG,
        'exponents': [2, 6, 10, 14],
    },
}


def from_spec(spec: Mapping, key: str = 'lift_law') -> LiftLaw:
    """Build a lift law from ``{family: NAME, ...}`` (see docs/lift_laws.md)."""
    spec = P.mapping(spec, key)
    family = spec.get('family')
    if not isinstance(family, str) or family not in FAMILIES:
        raise InputError(f'{key}.family', family, 'one of ' + ', '.join(sorted(FAMILIES)))
    module, func = FAMILIES[family].split(':')
    builder: Callable[[Mapping, str], LiftLaw] = getattr(importlib.import_module(module), func)
    params = {k: v for k, v in spec.items() if k != 'family'}
    return builder(params, key)


def preset_spec(name: str, key: str = 'lift_law.name') -> dict[str, Any]:
    """A deep copy of the preset's spec."""
    import copy

    if not isinstance(name, str) or name not in PRESETS:
        raise InputError(key, name, 'one of ' + ', '.join(sorted(PRESETS)))
    return copy.deepcopy(PRESETS[name])


def preset_from_spec(spec: Mapping, key: str) -> LiftLaw:
    """``{family: preset, name: NAME}``."""
    P.reject_unknown(spec, key, ('name',))
    return from_spec(preset_spec(P.get(spec, key, 'name'), f'{key}.name'), key)
