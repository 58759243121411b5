"""Camshaft speed and a smooth encoder angle on the time clock (docs/methods.md "Rig").

The encoder angle is unwrapped, and a least-squares cubic spline theta(t) with knots
every 1/8 revolution is fitted through it: quantisation steps and counting jitter
average out, a speed ripple of a few harmonics per revolution is kept. The speed is
its derivative; its mean, standard deviation and range describe the run.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from cam_design.errors import InputError

#: spline knots per revolution of the camshaft
KNOTS_PER_REV = 16
#: fewest full revolutions a run must cover
MIN_REVOLUTIONS = 1.5


@dataclass(frozen=True)
class Speed:
    """Encoder result: ``theta`` [rad] smoothed, unwrapped, increasing (sign folded in
    ``sign``: +1 when the encoder counts up); ``rpm`` mean, ``rpm_std`` and ``rpm_min``,
    ``rpm_max`` over the run; ``revolutions`` covered; ``quantum`` [rad] the smallest
    encoder step seen (0 for a continuous encoder)."""

    theta: NDArray[np.float64]
    sign: int
    rpm: float
    rpm_std: float
    rpm_min: float
    rpm_max: float
    revolutions: float
    quantum: float
    offset: float = 0.0

    @property
    def encoder(self) -> NDArray[np.float64]:
        """The smoothed encoder angle as the encoder counts [rad], with the quantisation
        offset (``quantisation_offset``) added."""
        return self.sign * self.theta + self.offset

    @property
    def variation(self) -> float:
        """(max - min) / mean of the speed within the run."""
        return (self.rpm_max - self.rpm_min) / self.rpm


def unwrap_angle(angle: NDArray[np.float64], name: str) -> NDArray[np.float64]:
    """The encoder angle unwrapped (a wrapped [0, 2 pi) reading made continuous)."""
    d = np.diff(angle)
    if d.size and np.median(np.abs(d)) > math.pi / 2:
        raise InputError(f'run {name} cam_angle_rad', f'steps of {np.median(np.abs(d)):.3g} '
                         'rad between samples', 'less than a quarter revolution per sample '
                         '(sample the encoder faster)')
    return np.unwrap(angle)


def _float_gcd(values: NDArray[np.float64], rel: float = 1e-6) -> float:
    """Greatest common divisor of positive floats (0 when there is none above
    ``rel`` times the smallest: not a lattice)."""
    g = float(values[0])
    floor = rel * g
    for v in values[1:32]:
        a, b = float(v), g
        while b > floor:
            a, b = b, math.fmod(a, b)
            if b > a - floor:        # remainder within rounding of the divisor
                b = 0.0
        g = a
        if g <= floor:
            return 0.0
    return g


def encoder_quantum(angle: NDArray[np.float64]) -> float:
    """The encoder's count step [rad] when the reading is quantised, else 0.

    Quantised: the readings (wrapped to one revolution) sit on a lattice of a whole
    number of counts per revolution, and the steps between samples differ (or repeat a
    count). A continuous angle sampled so that every step is the same cannot be told
    from counts and is taken as continuous.
    """
    d = np.abs(np.diff(angle))
    d = d[d < math.pi]                 # wraps are not steps
    pos = d[d > 0]
    if pos.size < 2:
        return 0.0
    values = np.unique(np.mod(angle, 2 * math.pi))
    gaps = np.diff(values)
    gaps = gaps[gaps > 1e-12]
    if gaps.size == 0:
        return 0.0
    q = _float_gcd(np.unique(np.round(gaps / np.min(gaps), 6)) * float(np.min(gaps)))
    if q <= 0:
        return 0.0
    on_lattice = np.abs((values - values[0]) / q - np.round((values - values[0]) / q))
    counts = 2 * math.pi / q
    lattice = bool(np.all(on_lattice < 1e-3)) and abs(counts - round(counts)) < 1e-3
    if lattice and (np.mean(d == 0) > 0.01 or np.std(pos) > 0.01 * q):
        return 2 * math.pi / round(counts)
    return 0.0


def quantisation_offset(read: NDArray[np.float64], fit: NDArray[np.float64],
                        quantum: float) -> float:
    """The constant [rad] to add to a smooth fit of quantised readings.

    A reading n q means the angle lies in [n q, (n + 1) q). With r = reading - fit, the
    true angle fit + b satisfies max r <= b < min r + q; the middle of that interval is
    taken (robust quantiles instead of the extremes). For readings spread evenly over
    the counts this is q/2; for a sampling locked to the counts (an rpm and a sampling
    rate in a simple ratio) it removes the bias that the fixed q/2 would leave.
    """
    r = read - fit
    hi, lo = np.quantile(r, [0.995, 0.005])
    return float(0.5 * (hi + lo + quantum))


def encoder_speed(time: NDArray[np.float64], angle: NDArray[np.float64], name: str,
                  max_variation: float) -> Speed:
    """Fit the smooth angle and the speed of a run; InputError when the run covers too
    few revolutions or its speed varies by more than ``max_variation``."""
    from scipy.interpolate import make_lsq_spline

    th = unwrap_angle(angle, name)
    span = th[-1] - th[0]
    sign = 1 if span >= 0 else -1
    th = sign * th
    revs = abs(span) / (2 * math.pi)
    if revs < MIN_REVOLUTIONS:
        raise InputError(f'run {name}', f'{revs:.2f} camshaft revolutions',
                         f'at least {MIN_REVOLUTIONS:g} revolutions at a steady speed '
                         '(record longer)')
    t0, t1 = float(time[0]), float(time[-1])
    nk = max(2, int(math.ceil(revs * KNOTS_PER_REV)))
    inner = np.linspace(t0, t1, nk + 1)[1:-1]
    knots = np.concatenate([[t0] * 4, inner, [t1] * 4])
    spl = make_lsq_spline(time, th, knots, k=3)
    fit = spl(time)
    grid = np.linspace(t0, t1, max(200, 16 * nk))
    w = spl.derivative()(grid[2:-2])   # ends of a spline fit are loose: not judged
    to_rpm = 30.0 / math.pi
    rpm = span * sign / (t1 - t0) * to_rpm
    quantum = encoder_quantum(angle)
    offset = quantisation_offset(sign * th, sign * fit, quantum) if quantum else 0.0
    out = Speed(theta=fit, sign=sign, rpm=float(rpm), rpm_std=float(np.std(w) * to_rpm),
                rpm_min=float(np.min(w) * to_rpm), rpm_max=float(np.max(w) * to_rpm),
                revolutions=float(revs), quantum=quantum, offset=offset)
    if out.rpm <= 0:
        raise InputError(f'run {name} cam_angle_rad', 'a standing shaft',
                         'a turning camshaft')
    if out.variation > max_variation:
        raise InputError(f'run {name} speed',
                         f'{out.rpm_min:.0f} to {out.rpm_max:.0f} rpm '
                         f'({100 * out.variation:.1f} % of {out.rpm:.0f} rpm)',
                         f'a steady speed within {100 * max_variation:g} % (rig.max_speed_'
                         'variation): split the run where the speed changes, or record '
                         'it at a steady speed')
    return out
