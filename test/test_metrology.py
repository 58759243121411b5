"""Metrology numerics: seed-004 worked example, exact synthetic cases for both
estimators, methods §7 #21 (false asymmetry), noise vs reported uncertainty."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from cam_design.dowel_pin import DowelPinGeometry
from cam_design.errors import InputError
from cam_metrology.metrology.analysis import (FeatureFailed, Settings, analyze_lobe,
                                              analyze_pin)
from cam_metrology.metrology.asymmetry import lift_spline, top_point
from cam_metrology.metrology.features import clean_feature
from cam_metrology.metrology.flank_fit import crb_shift_std, fit_shift
from cam_metrology.metrology.sensitive_point import circular_mean, seed_nose
from cam_metrology.metrology.synthetic import PolynomialRampCam, sample_lobe, sample_pin

ARCSEC = 1.0 / 3600.0   # deg
CAM = PolynomialRampCam()
PIN = DowelPinGeometry(pin_radius=2.5e-3, circle_radius=11.5e-3, probe_radius=2.0e-3)


def dms(d: float, m: float, s: float) -> float:
    """Degrees-minutes-seconds to rad."""
    return np.radians(d + m / 60 + s / 3600)


def _feature(smp, fid='lobe_1'):
    return clean_feature(fid, smp.stamp_ns, smp.theta, smp.s)


def _err_arcsec(measured_deg: float, true_rad: float) -> float:
    diff = (measured_deg - np.degrees(true_rad) + 180.0) % 360.0 - 180.0
    return diff * 3600.0


# ----------------------------------------------------------------- seed 004

def test_seed004_pin_geometry_numbers():
    """methods §7 #5, #6: alpha_max, h(0), h(alpha_max), h at the seed's rounded angle."""
    assert np.degrees(PIN.contact_half_angle) == pytest.approx(23.035684, abs=1e-6)
    assert PIN.lift(0.0) * 1e3 == pytest.approx(14.000, abs=1e-9)
    assert PIN.lift_min * 1e3 == pytest.approx(8.583005, abs=1e-6)
    assert PIN.lift(dms(23, 2, 6)) * 1e3 == pytest.approx(8.61678, abs=5e-4)


def test_seed004_phi0_with_erratum():
    """phi_m = 23°03'16", phi_n = 337°04'12" -> phi0 = 0°03'44" (seed prints 0°03'58")."""
    phi0 = np.degrees(seed_nose(dms(23, 3, 16), dms(337, 4, 12)))
    assert phi0 == pytest.approx(3 / 60 + 44 / 3600, abs=1e-9)
    assert phi0 == pytest.approx(0.062222, abs=1e-6)
    assert abs(phi0 - (3 / 60 + 58 / 3600)) > 3 * ARCSEC   # the printed value is wrong
    # the seed's own formula (phi_m + phi_n)/2 - 180 deg agrees with the circular mean
    seed = (np.degrees(dms(23, 3, 16) + dms(337, 4, 12))) / 2 - 180.0
    assert phi0 == pytest.approx(seed, abs=1e-12)


def test_circular_mean_across_zero_and_weights():
    assert np.degrees(circular_mean(np.radians([359.0, 3.0]))) == pytest.approx(1.0)
    # 3 unit vectors at 10 deg + 1 at 20 deg: tan(mean) = (3 sin 10 + sin 20)/(3 cos 10 + cos 20)
    s10, c10, s20, c20 = 0.17364817766693, 0.98480775301221, 0.34202014332567, 0.93969262078591
    expected = np.degrees(np.arctan((3 * s10 + s20) / (3 * c10 + c20)))
    assert np.degrees(circular_mean(np.radians([10.0, 20.0]), [3.0, 1.0])) == pytest.approx(
        expected, abs=1e-9)


# ----------------------------------------------------- exact synthetic cases

CASES = [  # direction, encoder sense, wrapped, revolutions, start, zero
    (1, 1, False, 1.0, 0.3, 0.0),
    (1, -1, True, 3.0, 5.9, 0.0123),
    (-1, 1, True, 2.0, -1.0, -0.007),
    (-1, -1, False, 1.5, 40.0, 0.5),
]


