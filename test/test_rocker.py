"""CG rocker synthesis (seed 001, methods.md §6 and §7 #1-#4)."""
from __future__ import annotations

import math

import pytest

from cam_design.errors import InputError
from cam_design.rocker import (eccentricity_for, frame_length_for, optimality,
                               sampled_deviation, synthesize, tangent_geometry)

D = math.pi / 180
L_ARM, RB = 45.8, 32.3      # mm (the synthesis is unit-agnostic)


def test_cg125_case_1() -> None:
    """#1 (erratum 1: S1 eq (10) drops y_K^2 from c; only the corrected c gives the
    paper's L_o = 57.494851 mm. The printed c gives eta* = 3.089746 deg,
    L = 57.559115 and L_o = 57.552078 mm, 57 um off the paper's own result)."""
    r = synthesize(L_ARM, RB, 7.865 * D, 0.9)
    assert math.degrees(r.eta) == pytest.approx(3.089302, abs=2e-6)
    assert r.frame_length == pytest.approx(57.501894, abs=2e-6)
    assert r.projected_frame_length == pytest.approx(57.494851, abs=2e-6)
    assert math.degrees(r.delta) == pytest.approx(0.118066, abs=1e-6)


def test_cg150_case_2_erratum_2() -> None:
    """#2 (erratum 2): the printed eta* = 3.307633 deg and L = 57.60741 mm follow from
    psi_max = 8.4519 deg, not the printed 8.541 deg. The printed delta = +-0.133395 deg
    is not reproduced (we get +-0.135340)."""
    r = synthesize(L_ARM, RB, 8.4519 * D)
    assert math.degrees(r.eta) == pytest.approx(3.307633, abs=2e-6)
    assert r.frame_length == pytest.approx(57.607410, abs=2e-6)
    assert math.degrees(r.delta) == pytest.approx(0.135340, abs=1e-6)


def test_cg150_as_printed_case_3() -> None:
    """#3: psi_max = 8.541 deg exactly as printed."""
    r = synthesize(L_ARM, RB, 8.541 * D)
    assert math.degrees(r.eta) == pytest.approx(3.340644, abs=1e-6)
    assert math.degrees(r.geometry.delta_tangent) == pytest.approx(0.138054, abs=1e-6)
    assert math.degrees(r.geometry.delta_end) == pytest.approx(-0.138054, abs=1e-6)
    assert r.frame_length == pytest.approx(57.623391, abs=1e-6)


def test_eccentricity_case_4() -> None:
    """#4: L = 57.60741, L_o = 57.6 -> e = 0.92395179; e = 0.92 -> L = 57.6073467."""
    assert eccentricity_for(57.60741, 57.6) == pytest.approx(0.92395179, abs=1e-7)
    assert frame_length_for(57.6, 0.92) == pytest.approx(57.6073467, abs=1e-7)


@pytest.mark.parametrize('psi', [7.865, 8.4519, 8.541, 5.0, 12.0])
def test_sampled_arc_matches_extremes(psi: float) -> None:
    """Independent check by sampling the tip over the arc: min = delta1, max = delta2,
    and they are equal and opposite at the optimum."""
    r = synthesize(L_ARM, RB, psi * D)
    lo, hi = sampled_deviation(r)
    assert hi == pytest.approx(r.geometry.delta_tangent, abs=1e-9)
    assert lo == pytest.approx(r.geometry.delta_end, abs=1e-12)
    assert hi == pytest.approx(-lo, rel=1e-9)


def test_bracket_signs() -> None:
    """f < 0 near eta = 0 and > 0 at psi_max (methods: about -0.013 and +0.031 rad)."""
    assert optimality(1e-6, L_ARM, RB, 8.4519 * D) == pytest.approx(-0.0127, abs=5e-4)
    assert optimality(8.4519 * D, L_ARM, RB, 8.4519 * D) == pytest.approx(0.0308, abs=5e-4)


def test_geometry_cam_centre_on_base_circle() -> None:
    """O1 lies on circle II and on the tangent at K."""
    g = tangent_geometry(3 * D, L_ARM, RB, 8 * D)
    assert math.hypot(g.x_o1, g.y_o1) == pytest.approx(RB, rel=1e-13)


@pytest.mark.parametrize('args,key', [((-1.0, RB, 0.1), 'arm_length'),
                                      ((L_ARM, 0.0, 0.1), 'base_radius'),
                                      ((L_ARM, RB, float('nan')), 'max_swing'),
                                      ((L_ARM, RB, 1.2), 'max_swing'),
                                      ((L_ARM, RB, 0.1, 100.0), 'eccentricity')])
def test_invalid(args: tuple, key: str) -> None:
    """Bad inputs name the parameter."""
    with pytest.raises(InputError) as info:
        synthesize(*args)
    assert info.value.key == key


@pytest.mark.parametrize('psi', [7.865, 8.4519, 8.541])
def test_polar_form_eqs_4_6(psi: float) -> None:
    """Independent check with S1 eqs 4-6: psi0 = arccos((L^2 + l^2 - R_b^2)/(2 L l)),
    tan beta = l sin(psi0 + psi)/(L - l cos(psi0 + psi)), delta = beta0 - beta: its
    extremes over the stroke are +-delta* at the optimum L."""
    import numpy as np

    r = synthesize(L_ARM, RB, psi * D)
    big = r.frame_length
    psi0 = math.acos((big ** 2 + L_ARM ** 2 - RB ** 2) / (2 * big * L_ARM))
    s = np.linspace(0, psi * D, 200001)
    beta = np.arctan2(L_ARM * np.sin(psi0 + s), big - L_ARM * np.cos(psi0 + s))
    delta = beta[0] - beta
    assert max(abs(delta.max()), abs(delta.min())) == pytest.approx(r.delta, rel=1e-8)
    assert delta.max() == pytest.approx(-delta.min(), rel=1e-8)


@pytest.mark.parametrize('unit', [1e297, 1e-300])
def test_extreme_length_units_are_scale_invariant(unit: float) -> None:
    """QA: the construction is scale-invariant; lengths given in any unit (here 1e297
    and 1e-300 x mm) must give case #1 scaled, not an OverflowError or underflow."""
    r = synthesize(L_ARM * unit, RB * unit, 7.865 * D, 0.9 * unit)
    assert math.degrees(r.eta) == pytest.approx(3.089302, abs=2e-6)
    assert r.frame_length / unit == pytest.approx(57.501894, abs=2e-6)
    assert r.projected_frame_length / unit == pytest.approx(57.494851, abs=2e-6)


def test_tiny_base_radius_against_huge_arm_is_input_error() -> None:
    """QA: `design rocker --arm-length 1e300 --base-radius 0.0323` raised OverflowError
    (a traceback); it must be an InputError naming the user's base radius."""
    with pytest.raises(InputError) as exc:
        synthesize(1e300, 0.0323, 7.865 * D)
    assert exc.value.key == 'base_radius' and exc.value.value == 0.0323
