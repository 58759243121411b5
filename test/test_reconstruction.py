"""Numerics of the reconstruction: rebound method, quintic smoothing spline, N-harmonic.

Truth is analytic: the methods.md §1.4 test cam (ramps + 2-6-10-14 polynomial) and an
eccentric disc, both with exact derivatives (cam_metrology.reconstruction.synthetic),
plus brute-force leave-one-out refits for the closed-form rebound.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.interpolate import CubicSpline, make_smoothing_spline

from cam_design.errors import InputError
from cam_design.lift_table.blas import single_thread_blas
from cam_metrology.reconstruction.harmonic import HarmonicOptions, reconstruct_harmonic
from cam_design.lift_table.samples import clean_samples
from cam_design.lift_table.rebound import (REBOUND_NOISE_FACTOR, ReboundOperator,
                                           rebound_fairing)
from cam_design.lift_table.spline import SplineOptions, reconstruct_spline
from cam_metrology.reconstruction.synthetic import (DEG, EccentricLobe, PolynomialLobe,
                                                    simulate)

LOBE = PolynomialLobe()


def rms_errors(rec, law) -> list[float]:
    return [float(np.sqrt(np.mean((d - law(rec.alpha, nu)) ** 2)))
            for nu, d in enumerate(rec.derivatives())]


def test_test_lobe_matches_methods_numbers():
    c = LOBE.coefficients()
    assert c[2] == pytest.approx(-17.001953125, abs=1e-9)
    assert c[14] == pytest.approx(2.353515625, abs=1e-9)
    assert LOBE(0.0, 2) * 1e3 == pytest.approx(-44.65130, abs=1e-4)   # mm/rad^2
    a = np.linspace(-1.5, 1.5, 11) + 0.0123
    for nu in range(3):
        fd = (LOBE(a + 1e-6, nu) - LOBE(a - 1e-6, nu)) / 2e-6
        assert np.allclose(fd, LOBE(a, nu + 1), atol=1e-8 * 10 ** nu)


def test_rebound_closed_form_equals_leave_one_out_refits():
    rng = np.random.default_rng(1)
    x = np.sort(rng.uniform(0.0, 3.0, 40))
    y = np.sin(3 * x) + rng.normal(0, 0.01, x.size)
    r = ReboundOperator(x).rebound(y)
    for i in range(1, x.size - 1):
        keep = np.arange(x.size) != i
        ref = CubicSpline(x[keep], y[keep], bc_type='natural')(x[i]) - y[i]
        assert r[i] == pytest.approx(ref, abs=1e-12)
    assert r[0] == 0.0 and r[-1] == 0.0


def test_rebound_noise_factor_matches_simulation():
    y = np.random.default_rng(0).normal(0.0, 1.0, 200_000)
    r = ReboundOperator(np.arange(y.size, dtype=float)).rebound(y)
    assert np.std(r[1:-1]) == pytest.approx(REBOUND_NOISE_FACTOR, rel=0.01)
    assert REBOUND_NOISE_FACTOR == pytest.approx(1.524, abs=0.002)


def test_methods_5_1_outlier_at_20_deg_is_flagged_and_removed():
    """§5.1: sigma = 0.5 um, +10 um at +20 deg: max |r| ~ 9 um at 20 deg, median ~0.44-0.5."""
    a = np.arange(-180.0, 180.0, 0.5) * DEG
    h = LOBE(a) + np.random.default_rng(0).normal(0.0, 0.5e-6, a.size)
    i20 = int(np.argmin(np.abs(a - 20 * DEG)))
    h[i20] += 10e-6
    r = ReboundOperator(a).rebound(h)
    assert int(np.argmax(np.abs(r))) == i20
    assert 8e-6 < abs(r[i20]) < 11.5e-6 and r[i20] < 0
    median = float(np.median(np.abs(r[1:-1])))
    # white noise: median |r| = 0.6745 * 1.524 * sigma = 0.514 um (methods prints 0.44)
    assert 0.40e-6 < median < 0.62e-6
    fair = rebound_fairing(a, h)
    assert np.flatnonzero(fair.outlier).tolist() == [i20]
    assert fair.sigma == pytest.approx(0.5e-6, rel=0.15)
    rec = reconstruct_spline(a, h)
    assert np.allclose(rec.outliers_alpha, [20 * DEG])
    assert rec.max_residual < 2.5e-6          # the spike is not in the fit


def test_spline_accuracy_and_better_acceleration_than_scipy_gcv():
    a, h = simulate(LOBE, 1200, 0.5e-6, seed=3, outliers=3)
    rec = reconstruct_spline(a, h)
    e = rms_errors(rec, LOBE)
    assert e[0] < 0.2e-6 and e[1] < 8e-6 and e[2] < 4e-4
    assert rec.parameter['outliers'] == 3
    assert rec.parameter['edf'] > 20
    with single_thread_blas():
        ref = make_smoothing_spline(a, h)
    e_ref = float(np.sqrt(np.mean((ref(rec.alpha, 2) - LOBE(rec.alpha, 2)) ** 2)))
    assert e[2] < 0.9 * e_ref


@pytest.mark.parametrize('criterion', ['gcv', 'risk'])
def test_spline_criteria_and_manual_smoothing(criterion):
    a, h = simulate(LOBE, 1800, 1e-6, seed=5)
    rec = reconstruct_spline(a, h, SplineOptions(criterion=criterion))
    assert rms_errors(rec, LOBE)[2] < 8e-4
    manual = reconstruct_spline(a, h, SplineOptions(smoothing=rec.parameter['smoothing']))
    assert manual.parameter['criterion'] == 'manual'
    assert np.allclose(manual.lift, rec.lift, atol=1e-9)
    stiff = reconstruct_spline(a, h, SplineOptions(smoothing=1e3 * rec.parameter['smoothing']))
    assert stiff.rms_residual > rec.rms_residual


def test_eccentric_disc_full_harmonic_is_order_one():
    law = EccentricLobe(4e-3)
    a, h = simulate(law, 720, 0.5e-6, seed=2)
    rec = reconstruct_harmonic(clean_samples(a, h), HarmonicOptions(basis='full'))
    assert rec.parameter['order'] == 1
    assert rec.spectrum[1][1] == pytest.approx(4e-3, abs=1e-7)
    e = rms_errors(rec, law)
    assert e[0] < 1e-7 and e[2] < 1e-7
    spl = reconstruct_spline(a, h)
    assert rms_errors(spl, law)[2] < 2e-4


def test_methods_5_2_orders_on_the_test_cam():
    """§5.2: (A) N ~ 20 / 30 / 60 for 9 / 1.8 / 0.12 um; (B) N = 15 for 1.1 um."""
    a = np.arange(-180.0, 180.0, 0.5) * DEG
    data = clean_samples(a, LOBE(a))
    got = []
    for tol in (9e-6, 1.8e-6, 0.12e-6):
        rec = reconstruct_harmonic(data, HarmonicOptions(basis='full', criterion='residual',
                                                         tol=tol))
        assert rec.max_residual <= tol
        got.append(rec.parameter['order'])
    assert got[0] == 20 and 28 <= got[1] <= 32 and 56 <= got[2] <= 64
    rec = reconstruct_harmonic(data, HarmonicOptions(order=15, half_angle=80 * DEG))
    assert rec.max_residual == pytest.approx(1.13e-6, rel=0.05)
    rec = reconstruct_harmonic(data, HarmonicOptions(criterion='residual', tol=1.2e-6,
                                                     half_angle=80 * DEG))
    assert rec.parameter['order'] == 15


def test_section_basis_automatic_on_noisy_test_cam():
    a, h = simulate(LOBE, 3600, 0.5e-6, seed=3, outliers=3)
    rec = reconstruct_harmonic(clean_samples(a, h))
    assert rec.parameter['basis'] == 'section' and not rec.parameter['asymmetric']
    assert rec.parameter['half_angle_rad'] == pytest.approx(80 * DEG, abs=2.5 * DEG)
    assert 12 <= rec.parameter['order'] <= 60
    e = rms_errors(rec, LOBE)
    assert e[0] < 0.2e-6 and e[2] < 5e-4
    assert rec.outliers_alpha.size == 3


def test_section_continuity_constraints_hold():
    a, h = simulate(LOBE, 720, 0.5e-6, seed=1)
    rec = reconstruct_harmonic(clean_samples(a, h), HarmonicOptions(
        order=20, continuity=3, half_angle=85 * DEG))
    phi = 85 * DEG
    for nu in range(4):
        scale = np.max(np.abs(rec.derivatives()[nu]))
        ends = rec.evaluate(np.array([-phi, phi]), nu)
        assert np.all(np.abs(ends) < 1e-9 * scale)


def test_asymmetric_lobe_gets_sines():
    def law(x, nu=0):
        return LOBE(x, nu) + (1e-4 * np.sin(x) * LOBE(x) / 8e-3 if nu == 0 else 0)
    a = np.arange(-180.0, 180.0, 0.25) * DEG
    h = law(a) + np.random.default_rng(4).normal(0, 0.3e-6, a.size)
    rec = reconstruct_harmonic(clean_samples(a, h))
    assert rec.parameter['asymmetric']
    assert rms_errors(rec, law)[0] < 1e-6


def test_orders_beyond_nyquist_are_capped_with_a_message():
    a, h = simulate(LOBE, 360, 0.5e-6, seed=1)
    data = clean_samples(a, h)
    full = reconstruct_harmonic(data, HarmonicOptions(basis='full', order=5000))
    assert full.parameter['order'] == full.parameter['nyquist_order'] == 179
    assert any('Nyquist' in w for w in full.warnings)
    sec = reconstruct_harmonic(data, HarmonicOptions(order=5000))
    assert sec.parameter['order'] == sec.parameter['nyquist_order']
    assert any('Nyquist' in w for w in sec.warnings)
    for rec in (full, sec):
        assert all(np.all(np.isfinite(d)) for d in rec.derivatives())


def test_full_basis_refuses_a_table_that_ends_on_a_flank():
    a = np.arange(-60.0, 60.0, 0.5) * DEG
    with pytest.raises(InputError, match='full'):
        reconstruct_harmonic(clean_samples(a, LOBE(a)), HarmonicOptions(basis='full'))


def test_full_basis_reports_base_circle_ripple():
    a, h = simulate(LOBE, 1800, 0.2e-6, seed=7)
    rec = reconstruct_harmonic(clean_samples(a, h), HarmonicOptions(basis='full', order=12))
    assert any('ripple' in w for w in rec.warnings)


# --- stress ------------------------------------------------------------------------------

def test_many_spikes_are_all_removed():
    a, h = simulate(LOBE, 3600, 0.5e-6, seed=11, outliers=30, outlier_size=10e-6)
    rec = reconstruct_spline(a, h)
    assert rec.parameter['outliers'] == 30
    e = rms_errors(rec, LOBE)
    assert e[0] < 0.25e-6 and e[2] < 5e-4


def test_gap_of_several_degrees_warns_and_stays_accurate_elsewhere():
    a, h = simulate(LOBE, 3600, 0.5e-6, seed=12, gap_deg=6.0)
    for rec in (reconstruct_spline(a, h), reconstruct_harmonic(clean_samples(a, h))):
        assert any('gap' in w for w in rec.warnings)
        away = np.abs(rec.alpha + 45 * DEG) > 6 * DEG
        for nu, tol in ((0, 0.5e-6), (2, 1.5e-3)):
            err = rec.derivatives()[nu][away] - LOBE(rec.alpha[away], nu)
            assert np.sqrt(np.mean(err ** 2)) < tol
        inside = np.abs(rec.alpha + 45 * DEG) < 3 * DEG
        assert np.max(np.abs(rec.lift[inside] - LOBE(rec.alpha[inside]))) < 20e-6


def test_uneven_sampling():
    a, h = simulate(LOBE, 3600, 0.5e-6, seed=13, jitter=0.45)
    rec = reconstruct_spline(a, h)
    assert any('uneven' in n for n in rec.notes)
    e = rms_errors(rec, LOBE)
    assert e[0] < 0.3e-6 and e[2] < 6e-4
    e = rms_errors(reconstruct_harmonic(clean_samples(a, h)), LOBE)
    assert e[0] < 0.3e-6 and e[2] < 6e-4
    manual = reconstruct_spline(a, h, SplineOptions(smoothing=rec.parameter['smoothing']))
    assert np.allclose(manual.lift, rec.lift, atol=1e-9)


def test_repeated_angles_from_two_turns_are_merged():
    a, h1 = simulate(LOBE, 1800, 1e-6, seed=14)
    _, h2 = simulate(LOBE, 1800, 1e-6, seed=15)
    rng = np.random.default_rng(0)
    order = rng.permutation(2 * a.size)
    alpha = np.concatenate([a, a + 2 * np.pi])[order]       # second turn unwrapped
    lift = np.concatenate([h1, h2])[order]
    data = clean_samples(alpha, lift)
    assert data.merged_repeats == a.size and data.wrapped >= a.size - 1
    rec = reconstruct_spline(data)
    assert rec.sigma == pytest.approx(1e-6 / math.sqrt(2), rel=0.15)


def test_constant_input_gives_constant_lift_and_zero_derivatives():
    a = np.linspace(-np.pi, np.pi, 721)[1:]
    for rec in (reconstruct_spline(a, np.full(a.size, 2e-3)),
                reconstruct_harmonic(clean_samples(a, np.zeros(a.size) + 1e-9),
                                     HarmonicOptions(basis='full'))):
        assert np.all(np.isfinite(rec.derivatives()))
        assert np.allclose(rec.velocity, 0, atol=1e-12)
        assert np.allclose(rec.acceleration, 0, atol=1e-10)


def test_nan_samples_are_dropped_and_counted():
    a, h = simulate(LOBE, 720, 0.5e-6, seed=16)
    h[::50] = np.nan
    a[7] = np.inf
    rec = reconstruct_spline(a, h)
    assert any('dropped 16 non-finite' in n for n in rec.notes)
    assert np.all(np.isfinite(rec.derivatives()))
    with pytest.raises(InputError, match='distinct finite angles'):
        reconstruct_spline(a, np.full(a.size, np.nan))
    with pytest.raises(InputError):
        reconstruct_spline(a[:5], h[:5])


@pytest.mark.parametrize('scale', [1e-6, 1e3])
def test_results_scale_with_the_lift(scale):
    """Very small and very large lifts: the reconstruction is scale-equivariant."""
    a, h = simulate(LOBE, 1800, 0.5e-6, seed=17, outliers=2)
    ref = reconstruct_spline(a, h)
    big = reconstruct_spline(a, h * scale)
    assert np.allclose(big.lift / scale, ref.lift, rtol=1e-6, atol=1e-12)
    assert np.allclose(big.acceleration / scale, ref.acceleration, rtol=1e-5, atol=1e-9)
    assert big.parameter['outliers'] == ref.parameter['outliers'] == 2
    hr = reconstruct_harmonic(clean_samples(a, h * scale))
    assert hr.parameter['order'] == reconstruct_harmonic(clean_samples(a, h)).parameter['order']


def test_unsorted_and_wrapped_input_gives_the_same_result():
    a, h = simulate(LOBE, 1800, 0.5e-6, seed=18)
    ref = reconstruct_spline(a, h)
    perm = np.random.default_rng(1).permutation(a.size)
    wrapped = np.mod(a[perm], 2 * np.pi)                      # [0, 2 pi)
    rec = reconstruct_spline(wrapped, h[perm])
    assert np.allclose(rec.lift, ref.lift, atol=1e-12)


def test_exact_nominal_table_is_left_alone():
    """A noise-free 1 deg table: no outliers, near-interpolation."""
    a = np.arange(-180.0, 180.0, 1.0) * DEG
    rec = reconstruct_spline(a, LOBE(a))
    assert rec.parameter['outliers'] == 0
    assert rec.max_residual < 1e-9
    assert rms_errors(rec, LOBE)[0] < 0.2e-6


def test_smooth_grid_is_the_exact_weighted_penalised_fit():
    from cam_design.lift_table.spline import _neumann_cube_banded, smooth_grid

    n = 60
    main = np.full(n, 2.0)
    main[0] = main[-1] = 1.0
    lap = np.diag(main) - np.eye(n, k=1) - np.eye(n, k=-1)
    cube = lap @ lap @ lap
    ab = _neumann_cube_banded(n)
    for k in range(4):
        assert np.allclose(ab[3 - k, k:], np.diag(cube, k))
    rng = np.random.default_rng(0)
    y = np.sin(np.linspace(0, 3, n)) + rng.normal(0, 0.01, n)
    missing = np.zeros(n, dtype=bool)
    missing[20:27] = True
    for lam in (1.0, 1e3, 1e6):
        w = np.diag((~missing).astype(float))
        ref = np.linalg.solve(w + lam * cube, w @ y)
        assert np.allclose(smooth_grid(y, missing, lam), ref, atol=1e-10)
        ref = np.linalg.solve(np.eye(n) + lam * cube, y)
        assert np.allclose(smooth_grid(y, np.zeros(n, dtype=bool), lam), ref, atol=1e-10)


def test_uneven_sampling_has_no_false_outliers():
    """Per-point rebound noise factors: jitter changes std(r_i) by up to 5x."""
    for seed in (4, 5):
        a, h = simulate(LOBE, 3600, 0.5e-6, seed=seed, jitter=0.45)
        assert rebound_fairing(a, h).outlier.sum() == 0
        _, spiky = simulate(LOBE, 3600, 0.5e-6, seed=seed, jitter=0.45, outliers=10)
        flagged = rebound_fairing(a, spiky).outlier
        spikes = np.abs(spiky - h) > 1e-6
        # a spike where the local noise factor is large (sparse neighbours) can stay
        # below its tolerance (4.5 sigma x factor): at most one of ten here
        assert np.count_nonzero(flagged[spikes]) >= 9 and flagged.sum() <= 11


def test_table_cut_on_the_flanks_has_unbiased_ends():
    """Free nodes beyond the data ends: the reflective DCT ends would force h' = 0
    there (an acceleration error of ~0.02 m/rad^2 within 5 deg of the ends)."""
    a = np.arange(-60.0, 60.0, 0.1) * DEG
    h = LOBE(a) + np.random.default_rng(1).normal(0.0, 0.5e-6, a.size)
    rec = reconstruct_spline(a, h)
    assert any('flank' in n for n in rec.notes)
    ends = np.abs(rec.alpha) > 55 * DEG
    for nu, tol in ((0, 0.2e-6), (1, 8e-6), (2, 6e-4)):
        err = rec.derivatives()[nu][ends] - LOBE(rec.alpha[ends], nu)
        assert np.sqrt(np.mean(err ** 2)) < tol


def test_underfit_series_is_reported():
    a, h = simulate(LOBE, 720, 0.5e-6, seed=3)
    rec = reconstruct_harmonic(clean_samples(a, h), HarmonicOptions(order=8))
    assert any('max residual' in w for w in rec.warnings)
    auto = reconstruct_harmonic(clean_samples(a, h))
    assert not any('max residual' in w for w in auto.warnings)


@pytest.mark.parametrize('offset', [0.3, 1e-2, 1e-4])
def test_two_interleaved_turns(offset):
    """Second turn sampled at slightly different angles (not exact repeats): a
    quintic P-spline on uniform knots fits the samples; near-duplicates must not make
    an interpolant oscillate (errors as for one averaged turn)."""
    a, h1 = simulate(LOBE, 1800, 0.5e-6, seed=1)
    _, h2 = simulate(LOBE, 1800, 0.5e-6, seed=2)
    a2 = a + offset * (2 * np.pi / 1800) * np.random.default_rng(0).uniform(-1, 1, a.size)
    alpha = np.concatenate([a, a2])
    lift = np.concatenate([h1, LOBE(a2) + (h2 - LOBE(a))])
    rec = reconstruct_spline(alpha, lift)
    e = rms_errors(rec, LOBE)
    assert e[0] < 0.15e-6 and e[1] < 6e-6 and e[2] < 3.5e-4
    assert rec.parameter['outliers'] == 0 and not rec.warnings
    har = reconstruct_harmonic(clean_samples(alpha, lift))
    assert rms_errors(har, LOBE)[2] < 3.5e-4


DUAL_PEAK = {
    'family': 'dual_peak',
    'ramp': {'height': 3.0e-4, 'velocity': 8.594366926962348e-4, 'angle': 0.5235987755982988},
    'rise': 8.0e-3, 'half_angle': 0.8726646259971648,
    'connection': {'start': 0.08726646259971647, 'angle': 0.6981317007977318,
                   'point_angle': 0.3490658503988659, 'point_lift': 1.0e-4},
    'secondary': {'rise': 1.5e-3, 'half_angle': 0.3490658503988659,
                  'ramp': {'height': 2.5e-4, 'velocity': 7.161972439135291e-4,
                           'angle': 0.5235987755982988}},
}


def test_dual_peak_cam_keeps_its_second_lobe():
    """The h'' sign-pattern rule (2 changes for a single lobe) must not flatten a real
    secondary lobe: with the design known the expected count comes from it; without,
    extra smoothing stops as soon as the fit leaves the data (and a warning says so)."""
    from_spec = pytest.importorskip('cam_design.lift_laws').from_spec
    from cam_metrology.reconstruction.profile import reconstruct_table
    from cam_design.lift_table.samples import LiftTable

    law = from_spec(DUAL_PEAK, 'law')
    centre = 0.5 * sum(law.support)

    def shifted(x, nu=0):
        return law(np.asarray(x) + centre, nu)
    a, h = simulate(shifted, 3600, 0.5e-6, seed=1)
    out = reconstruct_table(LiftTable('egr', a, h, shifted(a)), methods=('spline',))
    rec = out['spline'].reconstruction
    assert not rec.warnings and 'raised' not in rec.why
    assert rms_errors(rec, shifted)[2] < 6e-4
    blind = reconstruct_spline(a, h)
    assert any('sign changes' in w for w in blind.warnings)
    e = rms_errors(blind, shifted)
    assert e[0] < 0.5e-6 and e[2] < 1.2e-3


@pytest.mark.parametrize('n_per_rev, false_max', [(90, 2), (180, 0)])
def test_coarse_tables_keep_their_flank_points(n_per_rev, false_max):
    """At 2-4 deg steps the cubic spline's interpolation error on the flanks exceeds
    the noise; the local quintic confirmation keeps such points while still catching
    spikes (without it 28 of 180 noise-free points were flagged at 2 deg)."""
    a, h = simulate(LOBE, n_per_rev, 0.0, seed=1)
    assert rebound_fairing(a, h).outlier.sum() <= false_max
    a, h = simulate(LOBE, n_per_rev, 0.5e-6, seed=1)
    assert rebound_fairing(a, h).outlier.sum() <= false_max
    _, spiky = simulate(LOBE, n_per_rev, 0.5e-6, seed=1, outliers=5)
    found = rebound_fairing(a, spiky).outlier
    spikes = np.abs(spiky - h) > 1e-6
    assert found[spikes].sum() == 5 and found.sum() <= 5 + false_max


@pytest.mark.parametrize('n, jitter', [(300, 0.45), (40, 0.3), (1000, 0.0)])
def test_rebound_noise_factors_are_exact(n, jitter):
    """std(r_i)/sigma = |K e_i| / K_ii, K = Q T^-1 Q^T, against a dense computation."""
    a, _ = simulate(LOBE, n, 0.0, seed=4, jitter=jitter)
    op = ReboundOperator(a)
    h = np.diff(a)
    m = a.size - 2
    t = (np.diag((h[:-1] + h[1:]) / 3) + np.diag(h[1:-1] / 6, 1)
         + np.diag(h[1:-1] / 6, -1))
    q = np.zeros((a.size, m))
    for j in range(m):
        q[j, j], q[j + 1, j], q[j + 2, j] = 1 / h[j], -1 / h[j] - 1 / h[j + 1], 1 / h[j + 1]
    k = q @ np.linalg.solve(t, q.T)
    ref = np.sqrt(np.sum(k ** 2, axis=1)) / np.diag(k)
    if jitter:
        assert np.allclose(op.noise_factors()[1:-1], ref[1:-1], rtol=1e-8)
    else:   # uniform knots: the infinite-grid constant, exact 20 knots from the ends
        assert np.allclose(op.noise_factors()[20:-20], ref[20:-20], rtol=1e-8)
        assert np.allclose(op.noise_factors()[1:-1], ref[1:-1], rtol=0.25)