@pytest.mark.parametrize('direction,turn,wrapped,revs,start,zero', CASES)
def test_lobe_noise_free_both_estimators_exact(direction, turn, wrapped, revs, start, zero):
    nose = np.radians(123.456789)
    smp = sample_lobe(CAM, nose, direction, n_per_rev=3600, revolutions=revs, start=start,
                      turn=turn, wrapped=wrapped, zero=zero)
    res = analyze_lobe(_feature(smp), CAM, direction, Settings())
    v = res.values
    assert abs(_err_arcsec(v['angle_deg'], nose)) < 0.01
    assert abs(_err_arcsec(v['sensitive_point_angle_deg'], nose)) < 0.01
    assert v['validity']['valid']
    assert v['lift_offset_mm'] == pytest.approx(zero * 1e3, abs=1e-9)
    assert abs(v['asymmetry_deg']) < 0.01 * ARCSEC
    assert abs(v['lift_error_um']['rms']) < 1e-6
    assert v['revolutions'] == pytest.approx(revs - 1 / 3600, abs=1e-4)


def test_lobe_multi_pair_variant_exact():
    nose = np.radians(200.0)
    smp = sample_lobe(CAM, nose, 1, n_per_rev=7200)
    res = analyze_lobe(_feature(smp), CAM, 1, Settings(sp_pairs=2, sp_pair_spacing_deg=0.5,
                                                       sp_fit_order=2))
    assert abs(_err_arcsec(res.values['sensitive_point_angle_deg'], nose)) < 0.01


def _roller_lift_reference(flat_law, base_radius: float, roller: float, alpha: float) -> float:
    """Independent roller lift on a flat-tappet cam: radial function of the offset cam,
    min over phi of (R0 + h(phi) + r) / cos(phi - alpha), minus R0 + r."""
    def dist(phi: float) -> float:
        return (base_radius + float(flat_law(np.array(phi))) + roller) / np.cos(phi - alpha)
    best = minimize_scalar(dist, bounds=(alpha - 0.6, alpha + 0.6), method='bounded',
                           options={'xatol': 1e-12})
    return best.fun - base_radius - roller


def test_flat_designed_lobe_with_roller_probe_exact():
    """Design for a flat tappet, measured with a roller (ball) probe through convert_lift."""
    from cam_design import follower
    base = 0.040   # rho at the nose = R0 + h + h'' = 3.65 mm (methods §7 #10)
    seen = follower.convert_lift(CAM, base, follower.Follower('flat'),
                                 follower.Follower('roller', 0.004))
    for a in (-0.6, -0.2, 0.3):   # the conversion is what the probe sees
        assert float(seen(np.array(a))) == pytest.approx(
            _roller_lift_reference(CAM, base, 0.004, a), abs=2e-9)
    nose = np.radians(71.25)
    for direction in (1, -1):
        smp = sample_lobe(seen, nose, direction, n_per_rev=3600, revolutions=2, zero=0.002)
        v = analyze_lobe(_feature(smp), seen, direction, Settings()).values
        assert abs(_err_arcsec(v['angle_deg'], nose)) < 0.01
        assert abs(_err_arcsec(v['sensitive_point_angle_deg'], nose)) < 0.01


@pytest.mark.parametrize('turn,wrapped,revs', [(1, False, 1.0), (-1, True, 2.5)])
def test_pin_noise_free_both_estimators_exact(turn, wrapped, revs):
    centre = dms(0, 3, 44)
    smp = sample_pin(PIN, centre, n_per_rev=7200, revolutions=revs, turn=turn,
                     wrapped=wrapped, zero=-0.0041)
    res = analyze_pin(_feature(smp, 'dowel_pin'), PIN, 1, Settings())
    v = res.values
    assert abs(_err_arcsec(v['angle_deg'], centre)) < 0.01
    assert abs(_err_arcsec(v['sensitive_point_angle_deg'], centre)) < 0.01
    assert v['validity']['valid']
    # the lift table is the seed's absolute lift: top at R_z + R_x = 14 mm
    assert np.max(res.table[:, 1]) == pytest.approx(14e-3, abs=1e-8)
    # probe-stop samples and the tangent region are excluded
    assert np.max(np.abs(res.table[:, 0])) < PIN.contact_half_angle - np.radians(0.5) + 1e-9


