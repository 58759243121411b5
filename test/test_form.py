"""Form and harmonics over the revolution (cam_metrology.metrology.form), against closed
forms: known harmonics recovered within the noise, the Gaussian filter's transmission,
roundness of a lobed circle, the Nyquist refusal."""
from __future__ import annotations

import numpy as np
import pytest

from cam_design.errors import InputError
from cam_metrology.metrology.form import (analyze_form, gaussian_transmission,
                                          gaussian_weighting_filter, harmonics, nyquist_upr)

N = 3600
THETA = np.arange(N) * (2 * np.pi / N) + 0.3   # one revolution starting at 0.3 rad
NOISE = 0.1e-6


def _noisy(y: np.ndarray, seed: int = 1) -> np.ndarray:
    return y + np.random.default_rng(seed).normal(0.0, NOISE, y.size)


def test_chatter_37_upr_recovered_within_the_noise() -> None:
    """A 0.8 um chatter at 37 UPR (phase 1 rad) over a 3-lobed form of 2 um, 0.1 um noise:
    amplitude within 3 standard errors (sigma sqrt(2/N) = 2.4 nm), phase within 3 sigma
    of its own (se / A rad)."""
    dev = _noisy(0.8e-6 * np.cos(37 * THETA - 1.0) + 2e-6 * np.cos(3 * THETA - 0.5))
    res = analyze_form(THETA, dev)
    se = NOISE * np.sqrt(2.0 / N)
    top = {h['upr']: h for h in res.harmonics}
    assert [h['upr'] for h in res.harmonics[:2]] == [3, 37]
    assert top[37]['amplitude_um'] == pytest.approx(0.8, abs=3 * se * 1e6)
    assert np.radians(top[37]['phase_deg']) == pytest.approx(1.0, abs=3 * se / 0.8e-6)
    assert top[3]['amplitude_um'] == pytest.approx(2.0, abs=3 * se * 1e6)
    wav = res.waviness
    assert wav['upr_at_max'] == 37 and wav['band_upr'] == [15, 50]
    assert wav['max_amplitude_um'] == pytest.approx(0.8, abs=3 * se * 1e6)


def test_gappy_revolution_uses_least_squares() -> None:
    """A third of the samples missing at random: least squares gives the same harmonics
    within the noise (no resampling, no leakage from the gaps)."""
    dev = _noisy(0.8e-6 * np.cos(37 * THETA - 1.0))
    keep = np.random.default_rng(4).random(N) > 0.33
    spec = harmonics(THETA[keep], dev[keep], 50)
    se = NOISE * np.sqrt(2.0 / keep.sum())
    assert spec.amplitude[36] == pytest.approx(0.8e-6, abs=4 * se)
    assert np.max(np.delete(spec.amplitude, 36)) < 5 * se


def test_partial_chatter_located_on_the_cam() -> None:
    """Chatter only over 60 deg centred at 200 deg: the envelope peaks there (within 6 deg)
    at the chatter's amplitude (within 10 %), and spans about 60 deg."""
    centre, half = np.radians(200.0), np.radians(30.0)
    inside = np.abs((THETA - centre + np.pi) % (2 * np.pi) - np.pi) <= half
    dev = _noisy(np.where(inside, 0.8e-6 * np.cos(37 * THETA), 0.0))
    wav = analyze_form(THETA, dev, band=(20, 60)).waviness
    assert wav['at_deg'] == pytest.approx(200.0, abs=6.0)
    assert wav['peak_um'] == pytest.approx(0.8, rel=0.1)
    assert wav['extent_deg'] == pytest.approx(60.0, abs=10.0)


@pytest.mark.parametrize('cutoff', [15, 50, 150])
def test_gaussian_filter_transmits_half_at_the_cutoff(cutoff: int) -> None:
    """The ISO 16610-21 weighting function, convolved around the circle, passes 50 % of a
    sinusoid at the cut-off and exp(-ln2 (k/kc)^2) elsewhere (to 1e-3 of the amplitude)."""
    third = cutoff // 3
    for k, want in ((cutoff, 0.5), (third, float(gaussian_transmission(third, cutoff))),
                    (2 * cutoff, 1.0 / 16.0)):
        mean_line = gaussian_weighting_filter(np.cos(k * THETA), cutoff)
        assert np.max(np.abs(mean_line)) == pytest.approx(want, abs=1e-3)


def test_roundness_of_a_three_lobed_circle() -> None:
    """A 3-lobed circle of 2 um amplitude (PV 4 um) plus an eccentricity of 30 um (removed by
    the least-squares circle): roundness 4 um; 0.8 um chatter at 150 UPR beyond the 50 UPR
    cut-off is filtered out (transmission 2^-9)."""
    dev = 30e-6 * np.cos(THETA - 0.2) + 2e-6 * np.cos(3 * THETA) + \
        0.8e-6 * np.cos(150 * THETA)
    res = analyze_form(THETA, dev)
    assert res.roundness_um == pytest.approx(4.0, abs=0.01)


def test_band_beyond_nyquist_is_refused_in_one_line() -> None:
    """360 samples per revolution resolve 180 UPR: a band to 200 UPR is refused naming the
    key, the band and the limit."""
    theta = np.arange(360) * (2 * np.pi / 360)
    assert nyquist_upr(theta) == 180
    with pytest.raises(InputError) as err:
        analyze_form(theta, np.cos(3 * theta), band=(20, 200), key='lobes[0].form')
    msg = str(err.value)
    assert '\n' not in msg
    assert msg.startswith('lobes[0].form.waviness_band_upr: got [20, 200]')
    assert 'at most 180 UPR' in msg
