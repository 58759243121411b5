"""Top point / false asymmetry (methods §5.3) on features measured over several
revolutions with identical encoder angles (QA finding A1).

The bench repeats exactly the same encoder counts on every revolution; after the
mapping x = wrap(theta - x0) the repeated angles differ only by rounding (~1e-15 rad).
The regression spline used to count samples instead of positions, put one knot
interval per distinct angle and returned garbage (asymmetry 0.1-0.7 deg, residual
asymmetry up to 1e10 um). Truth here: a symmetric closed-form lobe, true axis 0.
"""
from __future__ import annotations

import numpy as np
import pytest

from cam_design.errors import InputError
from cam_metrology.metrology.analysis import Settings, analyze_lobe
from cam_metrology.metrology.asymmetry import (_check_conditioning, lift_spline,
                                               merge_repeated, top_point)
from cam_metrology.metrology.features import clean_feature
from cam_metrology.metrology.synthetic import PolynomialRampCam, sample_lobe

CAM = PolynomialRampCam()
NOSE = np.radians(123.4567)
NOISE = 0.5e-6   # m


def _analyze(n_per_rev: int, revs: float, noise: float, seed: int = 3, *,
             direction: int = 1, turn: int = 1, wrapped: bool = False) -> dict:
    smp = sample_lobe(CAM, NOSE, direction, n_per_rev=n_per_rev, revolutions=revs,
                      noise=noise, seed=seed, turn=turn, wrapped=wrapped)
    fs = clean_feature('lobe_1', smp.stamp_ns, smp.theta, smp.s)
    res = analyze_lobe(fs, CAM, direction, Settings())
    assert [w for w, _ in res.skipped if w == 'asymmetry'] == []
    return res.values


@pytest.mark.parametrize('revs', [2, 3])
@pytest.mark.parametrize('n_per_rev', [720, 1440])
def test_noise_free_repeated_angles_exact(n_per_rev, revs):
    """Before the fix: 720/rev x 2 gave 1.7e-7 deg and 0.07 um (near-singular)."""
    v = _analyze(n_per_rev, revs, 0.0)
    assert abs(v['asymmetry_deg']) < 1e-6
    assert abs(v['asymmetry_flank_deg']) < 1e-6
    res = v['residual_asymmetry_um']
    assert np.isfinite(res['rms']) and res['rms'] < 1e-3   # observed 1e-4..2e-4 um
    assert res['max'] < 1e-2


@pytest.mark.parametrize('revs', [2, 3])
@pytest.mark.parametrize('n_per_rev', [720, 1440])
@pytest.mark.parametrize('seed', [3, 11])
def test_noisy_repeated_angles_within_reported_sigma(n_per_rev, revs, seed):
    """0.5 um probe noise. Bound: |asymmetry| < 2 x angle_std_deg (the LSQ nose std).
    Over 40 seeds per case the asymmetry scatter was 0.20-0.22 x angle_std_deg and
    the largest |asymmetry| 0.49 x angle_std_deg, so the bound is ~9 standard
    deviations of the estimator. Before the fix 720/rev x 2, seed 3 gave 0.71 deg
    (5000 sigma) and a residual asymmetry of 1.5e5 um; 720/rev x 3 gave -0.26 deg."""
    v = _analyze(n_per_rev, revs, NOISE, seed)
    assert abs(v['asymmetry_deg']) < 2 * v['angle_std_deg']
    res = v['residual_asymmetry_um']
    # difference of two spline values of noisy data: rms ~0.3-0.4 um for 0.5 um noise
    assert np.isfinite(res['rms']) and res['rms'] < 2 * NOISE * 1e6
    assert np.isfinite(res['max']) and res['max'] < 10 * NOISE * 1e6
    assert abs(v['asymmetry_flank_deg']) < 0.01


@pytest.mark.parametrize('direction,turn,wrapped,revs', [
    (-1, 1, True, 2.0), (1, -1, True, 3.0), (-1, -1, False, 2.5)])
def test_repeated_angles_any_sense_wrapping_partial_revolution(direction, turn, wrapped,
                                                               revs):
    """Reversed encoder, direction -1, wrapped angles and a partial last revolution
    (positions seen 2 or 3 times: sqrt(count) weights)."""
    exact = _analyze(720, revs, 0.0, direction=direction, turn=turn, wrapped=wrapped)
    assert abs(exact['asymmetry_deg']) < 1e-6
    assert exact['residual_asymmetry_um']['rms'] < 1e-3
    noisy = _analyze(720, revs, NOISE, 5, direction=direction, turn=turn, wrapped=wrapped)
    assert abs(noisy['asymmetry_deg']) < 2 * noisy['angle_std_deg']
    assert noisy['residual_asymmetry_um']['rms'] < 2 * NOISE * 1e6