def test_pin_sensitive_points_inside_contact():
    """The pin's sensitive points are taken just inside the tangent point."""
    smp = sample_pin(PIN, 1.0, n_per_rev=7200)
    v = analyze_pin(_feature(smp, 'dowel_pin'), PIN, 1, Settings()).values
    am, an = np.radians(v['sensitive_points_alpha_deg'])
    amax = PIN.contact_half_angle
    assert -amax < am < -amax + np.radians(2) and amax - np.radians(2) < an < amax


# ------------------------------------------------------- false asymmetry (§5.3)

def test_methods_21_false_asymmetry_recovered():
    """§1.4 cam tabulated at 0.5°, instrument a = true - 0.37° -> nose at a = -0.37°."""
    a = np.radians(np.arange(-90.0, 90.0001, 0.5))
    spline = lift_spline(a, CAM(a + np.radians(0.37)))
    tp = top_point(spline, a[0], a[-1])
    assert np.degrees(tp.d) == pytest.approx(-0.37, abs=1e-6)
    assert np.degrees(tp.d_flank) == pytest.approx(-0.37, abs=1e-6)
    assert tp.residual_rms < 1e-9 < tp.apparent_rms


def test_real_asymmetry_is_reported():
    """An asymmetric part (one flank 2 % steeper) leaves a residual the axis cannot remove."""
    a = np.radians(np.arange(-90.0, 90.0001, 0.25))
    h = np.where(a < 0, CAM(a * 1.02), CAM(a))
    tp = top_point(lift_spline(a, h), a[0], a[-1])
    assert tp.residual_rms > 1e-6
    assert tp.flank_scatter > 1e-5


# ----------------------------------------------------------- noise and CRB

def test_lsq_error_within_reported_std_and_crb():
    nose = np.radians(33.3)
    z, ratios = [], []
    for seed in range(30):
        smp = sample_lobe(CAM, nose, 1, n_per_rev=1440, noise=1e-6, seed=seed, zero=1e-3)
        fs = _feature(smp)
        v = analyze_lobe(fs, CAM, 1, Settings()).values
        err = np.radians(_err_arcsec(v['angle_deg'], nose) / 3600)
        std = np.radians(v['angle_std_deg'])
        z.append(err / std)
        alpha = np.angle(np.exp(1j * (fs.theta - nose)))
        # the default model fits the run-out harmonic: its bound is ~7 % above the
        # offset-only bound
        ratios.append(std / crb_shift_std(alpha, CAM, 1e-6, theta=fs.theta))
        assert crb_shift_std(alpha, CAM, 1e-6, theta=fs.theta) == pytest.approx(
            1.07 * crb_shift_std(alpha, CAM, 1e-6), rel=0.03)
    z = np.asarray(z)
    assert np.max(np.abs(z)) < 4.0
    assert 0.6 < np.sqrt(np.mean(z**2)) < 1.5
    assert abs(np.mean(ratios) - 1.0) < 0.03   # residual-based sigma: ~2 % scatter each
    assert np.allclose(ratios, 1.0, atol=0.1)


def test_sensitive_point_noise_within_reported_std():
    nose = np.radians(300.0)
    z = []
    for seed in range(30):
        smp = sample_lobe(CAM, nose, -1, n_per_rev=3600, noise=0.5e-6, seed=seed)
        v = analyze_lobe(_feature(smp), CAM, -1, Settings()).values
        err = _err_arcsec(v['sensitive_point_angle_deg'], nose) / 3600
        z.append(err / v['sensitive_point_angle_std_deg'])
    z = np.asarray(z)
    assert np.max(np.abs(z)) < 4.5
    assert 0.5 < np.sqrt(np.mean(z**2)) < 1.6


