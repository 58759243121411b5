"""Lift-law specs in SI: a lift typed in millimetres (8.0 for 8 mm) or micrometres is
refused naming the key and the unit it looks like, instead of an 8 m cam."""
from __future__ import annotations

import math

import pytest

from cam_design.errors import InputError
from cam_design.lift_laws.registry import from_spec

D = math.pi / 180.0
POLY = {'family': 'polynomial', 'rise': 8.0e-3, 'half_angle': 60 * D,
        'exponents': [2, 6, 10, 14]}


@pytest.mark.parametrize('spec, key, value, unit, fix', [
    ({**POLY, 'rise': 8.0}, 'lift_law.rise', 8.0, 'millimetres', '0.008'),
    ({**POLY, 'rise': None, 'max_lift': 9000.0}, 'lift_law.max_lift', 9000.0,
     'micrometres', '0.009'),
    ({**POLY, 'ramp': {'kind': 'constant_velocity', 'height': 0.3, 'velocity': 0.01}},
     'lift_law.ramp.height', 0.3, 'millimetres', '0.0003'),
    ({'family': 'harmonic', 'order': 4, 'max_lift': 8.0, 'half_angle': 60 * D},
     'lift_law.max_lift', 8.0,
     'millimetres', '0.008'),
])
def test_lift_in_mm_names_the_unit(spec, key, value, unit, fix) -> None:
    with pytest.raises(InputError) as err:
        from_spec(spec)
    assert err.value.key == key and err.value.value == value
    assert unit in err.value.expected and f'write {fix}' in err.value.expected


def test_a_large_lift_in_metres_is_kept() -> None:
    law = from_spec({**POLY, 'rise': 0.05})          # a 50 mm marine-diesel lobe
    assert law.max_lift() == pytest.approx(0.05, rel=1e-6)