def test_merge_repeated_is_the_weighted_mean():
    a = np.array([0.3, 0.1, 0.3 + 2e-16, 0.2, 0.1 - 1e-15, 0.1])
    h = np.array([1.0, 2.0, 3.0, 4.0, 5.0, 8.0])
    pos, mean, count = merge_repeated(a, h)
    assert pos == pytest.approx([0.1, 0.2, 0.3], abs=1e-14)
    assert mean == pytest.approx([5.0, 4.0, 2.0], abs=1e-14)
    assert count.tolist() == [3, 1, 2]


def test_regression_on_merged_positions_equals_fit_of_all_samples():
    """Averaging repeated angles with sqrt(count) weights loses nothing: the spline is
    that of one revolution of the mean readings (independent reference)."""
    one = np.radians(np.arange(-80.0, 80.0 + 1e-9, 0.5))
    rng = np.random.default_rng(7)
    revs = [one + 1e-15 * k for k in range(3)]        # rounding-level differences
    lift = [CAM(one) + NOISE * rng.standard_normal(one.size) for _ in revs]
    spline = lift_spline(np.concatenate(revs), np.concatenate(lift),
                         knot_spacing=np.radians(0.5))
    ref = lift_spline(one, np.mean(lift, axis=0), knot_spacing=np.radians(0.5))
    grid = np.linspace(one[0], one[-1], 997)
    assert np.max(np.abs(spline(grid) - ref(grid))) < 1e-12


def test_methods_21_with_the_table_repeated():
    """methods §7 #21 (§1.4 cam at 0.5 deg, instrument = true - 0.37 deg -> -0.37 deg),
    the table read three times over identical angles: interpolation and regression."""
    a = np.radians(np.arange(-90.0, 90.0001, 0.5))
    h = CAM(a + np.radians(0.37))
    a3, h3 = np.tile(a, 3), np.tile(h, 3)
    a3[a.size:] += 1e-15 * np.sign(a3[a.size:])
    # the regression (knots widened to 1 deg for 0.5 deg data) approximates the ramp
    # junctions to ~1e-9 m; the interpolation reproduces the table
    for kw, tol in (({}, 1e-9), ({'knot_spacing': np.radians(0.5)}, 1e-8)):
        tp = top_point(lift_spline(a3, h3, **kw), a[0], a[-1])
        assert np.degrees(tp.d) == pytest.approx(-0.37, abs=1e-6)
        assert np.degrees(tp.d_flank) == pytest.approx(-0.37, abs=1e-6)
        assert tp.residual_rms < tol < tp.apparent_rms


def test_rank_deficient_regression_is_refused_with_a_reason():
    """The old failure mode (one knot interval per distinct angle over duplicated
    angles) is caught by the guard on the normal matrix, not solved into garbage."""
    one = np.radians(np.arange(-80.0, 80.0 + 1e-9, 0.5))
    knots = np.concatenate((np.full(6, one[0]), np.linspace(one[0], one[-1], one.size)[1:-1],
                            np.full(6, one[-1])))
    with pytest.raises(InputError, match='ill-conditioned'):
        _check_conditioning(one, np.ones(one.size), knots, np.radians(0.5))
    # the knots lift_spline chooses for the same data are well posed
    lift_spline(np.tile(one, 2), np.tile(CAM(one), 2), knot_spacing=np.radians(0.5))


def test_encoder_noise_does_not_narrow_the_knots():
    """Repeated positions scattered by 4 arcsec of encoder noise still count once."""
    one = np.radians(np.arange(-80.0, 80.0 + 1e-9, 0.5))
    rng = np.random.default_rng(2)
    a = np.concatenate([one + np.radians(4 / 3600) * rng.standard_normal(one.size)
                        for _ in range(2)])
    h = CAM(a) + NOISE * rng.standard_normal(a.size)
    tp = top_point(lift_spline(a, h, knot_spacing=np.radians(0.5)), -1.3, 1.3)
    assert abs(np.degrees(tp.d)) < 1e-3
    assert tp.residual_rms < 2 * NOISE


def test_non_finite_input_is_refused():
    a = np.radians(np.arange(-80.0, 80.0 + 1e-9, 0.5))
    h = CAM(a)
    h[10] = np.nan
    with pytest.raises(InputError, match='non-finite'):
        lift_spline(np.tile(a, 2), np.tile(h, 2), knot_spacing=np.radians(0.5))
