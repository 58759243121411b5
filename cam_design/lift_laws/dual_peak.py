"""Dual-peak EGR cam of patent CN103422923B (the patent, docs/lift_laws.md).

Segments in alpha (main nose at alpha = 0):

1. main ascending ramp h1 (S2 ramp: H1, v1, alpha1),
2. main working section h2 = H1 + H2 + sum c_i x^i (§1.4, mirrored about the nose),
3. main descending ramp h3 (mirror of h1), cut at its local angle gamma1' (the start
   of the connection, chosen from the exhaust-pulse phase),
4. connection h4 = sum B_k s^k (s from the cut; the patent writes A_k = (-1)^k B_k),
   seven conditions: h, h', h'' of h3 at the start; h = H6, h' = v5, h'' = 0 at the
   end; an interior point (alpha_A, h_A). Solved in u = s/alpha4 (cond ~1e4 instead of
   ~4e9 in raw degrees),
5. secondary working section h5 = H6 + H5 + sum c_i' x^i over alpha5, both halves,
6. secondary descending ramp h6 (S2 ramp: H6, v6, alpha6).

v5 must equal v6, otherwise h' jumps where h5 meets h6 (the patent lists them as
separate inputs). Checks: min h4 >= 0 and max h4 below the secondary nose.
"""
from __future__ import annotations

import dataclasses
from typing import Mapping

import numpy as np

from cam_design.errors import InputError
from cam_design.lift_laws import params as P
from cam_design.lift_laws.polynomial import (base_section, nose_order,
                                             polynomial_coefficients, polynomial_flank)
from cam_design.lift_laws.ramps import ramp_from_spec
from cam_design.lift_laws.segments import PiecewiseLaw, PowerSegment, Segment


def connection_matrix(alpha4: float, alpha_a: float, scale: float) -> np.ndarray:
    """The 7x7 matrix of S2 eqs 41-47 for the unknowns B_k scale^k, i.e. in the
    variable u = s/scale (scale = alpha4: the scaled solve; scale = 1: raw units)."""
    k = np.arange(7)
    end, pt = alpha4 / scale, alpha_a / scale
    rows = np.zeros((7, 7))
    rows[0, 0] = 1.0                                    # h(0)
    rows[1] = end ** k                                  # h(alpha4)
    rows[2, 1] = 1.0                                    # h'(0) (times scale)
    rows[3, 1:] = k[1:] * end ** (k[1:] - 1)            # h'(alpha4)
    rows[4, 2] = 2.0                                    # h''(0) (times scale^2)
    rows[5, 2:] = k[2:] * (k[2:] - 1) * end ** (k[2:] - 2)   # h''(alpha4)
    rows[6] = pt ** k                                   # interior point
    return rows


def connection_coefficients(h3: float, h3p: float, h3pp: float, h6: float, v5: float,
                            alpha4: float, alpha_a: float, h_a: float) -> np.ndarray:
    """B_0..B_6 of h4(s) = sum B_k s^k (any consistent units), solved in u = s/alpha4
    (cond ~1.4e4 instead of ~4e9 in raw degrees). The patent's A_k = (-1)^k B_k."""
    k = np.arange(7)
    rhs = np.array([h3, h6, h3p * alpha4, v5 * alpha4, h3pp * alpha4 ** 2, 0.0, h_a])
    beta = np.linalg.solve(connection_matrix(alpha4, alpha_a, alpha4), rhs)
    return beta / alpha4 ** k


def _clip(seg: Segment, lo: float, hi: float) -> Segment | None:
    a, b = max(seg.lo, lo), min(seg.hi, hi)
    return dataclasses.replace(seg, lo=a, hi=b) if b > a else None


