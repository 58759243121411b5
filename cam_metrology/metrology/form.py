"""Form of a feature over the revolution: harmonics in UPR, Gaussian filter, roundness,
waviness (pure numerics, no rclpy; docs/methods.md "Form and harmonics").

The input is a deviation profile ``dev`` [m] (a lobe's lift error, a base circle's or a
journal's radius deviation) against the encoder angle ``theta`` [rad] of each sample,
any number of revolutions, not necessarily uniform. Everything is expressed by its
harmonics in undulations per revolution (UPR):

    dev(theta) ~ c0 + sum_k A_k cos(k theta - phi_k),  k = 1 .. K

fitted by least squares over every sample (the discrete Fourier transform when the
samples are one uniform revolution: the same numbers, faster). A harmonic's
``phase_deg`` is ``phi_k`` in degrees: its first crest is at the encoder angle
``phi_k / k``. Dense data (several revolutions, millions of samples) are first averaged
into ``BIN_FACTOR`` bins per harmonic fitted, the bins' own sinc transmission divided out,
so the cost stays bounded. The sampling resolves harmonics up to the Nyquist UPR
``pi / largest angular gap``; a band above it is refused, never aliased.

Gaussian filter (ISO 16610-21 weighting function applied to the closed profile): the
mean line keeps harmonic k with the transmission ``exp(-ln 2 (k / k_c)^2)`` (50 % at the
cut-off ``k_c`` UPR). Roundness: peak-to-valley of the filtered profile about its
least-squares reference circle (LSCI; c + a cos + b sin, the small-eccentricity
limacon), over the samples of the circle. Waviness in a band [k_lo, k_hi]: the largest
harmonic amplitude there, its UPR, and where on the cam the band-passed profile sits
(its envelope from the one-sided harmonic sum: the centroid of the part above half its
peak, and that part's angular extent).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cam_design.errors import InputError
from cam_metrology.metrology import block_lsq
from cam_metrology.metrology.lobe_columns import mask_of, masked
from cam_metrology.metrology.long_columns import Buckets, bucket_count
from cam_metrology.metrology.spill import is_long, release, walk

TWO_PI = 2.0 * np.pi
UM = 1e6
#: default cut-off of the Gaussian profile filter [UPR] (the roundness handbooks' 50 UPR)
DEFAULT_CUTOFF_UPR = 50
#: the filter's mean line is summed up to this many cut-offs (transmission 2^-9 there)
FILTER_SPAN = 3
#: denser samples than twice this many bins per fitted harmonic are averaged into bins
BIN_FACTOR = 8
#: samples of the grid on which band-passed profiles and envelopes are evaluated
ENVELOPE_GRID = 4096
#: harmonics below this amplitude [m] (0.1 nm) are not reported: below any gauge's
#: resolution, their order and phase would be rounding noise
AMPLITUDE_FLOOR_M = 1e-10


@dataclass(frozen=True)
class Spectrum:
    """Harmonics 1..K of a profile: cosine and sine coefficients [m] (index k-1), the
    mean ``c0`` [m], and the Nyquist UPR of the sampling."""

    c0: float
    a: NDArray[np.float64]
    b: NDArray[np.float64]
    nyquist_upr: int

    @property
    def amplitude(self) -> NDArray[np.float64]:
        """A_k [m], k = 1..K."""
        return np.hypot(self.a, self.b)

    @property
    def phase(self) -> NDArray[np.float64]:
        """phi_k [rad] in [0, 2 pi), k = 1..K."""
        return np.mod(np.arctan2(self.b, self.a), TWO_PI)

    def profile(self, theta: NDArray[np.float64], weights: NDArray[np.float64] | None = None,
                ) -> NDArray[np.float64]:
        """sum_k w_k (a_k cos k theta + b_k sin k theta) [m] at ``theta`` [rad] (no mean;
        ``weights`` w_k, default 1)."""
        w = np.ones(self.a.size) if weights is None else weights
        out = np.zeros(np.shape(theta))
        for k in np.flatnonzero(w):
            out += w[k] * (self.a[k] * np.cos((k + 1) * theta) +
                           self.b[k] * np.sin((k + 1) * theta))
        return out


def _floats(a: Any) -> NDArray[np.float64]:
    """``a`` as float64 (a float64 array itself: a spilled column stays mapped)."""
    if isinstance(a, np.ndarray) and a.dtype == np.float64:
        return a
    return np.asarray(a, dtype=float)


def _long(a: NDArray[Any]) -> bool:
    """True for a column read a block at a time (``spill.is_long``)."""
    return is_long(a.size, a.itemsize)


def _sorted_steps(theta: NDArray[np.float64], mean: float) -> tuple[float, float, float]:
    """Of the angles mod 2 pi in ascending order (sorted a chunk at a time through
    ``long_columns.Buckets``): the largest step between neighbours, the largest
    |step - ``mean``| and the step across 2 pi (first + 2 pi - last) [rad]."""
    n = theta.size
    rows = Buckets([('t', 'f8')], 't', 0.0, TWO_PI, bucket_count(n))
    big, off, first, last = -np.inf, 0.0, None, None
    try:
        for a, b in walk(n, theta):
            part = np.empty(b - a, rows.dtype)
            part['t'] = np.mod(theta[a:b], TWO_PI)
            rows.add(part)
        for part in rows.sorted():
            t = part['t'] if last is None else np.concatenate(([last], part['t']))
            first = float(t[0]) if first is None else first
            if t.size > 1:
                step = np.diff(t)
                big = max(big, float(np.max(step)))
                step -= mean
                off = max(off, float(np.max(np.abs(step, out=step))))
            last = float(t[-1])
    finally:
        rows.close()
    assert first is not None and last is not None
    return big, off, float(first + TWO_PI - last)


def nyquist_upr(theta: NDArray[np.float64]) -> int:
    """Highest UPR the samples resolve: ``pi`` over the largest angular gap between
    neighbouring samples on the circle (every revolution folded onto one)."""
    th = _floats(theta)
    if th.size < 3:
        return 0
    if _long(th):
        big, _, wrap = _sorted_steps(th, 0.0)
        return int(np.floor(np.pi / max(big, wrap) * (1.0 + 1e-6)))
    t = np.mod(th, TWO_PI)
    t.sort()   # in place: one column of the angles alive, not three
    gap = max(float(np.max(np.diff(t))), float(t[0] + TWO_PI - t[-1]))
    return int(np.floor(np.pi / gap * (1.0 + 1e-6)))


def _uniform_revolution(theta: NDArray[np.float64]) -> bool:
    """True if the samples are one revolution on a uniform grid (in any order)."""
    n = theta.size
    if n < 8:
        return False
    if _long(theta):
        mean = TWO_PI / n
        _, off, wrap = _sorted_steps(theta, mean)
        return bool(max(off, abs(wrap - mean)) < 1e-9 * mean)
    t = np.mod(theta, TWO_PI)
    t.sort()
    step = np.diff(t)
    step -= TWO_PI / n
    mean = TWO_PI / n
    worst = max(float(np.max(np.abs(step, out=step))), abs(t[0] + TWO_PI - t[-1] - mean))
    return bool(worst < 1e-9 * mean)


def finite_pairs(th: NDArray[np.float64], y: NDArray[np.float64],
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The samples where both angle and value are finite (the arrays themselves, not
    copies, when all are; long ones checked and copied a block at a time)."""
    if _long(th):
        keep = mask_of(th.size, lambda a, b: np.isfinite(th[a:b]) & np.isfinite(y[a:b]),
                       th, y)
        return (th, y) if keep.all() else (masked(th, keep), masked(y, keep))
    keep = np.isfinite(th)
    keep &= np.isfinite(y)
    if keep.all():
        return th, y
    return th[keep], y[keep]


