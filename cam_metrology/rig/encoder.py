"""Camshaft speed and a smooth encoder angle on the time clock (docs/methods.md "Rig").

The encoder angle is unwrapped and a smooth model theta(t) is fitted through it by
linear least squares: a cubic polynomial in time (the mean speed and a slow drift) plus
the first ``HARMONICS`` harmonics of the mean revolution frequency (a speed ripple of a
few orders per revolution). Twenty coefficients for the whole run: quantisation steps
and counting jitter average out over every sample, not over a short stretch, so a
sampling rate locked to the counts leaves no local bias. The speed is its derivative;
the mean speed is the mean slope of the polynomial (whole ripple periods do not count),
its standard deviation and range describe the run.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np
from numpy.typing import NDArray

from cam_design.errors import InputError

#: harmonics of the revolution frequency in the angle model (orders 1..HARMONICS)
HARMONICS = 8
#: degree of the polynomial part of the angle model (mean speed and drift)
DRIFT_DEGREE = 3
#: an order of the angle model is kept when its amplitude exceeds this many standard
#: errors of a harmonic coefficient
SIGNIFICANT = 10.0
#: fewest full revolutions a run must cover
MIN_REVOLUTIONS = 1.5


@dataclass(frozen=True)
class Speed:
    """Encoder result: ``theta`` [rad] smoothed, unwrapped, increasing (sign folded in
    ``sign``: +1 when the encoder counts up); ``rpm`` mean, ``rpm_std`` and ``rpm_min``,
    ``rpm_max`` over the run; ``revolutions`` covered; ``quantum`` [rad] the smallest
    encoder step seen (0 for a continuous encoder). The ripple: the harmonic part of the
    angle model, H(t) = sum_k ripple_cos[k] cos(k w (t - t0)) + ripple_sin[k]
    sin(k w (t - t0)) [rad] over ``orders``, w = ``omega`` [rad/s]; ``psi0`` the uniform
    encoder angle (without H) at ``t0`` [rad] (``rig.ripple``); ``ripple_se`` [rad] the
    standard error of each ripple coefficient and ``angle_sigma`` [rad] the readings'
    scatter about the angle model that gives it (``angle_model``, ``angle_columns``)."""

    theta: NDArray[np.float64]
    sign: int
    rpm: float
    rpm_std: float
    rpm_min: float
    rpm_max: float
    revolutions: float
    quantum: float
    offset: float = 0.0
    orders: tuple[int, ...] = ()
    ripple_cos: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    ripple_sin: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    omega: float = 0.0
    t0: float = 0.0
    psi0: float = 0.0
    ripple_se: float = 0.0
    angle_sigma: float = 0.0

    def ripple_at(self, time: NDArray[np.float64]) -> NDArray[np.float64]:
        """H(t) [rad] at ``time`` [s] (zeros without ripple orders)."""
        out = np.zeros(np.shape(time))
        for k, a, b in zip(self.orders, self.ripple_cos, self.ripple_sin):
            ph = k * self.omega * (np.asarray(time) - self.t0)
            out += a * np.cos(ph) + b * np.sin(ph)
        return out

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


def _design(time: NDArray[np.float64], omega: float, orders: Sequence[int]
            ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Columns of the angle model at ``time`` and of its time derivative: Legendre
    polynomials up to ``DRIFT_DEGREE`` on the run, cos/sin of ``orders`` x ``omega``."""
    from numpy.polynomial import legendre

    t0, t1 = float(time[0]), float(time[-1])
    half = 0.5 * (t1 - t0)
    tau = (time - t0) / half - 1.0
    eye = np.eye(DRIFT_DEGREE + 1)
    cols = [legendre.legval(tau, eye[j]) for j in range(DRIFT_DEGREE + 1)]
    dcols = [legendre.legval(tau, legendre.legder(eye[j])) / half
             for j in range(DRIFT_DEGREE + 1)]
    for k in orders:
        ph = k * omega * (time - t0)
        cols += [np.cos(ph), np.sin(ph)]
        dcols += [-k * omega * np.sin(ph), k * omega * np.cos(ph)]
    return np.column_stack(cols), np.column_stack(dcols)


@dataclass(frozen=True)
class AngleModel:
    """The fitted angle model: ``fit`` [rad] and ``rate`` [rad/s] at the samples'
    times, ``omega`` the mean speed [rad/s]; the kept ripple ``orders`` with their
    cos/sin coefficients [rad] in the phase k ``omega_h`` (t - t0), t0 the first time;
    ``se`` [rad] the standard error of one coefficient (``coefficient_error``)."""

    fit: NDArray[np.float64]
    rate: NDArray[np.float64]
    omega: float
    orders: tuple[int, ...]
    cos: NDArray[np.float64]
    sin: NDArray[np.float64]
    omega_h: float
    se: float = 0.0


