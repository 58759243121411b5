"""Composite acceleration-segment engine (methods.md §1.3); constant-acceleration cam (§1.2).

The base section (ramp end t0 -> nose T) is a sequence of acceleration segments
i = 1..m of width w_i with h'' = A_i s_i(u), u in [0, 1], s_i one of the shapes
constant, half_sine, quarter_sine, quarter_cosine, polynomial (``segments.SHAPES``).
Integrating analytically from the ramp end state (H_r, v_r) makes h and h' continuous;
the amplitudes A_i solve the linear system

* h'(T) = 0 and h(T) = H_r + H (nose and rise),
* with ``continuity`` >= 2: h'' continuous at the ramp end and at every interior
  junction; with 3 also h''' (the "modified" types) and h'''(T) = 0,
* optional ``ratios`` [i, j, r]: A_j = r A_i (e.g. the nose acceleration of the
  3-segment constant-acceleration cam).

Rows that are identically zero (e.g. h'' continuity between two half-sines, both 0 at
the junction) are dropped; the remaining system must determine all A_i exactly,
otherwise InputError. **FB2 and MFB2 (S0 §2.5) are not available**: their segment
recipes are in pages of the book that the project does not have, so no preset is
provided (methods.md §1.3); this engine is where they would be loaded.
"""
from __future__ import annotations

import math
from typing import Mapping, Sequence

import numpy as np

from cam_design.errors import InputError
from cam_design.lift_laws import params as P
from cam_design.lift_laws.ramps import Ramp
from cam_design.lift_laws.segments import (SHAPES, Flank, PiecewiseLaw, Segment, ShapeSegment,
                                           shape_integral)


def _s(shape: str, poly: Sequence[float], u: float, order: int) -> float:
    return float(shape_integral(shape, poly, np.array([u]), order)[0])


def composite_flank(ramp: Ramp, rise: float, shapes: Sequence[tuple[str, float, tuple]],
                    *, continuity: int = 2, ratios: Sequence[tuple[int, int, float]] = (),
                    key: str = 'lift_law') -> Flank:
    """Ramp + acceleration segments ``(shape, width [rad], poly coefficients)``."""
    m = len(shapes)
    if m == 0:
        raise InputError(f'{key}.segments', [], 'at least one acceleration segment')
    if continuity not in (1, 2, 3):
        raise InputError(f'{key}.continuity', continuity, '1, 2 or 3')
    if rise <= 0:
        raise InputError(f'{key}.rise', rise, 'a rise > 0 m')
    t0 = ramp.angle
    starts = [t0]
    for i, (shape, w, _) in enumerate(shapes):
        if shape not in SHAPES:
            raise InputError(f'{key}.segments[{i}].shape', shape, 'one of ' + ', '.join(SHAPES))
        if not (w > 0 and math.isfinite(w)):
            raise InputError(f'{key}.segments[{i}].width', w, 'a width > 0 rad')
        starts.append(starts[-1] + w)
    end = starts[-1]
    rows: list[list[float]] = []
    rhs: list[float] = []
    i1 = [w * _s(sh, po, 1.0, 1) for sh, w, po in shapes]       # delta h' per unit A
    rows.append(i1)
    rhs.append(-ramp.velocity)
    rows.append([w * w * _s(sh, po, 1.0, 2) + i1[i] * (end - starts[i + 1])
                 for i, (sh, w, po) in enumerate(shapes)])
    rhs.append(rise - ramp.velocity * (end - t0))
    if continuity >= 2:
        sh, w, po = shapes[0]
        rows.append([_s(sh, po, 0.0, 0)] + [0.0] * (m - 1))
        rhs.append(ramp.end_acceleration)
        for i in range(m - 1):
            row = [0.0] * m
            row[i] = _s(shapes[i][0], shapes[i][2], 1.0, 0)
            row[i + 1] = -_s(shapes[i + 1][0], shapes[i + 1][2], 0.0, 0)
            rows.append(row)
            rhs.append(0.0)
    if continuity >= 3:
        for i in range(m - 1):
            row = [0.0] * m
            row[i] = _s(shapes[i][0], shapes[i][2], 1.0, -1) / shapes[i][1]
            row[i + 1] = -_s(shapes[i + 1][0], shapes[i + 1][2], 0.0, -1) / shapes[i + 1][1]
            rows.append(row)
            rhs.append(0.0)
        row = [0.0] * m
        row[-1] = _s(shapes[-1][0], shapes[-1][2], 1.0, -1)
        rows.append(row)
        rhs.append(0.0)
    for k, (i, j, r) in enumerate(ratios):
        if not (0 <= i < m and 0 <= j < m and i != j):
            raise InputError(f'{key}.ratios[{k}]', [i, j, r], f'segment indices in 0..{m - 1}')
        row = [0.0] * m
        row[j], row[i] = 1.0, -r
        rows.append(row)
        rhs.append(0.0)
    a = np.array(rows)
    b = np.array(rhs)
    keep = np.any(np.abs(a) > 1e-300, axis=1)
    if np.any(np.abs(b[~keep]) > 0):
        raise InputError(f'{key}.segments', 'h\'\' of the ramp end is not 0',
                         'a first shape that can match the ramp-end acceleration '
                         '(or continuity 1)')
    a, b = a[keep], b[keep]
    amp, _, rank, _ = np.linalg.lstsq(a, b, rcond=None)
    if rank < m:
        raise InputError(f'{key}.segments', f'{len(b)} conditions of rank {rank}',
                         f'a shape sequence and ratios that determine all {m} amplitudes')
    resid = a @ amp - b
    if np.max(np.abs(resid)) > 1e-9 * max(np.max(np.abs(b)), 1e-12):
        raise InputError(f'{key}.segments', f'{len(b)} conditions for {m} amplitudes',
                         'a consistent system (fewer continuity conditions or more '
                         'segments)')
    segs: list[Segment] = list(ramp.segments)
    h, v = ramp.height, ramp.velocity
    for (sh, w, po), s0, amp_i in zip(shapes, starts, amp):
        q = float(amp_i) * w * w
        segs.append(ShapeSegment(s0, s0 + w, s0, w, p0=h, p1=v * w, q=q, shape=sh,
                                 poly=tuple(po)))
        h = h + v * w + q * _s(sh, po, 1.0, 2)
        v = v + q * _s(sh, po, 1.0, 1) / w
    required = list(ramp.required) + [1] * m if not ramp.is_empty else [1] * m
    required.append(1)
    nose = 3 if continuity >= 3 else 1
    return Flank(tuple(segs), tuple(required), nose_order=nose)