def harmonics(theta: Any, dev: Any, max_upr: int, *, key: str = 'form.max_upr',
              nyquist: int | None = None) -> Spectrum:
    """Harmonics 1..``max_upr`` of ``dev`` [m] sampled at ``theta`` [rad] (module doc).

    One uniform revolution: its DFT. More samples than ``2 * BIN_FACTOR * max_upr``
    otherwise (several revolutions, encoder jitter, millions of samples): the means of
    angle and deviation over ``BIN_FACTOR * max_upr`` equal bins of the circle (bounded
    cost), fitted by least squares weighted by the counts; the bins' averaging transmits
    harmonic k by about sinc(k / bins), which is divided out (1 - sinc is at most 0.26 %
    at ``max_upr``). Fewer samples: least squares over every
    sample. InputError naming ``key`` when ``max_upr`` exceeds the Nyquist UPR of the
    samples (or there are too few samples for the fit). ``nyquist``: the Nyquist UPR of
    the finite samples when the caller has it (``nyquist_upr``, a sort of the angles)."""
    th, y = finite_pairs(_floats(theta), _floats(dev))
    nyq = nyquist_upr(th) if nyquist is None else nyquist
    if isinstance(max_upr, bool) or int(max_upr) != max_upr or max_upr < 1:
        raise InputError(key, max_upr, 'a whole number of UPR >= 1')
    if max_upr > nyq:
        raise InputError(key, max_upr, f'at most {nyq} UPR: the largest gap between samples '
                         f'({360.0 / max(2 * nyq, 1):.4g} deg or more) resolves no more '
                         '(Nyquist); sample more densely or lower the band')
    k = int(max_upr)
    if _uniform_revolution(th):
        return _fft_spectrum(th, y, k, nyq)
    bins = BIN_FACTOR * k
    if th.size > 2 * bins:
        return _binned_spectrum(th, y, k, nyq, bins)
    if th.size < 2 * k + 1:
        raise InputError(key, max_upr, f'at most {(th.size - 1) // 2} UPR for '
                         f'{th.size} samples')
    return _lsq_spectrum(th, y, k, nyq)


