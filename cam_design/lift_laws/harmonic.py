"""N-harmonic cam (N次谐波凸轮), docs/lift_laws.md [RECON: Shang's basis is unconfirmed].

Implicit ramps (default): h(alpha) = sum_{j=0..N} a_j cos(j pi alpha / Phi) for
|alpha| <= Phi (0 outside), Phi the working half-angle including the ramps. Odd
derivatives vanish at +-Phi automatically; the linear equalities impose h(Phi) = 0,
h''(Phi) = 0, optionally h''''(Phi) = 0 (``end_order: 4``), and h(0) = max_lift. The law
is C3 at +-Phi.

Explicit ramps (``ramp:`` given): the base section |alpha| <= Phi (Phi now the half
base-section angle) uses the basis cos(j pi alpha / (2 Phi)) (odd j give a non-zero end
slope) with h(Phi) = H_r, h'(Phi) = -v_r, h''(Phi) = 0 (a constant-velocity ramp end),
h'''(Phi) = 0 with ``end_order: 3`` (default; 2 omits it) and h(0) = max_lift.

The remaining coefficients are free: fitted by equality-constrained least squares to a
``target`` law sampled on the section, or, without a target, chosen to minimise the
integral of h''^2. Symmetric only (an asymmetric version would add sines).
"""
from __future__ import annotations

import math
from typing import Any, Callable, Mapping

import numpy as np

from cam_design.errors import InputError
from cam_design.lift_laws import params as P
from cam_design.lift_laws.ramps import Ramp, ramp_from_spec
from cam_design.lift_laws.segments import CosineSegment, PiecewiseLaw, Segment


def constrained_fit(c: np.ndarray, d: np.ndarray, w: np.ndarray, rhs: np.ndarray, *,
                    key: str, order: int) -> np.ndarray:
    """min |w a - rhs| subject to c a = d (rows scaled; null-space method; refinement)."""
    from scipy.linalg import null_space

    norm = np.max(np.abs(c), axis=1)
    c, d = c / norm[:, None], d / norm          # row scaling: j^4 reaches 1e6 and more
    if c.shape[1] < c.shape[0]:
        raise InputError(f'{key}.order', order, f'N >= {c.shape[0] - 1} for these conditions')
    a_p, *_ = np.linalg.lstsq(c, d, rcond=None)
    if np.max(np.abs(c @ a_p - d)) > 1e-12 * max(np.max(np.abs(d)), 1e-300):
        raise InputError(f'{key}.order', order, 'an order whose end conditions are solvable')
    z = null_space(c)
    if z.shape[1] == 0:
        return a_p
    wz = w @ z
    ridge = 1e-8 * np.linalg.norm(wz, 2)   # keeps the free amplitudes bounded when the
    # basis is nearly dependent (cos(j pi a/(2 Phi)) on half a period, large N)
    lhs = np.vstack([wz, ridge * np.eye(z.shape[1])])
    y, *_ = np.linalg.lstsq(lhs, np.concatenate([rhs - w @ a_p, np.zeros(z.shape[1])]),
                            rcond=None)
    a = a_p + z @ y
    for _ in range(2):              # iterative refinement of the equalities
        a = a + np.linalg.lstsq(c, d - c @ a, rcond=None)[0]
    return a


def _target_values(target: Callable[[np.ndarray], Any], alpha: np.ndarray,
                   key: str) -> np.ndarray:
    rhs = np.asarray(target(alpha), dtype=float)
    if not np.all(np.isfinite(rhs)):
        raise InputError(f'{key}.target', 'non-finite values', 'a finite target law')
    return rhs


def harmonic_coefficients(order: int, half_angle: float, max_lift: float, *,
                          end_order: int = 2, target: Callable | None = None,
                          samples: int = 2001, key: str = 'lift_law') -> np.ndarray:
    """a_0..a_N [m] of the implicit-ramp form. ``target``: a callable h(alpha) or None."""
    j = np.arange(order + 1, dtype=float)
    sgn = (-1.0) ** j
    rows = [sgn, sgn * j ** 2] + ([sgn * j ** 4] if end_order == 4 else [])
    rows.append(np.ones(order + 1))
    d = np.zeros(len(rows))
    d[-1] = max_lift
    if target is None:      # minimise sum j^4 a_j^2 (the integral of h''^2, orthogonal basis)
        w, rhs = np.diag(j ** 2), np.zeros(order + 1)
    else:
        alpha = np.linspace(-half_angle, half_angle, samples)
        w = np.cos(np.outer(alpha, j) * math.pi / half_angle)
        rhs = _target_values(target, alpha, key)
    return constrained_fit(np.array(rows), d, w, rhs, key=key, order=order)


