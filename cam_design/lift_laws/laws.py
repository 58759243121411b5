"""Spec handling shared by the flank families; the polynomial and table families."""
from __future__ import annotations

from typing import Any, Callable, Mapping

from cam_design.errors import InputError
from cam_design.lift_laws import params as P
from cam_design.lift_laws.polynomial import polynomial_flank
from cam_design.lift_laws.ramps import Ramp, ramp_from_spec
from cam_design.lift_laws.segments import Flank, PiecewiseLaw, assemble_lobe


def rise_from(spec: Mapping, key: str, ramp_height: float) -> float:
    """Base-section rise [m] from exactly one of ``rise`` or ``max_lift`` (total lift)."""
    has_rise, has_max = spec.get('rise') is not None, spec.get('max_lift') is not None
    if has_rise == has_max:
        raise InputError(f'{key}.rise', spec.get('rise'),
                         'exactly one of rise (base-section rise) or max_lift (total lift)')
    if has_rise:
        return P.lift(spec, key, 'rise')
    total = P.lift(spec, key, 'max_lift')
    if total <= ramp_height:
        raise InputError(f'{key}.max_lift', total,
                         f'a total lift above the ramp height {ramp_height:.6g} m')
    return total - ramp_height


def fall_spec(spec: Mapping, key: str, allowed: tuple[str, ...]) -> dict[str, Any] | None:
    """The fall-flank parameters with defaults from the rise flank, or None (mirror)."""
    fall = spec.get('fall')
    if fall is None:
        return None
    fall = P.mapping(fall, f'{key}.fall')
    P.reject_unknown(fall, f'{key}.fall', allowed)
    merged = {k: v for k, v in spec.items()
              if k not in ('fall', 'rise', 'max_lift') and k in allowed}
    merged.update(fall)
    return merged


FlankBuilder = Callable[[Mapping, str, Ramp, float], Flank]


def flanked_lobe(spec: Mapping, key: str, names: tuple[str, ...], build: FlankBuilder,
                 name: str) -> PiecewiseLaw:
    """Spec handling shared by the ramp + base-section families.

    ``names``: the family's own parameters (besides ramp, rise|max_lift, fall);
    ``build(spec, key, ramp, rise)`` makes one flank. The optional ``fall`` mapping
    takes the same parameters (defaults from the rise flank); its rise follows from
    the nose lift."""
    P.reject_unknown(spec, key, ('ramp', 'rise', 'max_lift', 'fall') + names)
    ramp = ramp_from_spec(spec.get('ramp'), f'{key}.ramp')
    rise = rise_from(spec, key, ramp.height)
    rise_flank = build(spec, key, ramp, rise)
    fall = fall_spec(spec, key, ('ramp',) + names)
    fall_flank = None
    if fall is not None:
        fk = f'{key}.fall'
        framp = ramp_from_spec(fall.get('ramp'), f'{fk}.ramp')
        frise = ramp.height + rise - framp.height
        if frise <= 0:
            raise InputError(f'{fk}.ramp.height', framp.height,
                             'a fall ramp lower than the nose lift')
        fall_flank = build(fall, fk, framp, frise)
    return assemble_lobe(rise_flank, fall_flank, key=key, name=name)


def _polynomial_flank(spec: Mapping, key: str, ramp: Ramp, rise: float) -> Flank:
    return polynomial_flank(ramp, rise, P.angle(spec, key, 'half_angle'),
                            P.integers(spec, key, 'exponents', [2, 6, 10, 14]), key=key)


def polynomial_from_spec(spec: Mapping, key: str) -> PiecewiseLaw:
    """``family: polynomial`` (§1.4): ramp + polynomial base section."""
    return flanked_lobe(spec, key, ('half_angle', 'exponents'), _polynomial_flank,
                        'polynomial')