#: samples per block when counting samples per grid bin (``roundness``)
BIN_BLOCK = 1 << 16


def _bin_index(angle: NDArray[np.float64], width: float, bins: int) -> NDArray[np.int64]:
    """``min(angle // width, bins - 1)`` as int64 [bin number] of angles [rad] in
    [0, 2 pi), with one temporary instead of three (memory)."""
    idx = np.floor_divide(angle, width, out=np.empty_like(angle)).astype(np.int64)
    np.minimum(idx, bins - 1, out=idx)
    return idx


def _binned_spectrum(th: NDArray[np.float64], y: NDArray[np.float64], k: int, nyq: int,
                     bins: int) -> Spectrum:
    """Harmonics of the bin means (angle and deviation) over ``bins`` equal bins of the
    circle, the bins' averaging (sinc) divided out."""
    width = TWO_PI / bins
    if _long(th):   # sums per bin a block at a time, added in sample order: bincount's
        count = np.zeros(bins, np.int64)
        at_sum, y_sum = np.zeros(bins), np.zeros(bins)
        for a, b in walk(th.size, th, y):
            angle = np.mod(th[a:b], TWO_PI)
            idx = _bin_index(angle, width, bins)
            count += np.bincount(idx, minlength=bins)
            np.add.at(at_sum, idx, angle)
            np.add.at(y_sum, idx, y[a:b])
    else:
        angle = np.mod(th, TWO_PI)
        idx = _bin_index(angle, width, bins)
        count = np.bincount(idx, minlength=bins)
        at_sum = np.asarray(np.bincount(idx, angle, minlength=bins), dtype=float)
        y_sum = np.asarray(np.bincount(idx, y, minlength=bins), dtype=float)
    filled = count > 0
    n = count[filled].astype(float)
    at = at_sum[filled] / n     # where the samples are
    mean = y_sum[filled] / n
    spec = _lsq_spectrum(at, mean, k, nyq, weights=np.sqrt(n))
    gain = np.sinc(np.arange(1, k + 1) / bins)
    return Spectrum(spec.c0, spec.a / gain, spec.b / gain, nyq)


def _fft_spectrum(th: NDArray[np.float64], y: NDArray[np.float64], k: int,
                  nyq: int) -> Spectrum:
    """The DFT of one uniform revolution, rotated to encoder angle 0."""
    n = th.size
    order = np.argsort(np.mod(th, TWO_PI), kind='stable')
    t0 = float(np.mod(th, TWO_PI)[order[0]])
    z = np.fft.rfft(y[order])[:k + 1] * (2.0 / n)
    z *= np.exp(-1j * np.arange(k + 1) * t0)   # sample 0 sits at t0, not 0
    return Spectrum(float(z[0].real / 2.0), z[1:].real.copy(), -z[1:].imag.copy(), nyq)


