"""Resampling a run to cam angle and averaging its cycles (docs/methods.md "Rig").

Every sample gets the smoothed encoder angle of its time stamp (``encoder``); the
revolution is cut into bins of equal width on the encoder angle, and each bin holds the
mean of all its samples over all cycles (the cycle-averaged lift), its sample count,
and the scatter of the per-cycle means (cycle-to-cycle variation). Bins sit on the
encoder angle, not on the lobe angle, so a change of the nose angle in a fit moves the
prediction, never the data.

The laser's zero is referenced to the seated valve: the longest stretch of the
revolution where the averaged lift stays at its lowest level is the base circle; the
mean lift over its middle half is the zero, and the sample-to-sample differences there
give the laser noise (median absolute deviation, so a stray spike does not count).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from cam_design.errors import InputError

TWO_PI = 2.0 * math.pi
#: the base circle: bins within this fraction of the lift range above the lowest level
BASE_LEVEL = 0.02


@dataclass(frozen=True)
class Cycles:
    """Cycle-averaged run on encoder-angle bins.

    phi: (B,) bin centres [rad] in [0, 2 pi); phi_mean: (B,) mean encoder angle of the
    bin's samples [rad] (where its mean lift belongs; the centre when empty);
    step [rad]; index: (N,) bin of each
    sample; enc: (N,) smoothed encoder angle of each sample [rad] (unwrapped, as the
    encoder counts); count: (B,) samples per bin; lift: (B,) mean lift [m] referenced to
    the seated valve (NaN in an empty bin); scatter: (B,) standard deviation [m] of the
    per-cycle means (NaN with fewer than 2 cycles); velocity: (B,) mean vibrometer
    velocity [m/s] or None; zero: the laser reading [m] of the seated valve; noise: the
    laser noise [m] of one sample; cycles: complete revolutions; base: (B,) bool, the
    base-circle bins used for the zero and the noise.
    """

    phi: NDArray[np.float64]
    phi_mean: NDArray[np.float64]
    step: float
    index: NDArray[np.int64]
    enc: NDArray[np.float64]
    count: NDArray[np.int64]
    lift: NDArray[np.float64]
    scatter: NDArray[np.float64]
    velocity: NDArray[np.float64] | None
    zero: float
    noise: float
    cycles: int
    base: NDArray[np.bool_]

    @property
    def stderr(self) -> NDArray[np.float64]:
        """Standard error [m] of each bin mean from the laser noise (inf when empty)."""
        with np.errstate(divide='ignore'):
            return np.where(self.count > 0, self.noise / np.sqrt(np.maximum(self.count, 1)),
                            np.inf)


def bin_means(index: NDArray[np.int64], values: NDArray[np.float64], nbins: int
              ) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Mean of ``values`` per bin (NaN when empty) and the counts."""
    count = np.bincount(index, minlength=nbins)
    total = np.bincount(index, weights=values, minlength=nbins)
    with np.errstate(invalid='ignore', divide='ignore'):
        return np.where(count > 0, total / np.maximum(count, 1), np.nan), count


def _base_bins(lift: NDArray[np.float64]) -> NDArray[np.bool_]:
    """The middle half of the longest circular stretch of lowest-level bins."""
    ok = np.isfinite(lift)
    lo, hi = np.nanmin(lift), np.nanmax(lift)
    low = ok & (lift <= lo + BASE_LEVEL * (hi - lo))
    n = lift.size
    if np.all(low):
        return low
    start = int(np.argmin(low))          # a bin that is not low: stretches do not wrap
    rolled = np.roll(low, -start)
    best, best_len, i = (0, 0), 0, 0
    while i < n:
        if rolled[i]:
            j = i
            while j < n and rolled[j]:
                j += 1
            if j - i > best_len:
                best, best_len = (i, j), j - i
            i = j
        else:
            i += 1
    i0, i1 = best
    q = (i1 - i0) // 4
    sel = np.zeros(n, dtype=bool)
    sel[i0 + q:i1 - q] = True
    return np.roll(sel, start)


def average_cycles(enc: NDArray[np.float64], lift: NDArray[np.float64],
                   velocity: NDArray[np.float64] | None, step: float, name: str
                   ) -> Cycles:
    """Bin a run's samples on the encoder angle ``enc`` [rad] (``step`` [rad] wide) and
    average them over the cycles; the lift comes out referenced to the seated valve."""
    nb = int(round(TWO_PI / step))
    width = TWO_PI / nb
    phi_s = np.mod(enc, TWO_PI)
    index = np.minimum((phi_s / width).astype(np.int64), nb - 1)
    raw, count = bin_means(index, lift, nb)
    empty = int(np.sum(count == 0))
    if empty > nb // 20:
        raise InputError(f'run {name}', f'{empty} of {nb} cam-angle bins without a sample',
                         'a sampling rate high enough for the speed (at least one sample '
                         f'per {math.degrees(width):g} deg; raise rig.step_deg)')
    base = _base_bins(raw)
    if not np.any(base):
        raise InputError(f'run {name} valve_lift_m', 'no base circle',
                         'a valve that rests on its seat for part of the revolution')
    zero = float(np.nanmean(raw[base]))
    on_base = base[index]
    d = np.diff(lift)[on_base[1:] & on_base[:-1]]
    noise = 1.4826 * float(np.median(np.abs(d - np.median(d)))) / math.sqrt(2.0) \
        if d.size > 10 else math.nan
    if not math.isfinite(noise) or noise <= 0:
        noise = max(1e-9, float(np.nanstd(lift[on_base]))) if np.any(on_base) else 1e-9
    # cycle-to-cycle scatter: per-cycle bin means, std across cycles
    cyc = np.floor(np.abs(enc - enc[0]) / TWO_PI).astype(np.int64)
    ncyc = int(cyc[-1]) + 1
    scatter = np.full(nb, np.nan)
    if ncyc >= 2:
        key = cyc * nb + index
        means, cnt = bin_means(key, lift, ncyc * nb)
        m = means.reshape(ncyc, nb)
        with np.errstate(invalid='ignore'):
            ok = np.sum(np.isfinite(m), axis=0) >= 2
            scatter[ok] = np.nanstd(m[:, ok], axis=0, ddof=1)
    vel = None if velocity is None else bin_means(index, velocity, nb)[0]
    centre: NDArray[np.float64] = (np.arange(nb, dtype=np.float64) + 0.5) * width
    at = bin_means(index, phi_s, nb)[0]
    return Cycles(phi=centre, phi_mean=np.where(np.isfinite(at), at, centre), step=width,
                  index=index, enc=enc,
                  count=count, lift=raw - zero, scatter=scatter, velocity=vel, zero=zero,
                  noise=noise, cycles=int(math.floor(abs(enc[-1] - enc[0]) / TWO_PI)),
                  base=base)