def ramped_harmonic_coefficients(order: int, half_angle: float, ramp: Ramp,
                                 max_lift: float, *, end_order: int = 3,
                                 target: Callable | None = None, samples: int = 2001,
                                 key: str = 'lift_law') -> np.ndarray:
    """a_0..a_N [m] of the explicit-ramp form, basis cos(j pi alpha/(2 Phi))."""
    j = np.arange(order + 1, dtype=float)
    k = j * math.pi / (2 * half_angle)
    th = j * math.pi / 2
    cos_t = np.where(j % 2 == 1, 0.0, np.cos(th))     # exact zeros for odd j
    sin_t = np.where(j % 2 == 0, 0.0, np.sin(th))
    rows = [cos_t, -k * sin_t, -k ** 2 * cos_t] + ([k ** 3 * sin_t] if end_order == 3 else [])
    rows.append(np.ones(order + 1))
    d = np.array([ramp.height, -ramp.velocity, 0.0] + ([0.0] if end_order == 3 else [])
                 + [max_lift])
    alpha = np.linspace(-half_angle, half_angle, samples)
    if target is None:      # minimise the sampled integral of h''^2
        w, rhs = -(k ** 2) * np.cos(np.outer(alpha, k)), np.zeros(samples)
    else:
        w, rhs = np.cos(np.outer(alpha, k)), _target_values(target, alpha, key)
    return constrained_fit(np.array(rows), d, w, rhs, key=key, order=order)


def harmonic_law(amplitudes: np.ndarray, half_angle: float, *, ramp: Ramp | None = None,
                 end_order: int = 3, key: str = 'lift_law') -> PiecewiseLaw:
    """The law of given amplitudes; without ``ramp`` on [-Phi, Phi] (C3 at the ends),
    with ``ramp`` the basis cos(j pi alpha/(2 Phi)) between the mirrored ramps."""
    amps = tuple(float(a) for a in amplitudes)
    if ramp is None:
        seg = CosineSegment(-half_angle, half_angle, 0.0, half_angle, amplitudes=amps)
        return PiecewiseLaw([seg], [3, 3], key=key, name='harmonic')
    seg = CosineSegment(-half_angle, half_angle, 0.0, 2 * half_angle, amplitudes=amps)
    total = ramp.angle + half_angle
    rise: list[Segment] = [s.mapped(+1, total) for s in ramp.segments]
    fall: list[Segment] = [s.mapped(-1, total) for s in ramp.segments]
    end = min(end_order, 3) if ramp.end_acceleration == 0.0 else 1
    required = (list(ramp.required) + [end, end] + list(reversed(ramp.required[1:]))
                + [ramp.required[0]])
    return PiecewiseLaw(rise + [seg] + fall, required, key=key, name='harmonic')


def harmonic_from_spec(spec: Mapping, key: str) -> PiecewiseLaw:
    """``family: harmonic``: order, half_angle, max_lift, end_order, target, ramp."""
    from cam_design.lift_laws.registry import from_spec

    P.reject_unknown(spec, key, ('order', 'half_angle', 'max_lift', 'end_order', 'target',
                                 'ramp'))
    order = P.integers({'order': [P.get(spec, key, 'order')]}, key, 'order', minimum=2)[0]
    if order > 200:
        raise InputError(f'{key}.order', order, 'an order N <= 200')
    phi = P.positive(spec, key, 'half_angle')
    if phi > math.pi:
        raise InputError(f'{key}.half_angle', phi, 'a half-angle <= pi rad')
    hmax = P.lift(spec, key, 'max_lift')
    target = None
    if spec.get('target') is not None:
        target = from_spec(spec['target'], f'{key}.target')
    ramp = ramp_from_spec(spec.get('ramp'), f'{key}.ramp')
    if ramp.is_empty:
        end_order = int(P.choice(spec, key, 'end_order', (2, 4), 2))
        a = harmonic_coefficients(order, phi, hmax, end_order=end_order, target=target,
                                  key=key)
        law = harmonic_law(a, phi, key=key)
    else:
        end_order = int(P.choice(spec, key, 'end_order', (2, 3), 3))
        if hmax <= ramp.height:
            raise InputError(f'{key}.max_lift', hmax,
                             f'a lift above the ramp height {ramp.height:.6g} m')
        a = ramped_harmonic_coefficients(order, phi, ramp, hmax, end_order=end_order,
                                         target=target, key=key)
        law = harmonic_law(a, phi, ramp=ramp, end_order=end_order, key=key)
    if not law.flank_is_monotone():
        raise InputError(f'{key}.order', order,
                         'parameters giving monotone flanks (this fit has h\' of the wrong '
                         'sign somewhere; change order, half_angle or target)')
    law.amplitudes = a   # type: ignore[attr-defined]
    return law