def test_fit_with_runout_harmonic():
    nose, ecc = np.radians(50.0), 3e-6
    smp = sample_lobe(CAM, nose, 1, n_per_rev=3600)
    s = smp.s + ecc * np.cos(smp.theta - 0.7)
    fs = clean_feature('lobe_1', smp.stamp_ns, smp.theta, s)
    v = analyze_lobe(fs, CAM, 1, Settings(fit_runout=True)).values
    assert abs(_err_arcsec(v['angle_deg'], nose)) < 0.01
    assert v['fitted_runout_amplitude_um'] == pytest.approx(3.0, abs=1e-6)
    v0 = analyze_lobe(fs, CAM, 1, Settings()).values
    assert v0['base_circle_runout_um'] == pytest.approx(6.0, rel=0.05)


# ------------------------------------------------------------- edge cases

def test_fit_shift_rejects_too_few_samples_and_flat_data():
    x = np.linspace(-0.1, 0.1, 3)
    with pytest.raises(InputError):
        fit_shift(x, np.zeros(3), CAM)
    x = np.linspace(2.0, 3.0, 50)   # base circle only: the shift is not determined
    with pytest.raises(InputError, match='flanks'):
        fit_shift(x, np.zeros(50), CAM)


def test_missing_flank_fails_with_reason():
    smp = sample_lobe(CAM, 0.0, 1, n_per_rev=3600)
    alpha = np.angle(np.exp(1j * smp.theta))
    keep = ~((alpha > 0.1) & (alpha < 1.2))   # the fall flank is missing
    fs = clean_feature('lobe_1', smp.stamp_ns[keep], smp.theta[keep], smp.s[keep])
    with pytest.raises(FeatureFailed, match='flank'):
        analyze_lobe(fs, CAM, 1, Settings())


def test_settings_validate_types():
    with pytest.raises(InputError, match='metrology.sp_pairs'):
        Settings.from_params({'sp_pairs': 'two'})
    with pytest.raises(InputError, match='metrology.fit_runout'):
        Settings.from_params({'fit_runout': 'yes'})
    with pytest.raises(InputError, match='metrology.max_shift_deg'):
        Settings.from_params({'max_shift_deg': float('nan')})
    with pytest.raises(InputError, match='metrology.sp_fit_order'):
        Settings.from_params({'sp_fit_order': 7})
    with pytest.raises(InputError, match='metrology.sp_half_window_deg'):
        Settings.from_params({'sp_half_window_deg': 0})


def test_huge_sample_count_is_fast_enough_and_exact():
    nose = np.radians(10.0)
    smp = sample_lobe(CAM, nose, 1, n_per_rev=36000, revolutions=3)
    v = analyze_lobe(_feature(smp), CAM, 1, Settings()).values
    assert abs(_err_arcsec(v['angle_deg'], nose)) < 0.01
    assert v['samples_used'] == 108000


def test_hermite_tabulation_matches_law():
    from cam_metrology.metrology.flank_fit import HermiteLift
    lo, hi = CAM.support
    tab = HermiteLift(CAM, (lo, hi), np.radians(0.01))
    a = np.random.default_rng(2).uniform(lo - 0.1, hi + 0.1, 5000)
    assert np.max(np.abs(tab(a) - CAM(a))) < 1e-11
    # h'' jumps at the ramp junction (60 deg): h' is still within 1e-5 relative there
    assert np.max(np.abs(tab(a, 1) - CAM(a, 1))) < 1e-5 * np.max(np.abs(CAM(a, 1)))
    assert tab(np.array([lo - 0.2, hi + 0.2])).tolist() == [0.0, 0.0]


def test_pin_direction_minus_one_and_multi_pair():
    centre = np.radians(271.5)
    smp = sample_pin(PIN, centre, n_per_rev=3600, turn=-1, zero=0.02)
    v = analyze_pin(_feature(smp, 'dowel_pin'), PIN, -1, Settings(sp_pairs=1)).values
    assert abs(_err_arcsec(v['angle_deg'], centre)) < 0.01
    assert abs(_err_arcsec(v['sensitive_point_angle_deg'], centre)) < 0.01


