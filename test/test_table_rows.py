"""What cleaning a measured table did to its rows is said, never silent: a non-finite
row dropped, repeated angles merged (with the largest spread between the repeats, so a
bad duplicate row is found by its angle), in the dynamics' note and in its refusal."""
from __future__ import annotations

import math

import numpy as np
import pytest

from cam_design.errors import InputError
from cam_design.lift_table.samples import clean_samples
from cam_design.lift_table.lobe_table import lobe_law

D = math.pi / 180.0


def _lobe(deg: np.ndarray) -> np.ndarray:
    """A 140 deg cos^2 lobe of 8 mm rounded to 0.01 mm [m]."""
    x = np.clip(deg * D * 180.0 / 140.0, -math.pi / 2, math.pi / 2)
    return np.round(8.0 * np.cos(x) ** 2 * 100.0) / 1e5


def test_merged_repeats_report_their_largest_spread() -> None:
    a = np.array([0.0, 1.0, 1.0, 2.0, 3.0, 3.0, 4.0, 5.0, 6.0, 7.0]) * D
    h = np.array([0.0, 1.0, 1.5, 2.0, 3.0, 3.1, 4.0, 5.0, 6.0, 7.0]) * 1e-3
    out = clean_samples(a, h)
    assert out.merged_repeats == 2
    assert out.lift[1] == pytest.approx(1.25e-3, rel=1e-12)
    assert 'largest spread 0.5 mm at 1.000 deg' in out.notes[-1]


def test_dynamics_table_says_what_was_dropped() -> None:
    deg = np.arange(-175.0, 180.0, 5.0)
    h = _lobe(deg)
    h[deg == 10.0] = np.nan
    law = lobe_law(deg * D, h, key='lobe.csv')
    said = '; '.join(law.lobe.warnings)
    assert 'rows: dropped 1 non-finite sample(s) (the first: sample 38 at 10 deg)' in said


def test_a_typed_row_is_named_when_the_lobe_is_refused() -> None:
    """One row typed 90 mm instead of 0.9 mm in a 1 deg table: the lobe no cam can
    have is refused, and the refusal names that row (angle, lift, how far off its
    neighbours) instead of only the peak acceleration."""
    deg = np.arange(-180.0, 180.0, 1.0)
    h = _lobe(deg)
    h[deg == -60.0] = 90e-3
    with pytest.raises(InputError) as err:
        lobe_law(deg * D, h, key='lobe.csv')
    text = str(err.value)
    assert 'lobe.csv' in text and 'peak acceleration' in text
    assert 'the row at -60 deg (90 mm) stands' in text and 'a typo?' in text


def test_a_conflicting_repeat_is_named_in_the_refusal() -> None:
    deg = np.arange(-175.0, 180.0, 5.0)
    h = _lobe(deg)
    a = np.append(deg, -85.0) * D
    v = np.append(h, 3e-3)   # the lobe is 0 there: a row pasted from elsewhere
    with pytest.raises(InputError) as err:
        lobe_law(a, v, key='lobe.csv')
    text = str(err.value)
    assert 'largest spread 3 mm at -85.000 deg' in text and 'mend the repeated rows' in text
