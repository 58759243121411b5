"""N-harmonic cam (N次谐波凸轮), methods.md §1.6 [RECON: the book's basis is unconfirmed].

h(alpha) = sum_{j=0..N} a_j cos(j pi alpha / Phi) for |alpha| <= Phi (0 outside), with
Phi the working half-angle including the (implicit) ramps. Odd derivatives vanish at
+-Phi automatically; the linear equalities impose h(Phi) = 0, h''(Phi) = 0, optionally
h''''(Phi) = 0 (``end_order: 4``), and h(0) = max_lift. The remaining N + 1 - 3 (or 4)
coefficients are free: fitted by equality-constrained least squares to a ``target``
law sampled on [-Phi, Phi], or, without a target, chosen to minimise the integral of
h''^2 (sum j^4 a_j^2). The law is C3 at +-Phi (its h'''' is continuous too with
end_order 4). Symmetric only (an asymmetric version would add sines).
"""
from __future__ import annotations

import math
from typing import Mapping

import numpy as np

from cam_design.errors import InputError
from cam_design.lift_laws import params as P
from cam_design.lift_laws.segments import CosineSegment, PiecewiseLaw


def harmonic_coefficients(order: int, half_angle: float, max_lift: float, *,
                          end_order: int = 2, target: object | None = None,
                          samples: int = 2001, key: str = 'lift_law') -> np.ndarray:
    """a_0..a_N [m] (see the module docstring). ``target``: a callable h(alpha) or None."""
    from scipy.linalg import null_space

    n = order
    j = np.arange(n + 1, dtype=float)
    sgn = (-1.0) ** j
    rows = [sgn, sgn * j ** 2]
    if end_order == 4:
        rows.append(sgn * j ** 4)
    rows.append(np.ones(n + 1))
    c = np.array(rows)
    d = np.zeros(len(rows))
    d[-1] = max_lift
    norm = np.max(np.abs(c), axis=1)
    c, d = c / norm[:, None], d / norm      # row scaling: j^4 reaches 1e6 and more
    if n + 1 < len(rows):
        raise InputError(f'{key}.order', order, f'N >= {len(rows) - 1} for end_order {end_order}')
    a_p, *_ = np.linalg.lstsq(c, d, rcond=None)
    if np.max(np.abs(c @ a_p - d)) > 1e-12 * max(np.max(np.abs(d)), 1e-300):
        raise InputError(f'{key}.order', order, 'an order whose end conditions are solvable')
    z = null_space(c)
    if z.shape[1] == 0:
        return a_p
    if target is None:
        w = np.diag(j ** 2)              # minimise sum j^4 a_j^2 (the integral of h''^2)
        rhs = np.zeros(n + 1)
    else:
        alpha = np.linspace(-half_angle, half_angle, samples)
        w = np.cos(np.outer(alpha, j) * math.pi / half_angle)
        rhs = np.asarray(target(alpha), dtype=float)   # type: ignore[operator]
        if not np.all(np.isfinite(rhs)):
            raise InputError(f'{key}.target', 'non-finite values', 'a finite target law')
    y, *_ = np.linalg.lstsq(w @ z, rhs - w @ a_p, rcond=None)
    a = a_p + z @ y
    for _ in range(2):              # iterative refinement of the equalities
        a = a + np.linalg.lstsq(c, d - c @ a, rcond=None)[0]
    return a


def harmonic_law(amplitudes: np.ndarray, half_angle: float, *,
                 key: str = 'lift_law') -> PiecewiseLaw:
    """The law of given amplitudes on [-Phi, Phi] (C3 at the ends is verified)."""
    seg = CosineSegment(-half_angle, half_angle, 0.0, half_angle,
                        amplitudes=tuple(float(a) for a in amplitudes))
    return PiecewiseLaw([seg], [3, 3], key=key, name='harmonic')


def harmonic_from_spec(spec: Mapping, key: str) -> PiecewiseLaw:
    """``family: harmonic``: order N, half_angle Phi, max_lift, end_order 2|4, target."""
    from cam_design.lift_laws.registry import from_spec

    P.reject_unknown(spec, key, ('order', 'half_angle', 'max_lift', 'end_order', 'target'))
    order = P.integers({'order': [P.get(spec, key, 'order')]}, key, 'order', minimum=2)[0]
    if order > 200:
        raise InputError(f'{key}.order', order, 'an order N <= 200')
    phi = P.positive(spec, key, 'half_angle')
    if phi > math.pi:
        raise InputError(f'{key}.half_angle', phi, 'a half-angle <= pi rad')
    hmax = P.positive(spec, key, 'max_lift')
    end_order = int(P.choice(spec, key, 'end_order', (2, 4), 2))
    target = None
    if spec.get('target') is not None:
        target = from_spec(spec['target'], f'{key}.target')
    a = harmonic_coefficients(order, phi, hmax, end_order=end_order, target=target, key=key)
    law = harmonic_law(a, phi, key=key)
    if not law.flank_is_monotone():
        raise InputError(f'{key}.order', order,
                         'parameters giving monotone flanks (this fit has h\' of the wrong '
                         'sign somewhere; change order, half_angle or target)')
    law.amplitudes = a   # type: ignore[attr-defined]
    return law
