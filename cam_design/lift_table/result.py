"""The result of one reconstruction method on one feature (shared by spline/harmonic)."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cam_design.errors import InputError, require_positive

Evaluator = Callable[[NDArray[np.float64], int], NDArray[np.float64]]
#: residuals [m] below this never warn: 1 nm, 100 x below the resolution of 0.1 um class
#: gauges; rounding of noise-free tables leaves ~1e-14 m
RESIDUAL_FLOOR = 1e-9
#: the lobe, for the h'' shape check: lift above this fraction of the largest lift
LOBE_FRACTION = 0.02


@dataclass
class Reconstruction:
    """Reconstructed lift of one feature by one method.

    ``alpha`` [rad] is the uniform output grid; ``lift`` [m], ``velocity`` [m/rad],
    ``acceleration`` [m/rad^2], ``jerk`` [m/rad^3] are on it. ``residual`` [m] is
    data minus fit at the kept data points ``data_alpha`` (outliers excluded).
    ``parameter`` holds the chosen order or smoothing level and ``why`` says how it
    was chosen. ``evaluate(alpha, nu)`` gives the fit anywhere in its span.
    """

    method: str
    alpha: NDArray[np.float64]
    lift: NDArray[np.float64]
    velocity: NDArray[np.float64]
    acceleration: NDArray[np.float64]
    jerk: NDArray[np.float64]
    data_alpha: NDArray[np.float64]
    residual: NDArray[np.float64]
    parameter: dict[str, Any]
    why: str
    sigma: float
    evaluate: Evaluator
    outliers_alpha: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    warnings: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    spectrum: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None
    #: which input samples were treated as outliers (spline: after the second look)
    outlier_mask: NDArray[np.bool_] | None = None

    @property
    def rms_residual(self) -> float:
        """RMS of the residuals at the kept data points [m]."""
        return float(np.sqrt(np.mean(self.residual ** 2))) if self.residual.size else 0.0

    @property
    def max_residual(self) -> float:
        """Largest absolute residual at the kept data points [m]."""
        return float(np.max(np.abs(self.residual))) if self.residual.size else 0.0

    def derivatives(self) -> NDArray[np.float64]:
        """(4, n): lift, velocity, acceleration, jerk on the grid (per rad)."""
        return np.stack([self.lift, self.velocity, self.acceleration, self.jerk])

    def check_residuals(self, limit: float = 7.0, tol: float = 0.0) -> None:
        """Warn when a residual exceeds ``limit`` noise standard deviations (and
        ``tol`` [m], and ``RESIDUAL_FLOOR``): the fit misses a feature of the data
        (truncation ripple, under-smoothing of a sharp feature, or an undetected
        outlier). The floor keeps rounding-level residuals of noise-free data (sigma
        ~1e-18 m) from warning."""
        bound = max(limit * self.sigma, tol, RESIDUAL_FLOOR)
        worst = self.max_residual
        if self.residual.size and bound > 0 and worst > bound:
            where = float(self.data_alpha[int(np.argmax(np.abs(self.residual)))])
            limit_text = (f'{limit:g} noise sigma ({bound:.3g} m)'
                          if bound == limit * self.sigma else
                          f'{bound:.3g} m (noise sigma {self.sigma:.3g} m)')
            self.warnings.append(f'max residual {worst:.3g} m at {np.degrees(where):.2f} deg '
                                 f'exceeds {limit_text}')

    def check_shape(self, expected: int | None,
                    still: NDArray[np.bool_] | None = None, above_noise: bool = False
                    ) -> None:
        """Warn when the significant signs of h'' (|h''| > 5 % of its largest value) do
        not follow the pattern of a cam lobe: + - + for one lobe (``expected`` = 2 sign
        changes), + - + - + for 4, ...; None: no check. A table that is not a cam, a
        stepped table or angles not taken from the lobe centre show up here. ``still``
        (on the output grid): a dwell, left out (see ``sign_pattern``). ``above_noise``:
        the extra sign changes stand above the noise of h'' (the lobe's own shape, e.g.
        a ramp whose velocity returns to zero), which the warning then says."""
        if expected is None or self.acceleration.size < 3:
            return
        got = sign_pattern(self.acceleration, lift=self.lift, still=still)
        want = '+' + '-+' * (expected // 2) if expected % 2 == 0 else None
        if (got == want) if want is not None else (len(got) - 1 == expected):
            return
        shown = ' '.join(got) if len(got) <= 9 else f'{len(got) - 1} sign changes'
        what = (f'{" ".join(want)} for a lobe with {expected} sign changes'
                if want is not None else f'{expected} sign changes')
        head = f"h'' has {max(len(got) - 1, 0)} significant sign changes, pattern {shown} "
        self.warnings.append(head + (
            f"(a cam lobe usually has {what}), above the noise of h'': not the usual "
            "shape of a cam lobe; the lobe's own (a ramp whose velocity returns to zero, a "
            'second lobe), a table that is not a lobe, or angles not taken from the lobe '
            'centre' if above_noise else
            f'(expected {what}): not the shape of a cam lobe; check that the table is a '
            'lobe measured from its centre, without steps (noise or a real feature '
            'otherwise)'))

    def check_finite(self) -> None:
        """Raise InputError if any output is not finite (never publish silent NaN)."""
        for name in ('lift', 'velocity', 'acceleration', 'jerk'):
            if not np.all(np.isfinite(getattr(self, name))):
                raise InputError(f'{self.method}.{name}', 'non-finite values',
                                 'finite reconstructed values (numerical failure)')


def output_grid(alpha_min: float, alpha_max: float, step: float) -> NDArray[np.float64]:
    """Uniform grid k*step [rad] (integer k) covering [alpha_min, alpha_max]."""
    step = require_positive('step', step)
    k0 = int(np.ceil(alpha_min / step - 1e-9))
    k1 = int(np.floor(alpha_max / step + 1e-9))
    if k1 - k0 + 1 > 10_000_000:
        raise InputError('step', step, 'a step giving at most 1e7 grid points')
    if k1 < k0:
        return np.array([0.5 * (alpha_min + alpha_max)])
    return np.arange(k0, k1 + 1, dtype=np.float64) * step


def per_second(derivs: ArrayLike, rpm: float) -> dict[str, NDArray[np.float64]]:
    """Velocity [m/s], acceleration [m/s^2], jerk [m/s^3] at cam speed ``rpm`` from
    (4, n) derivatives per rad (v = w h', a = w^2 h'', j = w^3 h''')."""
    omega = require_positive('rpm', rpm) * 2.0 * np.pi / 60.0
    d = np.asarray(derivs, dtype=float)
    return {'velocity_m_per_s': omega * d[1], 'acceleration_m_per_s2': omega ** 2 * d[2],
            'jerk_m_per_s3': omega ** 3 * d[3]}


def sign_pattern(acc: NDArray[np.float64], frac: float = 0.05,
                 lift: NDArray[np.float64] | None = None,
                 still: NDArray[np.bool_] | None = None) -> str:
    """Run-length compressed signs ('+'/'-') of ``acc`` where |acc| > frac x max|acc|;
    with ``lift`` (same grid) only on the lobe, where the lift exceeds 2 % of its
    largest value (on the base circle h'' is noise around 0); samples marked ``still``
    (a dwell: h' = 0 within the noise, so h'' is noise around 0 too) are left out."""
    a = np.asarray(acc, dtype=float)
    used = np.ones(a.size, dtype=bool)
    if lift is not None and np.size(lift):
        h = np.asarray(lift, dtype=float)
        used &= h > LOBE_FRACTION * float(np.max(h))
    if still is not None:
        used &= ~np.asarray(still, dtype=bool)
    top = float(np.max(np.abs(a[used]))) if np.any(used) else 0.0
    if not top > 0:
        return ''
    s = np.sign(a[used & (np.abs(a) > frac * top)])
    keep = np.concatenate([[True], s[1:] != s[:-1]])
    return ''.join('+' if v > 0 else '-' for v in s[keep])


def sign_changes(acc: NDArray[np.float64], frac: float = 0.05,
                 lift: NDArray[np.float64] | None = None,
                 still: NDArray[np.bool_] | None = None) -> int:
    """Sign changes of ``acc`` among samples with |acc| > frac * max|acc| (on the lobe
    only when ``lift`` is given, and not ``still``: see ``sign_pattern``)."""
    return max(len(sign_pattern(acc, frac, lift, still)) - 1, 0)
