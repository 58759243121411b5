"""The shared LiftLaw interface and TabulatedLift (cam_design/lift_laws/base.py)."""
from __future__ import annotations

import numpy as np
import pytest

from cam_design.errors import InputError, require_finite, require_positive
from cam_design.lift_laws import TabulatedLift


def cosine_bump(a: np.ndarray, nu: int = 0, width: float = 1.0, lift: float = 8e-3) -> np.ndarray:
    """h = lift cos^4(pi a / (2 width)) and its derivatives (closed form), zero outside."""
    w = np.pi / (2 * width)
    c, s = np.cos(w * a), np.sin(w * a)
    forms = [c**4, -4 * w * c**3 * s, w**2 * (12 * c**2 * s**2 - 4 * c**4),
             w**3 * (-24 * c * s**3 + 40 * c**3 * s)]
    return np.where(np.abs(a) <= width, lift * forms[nu], 0.0)


def test_tabulated_reproduces_smooth_law_and_derivatives() -> None:
    a = np.linspace(-1.0, 1.0, 721)
    law = TabulatedLift(a, cosine_bump(a))
    x = np.linspace(-0.95, 0.95, 333)
    for nu, tol in [(0, 1e-12), (1, 1e-9), (2, 1e-6), (3, 1e-3)]:
        err = np.max(np.abs(law(x, nu) - cosine_bump(x, nu)))
        assert err < tol * np.max(np.abs(cosine_bump(x, nu))), (nu, err)


def test_outside_support_is_base_circle_and_shape_kept() -> None:
    a = np.linspace(-1.0, 1.0, 101)
    law = TabulatedLift(a, cosine_bump(a))
    assert law.support == (-1.0, 1.0)
    assert law(np.array([-2.0, 1.5])).tolist() == [0.0, 0.0]
    grid = np.zeros((3, 4))
    assert law(grid).shape == (3, 4)
    assert law.derivatives([0.0, 0.1]).shape == (4, 2)
    assert law(0.0) == pytest.approx(8e-3, abs=1e-12)


@pytest.mark.parametrize('alpha, h, match', [
    ([0, 1, 1, 2, 3, 4], [0] * 6, r'lift.alpha\[2\].*strictly increasing'),
    ([0, 1, 2, 3, 4, 5], [0] * 5, r'lift.h.*as many values'),
    ([0, 1, 2], [0] * 3, 'at least 6'),
    ([0, 1, 2, 3, 4, float('nan')], [0] * 6, 'lift.alpha.*finite'),
    ([0, 1, 2, 3, 4, 5], [0, 0, float('inf'), 0, 0, 0], 'lift.h.*finite'),
    ([5, 4, 3, 2, 1, 0], [0] * 6, 'strictly increasing'),
    ([0, 1, 2, 'x', 4, 5], [0] * 6, r'lift.alpha: .*list of numbers'),
    ([0, 1, 2, 3, 4, 5], [0, [1, 2], 0, 0, 0, 0], r'lift.h: .*list of numbers'),
])
def test_bad_tables_are_rejected_with_key(alpha: list, h: list, match: str) -> None:
    with pytest.raises(InputError, match=match):
        TabulatedLift(alpha, h)


def test_derivative_order_is_checked() -> None:
    law = TabulatedLift(np.linspace(-1, 1, 11), np.zeros(11))
    with pytest.raises(InputError, match='nu'):
        law(0.0, 4)


def test_require_helpers() -> None:
    assert require_finite('k', '2.5') == 2.5
    with pytest.raises(InputError, match='k: got True'):
        require_finite('k', True)
    with pytest.raises(InputError, match='> 0'):
        require_positive('r', 0.0)
    assert require_positive('r', 0.0, allow_zero=True) == 0.0
    err = InputError('a.b', 'x' * 200, 'short')
    assert len(str(err)) < 120 and err.key == 'a.b'


def test_coarse_table_that_rings_below_the_base_circle_is_rejected() -> None:
    """QA #29: a 7-point lobe interpolated to -1 mm between its points, silently."""
    alpha = [-1.2, -0.8, -0.4, 0.0, 0.4, 0.8, 1.2]
    h = [0.0, 0.001, 0.006, 0.008, 0.006, 0.001, 0.0]
    with pytest.raises(InputError, match=r'lift.alpha: .*tabulate more points'):
        TabulatedLift(alpha, h)
    # the same lobe finely tabulated is accepted and stays >= 0 within 1 um
    a = np.linspace(-np.pi / 2, np.pi / 2, 181)
    law = TabulatedLift(a, cosine_bump(a, width=np.pi / 2))
    assert np.min(law(np.linspace(-1.5, 1.5, 5001))) > -1e-6


@pytest.mark.parametrize('h, match', [
    ([0, 1e-3, -5e-4, 8e-3, 1e-3, 0], r'lift.h\[2\]: .*>= 0'),
    ([1e-3, 2e-3, 5e-3, 8e-3, 2e-3, 0], r'lift.h\[0\]: .*both ends'),
    ([0, 1, 5, 8, 1, 0], r'lift.h: .*mm given'),
    ([0, 0, 0, 0, 0, 0], r'lift.h: .*positive lift'),
])
def test_design_table_rules(h: list, match: str) -> None:
    """A design table covers the whole lobe: >= 0, zero at both ends, in metres."""
    from cam_design.lift_laws.base import check_design_table
    with pytest.raises(InputError, match=match):
        check_design_table(np.linspace(-1.0, 1.0, 6), np.array(h, dtype=float), 'lift')


def test_table_family_and_scene_share_the_design_rules() -> None:
    """`family: table` used to accept negative lifts and non-zero ends (QA, reconstruct fixer)."""
    from cam_design.lift_laws import from_spec
    a = np.linspace(-1.2, 1.2, 49)
    good = cosine_bump(a, width=1.2)
    assert from_spec({'family': 'table', 'alpha': a.tolist(), 'h': good.tolist()},
                     'lobes[0].lift_law')(0.0) == pytest.approx(8e-3)
    with pytest.raises(InputError, match=r'lobes\[0\].lift_law.h\[0\]: .*both ends'):
        from_spec({'family': 'table', 'alpha': a.tolist(), 'h': (good + 1e-3).tolist()},
                  'lobes[0].lift_law')
    with pytest.raises(InputError, match=r'lift_law.alpha\[0\]: .*degrees given'):
        from_spec({'family': 'table', 'alpha': (a * 180).tolist(), 'h': good.tolist()},
                  'lift_law')
