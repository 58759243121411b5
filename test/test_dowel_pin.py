"""Dowel-pin geometry of seed 004 (methods.md §5.4, §7 cases 5 and 6)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from cam_design.dowel_pin import DowelPinGeometry
from cam_design.errors import InputError

MM = 1e-3
SEED = DowelPinGeometry(pin_radius=2.5 * MM, circle_radius=11.5 * MM, probe_radius=2.0 * MM)


def dms(d: float, m: float, s: float) -> float:
    """Degrees-minutes-seconds to radians."""
    return math.radians(d + m / 60 + s / 3600)


def test_case5_contact_angle_and_lifts() -> None:
    """alpha_max = 23.035684° (seed prints the truncated 23°02'06"), h(0) = 14 mm,
    h(alpha_max) = 8.583005 mm."""
    assert math.degrees(SEED.contact_half_angle) == pytest.approx(23.035684, abs=1e-6)
    assert SEED.lift(0.0) == pytest.approx(14.000 * MM, abs=1e-12)
    assert SEED.lift(SEED.contact_half_angle) == pytest.approx(8.583005 * MM, abs=1e-9)
    assert SEED.lift_min == pytest.approx(8.583005 * MM, abs=1e-9)
    assert SEED.lift_max == pytest.approx(14.0 * MM, abs=1e-15)


def test_case6_lift_at_seed_rounded_angle() -> None:
    """At the seed's rounded 23°02'06" the lift is 8.61678 mm (printed h_m = h_n = 8.617 mm)."""
    assert SEED.lift(dms(23, 2, 6)) == pytest.approx(8.61678 * MM, abs=5e-4 * MM)
    # symmetric cam: h(-a) = h(a), h'(-a) = -h'(a)
    a = np.linspace(-0.39, 0.39, 41)
    np.testing.assert_allclose(SEED.lift(-a), SEED.lift(a), rtol=0, atol=1e-16)
    np.testing.assert_allclose(SEED.lift(-a, 1), -SEED.lift(a, 1), rtol=0, atol=1e-16)


def test_law_of_cosines_closure() -> None:
    """Independent check: the probe centre at L is exactly R_x + R_c from the pin centre."""
    a = np.linspace(-0.4, 0.4, 81)
    centre_distance = SEED.lift(a) + SEED.probe_radius
    pin = SEED.circle_radius * np.stack([np.cos(a), np.sin(a)])
    probe = np.stack([centre_distance, np.zeros_like(a)])
    gap = np.hypot(*(probe - pin))
    np.testing.assert_allclose(gap, SEED.pin_radius + SEED.probe_radius, rtol=0, atol=1e-15)


@pytest.mark.parametrize('nu', [1, 2, 3])
def test_derivatives_match_complex_step_free_difference(nu: int) -> None:
    """Analytic h', h'', h''' against a 4th-order central difference of the lower one."""
    a = np.linspace(-0.38, 0.38, 37)
    e = 1e-4
    lower = SEED.lift
    fd = (-lower(a + 2 * e, nu - 1) + 8 * lower(a + e, nu - 1)
          - 8 * lower(a - e, nu - 1) + lower(a - 2 * e, nu - 1)) / (12 * e)
    scale = np.max(np.abs(fd))
    np.testing.assert_allclose(SEED.lift(a, nu), fd, rtol=0, atol=1e-8 * scale)


def test_seed_printed_slope_lacks_cos_factor() -> None:
    """The seed prints h' = -R_z sin a [1 + R_z / sqrt(.)]; the true slope has R_z cos a."""
    a = 0.3
    rz, rho = SEED.circle_radius, SEED.pin_radius + SEED.probe_radius
    root = math.sqrt(rho**2 - (rz * math.sin(a)) ** 2)
    printed = -rz * math.sin(a) * (1 + rz / root)
    assert SEED.lift(a, 1) != pytest.approx(printed, rel=1e-3)
    assert SEED.lift(a, 1) == pytest.approx(-rz * math.sin(a) * (1 + rz * math.cos(a) / root))


def test_no_contact_is_nan_not_a_number() -> None:
    """Outside contact the lift is undefined: NaN, never a plausible-looking value."""
    assert np.isnan(SEED.lift(0.5))
    assert np.isnan(SEED.lift(-0.5, 2))
    # behind the axis the radicand is positive again, but the probe cannot reach the pin
    for nu in range(4):
        assert np.all(np.isnan(SEED.lift(np.array([np.pi, -np.pi, 3.0, np.pi / 2 + 0.01]), nu)))


@pytest.mark.parametrize('kwargs, key', [
    ({'pin_radius': -1e-3, 'circle_radius': 0.01, 'probe_radius': 0.002}, 'pin_radius'),
    ({'pin_radius': 1e-3, 'circle_radius': 0.0, 'probe_radius': 0.002}, 'circle_radius'),
    ({'pin_radius': 1e-3, 'circle_radius': 0.01, 'probe_radius': float('nan')}, 'probe_radius'),
    ({'pin_radius': 5e-3, 'circle_radius': 0.006, 'probe_radius': 0.002}, 'circle_radius'),
])
def test_bad_geometry_names_the_key(kwargs: dict, key: str) -> None:
    with pytest.raises(InputError, match=f'dowel_pin.{key}'):
        DowelPinGeometry(**kwargs)