def test_pin_with_too_few_samples_fails():
    smp = sample_pin(PIN, 0.0, n_per_rev=90)
    with pytest.raises(FeatureFailed):
        analyze_pin(_feature(smp, 'dowel_pin'), PIN, 1, Settings())


def test_asymmetric_design_lobe_exact_and_asymmetry_skipped():
    """Rise flank 10 % shorter than the fall flank: both estimators still exact (the
    sensitive points differ per flank), the symmetry axis is not meaningful."""
    from cam_design.lift_laws.base import TabulatedLift
    a = np.radians(np.arange(-80.0 / 1.1, 80.0001, 0.1))
    law = TabulatedLift(a, np.where(a < 0, CAM(a * 1.1), CAM(a)))
    nose = np.radians(15.0)
    smp = sample_lobe(law, nose, 1, n_per_rev=3600, zero=0.003)
    res = analyze_lobe(_feature(smp), law, 1, Settings())
    v = res.values
    assert abs(_err_arcsec(v['angle_deg'], nose)) < 0.01
    assert abs(_err_arcsec(v['sensitive_point_angle_deg'], nose)) < 0.01
    am, an = v['sensitive_points_alpha_deg']
    assert am == pytest.approx(-an / 1.1, abs=0.01)
    assert 'asymmetry_deg' not in v
    assert res.skipped == [('asymmetry', 'design lift is asymmetric: no symmetry axis')]


def test_spikes_are_rejected_and_counted():
    """Dirt on the probe: 12 spikes of +-20..80 um on a lobe and on the pin."""
    rng = np.random.default_rng(9)
    nose = np.radians(140.0)
    smp = sample_lobe(CAM, nose, 1, n_per_rev=3600, noise=0.3e-6, seed=2)
    s = smp.s.copy()
    idx = rng.choice(s.size, 12, replace=False)
    s[idx] += rng.choice([-1, 1], 12) * rng.uniform(20e-6, 80e-6, 12)
    fs = clean_feature('lobe_1', smp.stamp_ns, smp.theta, s)
    v = analyze_lobe(fs, CAM, 1, Settings()).values
    assert v['samples_outliers_rejected'] == 12
    assert abs(_err_arcsec(v['angle_deg'], nose)) < 4 * v['angle_std_deg'] * 3600
    assert abs(_err_arcsec(v['sensitive_point_angle_deg'], nose)) < \
        4 * v['sensitive_point_angle_std_deg'] * 3600
    assert v['lift_error_um']['max_plus'] < 3.0
    keep_all = analyze_lobe(fs, CAM, 1, Settings(outlier_sigma=0.0)).values
    assert keep_all['samples_outliers_rejected'] == 0
    assert keep_all['residual_rms_um'] > 3 * v['residual_rms_um']
    centre = np.radians(5.0)
    smp = sample_pin(PIN, centre, n_per_rev=3600)
    s = smp.s.copy()
    alpha = np.angle(np.exp(1j * (smp.theta - centre)))
    s[np.flatnonzero(np.abs(alpha) < 0.3)[::40]] += 50e-6   # spikes on the contact part
    fs = clean_feature('dowel_pin', smp.stamp_ns, smp.theta, s)
    v = analyze_pin(fs, PIN, 1, Settings()).values
    assert v['samples_outliers_rejected'] > 0
    assert abs(_err_arcsec(v['angle_deg'], centre)) < 0.01
    assert abs(_err_arcsec(v['sensitive_point_angle_deg'], centre)) < 0.01


