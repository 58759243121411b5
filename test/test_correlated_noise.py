"""Noise that neighbouring rows share (a trace low-pass filtered before it was sampled,
a cycle average): found on the base circle (``noise.base_circle_noise``), its spread
taken as the rows' noise by the lobe law, and said on every route. Truth: closed-form
lobes (``truth_lobes``) plus Butterworth-filtered Gaussian noise of a known spread."""
from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.interpolate import make_smoothing_spline
from scipy.signal import butter, lfilter

from cam_design.lift_table.lobe_table import lobe_law
from cam_design.lift_table.noise import base_circle_noise
from cam_design.lift_table.truth_lobes import DEG, BumpLobe, families, measured_table


def filtered_noise(n: int, sigma: float, cut: float, seed: int) -> np.ndarray:
    """Gaussian noise through a 2nd-order Butterworth low-pass at ``cut`` of the Nyquist
    frequency, scaled to the standard deviation ``sigma`` [m]."""
    w = np.random.default_rng(seed).normal(0.0, 1.0, n)
    b, a = butter(2, cut)
    w = lfilter(b, a, w)
    return w * sigma / float(np.std(w))


@pytest.mark.parametrize('cut', [0.5, 0.3, 0.1])
def test_filtered_noise_is_found_with_its_spread(cut: float) -> None:
    """5 um filtered noise on a C2 lobe at 0.5 deg: lag-one correlation 0.4-0.99 found
    on the base circle, its spread within 15 % of the 5 um put in (the rows' own
    neighbours estimate 0.2-1 um)."""
    a = np.radians(np.arange(-180.0, 180.0, 0.5))
    h = BumpLobe()(a) + filtered_noise(a.size, 5e-6, cut, seed=3)
    found = base_circle_noise(h)
    assert found is not None and found.correlated
    assert found.sigma == pytest.approx(5e-6, rel=0.15)
    assert found.rows > 200


def test_independent_noise_rounding_and_eccentrics_are_not_flagged() -> None:
    """No false alarm on the accuracy families' tables (white noise 0.1-2 um, 0.01 mm
    rounding, spikes; 0.1-2.5 deg) nor on eccentrics (no base circle: exact, noisy,
    rounded), where a smooth bottom would look correlated."""
    for fam in families():
        for step, sigma, quantum, spikes in ((0.1, 0.5e-6, 0.0, 0), (0.5, 2e-6, 0.0, 5),
                                             (1.0, 0.1e-6, 1e-5, 0), (2.5, 0.5e-6, 0.0, 5)):
            for seed in (1, 2):
                _, h = measured_table(fam.law, step * DEG, sigma=sigma, quantum=quantum,
                                      outliers=spikes, seed=seed)
                found = base_circle_noise(h, quantum)
                assert found is None or not found.correlated, (fam.name, step, found)
    rng = np.random.default_rng(5)
    for step in (0.1, 0.5, 1.0):
        a = np.radians(np.arange(-180.0, 180.0, step))
        for e, sigma, quantum in ((2e-3, 0.0, 0.0), (5e-3, 1e-7, 0.0), (5e-3, 1e-6, 0.0),
                                  (2e-3, 1e-7, 1e-5)):
            h = e * (1.0 - np.cos(a)) + rng.normal(0.0, sigma, a.size)
            if quantum:
                h = np.round(h / quantum) * quantum
            assert base_circle_noise(h, quantum) is None, (step, e, sigma)


def test_lobe_law_and_reconstruct_of_a_filtered_trace() -> None:
    """A C2 lobe at 0.25 deg with 5 um of noise filtered at 0.3 of the Nyquist
    frequency. The rows' neighbours saw 0.24 um: the law took the table for an
    eccentric (no base circle), interpolated the noise (h'' 0.15 m/rad^2 RMS off, 5 times
    the lobe's peak h'' of 0.028; 17 times scipy's GCV spline) and said nothing, and
    reconstruct's spline (GCV) was 15 times scipy's error. Now: a base circle, the noise
    5 um (within 15 %), the lobe law's h'' within 0.4 x scipy's error (measured 0.18),
    reconstruct's spline within 0.5 x (measured 0.27), max lift within 10 um of 8 mm,
    and a warning naming the correlation on both."""
    from cam_design.lift_table.samples import LiftTable
    from cam_metrology.reconstruction.profile import reconstruct_table

    law = BumpLobe()
    a = np.radians(np.arange(-180.0, 180.0, 0.25))
    h = law(a) + filtered_noise(a.size, 5e-6, 0.3, seed=4)
    lobe = lobe_law(a, h, key='trace.csv')
    assert not lobe.lobe.periodic and lobe.lobe.method == 'smoothed'
    assert lobe.lobe.sigma == pytest.approx(5e-6, rel=0.15)
    assert any('correlated row to row' in w for w in lobe.lobe.warnings)
    g = np.arange(a[0], a[-1], 0.05 * DEG)

    def error(curve) -> float:
        return float(np.sqrt(np.mean((curve(g, 2) - law(g, 2)) ** 2)))
    ref = error(make_smoothing_spline(a, h))
    assert error(lobe) < 0.4 * ref
    assert abs(float(np.max(lobe(np.linspace(-0.1, 0.1, 2001)))) - law.rise) < 10e-6
    rec = reconstruct_table(LiftTable('trace', a, h), methods=('spline',))
    spline = rec['spline'].reconstruction
    assert error(spline.evaluate) < 0.5 * ref
    assert any('correlated row to row' in w for w in spline.warnings)


def test_card_of_a_filtered_trace_says_so(tmp_path, capsys) -> None:
    """The card of such a trace (CSV in mm) prints the warning and the lobe's events at
    1 mm within 0.1 deg of the closed form (+-53.03 deg)."""
    from cam_metrology.cli import main

    law = BumpLobe()
    deg = np.arange(-180.0, 180.0, 0.25)
    h = law(np.radians(deg)) + filtered_noise(deg.size, 5e-6, 0.3, seed=4)
    path = tmp_path / 'trace.csv'
    path.write_text('alpha_deg,lift_mm\n' + ''.join(
        f'{d:.2f},{v * 1e3:.6f}\n' for d, v in zip(deg, h)))
    assert main(['card', str(path), '--json', '-']) == 0
    out = capsys.readouterr()
    card = json.loads(out.out)['cards']['trace']
    one = next(e for e in card['heights'] if abs(e['height_mm'] - 1.0) < 1e-9)
    half = 75.0 * np.sqrt(1.0 - (1e-3 / law.rise) ** (1.0 / 3.0))   # h = rise (1 - x^2)^3
    assert one['opening_deg'] == pytest.approx(-half, abs=0.1)
    assert one['closing_deg'] == pytest.approx(half, abs=0.1)
    assert 'correlated row to row' in out.err + out.out
