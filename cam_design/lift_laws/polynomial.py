"""High-order polynomial (高次方) cam, docs/lift_laws.md (S2 eqs 2, 18-32 corrected).

Any 2..8 exponents are accepted: n exponents fix h, h', ..., h^(n-1) at the ramp end
(zero beyond h'), so 4 give C3 (the patent's five-term form), 3 give C2, 5 and more
also zero h^(4).. there. Four exponents use the closed form below, other counts the
exact rational solution of the moment system.

Base section from the ramp end to the nose, x = 1 - (t - alpha_r)/alpha0 (x = 1 at the
ramp end, 0 at the nose; alpha0 = half base-section angle = alpha2/2 of the patent):
h = H_r + H + sum_i c_i x^i. Conditions at x = 1: h = H_r, h' = v_r, h'' = h''' = 0;
so the ramp/base junction is C3 and the nose is C3 for even exponents (the lobe is
built by mirroring, so odd exponents >= 5 are also C3 at the nose; 3 gives C2).

Closed form (four exponents; j over the other three, e1..e3 their elementary
symmetric sums): c_i = [v alpha0 (1 - e1 + e2) - H e3] / prod_j (j - i).
The patent's printed eqs (24)-(25) are wrong (erratum 3); (26)-(27) agree.
"""
from __future__ import annotations

import math
from typing import Sequence

from cam_design.errors import InputError
from cam_design.lift_laws.ramps import Ramp
from cam_design.lift_laws.segments import Flank, PowerSegment, Segment, solve_moments

MAX_EXPONENT = 60


def check_exponents(exponents: Sequence[int], count: int | tuple[int, int],
                    key: str) -> list[int]:
    """``count`` (or a (min, max) range of) distinct increasing exponents in 2..60."""
    exps = [int(e) for e in exponents]
    lo, hi = (count, count) if isinstance(count, int) else count
    if not lo <= len(exps) <= hi:
        raise InputError(key, list(exponents), f'{lo} exponents' if lo == hi
                         else f'{lo} to {hi} exponents')
    if any(e < 2 or e > MAX_EXPONENT for e in exps):
        raise InputError(key, list(exponents), f'exponents in 2..{MAX_EXPONENT}')
    if any(b <= a for a, b in zip(exps, exps[1:])):
        raise InputError(key, list(exponents), 'strictly increasing exponents')
    return exps


def polynomial_coefficients(exponents: Sequence[int], rise: float, velocity: float,
                            half_angle: float, *, key: str = 'exponents'
                            ) -> dict[int, float]:
    """c_i of §1.4 by the corrected closed form (SI: rise [m], velocity [m/rad], rad).

    Returns {exponent: c_i [m]}; c0 = rise is implicit.
    """
    exps = check_exponents(exponents, 4, key)
    out = {}
    for i in exps:
        others = [j for j in exps if j != i]
        e1 = sum(others)
        e2 = others[0] * others[1] + others[0] * others[2] + others[1] * others[2]
        e3 = others[0] * others[1] * others[2]
        den = math.prod(j - i for j in others)
        out[i] = (velocity * half_angle * (1 - e1 + e2) - rise * e3) / den
    return out


def polynomial_coefficients_exact(exponents: Sequence[int], rise: float, velocity: float,
                                  half_angle: float) -> dict[int, float]:
    """The same coefficients from the moment system solved in exact rationals."""
    exps = [int(e) for e in exponents]
    rhs = [-rise, -velocity * half_angle] + [0.0] * (len(exps) - 2)
    return dict(zip(exps, solve_moments(exps, rhs)))


def nose_order(exponents: Sequence[int]) -> int:
    """Continuity order of the mirrored nose: x^k with odd k has a jump in derivative k."""
    odd = [e for e in exponents if e % 2]
    return min([3] + [e - 1 for e in odd])


def base_section(start: float, base_height: float, rise: float, half_angle: float,
                 coefficients: dict[int, float]) -> PowerSegment:
    """PowerSegment of h = base_height + rise + sum c_i x^i on [start, start + half_angle]."""
    coeffs = [(0, base_height + rise)] + sorted(coefficients.items())
    return PowerSegment(start, start + half_angle, start + half_angle, -half_angle,
                        coefficients=tuple(coeffs))


def polynomial_flank(ramp: Ramp, rise: float, half_angle: float, exponents: Sequence[int],
                     *, key: str) -> Flank:
    """Ramp + polynomial base section, in flank coordinate."""
    if rise <= 0:
        raise InputError(f'{key}.rise', rise, 'a base-section rise > 0 m')
    if half_angle <= 0:
        raise InputError(f'{key}.half_angle', half_angle, 'a half base-section angle > 0 rad')
    exps = check_exponents(exponents, (2, 8), f'{key}.exponents')
    if len(exps) == 4:
        coeffs = polynomial_coefficients(exps, rise, ramp.velocity, half_angle,
                                         key=f'{key}.exponents')
    else:
        coeffs = polynomial_coefficients_exact(exps, rise, ramp.velocity, half_angle)
    segs: list[Segment] = list(ramp.segments)
    segs.append(base_section(ramp.angle, ramp.height, rise, half_angle, coeffs))
    # n exponents fix h..h^(n-1) where the base section starts (ramp end or, without a
    # ramp, the base circle): 3 exponents (e.g. the 3-4-5 law) give C2 there, not C3
    end = min(3, len(exps) - 1) if ramp.end_acceleration == 0.0 else 1
    required = list(ramp.required) + [end]
    required.append(nose_order(exponents))
    return Flank(tuple(segs), tuple(required), nose_order=nose_order(exponents))


def base_section_fullness(coefficients: dict[int, float], rise: float) -> float:
    """Fullness of the base section alone (valve opening at the ramp end), §1.4:
    [H + sum c_i/(i+1)] / H (the mean of h - H_r over x in [0, 1] divided by H)."""
    return (rise + sum(c / (i + 1) for i, c in coefficients.items())) / rise