def dual_peak_from_spec(spec: Mapping, key: str) -> PiecewiseLaw:
    """``family: dual_peak`` (see docs/lift_laws.md)."""
    P.reject_unknown(spec, key, ('ramp', 'rise', 'half_angle', 'exponents', 'connection',
                                 'secondary'))
    ramp1 = ramp_from_spec(spec.get('ramp'), f'{key}.ramp',
                           default_kind='constant_acceleration_velocity')
    if ramp1.is_empty:
        raise InputError(f'{key}.ramp', spec.get('ramp'),
                         'a main ramp (the connection starts on it)')
    rise = P.lift(spec, key, 'rise')
    alpha0 = P.angle(spec, key, 'half_angle')
    exps = P.integers(spec, key, 'exponents', [2, 6, 10, 14])
    main = polynomial_flank(ramp1, rise, alpha0, exps, key=key)
    t_main = main.length
    rise_segs = [s.mapped(+1, t_main) for s in main.segments]
    fall_segs = [s.mapped(-1, t_main) for s in main.segments]
    required: list[int] = list(main.required[:-1]) + [main.nose_order]
    fall_required = list(reversed(main.required[:-1]))

    ck = f'{key}.connection'
    conn = P.mapping(P.get(spec, key, 'connection'), ck)
    P.reject_unknown(conn, ck, ('start', 'angle', 'point_angle', 'point_lift'))
    start = P.angle(conn, ck, 'start')
    if start >= ramp1.angle:
        raise InputError(f'{ck}.start', start,
                         f'a point on the main descending ramp, 0 < start < {ramp1.angle:.6g} rad')
    cut = alpha0 + start
    kept, kept_req = [], []
    for seg, req in zip(sorted(fall_segs, key=lambda g: g.lo), fall_required):
        c = _clip(seg, -np.inf, cut)
        if c is not None:
            kept.append(c)
            kept_req.append(req)
    kept_req = kept_req[:-1]     # the last kept piece ends at the connection
    h3 = [float(kept[-1](cut, n)) for n in range(3)]

    sk = f'{key}.secondary'
    sec = P.mapping(P.get(spec, key, 'secondary'), sk)
    P.reject_unknown(sec, sk, ('rise', 'half_angle', 'exponents', 'velocity', 'ramp'))
    ramp6 = ramp_from_spec(sec.get('ramp'), f'{sk}.ramp',
                           default_kind='constant_acceleration_velocity')
    if ramp6.is_empty:
        raise InputError(f'{sk}.ramp', sec.get('ramp'), 'a secondary descending ramp')
    v5 = P.positive(sec, sk, 'velocity', ramp6.velocity)
    if abs(v5 - ramp6.velocity) > 1e-12 * ramp6.velocity:
        raise InputError(f'{sk}.velocity', v5, f'v5 = v6 = {ramp6.velocity:.9g} m/rad '
                         '(otherwise h\' jumps where h5 meets h6)')
    h5_rise = P.lift(sec, sk, 'rise')
    a5 = P.angle(sec, sk, 'half_angle')
    exps5 = P.integers(sec, sk, 'exponents', [2, 6, 10, 14])

    alpha4 = P.angle(conn, ck, 'angle')
    alpha_a = P.angle(conn, ck, 'point_angle', alpha4 / 2)
    if alpha_a >= alpha4:
        raise InputError(f'{ck}.point_angle', alpha_a, f'0 < point_angle < angle ({alpha4:.6g})')
    h_a = P.positive(conn, ck, 'point_lift')
    b = connection_coefficients(h3[0], h3[1], h3[2], ramp6.height, v5, alpha4, alpha_a, h_a)
    conn_seg = PowerSegment(cut, cut + alpha4, cut, alpha4,
                            coefficients=tuple((k, float(b[k] * alpha4 ** k)) for k in range(7)))
    s = np.linspace(cut, cut + alpha4, 4001)
    h4 = conn_seg(s)
    if h4.min() < 0:
        raise InputError(f'{ck}.point_lift', h_a, 'a connection that stays >= 0 (min h4 = '
                         f'{h4.min():.4g} m at alpha = {np.degrees(s[np.argmin(h4)]):.4g} deg)')
    if h4.max() > ramp6.height + h5_rise:
        raise InputError(f'{ck}.point_lift', h_a, 'a connection below the secondary nose')

    c1 = cut + alpha4
    coeffs5 = polynomial_coefficients(exps5, h5_rise, v5, a5, key=f'{sk}.exponents')
    h5_up = base_section(c1, ramp6.height, h5_rise, a5, coeffs5)
    nose5 = c1 + a5
    h5_down = h5_up.mapped(-1, 2 * nose5)
    e5 = nose5 + a5
    end = e5 + ramp6.angle
    h6 = [seg.mapped(-1, end) for seg in ramp6.segments]
    end_order = 3 if ramp6.end_acceleration == 0.0 else 1
    segments = rise_segs + kept + [conn_seg, h5_up, h5_down] + h6
    required = (required + kept_req + [2, 2, nose_order(exps5), end_order]
                + list(reversed(ramp6.required[1:])) + [ramp6.required[0]])
    law = PiecewiseLaw(segments, required, key=key, name='dual_peak')
    law.connection = b   # type: ignore[attr-defined]
    return law