def composite_from_spec(spec: Mapping, key: str) -> PiecewiseLaw:
    """``family: composite``: see docs/lift_laws.md."""
    from cam_design.lift_laws.laws import flanked_lobe

    return flanked_lobe(spec, key, ('segments', 'continuity', 'ratios'), _flank, 'composite')


def _flank(spec: Mapping, key: str, ramp: Ramp, rise: float) -> Flank:
    raw = P.get(spec, key, 'segments')
    if isinstance(raw, (str, bytes, Mapping)) or not isinstance(raw, Sequence):
        raise InputError(f'{key}.segments', raw, 'a list of {shape, width} mappings')
    shapes = []
    for i, item in enumerate(raw):
        k = f'{key}.segments[{i}]'
        item = P.mapping(item, k)
        P.reject_unknown(item, k, ('shape', 'width', 'coefficients'))
        shape = P.choice(item, k, 'shape', SHAPES)
        poly = tuple(P.numbers(item, k, 'coefficients')) if shape == 'polynomial' else ()
        shapes.append((shape, P.positive(item, k, 'width'), poly))
    ratios = []
    for i, r in enumerate(spec.get('ratios') or []):
        if not (isinstance(r, Sequence) and len(r) == 3):
            raise InputError(f'{key}.ratios[{i}]', r, '[i, j, r]: amplitude j = r * amplitude i')
        ratios.append((int(r[0]), int(r[1]), float(r[2])))
    cont = int(P.finite(spec, key, 'continuity', 2))
    return composite_flank(ramp, rise, shapes, continuity=cont, ratios=ratios, key=key)


def constant_acceleration_amplitudes(v0: float, alpha0: float, rise: float,
                                     phi1: float) -> tuple[float, float]:
    """Closed form of §1.2 (two segments): a1, a2 [m/rad^2].

    a1 = 2 [H - v0 (alpha0 - phi2/2)] / (phi1 alpha0), a2 = -(v0 + a1 phi1) / phi2.
    """
    phi2 = alpha0 - phi1
    a1 = 2 * (rise - v0 * (alpha0 - phi2 / 2)) / (phi1 * alpha0)
    return a1, -(v0 + a1 * phi1) / phi2


def constant_acceleration_from_spec(spec: Mapping, key: str) -> PiecewiseLaw:
    """``family: constant_acceleration`` (§1.2): 2 segments, or 3 with a gentler nose.

    Parameters: ramp, rise|max_lift, half_angle (alpha0), positive_width (phi1);
    optional nose_width (phi3) and nose_ratio r = a3/a2 in (0, 1] for the 3-segment
    variant; optional fall {ramp, half_angle, positive_width, nose_width, nose_ratio}.
    """
    from cam_design.lift_laws.laws import flanked_lobe

    names = ('half_angle', 'positive_width', 'nose_width', 'nose_ratio')
    return flanked_lobe(spec, key, names, _ca_flank, 'constant_acceleration')


def _ca_flank(spec: Mapping, key: str, ramp: Ramp, rise: float) -> Flank:
    alpha0 = P.positive(spec, key, 'half_angle')
    phi1 = P.positive(spec, key, 'positive_width')
    phi3 = P.positive(spec, key, 'nose_width', 0.0, allow_zero=True)
    if phi1 + phi3 >= alpha0:
        raise InputError(f'{key}.positive_width', phi1,
                         f'positive_width + nose_width < half_angle ({alpha0:.6g} rad)')
    widths = [phi1, alpha0 - phi1 - phi3] + ([phi3] if phi3 > 0 else [])
    ratios = []
    if phi3 > 0:
        r = P.positive(spec, key, 'nose_ratio')
        if r > 1:
            raise InputError(f'{key}.nose_ratio', r, 'a3/a2 in (0, 1] (a gentler nose)')
        ratios = [(1, 2, r)]
    flank = composite_flank(ramp, rise, [('constant', w, ()) for w in widths],
                            continuity=1, ratios=ratios, key=key)
    accs = [s(s.hi, 2) for s in flank.segments[len(ramp.segments):]]
    if not (accs[0] > 0 and all(a < 0 for a in accs[1:])):
        raise InputError(f'{key}.positive_width', phi1,
                         'widths giving a positive then negative acceleration '
                         f'(got {", ".join(f"{a:.4g}" for a in accs)} m/rad^2)')
    return flank
