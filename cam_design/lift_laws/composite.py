"""Composite acceleration-segment engine (docs/lift_laws.md); constant-acceleration cam (§1.2).

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
otherwise InputError. **FB2 and MFB2 (Shang §2.5) are not available**: their segment
recipes are in pages of Shang (1988) that the project does not have, so no preset is
provided (docs/lift_laws.md); this engine is where they would be loaded.
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
    """Shape integral/value/derivative at one u; rounding noise (sin(pi) = 1.2e-16) -> 0,
    so that an end value that is zero in exact arithmetic gives an exactly zero row."""
    v = float(shape_integral(shape, poly, np.array([u]), order)[0])
    return 0.0 if abs(v) < 1e-14 else v


def _system(ramp: Ramp, rise: float, shapes: Sequence[tuple[str, float, tuple]],
            continuity: int, ratios: Sequence[tuple[int, int, float]]
            ) -> tuple[np.ndarray, np.ndarray]:
    """Rows and right-hand side of the amplitude conditions for given widths."""
    m = len(shapes)
    starts = np.concatenate([[ramp.angle], ramp.angle + np.cumsum([w for _, w, _ in shapes])])
    end = starts[-1]
    rows: list[list[float]] = []
    rhs: list[float] = []
    i1 = [w * _s(sh, po, 1.0, 1) for sh, w, po in shapes]       # delta h' per unit A
    rows.append(i1)
    rhs.append(-ramp.velocity)
    rows.append([w * w * _s(sh, po, 1.0, 2) + i1[i] * (end - starts[i + 1])
                 for i, (sh, w, po) in enumerate(shapes)])
    rhs.append(rise - ramp.velocity * (end - ramp.angle))
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
    for i, j, r in ratios:
        row = [0.0] * m
        row[j], row[i] = 1.0, -r
        rows.append(row)
        rhs.append(0.0)
    return np.array(rows), np.array(rhs)


def _solve(a: np.ndarray, b: np.ndarray, m: int, key: str) -> np.ndarray:
    """Amplitudes by least squares; InputError if the system is rank-deficient or
    inconsistent (rows are scaled to unit max first)."""
    keep = np.any(np.abs(a) > 0, axis=1)
    if np.any(np.abs(b[~keep]) > 0):
        raise InputError(f'{key}.segments', 'h\'\' of the ramp end is not 0',
                         'a first shape that can match the ramp-end acceleration '
                         '(or continuity 1)')
    a, b = a[keep], b[keep]
    norm = np.maximum(np.max(np.abs(a), axis=1), 1e-300)
    a, b = a / norm[:, None], b / norm
    amp, _, rank, _ = np.linalg.lstsq(a, b, rcond=None)
    resid = float(np.max(np.abs(a @ amp - b))) / max(float(np.max(np.abs(b))), 1e-300)
    if rank < m:
        raise InputError(f'{key}.segments', f'{len(b)} conditions of rank {rank}',
                         f'a shape sequence and ratios that determine all {m} amplitudes')
    if resid > 1e-9:
        raise InputError(f'{key}.segments', f'{len(b)} conditions for {m} amplitudes',
                         'a consistent system (fewer continuity conditions, more '
                         'segments, or free_widths)')
    return amp


def _fit_widths(ramp: Ramp, rise: float, shapes: list[tuple[str, float, tuple]],
                continuity: int, ratios: Sequence[tuple[int, int, float]],
                half_angle: float, key: str) -> list[tuple[str, float, tuple]]:
    """Widths w_i = half_angle * softmax(z) making the system consistent (least_squares)."""
    from scipy.optimize import least_squares

    m = len(shapes)
    if m < 2:
        raise InputError(f'{key}.free_widths', True, 'at least two segments')
    frac = np.array([w for _, w, _ in shapes])
    z0 = np.log(frac / frac.sum())[1:] - np.log(frac[0] / frac.sum())

    def with_widths(z: np.ndarray) -> list[tuple[str, float, tuple]]:
        e = np.exp(np.concatenate([[0.0], z]))
        w = half_angle * e / e.sum()
        return [(sh, float(wi), po) for (sh, _, po), wi in zip(shapes, w)]

    def residual(z: np.ndarray) -> np.ndarray:
        a, b = _system(ramp, rise, with_widths(z), continuity, ratios)
        keep = np.any(np.abs(a) > 0, axis=1)
        a, b = a[keep], b[keep]
        norm = np.maximum(np.max(np.abs(a), axis=1), 1e-300)
        a, b = a / norm[:, None], b / norm
        amp = np.linalg.lstsq(a, b, rcond=None)[0]
        return (a @ amp - b) / max(float(np.max(np.abs(b))), 1e-300)

    sol = least_squares(residual, z0, xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=2000)
    best = with_widths(sol.x)
    if float(np.max(np.abs(residual(sol.x)))) > 1e-9:
        raise InputError(f'{key}.segments', 'no consistent widths found (residual '
                         f'{float(np.max(np.abs(residual(sol.x)))):.3g})',
                         'shapes, ratios and continuity that some widths can satisfy')
    return best


def composite_flank(ramp: Ramp, rise: float, shapes: Sequence[tuple[str, float, tuple]],
                    *, continuity: int = 2, ratios: Sequence[tuple[int, int, float]] = (),
                    half_angle: float | None = None, key: str = 'lift_law') -> Flank:
    """Ramp + acceleration segments ``(shape, width [rad], poly coefficients)``.

    With ``half_angle`` the widths are free (their given values are the start): they
    are scaled to sum to ``half_angle`` and adjusted by least squares until all the
    conditions hold (docs/lift_laws.md step 3)."""
    m = len(shapes)
    if m == 0:
        raise InputError(f'{key}.segments', [], 'at least one acceleration segment')
    if continuity not in (1, 2, 3):
        raise InputError(f'{key}.continuity', continuity, '1, 2 or 3')
    if rise <= 0:
        raise InputError(f'{key}.rise', rise, 'a rise > 0 m')
    for i, (shape, w, _) in enumerate(shapes):
        if shape not in SHAPES:
            raise InputError(f'{key}.segments[{i}].shape', shape, 'one of ' + ', '.join(SHAPES))
        if not (w > 0 and math.isfinite(w)):
            raise InputError(f'{key}.segments[{i}].width', w, 'a width > 0 rad')
    for k, (i, j, r) in enumerate(ratios):
        if not (0 <= i < m and 0 <= j < m and i != j and math.isfinite(r)):
            raise InputError(f'{key}.ratios[{k}]', [i, j, r], f'segment indices in 0..{m - 1}')
    shapes = list(shapes)
    if half_angle is not None:
        shapes = _fit_widths(ramp, rise, shapes, continuity, ratios, half_angle, key)
    amp = _solve(*_system(ramp, rise, shapes, continuity, ratios), m, key)
    starts = list(ramp.angle + np.concatenate([[0.0], np.cumsum([w for _, w, _ in shapes])]))
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

    return flanked_lobe(spec, key, ('segments', 'continuity', 'ratios', 'free_widths',
                                    'half_angle'), _flank, 'composite')


def _flank(spec: Mapping, key: str, ramp: Ramp, rise: float) -> Flank:
    """One composite flank from its spec (segments, continuity, ratios, free_widths)."""
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
        shapes.append((shape, P.angle(item, k, 'width'), poly))
    ratios = []
    for i, r in enumerate(spec.get('ratios') or []):
        if not (isinstance(r, Sequence) and len(r) == 3):
            raise InputError(f'{key}.ratios[{i}]', r, '[i, j, r]: amplitude j = r * amplitude i')
        ratios.append((int(r[0]), int(r[1]), float(r[2])))
    cont = int(P.finite(spec, key, 'continuity', 2))
    half = None
    if P.get(spec, key, 'free_widths', False) is True:
        half = P.angle(spec, key, 'half_angle')
    elif spec.get('half_angle') is not None:
        raise InputError(f'{key}.half_angle', spec['half_angle'],
                         'no half_angle unless free_widths: true (the widths sum to it)')
    return composite_flank(ramp, rise, shapes, continuity=cont, ratios=ratios,
                           half_angle=half, key=key)


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
    alpha0 = P.angle(spec, key, 'half_angle')
    phi1 = P.angle(spec, key, 'positive_width')
    phi3 = P.angle(spec, key, 'nose_width', 0.0, allow_zero=True)
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