def test_real_form_error_is_not_rejected_as_outliers():
    """A smooth 8 um bump over 4 deg of the fall flank is a real lift error: kept and
    reported, not removed as outliers."""
    nose = np.radians(200.0)
    smp = sample_lobe(CAM, nose, 1, n_per_rev=3600, noise=0.3e-6, seed=4)
    alpha = np.angle(np.exp(1j * (smp.theta - nose)))
    bump = 8e-6 * np.exp(-0.5 * ((alpha - np.radians(30)) / np.radians(1.0)) ** 2)
    fs = clean_feature('lobe_1', smp.stamp_ns, smp.theta, smp.s + bump)
    v = analyze_lobe(fs, CAM, 1, Settings()).values
    assert v['samples_outliers_rejected'] <= 2
    assert v['lift_error_um']['max_plus'] > 6.5
    assert v['angle_noise_estimate_arcsec'] < 1.0   # the bump is not taken for noise
    assert v['probe_noise_estimate_um'] == pytest.approx(0.3, rel=0.1)


def test_encoder_noise_is_estimated_and_weighted():
    """Angle (encoder) noise of 4" adds h'^2 sigma_theta^2 to the flank residuals: it is
    estimated, the fit is weighted, and the reported std stays honest."""
    nose, enc = 1.0, 20e-6
    z = []
    for seed in range(30):
        smp = sample_lobe(CAM, nose, 1, n_per_rev=3600, noise=0.3e-6, seed=seed)
        theta = smp.theta + enc * np.random.default_rng(seed + 100).standard_normal(
            smp.theta.size)
        v = analyze_lobe(clean_feature('l', smp.stamp_ns, theta, smp.s), CAM, 1,
                         Settings()).values
        z.append(np.radians(_err_arcsec(v['angle_deg'], nose) / 3600)
                 / np.radians(v['angle_std_deg']))
        assert v['angle_noise_estimate_arcsec'] == pytest.approx(
            np.degrees(enc) * 3600, rel=0.3)
        assert v['probe_noise_estimate_um'] == pytest.approx(0.3, rel=0.1)
    assert 0.6 < np.sqrt(np.mean(np.square(z))) < 1.4


def test_sensitive_point_failure_keeps_the_lsq_result():
    """Too few samples in the sensitive-point windows: SP is skipped with the reason,
    the full-flank result stands."""
    nose = np.radians(80.0)
    smp = sample_lobe(CAM, nose, 1, n_per_rev=720)
    res = analyze_lobe(_feature(smp), CAM, 1, Settings(sp_half_window_deg=0.1))
    assert abs(_err_arcsec(res.values['angle_deg'], nose)) < 0.01
    assert res.values['sensitive_point_angle_deg'] is None
    assert 'samples within' in res.values['sensitive_point_error']
    assert res.skipped[0][0] == 'sensitive_point'


def test_wrong_design_lift_fails_the_feature():
    """Data of a 7 mm / 55 deg lobe analysed against the 8.3 mm / 50 deg design."""
    other = PolynomialRampCam(rise=6.0e-3, half_angle=np.radians(40))
    smp = sample_lobe(other, 1.0, 1, n_per_rev=1440)
    with pytest.raises(FeatureFailed, match='does not match the design'):
        analyze_lobe(_feature(smp), CAM, 1, Settings())