def _lsq_spectrum(th: NDArray[np.float64], y: NDArray[np.float64], k: int,
                  nyq: int, weights: NDArray[np.float64] | None = None) -> Spectrum:
    """Least squares over every sample (rows scaled by ``weights``), the design matrix a
    block of rows at a time."""
    w = np.ones(th.size) if weights is None else weights

    def blocks() -> Any:
        step = max(block_lsq.BLOCK_ROWS // max(k, 1), 1024)
        ks = np.arange(1, k + 1)
        for i in range(0, th.size, step):
            arg = np.outer(th[i:i + step], ks)
            wb = w[i:i + step, None]
            yield wb * np.column_stack([np.ones(arg.shape[0]), np.cos(arg), np.sin(arg)]), \
                w[i:i + step] * y[i:i + step]

    coef = block_lsq.solve(*block_lsq.triangle(blocks()))
    return Spectrum(float(coef[0]), coef[1:k + 1].copy(), coef[k + 1:].copy(), nyq)


def gaussian_transmission(upr: Any, cutoff_upr: float) -> NDArray[np.float64]:
    """Amplitude transmission of the Gaussian mean line at ``upr``:
    exp(-ln 2 (upr / cutoff)^2), 0.5 at the cut-off."""
    u = np.asarray(upr, dtype=float) / float(cutoff_upr)
    return np.exp(-np.log(2.0) * u * u)


def gaussian_weighting_filter(dev: Any, cutoff_upr: float) -> NDArray[np.float64]:
    """Mean line [m] of a closed profile sampled uniformly over one revolution, by
    circular convolution with the sampled Gaussian weighting function
    s(x) = exp(-pi (x / (alpha lambda_c))^2) / (alpha lambda_c), alpha = sqrt(ln 2 / pi),
    lambda_c = 2 pi / cutoff [rad] (ISO 16610-21), normalised to unit sum."""
    y = np.asarray(dev, dtype=float)
    n = y.size
    x = (np.arange(n) - n // 2) * (TWO_PI / n)
    alpha = np.sqrt(np.log(2.0) / np.pi)
    width = alpha * TWO_PI / float(cutoff_upr)
    s = np.exp(-np.pi * (x / width) ** 2)
    s /= s.sum()
    kernel = np.fft.ifftshift(s)
    return np.fft.irfft(np.fft.rfft(y) * np.fft.rfft(kernel), n)


@dataclass(frozen=True)
class FormResult:
    """Form numbers of one profile (report fields, µm and degrees)."""

    harmonics: list[dict[str, float]]
    roundness_um: float | None
    waviness: dict[str, Any]
    cutoff_upr: int
    nyquist_upr: int

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready fields of ``features.<id>``."""
        return {'harmonics': self.harmonics, 'roundness_um': self.roundness_um,
                'waviness': self.waviness,
                'form_filter': {'kind': 'gaussian', 'cutoff_upr': self.cutoff_upr,
                                'nyquist_upr': self.nyquist_upr}}


def harmonic_list(spec: Spectrum, upto: int, floor_m: float = AMPLITUDE_FLOOR_M,
                  ) -> list[dict[str, float]]:
    """Harmonics 1..``upto`` as {upr, amplitude_um, phase_deg}, the largest first,
    those above ``floor_m`` [m] only."""
    amp = spec.amplitude[:upto]
    ph = np.degrees(spec.phase[:upto])
    order = np.argsort(-amp, kind='stable')
    return [{'upr': int(k + 1), 'amplitude_um': float(amp[k] * UM),
             'phase_deg': float(ph[k])} for k in order if amp[k] > floor_m]


def waviness(spec: Spectrum, band: tuple[int, int]) -> dict[str, Any]:
    """Largest harmonic in ``band`` = (lo, hi) UPR, and where the band-passed profile
    sits: ``peak_um`` (the largest value of its envelope), ``at_deg`` (encoder angle of
    the centroid, weighted by the envelope squared, of the part above half that peak)
    and ``extent_deg`` (the angular length of that part)."""
    lo, hi = band
    amp = spec.amplitude
    sel = np.arange(lo - 1, hi)
    k = int(sel[np.argmax(amp[sel])])
    if amp[k] < AMPLITUDE_FLOOR_M:   # nothing there: no UPR or place to name
        return {'band_upr': [int(lo), int(hi)], 'max_amplitude_um': float(amp[k] * UM),
                'upr_at_max': None, 'at_deg': None, 'peak_um': None, 'extent_deg': None}
    grid = np.arange(ENVELOPE_GRID) * (TWO_PI / ENVELOPE_GRID)
    ks = sel + 1
    z = (spec.a[sel] - 1j * spec.b[sel])[None, :] * np.exp(1j * np.outer(grid, ks))
    env = np.abs(z.sum(axis=1))
    peak = float(np.max(env))
    high = env >= 0.5 * peak
    w = env[high] ** 2   # where it sits: the centroid of the envelope above half its peak
    at = np.arctan2(np.sum(w * np.sin(grid[high])), np.sum(w * np.cos(grid[high])))
    return {'band_upr': [int(lo), int(hi)], 'max_amplitude_um': float(amp[k] * UM),
            'upr_at_max': k + 1, 'at_deg': float(np.degrees(at) % 360.0),
            'peak_um': peak * UM,
            'extent_deg': float(np.count_nonzero(high) * 360.0 / grid.size)}


def roundness(theta: NDArray[np.float64], spec: Spectrum, cutoff_upr: int,
              circle: NDArray[np.bool_] | None = None) -> float | None:
    """Peak-to-valley [m] of the Gaussian-filtered profile about its least-squares
    circle, over the samples of ``circle`` (all when None); None with fewer than 10.
    More samples than a grid of ``max(ENVELOPE_GRID, 16 x the harmonics kept)`` angles:
    the profile is evaluated on that grid instead, at the grid angles whose bin holds
    circle samples only (bounded cost)."""
    mask = np.ones(theta.size, bool) if circle is None else circle
    if np.count_nonzero(mask) < 10:
        return None
    upto = min(spec.a.size, FILTER_SPAN * cutoff_upr)
    grid = max(ENVELOPE_GRID, 16 * upto)
    if theta.size <= grid:
        t = theta[mask]
    else:
        total = np.zeros(grid, np.int64)   # counted a block at a time (memory)
        inside = np.zeros(grid, np.int64)
        for a in range(0, theta.size, BIN_BLOCK):
            idx = _bin_index(np.mod(theta[a:a + BIN_BLOCK], TWO_PI), TWO_PI / grid, grid)
            total += np.bincount(idx, minlength=grid)
            inside += np.bincount(idx[mask[a:a + BIN_BLOCK]], minlength=grid)
            release(theta)   # a spilled column: one block resident
        del idx
        t = ((np.arange(grid) + 0.5) * (TWO_PI / grid))[(total > 0) & (inside == total)]
        if t.size < 10:
            return None
    w = gaussian_transmission(np.arange(1, upto + 1), cutoff_upr)
    part = Spectrum(spec.c0, spec.a[:upto], spec.b[:upto], spec.nyquist_upr)
    mean_line = spec.c0 + part.profile(t, w)
    coef = block_lsq.harmonic_lstsq(t, mean_line)
    resid = mean_line - block_lsq.first_harmonic(t, *(float(v) for v in coef))
    return float(np.max(resid) - np.min(resid))


def check_band(band: tuple[int, int], nyquist: int, key: str) -> None:
    """InputError naming ``key`` when the band is empty or above the Nyquist UPR."""
    lo, hi = band
    if not 1 <= lo <= hi:
        raise InputError(key, list(band), '[lo, hi] UPR with 1 <= lo <= hi')
    if hi > nyquist:
        raise InputError(key, list(band), f'a band up to at most {nyquist} UPR: the '
                         'sampling resolves no more (Nyquist UPR = pi / largest angular '
                         'gap); sample more densely or lower the band')


def analyze_form(theta: Any, dev: Any, *, cutoff_upr: int = DEFAULT_CUTOFF_UPR,
                 band: tuple[int, int] | None = None, circle: Any = None,
                 key: str = 'form') -> FormResult:
    """Harmonics up to the cut-off, roundness about the LSCI over ``circle`` and waviness
    in ``band`` (default: 15 UPR to the cut-off) of the profile ``dev`` [m] at
    ``theta`` [rad]; InputError naming ``key`` for a band or cut-off the sampling does
    not resolve."""
    th, y = _floats(theta), _floats(dev)
    if _long(th):   # a block at a time
        ok = mask_of(th.size, lambda a, b: np.isfinite(th[a:b]) & np.isfinite(y[a:b]), th, y)
    else:
        ok = np.isfinite(th)
        ok &= np.isfinite(y)
    mask = ok if circle is None else ok & np.asarray(circle, bool)
    if ok.all():
        th_ok, y_ok = th, y
    else:
        th_ok, y_ok = (masked(th, ok), masked(y, ok)) if _long(th) else (th[ok], y[ok])
    band = band or (min(15, cutoff_upr), cutoff_upr)
    nyq = nyquist_upr(th_ok)
    check_band(band, nyq, f'{key}.waviness_band_upr')
    if cutoff_upr > nyq:
        raise InputError(f'{key}.cutoff_upr', cutoff_upr, f'at most {nyq} UPR (the '
                         'Nyquist UPR of the sampling)')
    upto = max(band[1], min(FILTER_SPAN * cutoff_upr, nyq))
    spec = harmonics(th_ok, y_ok, upto, key=f'{key}.cutoff_upr', nyquist=nyq)
    circ = mask[ok]
    rnd = roundness(th_ok, spec, cutoff_upr, circ)
    return FormResult(harmonic_list(spec, cutoff_upr), None if rnd is None else rnd * UM,
                      waviness(spec, band), int(cutoff_upr), nyq)
