"""Sensitive-point method (docs/metrology.md, Liu).

An angle inferred from a lift reading has the error dh/|h'|, so the crossings of
the measured lift with design levels are taken where |h'| of the design lift as
seen by the probe is largest: alpha_m on the rise flank (alpha < 0) and alpha_n on
the fall flank (alpha > 0). The measured crossing angles phi_m, phi_n give the nose
as their circular mean (seed: phi0 = (phi_m + phi_n)/2 - 180 deg for phi_m ~ 23 deg,
phi_n ~ 337 deg). The crossing is found from a local fit over a window around the
sensitive point, not from two neighbouring samples: the deviation of the measured
lift from the design lift (small and smooth) is fitted by a low-order polynomial and
``g(alpha) + p(alpha) = level`` is solved by Newton. Without noise and for a pure
shift this is exact; with noise the crossing's uncertainty comes from the fit.

Multi-pair variant (seed §5(2)): level pairs at alpha_m + k*spacing and
alpha_n - k*spacing (k = -K..K); each pair's nose is averaged with weights
1/var (= |h'|^2 weights for a symmetric lobe). Validity (seed §3): re-zeroed at the
nose found, the measured lifts at alpha_m and alpha_n must match the design levels
equally (h_m = h_n for a symmetric lobe).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import brentq

from cam_design.errors import InputError
from cam_metrology.metrology.flank_fit import Lift
from cam_metrology.metrology.lobe_columns import mask_of, selected

ARCSEC = np.pi / (180 * 3600)


def circular_mean(angles: NDArray[np.float64] | list[float],
                  weights: NDArray[np.float64] | list[float] | None = None) -> float:
    """Weighted circular mean [rad] of angles [rad]: atan2(sum w sin, sum w cos)."""
    a = np.asarray(angles, dtype=float)
    w = np.ones_like(a) if weights is None else np.asarray(weights, dtype=float)
    return float(np.arctan2(np.sum(w * np.sin(a)), np.sum(w * np.cos(a))))


def seed_nose(phi_m: float, phi_n: float) -> float:
    """Nose/pin-centre angle [rad] from the two crossing angles [rad] of a symmetric
    feature (Liu): the circular mean, wrapped to [0, 2 pi)."""
    return float(np.mod(circular_mean([phi_m, phi_n]), 2 * np.pi))


def sensitive_points(lift: Lift, lo: float, hi: float, samples: int = 20001,
                     ) -> tuple[float, float]:
    """(alpha_m, alpha_n) [rad]: argmax |h'| on (lo, 0) and on (0, hi).

    A dense grid locates the maxima; a root of h'' refines each one when h'' changes
    sign around it (else the grid point is kept).
    """
    out = []
    for a, b in ((lo, 0.0), (0.0, hi)):
        grid = np.linspace(a, b, samples)
        slope = np.abs(lift(grid, 1))
        k = int(np.argmax(slope))
        best = float(grid[k])
        if 0 < k < samples - 1:
            left, right = float(grid[k - 1]), float(grid[k + 1])
            fl, fr = float(lift(np.array(left), 2)), float(lift(np.array(right), 2))
            if fl * fr < 0:
                best = brentq(lambda t: float(lift(np.array(t), 2)), left, right,
                              xtol=1e-15)
        out.append(best)
    return out[0], out[1]


@dataclass(frozen=True)
class Crossing:
    """Measured crossing of a design level: angle [rad] (relative frame), its std,
    the measured lift deviation at the design angle [m], samples used."""

    alpha: float
    std: float
    deviation_at_design: float
    samples: int


def crossing(x: NDArray[np.float64], lift_ref: NDArray[np.float64], lift: Lift,
             alpha_design: float, window: tuple[float, float], order: int = 1) -> Crossing:
    """Angle where the measured lift (referenced, ``lift_ref`` [m] at ``x`` [rad])
    crosses the design level ``lift(alpha_design)``, from a local fit over
    ``window`` = (lo, hi) [rad] of the deviation from design."""
    sel = (x >= window[0]) & (x <= window[1])
    n = int(np.count_nonzero(sel))
    if n < order + 3:
        raise InputError('sensitive_point.samples', n,
                         f'at least {order + 3} samples within '
                         f'[{np.degrees(window[0]):.3f}, {np.degrees(window[1]):.3f}] deg')
    xs = x[sel]
    dev = lift_ref[sel] - lift(xs, 0)
    u = xs - alpha_design
    vand = np.vander(u, order + 1, increasing=True)
    coef, *_ = np.linalg.lstsq(vand, dev, rcond=None)
    res = dev - vand @ coef
    dof = max(n - order - 1, 1)
    cov = float(res @ res) / dof * np.linalg.pinv(vand.T @ vand)
    level = float(lift(np.array(alpha_design), 0))
    a = alpha_design
    for _ in range(50):
        t = a - alpha_design
        p = np.polynomial.polynomial.polyval(t, coef)
        dp = np.polynomial.polynomial.polyval(t, np.polynomial.polynomial.polyder(coef))
        slope = float(lift(np.array(a), 1)) + dp
        step = (float(lift(np.array(a), 0)) + p - level) / slope
        a -= step
        if abs(step) < 1e-15:
            break
    if not (np.isfinite(a) and window[0] - (window[1] - window[0]) <= a
            <= window[1] + (window[1] - window[0])):
        raise InputError('sensitive_point.crossing', float(np.degrees(a)),
                         f'a crossing of the level {level * 1e3:.4f} mm near the window '
                         f'[{np.degrees(window[0]):.3f}, {np.degrees(window[1]):.3f}] deg '
                         '(the measured lift does not reach it there)')
    basis = (a - alpha_design) ** np.arange(order + 1)
    var_p = float(basis @ cov @ basis)
    return Crossing(float(a), float(np.sqrt(max(var_p, 0.0)) / abs(slope)),
                    float(coef[0]), n)


@dataclass(frozen=True)
class SensitivePointResult:
    """Shift ``d`` [rad] of the nose in the relative frame, its std, the sensitive
    points, the crossings per pair and the validity check (lift deviations at
    alpha_m, alpha_n after re-zeroing [m], and whether they agree)."""

    d: float
    d_std: float
    alpha_m: float
    alpha_n: float
    level_m: float
    level_n: float
    crossings: tuple[tuple[Crossing, Crossing], ...]
    validity_dev_m: float
    validity_dev_n: float
    valid: bool
    iterations: int


def sensitive_point_shift(x: NDArray[np.float64], lift_ref: NDArray[np.float64],
                          lift: Lift, alpha_m: float, alpha_n: float, *,
                          half_window: float, pairs: int = 0, spacing: float = 0.0,
                          limits: tuple[float, float] = (-np.inf, np.inf), order: int = 1,
                          inward_only: bool = False,
                          validity_tol: float = 1e-6, max_iter: int = 10,
                          used: NDArray[np.bool_] | None = None) -> SensitivePointResult:
    """Nose shift d [rad] by the sensitive-point method (multi-pair if ``pairs`` > 0).

    ``x`` [rad] sample angles relative to a coarse nose, ``lift_ref`` [m] readings
    referenced to the design zero (base circle, or pin geometry); windows are
    clipped to ``limits`` [rad] (the contact range of a dowel pin); ``inward_only``
    puts the extra pairs only towards the top (k = 0..2K). The frame is re-centred on
    the current estimate until the shift converges. ``used``: the samples to use (all
    when None).

    Only the samples within ``SP_REACH`` of every window the iteration may use are
    taken (copied once); should the shift move further, the whole set is used: the
    result is the same either way, the memory a small part of the feature.
    """
    kw = dict(half_window=half_window, pairs=pairs, spacing=spacing, limits=limits,
              order=order, inward_only=inward_only, validity_tol=validity_tol,
              max_iter=max_iter)
    reach = half_window + (2 * pairs if inward_only else pairs) * spacing + SP_REACH
    near = mask_of(x.size, lambda a, b: (np.abs(x[a:b] - alpha_m) <= reach) |
                   (np.abs(x[a:b] - alpha_n) <= reach), x)   # a block at a time
    if used is not None:
        near &= used
    try:
        return _sp_iterate(selected(x, near), selected(lift_ref, near), lift, alpha_m, alpha_n,
                           max_shift=SP_REACH, **kw)   # type: ignore[arg-type]
    except _OutOfReach:
        sel = np.ones(x.size, bool) if used is None else used
        return _sp_iterate(x[sel], lift_ref[sel], lift, alpha_m, alpha_n,
                           max_shift=np.inf, **kw)   # type: ignore[arg-type]


#: samples farther than this [rad] from every window are left out (0.2 rad = 11.5 deg,
#: more than the largest shift a credible fit moves: ``max_shift_deg`` 5 deg)
SP_REACH = 0.2


class _OutOfReach(Exception):
    """The shift moved farther than the samples taken cover."""


def _sp_iterate(x: NDArray[np.float64], lift_ref: NDArray[np.float64], lift: Lift,
                alpha_m: float, alpha_n: float, *, half_window: float, pairs: int,
                spacing: float, limits: tuple[float, float], order: int,
                inward_only: bool, validity_tol: float, max_iter: int,
                max_shift: float) -> SensitivePointResult:
    """The iteration of ``sensitive_point_shift`` on the samples given; raises
    ``_OutOfReach`` when a window would need samples beyond ``max_shift`` [rad]."""
    d = 0.0
    # pairs on both sides of the sensitive points, or (dowel pin: the sensitive points
    # sit at the edge of contact) only towards the top
    ks = np.arange(0, 2 * pairs + 1) if inward_only else np.arange(-pairs, pairs + 1)
    it = 0
    for it in range(1, max_iter + 1):
        if abs(d) > max_shift:
            raise _OutOfReach
        xr = x - d
        shifts, variances, cross = [], [], []
        for k in ks:
            am, an = alpha_m + k * spacing, alpha_n - k * spacing
            cm = crossing(xr, lift_ref, lift, am, _win(am, half_window, limits), order)
            cn = crossing(xr, lift_ref, lift, an, _win(an, half_window, limits), order)
            cross.append((cm, cn))
            shifts.append(0.5 * ((cm.alpha - am) + (cn.alpha - an)))
            variances.append(0.25 * (cm.std**2 + cn.std**2))
        var = np.asarray(variances)
        w = 1.0 / var if np.all(var > 0) else np.ones_like(var)
        step = float(np.sum(w * np.asarray(shifts)) / np.sum(w))
        d += step
        if abs(step) < 1e-14:
            break
    std = float(np.sqrt(1.0 / np.sum(1.0 / var))) if np.all(var > 0) else 0.0
    centre = cross[0 if inward_only else pairs]
    dev_m, dev_n = centre[0].deviation_at_design, centre[1].deviation_at_design
    tol = max(validity_tol, 3.0 * np.hypot(centre[0].std * abs(float(lift(np.array(alpha_m), 1))),
                                           centre[1].std * abs(float(lift(np.array(alpha_n), 1)))))
    return SensitivePointResult(
        d, std, alpha_m, alpha_n, float(lift(np.array(alpha_m), 0)),
        float(lift(np.array(alpha_n), 0)), tuple(cross), dev_m, dev_n,
        bool(abs(dev_m - dev_n) <= tol), it)


def _win(centre: float, half: float, limits: tuple[float, float]) -> tuple[float, float]:
    """Window [rad] around ``centre`` clipped to ``limits``."""
    return max(centre - half, limits[0]), min(centre + half, limits[1])