def _slipping_revolutions(nose: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(stamps [ns], theta [rad], s [m]) of three revolutions whose noses sit at
    ``nose`` -1, 0 and +1 arcsec (a slipping drive), 3600 samples each."""
    parts = [sample_lobe(CAM, nose + k * np.radians(1 / 3600), 1, n_per_rev=3600,
                         start=0.5 + 2 * np.pi * (k + 1)) for k in (-1, 0, 1)]
    theta = np.concatenate([p.theta for p in parts])
    s = np.concatenate([p.s for p in parts])
    return np.arange(theta.size, dtype=np.int64) * 1_000_000, theta, s


def test_per_revolution_repeatability():
    """Three revolutions whose noses differ by +-1 arcsec (a slipping drive): the joint
    fit is the mean, the per-revolution deviations recover the slip."""
    nose = np.radians(10.0)
    stamps, theta, s = _slipping_revolutions(nose)
    v = analyze_lobe(clean_feature('lobe_1', stamps, theta, s), CAM, 1, Settings()).values
    assert abs(_err_arcsec(v['angle_deg'], nose)) < 0.01
    assert np.allclose(v['per_revolution_deviation_arcsec'], [-1.0, 0.0, 1.0], atol=0.01)
    assert v['per_revolution_std_arcsec'] == pytest.approx(1.0, abs=0.01)


def test_per_revolution_repeatability_with_an_angle_stepping_back():
    """Two readings swapped in time across a revolution boundary (the angle steps back
    once, so revolutions are no longer runs of rows): the revolutions are still told
    apart (by mask) and give the same deviations as the runs-of-rows path."""
    nose = np.radians(10.0)
    stamps, theta, s = _slipping_revolutions(nose)
    plain = analyze_lobe(clean_feature('lobe_1', stamps, theta, s), CAM, 1,
                         Settings()).values
    turns = np.floor((np.unwrap(theta) - theta[0]) / (2 * np.pi))
    i = int(np.flatnonzero(np.diff(turns))[0]) + 1     # first row of the 2nd revolution
    theta[[i - 1, i]], s[[i - 1, i]] = theta[[i, i - 1]], s[[i, i - 1]]
    v = analyze_lobe(clean_feature('lobe_1', stamps, theta, s), CAM, 1, Settings()).values
    assert np.allclose(v['per_revolution_deviation_arcsec'], [-1.0, 0.0, 1.0], atol=0.01)
    assert np.allclose(v['per_revolution_deviation_arcsec'],
                       plain['per_revolution_deviation_arcsec'], atol=0.005)


def test_lobe_scan_without_base_circle():
    """Only the lobe was scanned (no base-circle samples): the offset comes from the
    fit itself; both estimators stay exact."""
    nose = np.radians(222.0)
    smp = sample_lobe(CAM, nose, 1, n_per_rev=3600, zero=0.0042)
    alpha = np.angle(np.exp(1j * (smp.theta - nose)))
    keep = np.abs(alpha) < np.radians(75.0)
    fs = clean_feature('lobe_1', smp.stamp_ns[keep], smp.theta[keep], smp.s[keep])
    v = analyze_lobe(fs, CAM, 1, Settings()).values
    assert abs(_err_arcsec(v['angle_deg'], nose)) < 0.01
    assert abs(_err_arcsec(v['sensitive_point_angle_deg'], nose)) < 0.01
    assert v['lift_offset_mm'] == pytest.approx(4.2, abs=1e-9)
    assert v['base_circle_runout_um'] is None


def test_pin_multi_pair_goes_inward():
    """Extra pin pairs lie towards the top (outside the contact there is no lift)."""
    centre = np.radians(123.0)
    smp = sample_pin(PIN, centre, n_per_rev=7200, noise=0.3e-6, seed=3)
    one = analyze_pin(_feature(smp, 'dowel_pin'), PIN, 1, Settings()).values
    multi = analyze_pin(_feature(smp, 'dowel_pin'), PIN, 1,
                        Settings(sp_pairs=2, sp_pair_spacing_deg=2.0)).values
    assert multi['sensitive_point_angle_deg'] is not None
    assert multi['sensitive_point_angle_std_deg'] < one['sensitive_point_angle_std_deg']
    for v in (one, multi):
        assert abs(_err_arcsec(v['sensitive_point_angle_deg'], centre)) < \
            4 * v['sensitive_point_angle_std_deg'] * 3600


def test_gap_at_the_nose_is_harmless():
    """No samples within 1.5 deg of the nose (flat top, no information on the angle):
    the flanks carry both the angle and the symmetry axis."""
    nose = np.radians(300.0)
    smp = sample_lobe(CAM, nose, 1, n_per_rev=3600)
    alpha = np.angle(np.exp(1j * (smp.theta - nose)))
    keep = np.abs(alpha) > np.radians(1.5)
    fs = clean_feature('lobe_1', smp.stamp_ns[keep], smp.theta[keep], smp.s[keep])
    res = analyze_lobe(fs, CAM, 1, Settings())
    assert abs(_err_arcsec(res.values['angle_deg'], nose)) < 0.01
    assert abs(_err_arcsec(res.values['sensitive_point_angle_deg'], nose)) < 0.01
    assert abs(res.values['asymmetry_deg']) * 3600 < 0.01
    assert res.skipped == []