def angle_model(time: NDArray[np.float64], theta: NDArray[np.float64]) -> AngleModel:
    """Fit the smooth angle model to unwrapped, increasing readings ``theta`` [rad] at
    ``time`` [s].

    The harmonic frequency is the mean speed, refined twice. Then only the orders whose
    amplitude stands out of the readings' scatter (``SIGNIFICANT`` standard errors)
    are kept and the model is fitted again: an order that is only counting noise would
    put the same angle error into every cycle, where averaging cannot remove it."""
    t0, t1 = float(time[0]), float(time[-1])
    y = theta - theta[0]
    omega = float(y[-1]) / (t1 - t0)
    orders: list[int] = list(range(1, HARMONICS + 1))
    for step in range(4):
        omega_h = omega
        a, da = _design(time, omega, orders)
        coef, *_ = np.linalg.lstsq(a, y, rcond=None)
        p = coef[:DRIFT_DEGREE + 1]
        # mean slope of the polynomial part: (P(1) - P(-1)) / duration
        omega = float(np.sum(p[1::2])) * 2.0 / (t1 - t0)
        if step == 2:
            resid = y - a @ coef
            se = float(np.std(resid)) * math.sqrt(2.0 / y.size)
            amp = np.hypot(coef[DRIFT_DEGREE + 1::2], coef[DRIFT_DEGREE + 2::2])
            orders = [k for k, v in zip(orders, amp) if v > SIGNIFICANT * se]
    harm = coef[DRIFT_DEGREE + 1:]
    return AngleModel(fit=a @ coef + theta[0], rate=da @ coef, omega=omega,
                      orders=tuple(orders), cos=np.asarray(harm[0::2], dtype=float),
                      sin=np.asarray(harm[1::2], dtype=float), omega_h=omega_h,
                      se=coefficient_error(time, y - a @ coef, omega_h, orders))


def angle_columns(time: NDArray[np.float64], speed: Speed
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(columns, covariance) of a run's angle model: the model's columns at ``time``
    (n x m: the cubic's, then cos and sin of each kept order; ``speed.theta`` moves by
    columns @ d for coefficient errors d [rad]) and the coefficients' covariance
    ``speed.angle_sigma``^2 (A^T A)^-1 [rad^2]."""
    a, _ = _design(time, speed.omega, speed.orders)
    cov = np.linalg.pinv(a.T @ a) * speed.angle_sigma ** 2
    return a, np.asarray(cov, dtype=np.float64)


def coefficient_error(time: NDArray[np.float64], resid: NDArray[np.float64], omega: float,
                      orders: Sequence[int]) -> float:
    """Standard error [rad] of one harmonic coefficient of the angle model, from its
    residuals ``resid`` [rad]: the larger of the white-noise value std * sqrt(2 / n) and
    the residuals' own amplitude between the kept orders (their projections on the
    half orders k +- 1/2 next to them, mean square per coefficient). Quantisation and
    counting errors are not white: aliased by the sampling they can sit at low
    frequencies, where the harmonic coefficients feel them; the neighbouring half
    orders measure that local level."""
    n = resid.size
    white = float(np.std(resid)) * math.sqrt(2.0 / n)
    halves = sorted({h for k in orders for h in (k - 0.5, k + 0.5)})
    if not halves:
        return white
    ph = np.outer(time - time[0], np.asarray(halves) * omega)
    pc = 2.0 / n * (resid @ np.cos(ph))
    ps = 2.0 / n * (resid @ np.sin(ph))
    local = float(np.sqrt(np.mean(0.5 * (pc ** 2 + ps ** 2))))
    return max(white, local)


def encoder_speed(time: NDArray[np.float64], angle: NDArray[np.float64], name: str,
                  max_variation: float) -> Speed:
    """Fit the smooth angle and the speed of a run; InputError when the run covers too
    few revolutions or its speed varies by more than ``max_variation``."""
    th = unwrap_angle(angle, name)
    span = th[-1] - th[0]
    sign = 1 if span >= 0 else -1
    th = sign * th
    revs = abs(span) / (2 * math.pi)
    if revs < MIN_REVOLUTIONS:
        raise InputError(f'run {name}', f'{revs:.2f} camshaft revolutions',
                         f'at least {MIN_REVOLUTIONS:g} revolutions at a steady speed '
                         '(record longer)')
    model = angle_model(time, th)
    fit, w = model.fit, model.rate
    to_rpm = 30.0 / math.pi
    quantum = encoder_quantum(angle)
    offset = quantisation_offset(sign * th, sign * fit, quantum) if quantum else 0.0
    t0 = float(time[0])
    h0 = float(np.sum(model.cos))            # H(t0): every phase is 0 there
    out = Speed(theta=fit, sign=sign, rpm=float(model.omega * to_rpm),
                rpm_std=float(np.std(w) * to_rpm),
                rpm_min=float(np.min(w) * to_rpm), rpm_max=float(np.max(w) * to_rpm),
                revolutions=float(revs), quantum=quantum, offset=offset,
                orders=model.orders, ripple_cos=model.cos, ripple_sin=model.sin,
                omega=model.omega_h, t0=t0,
                psi0=float(sign * (fit[0] - h0) + offset), ripple_se=model.se,
                angle_sigma=model.se / math.sqrt(2.0 / max(1, time.size)))
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
