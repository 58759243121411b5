"""The cam card: a lobe's numbers in the terms of the trade (docs/cam_card.md).

Pure numerics (no rclpy). A card is computed from a lift law (the design) or from a
lift table (a measured lobe, optionally with the design as the reference it is compared
with). Angles ``alpha`` [rad] are cam angles from the lobe centreline of the design (the
fitted nose of a measured lobe), rise flank negative; lifts [m] above the base circle.

Definitions (stated once, used everywhere):

* checking height ``y``: the opening event is the *first* angle where the lift reaches
  ``y`` on the rise, the closing event the *last* where it falls below ``y``;
  ``duration_cam_deg`` = closing - opening, crank degrees = 2 x cam degrees (four-stroke);
  the lobe ``centreline_deg`` at that height is the midpoint of the two events;
* ``max_lift_m``: the largest lift; ``area_mm_deg``: the area under the lift curve over
  the lobe, in mm x cam degree; ``fullness``: area / (max lift x duration of the lift
  above the base circle), 1 for a rectangle, 2/3 for a parabola;
* derivatives in mm/deg, mm/deg^2, mm/deg^3 (and m/rad^k: ``*_si``).

Events of a measured table are not interpolated between two noisy samples: within
``half_window`` of the reference crossing the deviation measured - reference is fitted
by a straight line (the sensitive-point rule of docs/metrology.md) and
``reference(a) + p(a) = y`` is solved; without a reference a quadratic in ``alpha`` is
fitted to the samples around the crossing. Exact on noise-free data of a shifted design.
"""
from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from cam_design.errors import InputError

if TYPE_CHECKING:   # the lift-law package is not loaded for a card (cam-bench --help)
    from cam_design.lift_laws.base import LiftLaw

__all__ = ['DEFAULT_HEIGHTS_M', 'law_events', 'law_peak', 'table_events', 'table_peak',
           'table_events_std', 'table_peak_std',
           'card_from_law', 'card_from_table', 'crank_events', 'lobe_separation_deg',
           'card_text', 'parse_heights_mm']

DEG = math.pi / 180.0
#: default checking heights [m]: 1 mm, 0.050 in, 0.1 mm
DEFAULT_HEIGHTS_M: tuple[float, ...] = (1.0e-3, 1.27e-3, 1.0e-4)
_GRID = 20001


def parse_heights_mm(text: str, key: str = '--heights-mm') -> tuple[float, ...]:
    """``'1,1.27,0.1'`` -> heights in m (each finite and > 0)."""
    out = []
    for part in str(text).split(','):
        try:
            value = float(part)
        except ValueError:
            raise InputError(key, text, 'comma-separated heights in mm, e.g. 1,1.27,0.1') \
                from None
        if not (math.isfinite(value) and value > 0):
            raise InputError(key, text, 'heights in mm > 0, e.g. 1,1.27,0.1')
        out.append(value * 1e-3)
    return tuple(out)


# ------------------------------------------------------------------------ laws
def _grid(law: Callable[..., Any]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    lo, hi = getattr(law, 'support', (-math.pi, math.pi))
    a = np.linspace(lo, hi, _GRID)
    return a, np.asarray(law(a, 0), dtype=float)


def law_peak(law: Callable[..., Any]) -> tuple[float, float]:
    """(alpha [rad], max lift [m]) of a law: grid maximum refined by a bounded search."""
    from scipy.optimize import minimize_scalar

    a, h = _grid(law)
    i = int(np.argmax(h))
    lo, hi = a[max(i - 1, 0)], a[min(i + 1, a.size - 1)]
    if hi <= lo:
        return float(a[i]), float(h[i])
    res = minimize_scalar(lambda x: -float(law(np.array([x]), 0)[0]), bounds=(lo, hi),
                          method='bounded', options={'xatol': 1e-13})
    if -res.fun >= h[i]:
        return float(res.x), float(-res.fun)
    return float(a[i]), float(h[i])


#: Gauss-Legendre points per panel of the area rule, and the widest panel [rad]
_AREA_POINTS = 8
_AREA_PANEL = 0.25 * DEG


def law_area(law: Callable[..., Any], breaks: Sequence[float]) -> float:
    """Area [m rad] under ``law`` between consecutive ``breaks`` [rad] (its support
    ends and junctions, where a derivative may jump): composite Gauss-Legendre with
    ``_AREA_POINTS`` points on panels no wider than ``_AREA_PANEL`` (at least 64 per
    piece), the law called once on every node. Exact for polynomials of degree 15 on a
    panel; a spline knot inside a panel (C4 for a quintic) costs O(panel^6) there."""
    x, w = np.polynomial.legendre.leggauss(_AREA_POINTS)
    nodes, weights = [], []
    for b0, b1 in zip(breaks, breaks[1:]):
        m = max(64, math.ceil((b1 - b0) / _AREA_PANEL))
        edges = np.linspace(b0, b1, m + 1)
        half = 0.5 * np.diff(edges)[:, None]
        nodes.append((0.5 * (edges[:-1] + edges[1:]))[:, None] + half * x[None, :])
        weights.append(half * w[None, :])
    if not nodes:
        return 0.0
    a = np.concatenate([n.ravel() for n in nodes])
    return float(np.dot(np.concatenate([v.ravel() for v in weights]),
                        np.asarray(law(a, 0), dtype=float)))


def _root(f: Callable[[float], float], a: float, b: float) -> float:
    from scipy.optimize import brentq

    fa, fb = f(a), f(b)
    if fa == 0.0:
        return a
    if fb == 0.0:
        return b
    return float(brentq(f, a, b, xtol=1e-15, rtol=4 * np.finfo(float).eps, maxiter=200))


def law_events(law: Callable[..., Any], height: float, key: str = 'height'
               ) -> tuple[float, float]:
    """(opening, closing) [rad] of ``law`` at ``height`` [m] (first rise crossing, last
    fall crossing). InputError naming ``key`` if ``height`` is not below the max lift."""
    a, h = _grid(law)
    peak = float(np.max(h))
    if not (0.0 < height < peak):
        raise InputError(key, f'{height * 1e3:g} mm',
                         f'a checking height > 0 and below the max lift '
                         f'({peak * 1e3:.4f} mm)')
    above = np.nonzero(h >= height)[0]
    i, j = int(above[0]), int(above[-1])
    if i == 0 or j == a.size - 1:
        lo, hi = getattr(law, 'support', (a[0], a[-1]))
        raise InputError(key, f'{height * 1e3:g} mm',
                         f'a checking height above the lift at the ends of the law\'s '
                         f'support ({float(h[0]) * 1e3:.4g} / {float(h[-1]) * 1e3:.4g} mm at '
                         f'{math.degrees(lo):.2f} / {math.degrees(hi):.2f} deg): the lobe '
                         'does not come down to the base circle there')

    def f(x: float) -> float:
        return float(law(np.array([x]), 0)[0]) - height

    opening = _root(f, a[i - 1], a[i])
    closing = _root(f, a[j], a[j + 1])
    return opening, closing


# ---------------------------------------------------------------------- tables
def _sorted(alpha: Any, lift: Any) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The finite rows of a table [rad, m] in angle order (the arrays themselves when
    they already are: a measured table of millions of rows is not copied)."""
    a = np.asarray(alpha, dtype=float).reshape(-1)
    h = np.asarray(lift, dtype=float).reshape(-1)
    keep = np.isfinite(a)
    keep &= np.isfinite(h)
    if not keep.all():
        a, h = a[keep], h[keep]
    del keep
    if a.size > 1 and bool(np.all(a[1:] >= a[:-1])):
        return a, h
    order = np.argsort(a, kind='stable')
    return a[order], h[order]


def _local(a: NDArray[np.float64], h: NDArray[np.float64], centre: float,
           half_window: float, need: int) -> NDArray[np.bool_]:
    sel = np.abs(a - centre) <= half_window
    if np.count_nonzero(sel) < need:
        raise InputError('lift table', f'{np.count_nonzero(sel)} samples within '
                         f'{math.degrees(half_window):g} deg of {math.degrees(centre):.3f} deg',
                         f'at least {need} samples around each event')
    return sel


def table_events(alpha: Any, lift: Any, height: float, reference: Any = None, *,
                 half_window: float = 1.0 * DEG, key: str = 'height') -> tuple[float, float]:
    """(opening, closing) [rad] of a measured lift table at ``height`` [m] (module doc).

    ``reference``: a law (the design as seen by the same probe) or None."""
    a, h = _sorted(alpha, lift)
    if a.size < 8:
        raise InputError('lift table', f'{a.size} points', 'at least 8 finite points')
    if reference is not None:
        guess = law_events(reference, height, key)
        dev = h - np.asarray(reference(a, 0), dtype=float)
        out = []
        for g in guess:
            sel = _local(a, h, g, half_window, 3)
            p = np.polyfit(a[sel] - g, dev[sel], 1)
            lo, hi = g - half_window, g + half_window

            def f(x: float, p: Any = p, g: float = g) -> float:
                return float(reference(np.array([x]), 0)[0] + np.polyval(p, x - g)) - height
            if f(lo) * f(hi) > 0:
                raise InputError(key, f'{height * 1e3:g} mm', 'a checking height the measured '
                                 f'lift crosses within {math.degrees(half_window):g} deg of '
                                 'the design crossing')
            out.append(_root(f, lo, hi))
        return out[0], out[1]
    peak = float(np.max(h))
    if not (0.0 < height < peak):
        raise InputError(key, f'{height * 1e3:g} mm',
                         f'a checking height > 0 and below the max lift ({peak * 1e3:.4f} mm)')
    above = np.nonzero(h >= height)[0]
    out = []
    for i0, i1 in ((int(above[0]) - 1, int(above[0])), (int(above[-1]), int(above[-1]) + 1)):
        if i0 < 0 or i1 >= a.size:
            raise InputError(key, f'{height * 1e3:g} mm', 'a table that starts and ends '
                             'below the checking height')
        g = a[i0] + (height - h[i0]) * (a[i1] - a[i0]) / (h[i1] - h[i0])
        sel = _local(a, h, g, half_window, 3)
        p = np.polyfit(a[sel] - g, h[sel], min(2, int(np.count_nonzero(sel)) - 1))
        lo, hi = g - half_window, g + half_window

        def f(x: float, p: Any = p, g: float = g) -> float:
            return float(np.polyval(p, x - g)) - height
        try:
            out.append(_root(f, max(lo, a[i0] - half_window / 2),
                             min(hi, a[i1] + half_window / 2)))
        except ValueError:
            out.append(g)
    return out[0], out[1]


def _fit_std(x: Any, y: Any, order: int, at: float) -> float:
    """Standard error [units of y] of a least-squares polynomial of ``order`` evaluated
    at ``at``, from its residual variance (0 when there are no spare degrees of freedom)."""
    X = np.vander(np.asarray(x, dtype=float), order + 1)
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    dof = x.size - (order + 1)
    if dof <= 0:
        return 0.0
    s2 = float(np.sum((y - X @ coef) ** 2)) / dof
    v = np.vander(np.array([at]), order + 1)[0]
    return math.sqrt(max(s2 * float(v @ np.linalg.pinv(X.T @ X) @ v), 0.0))


def table_events_std(alpha: Any, lift: Any, height: float, events: tuple[float, float],
                     reference: Any, *, half_window: float = 1.0 * DEG
                     ) -> tuple[float, float]:
    """Standard uncertainties [rad] of the events of ``table_events`` with a reference:
    the standard error of the local deviation fit at the event over the slope there."""
    a, h = _sorted(alpha, lift)
    guess = law_events(reference, height)
    dev = h - np.asarray(reference(a, 0), dtype=float)
    out = []
    for g, r in zip(guess, events):
        sel = np.abs(a - g) <= half_window
        p = np.polyfit(a[sel] - g, dev[sel], 1)
        slope = float(reference(np.array([r]), 1)[0]) + p[0]
        out.append(_fit_std(a[sel] - g, dev[sel], 1, r - g) / max(abs(slope), 1e-300))
    return out[0], out[1]


def table_peak_std(alpha: Any, lift: Any, reference: Any, peak_alpha: float, *,
                   half_window: float = 3.0 * DEG) -> float:
    """Standard uncertainty [m] of the max lift of ``table_peak`` with a reference."""
    a, h = _sorted(alpha, lift)
    g, _ = law_peak(reference)
    sel = np.abs(a - g) <= half_window
    dev = h - np.asarray(reference(a, 0), dtype=float)
    return _fit_std(a[sel] - g, dev[sel], 2, peak_alpha - g)


def table_peak(alpha: Any, lift: Any, reference: Any = None, *,
               half_window: float = 3.0 * DEG) -> tuple[float, float]:
    """(alpha [rad], max lift [m]) of a table: a quadratic fit of the deviation from
    ``reference`` (or of the lift itself) within ``half_window`` of the peak."""
    from scipy.optimize import minimize_scalar

    a, h = _sorted(alpha, lift)
    if reference is not None:
        g, _ = law_peak(reference)
        sel = _local(a, h, g, half_window, 4)
        dev = h - np.asarray(reference(a, 0), dtype=float)
        p = np.polyfit(a[sel] - g, dev[sel], 2)

        def total(x: float) -> float:
            return float(reference(np.array([x]), 0)[0] + np.polyval(p, x - g))
    else:
        g = float(a[int(np.argmax(h))])
        sel = _local(a, h, g, half_window, 4)
        p = np.polyfit(a[sel] - g, h[sel], 2)

        def total(x: float) -> float:
            return float(np.polyval(p, x - g))
    res = minimize_scalar(lambda x: -total(x), bounds=(g - half_window, g + half_window),
                          method='bounded', options={'xatol': 1e-12})
    return float(res.x), float(-res.fun)


# ------------------------------------------------------------------------ cards
def _height_entries(events: Sequence[tuple[float, float, float]]) -> list[dict[str, Any]]:
    out = []
    for y, o, c in events:
        out.append({'height_m': y, 'height_mm': y * 1e3,
                    'opening_deg': math.degrees(o), 'closing_deg': math.degrees(c),
                    'duration_cam_deg': math.degrees(c - o),
                    'duration_crank_deg': 2.0 * math.degrees(c - o),
                    'centreline_deg': math.degrees(0.5 * (o + c))})
    return out


def _common(max_lift: float, peak_alpha: float, entries: list[dict[str, Any]],
            area: float, support: tuple[float, float], rocker_ratio: float | None,
            ) -> dict[str, Any]:
    card: dict[str, Any] = {
        'max_lift_m': max_lift, 'max_lift_mm': max_lift * 1e3,
        'max_lift_alpha_deg': math.degrees(peak_alpha),
        'heights': entries,
        'centreline_deg': entries[0]['centreline_deg'] if entries else None,
        'area_mm_deg': area * 1e3 / DEG,
        'area_m_rad': area,
        'lift_duration_deg': math.degrees(support[1] - support[0]),
        'fullness': (area / (max_lift * (support[1] - support[0]))
                     if max_lift > 0 and support[1] > support[0] else None),
    }
    if rocker_ratio is not None:
        card['rocker_ratio'] = rocker_ratio
        card['max_valve_lift_m'] = rocker_ratio * max_lift
        card['max_valve_lift_mm'] = rocker_ratio * max_lift * 1e3
    return card


def card_from_law(law: LiftLaw, heights: Sequence[float] = DEFAULT_HEIGHTS_M,
                  *, rocker_ratio: float | None = None, key: str = 'heights',
                  derivatives: Callable[..., Any] | None = None,
                  derivative_points: int = _GRID, floor: float = 0.0,
                  joins: Sequence[tuple[float, float, float]] = ()) -> dict[str, Any]:
    """The design card of a lift law (module doc for every field).

    ``derivatives``: the law whose h', h'', h''' are reported (default ``law``; e.g. the
    exact converted lift when ``law`` is its C2 tabulation, whose h''' has spikes),
    sampled at ``derivative_points`` evenly spaced angles over the support.

    A law from a table: ``floor`` [m] is the lift its rows cannot tell from the base
    circle (noise, rounding): a height at or below it gets the duration seat to seat
    (where the law leaves and rejoins the base circle) and a note; ``joins`` (start,
    end [rad], lift [m]) are the law's joins to the base circle where the table stops
    mid-lobe: a height below that lift gets a note that its events are the join's.
    A height at or above the max lift is refused (InputError naming it)."""
    peak_alpha, max_lift = law_peak(law)
    notes: dict[int, str] = {}
    events = []
    for j, y in enumerate(heights):
        if 0.0 < y <= floor < max_lift:
            lo, hi = law.support
            events.append((y, float(lo), float(hi)))
            notes[j] = (f'at or below the base-circle level the rows can tell '
                        f'({floor * 1e3:.4g} mm): events where the lobe leaves and rejoins '
                        'the base circle')
            continue
        events.append((y, *law_events(law, y, f'{key}[{j}]')))
        low = [lift for _a, _b, lift in joins if y < lift]
        if low:
            notes[j] = (f'below the lift where the table stops mid-lobe '
                        f'({max(low) * 1e3:.4g} mm): the events are those of the join to '
                        'the base circle, not of measured rows')
    lo, hi = law.support
    a, h = _grid(law)
    on = np.nonzero(h > 0)[0]
    support = (float(a[max(on[0] - 1, 0)]), float(a[min(on[-1] + 1, a.size - 1)]))
    breaks = sorted(set([lo, hi] + [j for j in getattr(law, 'junctions', ()) if lo < j < hi]))
    area = law_area(law, breaks)
    entries = _height_entries(events)
    for j, text in notes.items():
        entries[j]['note'] = text
    card = _common(max_lift, peak_alpha, entries, area, support, rocker_ratio)
    card['source'] = 'design'
    dlaw = law if derivatives is None else derivatives
    ad = a if derivative_points == _GRID else np.linspace(lo, hi, derivative_points)
    d = np.stack([np.asarray(dlaw(ad, k), dtype=float) for k in (1, 2, 3)])
    for k, (name, unit) in enumerate((('velocity', 'mm_per_deg'),
                                      ('acceleration', 'mm_per_deg2'),
                                      ('jerk', 'mm_per_deg3')), start=1):
        vals = d[k - 1]
        scale = 1e3 * DEG ** k
        card[f'{name}_max_{unit}'] = float(np.max(vals)) * scale
        card[f'{name}_min_{unit}'] = float(np.min(vals)) * scale
        card[f'{name}_max_si'] = float(np.max(vals))
        card[f'{name}_min_si'] = float(np.min(vals))
    return card


def card_from_table(alpha: Any, lift: Any, heights: Sequence[float] = DEFAULT_HEIGHTS_M,
                    reference: Any = None, *, rocker_ratio: float | None = None,
                    key: str = 'heights', source: str = 'measured',
                    area: float | None = None) -> dict[str, Any]:
    """The card of a measured lift table (``reference``: the design law for the same
    probe, used for the local fits; module doc). Derivatives of measured data are not
    given here (they need a smoothing model: ``cam-bench reconstruct``). ``area``: the
    lift area over the support [m rad] when the caller has it (a table too long to
    pass whole: then only the rows around the peak and the events are given); computed
    here otherwise."""
    a, h = _sorted(alpha, lift)
    peak_alpha, max_lift = table_peak(a, h, reference)
    events = [(y, *table_events(a, h, y, reference, key=f'{key}[{j}]'))
              for j, y in enumerate(heights)]
    if reference is not None:
        support = (float(reference.support[0]), float(reference.support[1]))
    else:
        idx = np.nonzero(h > 0.002 * max_lift)[0]
        support = (float(a[idx[0]]), float(a[idx[-1]])) if idx.size else (0.0, 0.0)
    if area is None:
        inside = (a >= support[0]) & (a <= support[1])
        trap = getattr(np, 'trapezoid', None) or getattr(np, 'trapz')
        area = float(trap(h[inside], a[inside])) if np.count_nonzero(inside) > 1 else 0.0
    card = _common(max_lift, peak_alpha, _height_entries(events), area, support,
                   rocker_ratio)
    card['source'] = source
    card['derivatives'] = 'not computed from measured points (cam-bench reconstruct)'
    return card


def crank_events(card: dict[str, Any], role: str, centreline_crank_deg: float
                 ) -> dict[str, Any]:
    """Valve events in crank degrees for a lobe whose centreline is at
    ``centreline_crank_deg`` (intake: degrees after TDC; exhaust: degrees before TDC of
    the overlap), four-stroke (crank = 2 x cam). Returns per height
    ``{height_m, opens, closes}`` with the trade's words (BTDC/ABDC for an intake,
    BBDC/ATDC for an exhaust)."""
    if role not in ('intake', 'exhaust'):
        raise InputError('role', role, 'intake | exhaust')
    centre = centreline_crank_deg if role == 'intake' else -centreline_crank_deg
    out = []
    for e in card['heights']:
        # crank angle after TDC of the overlap of each event
        o = centre + 2.0 * (e['opening_deg'] - card['centreline_deg'])
        c = centre + 2.0 * (e['closing_deg'] - card['centreline_deg'])
        if role == 'intake':
            entry = {'opens_btdc_deg': -o, 'closes_abdc_deg': c - 180.0}
        else:
            entry = {'opens_bbdc_deg': -180.0 - o, 'closes_atdc_deg': c}
        out.append({'height_m': e['height_m'], **entry})
    return {'role': role, 'centreline_crank_deg': centreline_crank_deg, 'events': out}


def lobe_separation_deg(intake_centreline_atdc: float, exhaust_centreline_btdc: float
                        ) -> float:
    """Lobe separation angle [cam deg] from the centrelines in crank degrees."""
    return 0.5 * (intake_centreline_atdc + exhaust_centreline_btdc)


def centreline_crank_atdc(phase_deg: float, centreline_alpha_deg: float, direction: int,
                          tdc_deg: float, cylinder_tdc_crank_deg: float = 0.0) -> float:
    """Crank degrees after the cylinder's TDC of the overlap of a lobe centreline,
    wrapped to (-360, 360] (a four-stroke cycle; an exhaust centreline is then negative,
    its BTDC value is minus this).

    ``phase_deg``: nose minus datum [cam deg, encoder frame]; ``centreline_alpha_deg``:
    the card's centreline from the nose [cam deg, alpha frame, which runs with the
    engine]; ``direction``: the scene's (engine time = direction x encoder angle);
    ``tdc_deg``: cylinder 1's TDC of the overlap from the datum, like a phase;
    ``cylinder_tdc_crank_deg``: this cylinder's TDC after cylinder 1's [crank deg].
    crank = 2 (direction (phase - tdc) + centreline_alpha) - cylinder offset."""
    crank = 2.0 * (direction * (phase_deg - tdc_deg) + centreline_alpha_deg) \
        - cylinder_tdc_crank_deg
    out = 360.0 - (360.0 - crank) % 720.0
    return out


def _fixed(value: float, spec: str) -> str:
    """``value`` formatted by ``spec``, without the minus sign of a value that rounds
    to zero (a nose at -1e-13 deg prints 0.000, not -0.000; the width is kept)."""
    text = format(value, spec)
    if not (text.lstrip().startswith('-') and float(text) == 0.0):
        return text
    return text.replace('-', ' ', 1) if text.startswith(' ') else text[1:]


def _num(value: Any, spec: str) -> str:
    width = int(spec.split('.')[0] or 0)
    return '-'.rjust(width) if value is None else _fixed(value, spec)


def card_text(cards: dict[str, dict[str, Any]]) -> str:
    """A fixed-width text of one or more cards (name -> card), side by side per height."""
    lines = []
    for name, card in cards.items():
        lines.append(f'{name} ({card.get("source", "")}): max lift '
                     f'{_num(card.get("max_lift_mm"), ".4f")} mm at '
                     f'{_num(card.get("max_lift_alpha_deg"), ".3f")} deg'
                     + (f', valve {card["max_valve_lift_mm"]:.4f} mm (rocker ratio x lift, '
                        'lash not taken off)'
                        if card.get('max_valve_lift_mm') is not None else '')
                     + f', area {_num(card.get("area_mm_deg"), ".2f")} mm deg, fullness '
                     f'{_num(card.get("fullness"), ".4f")}')
        if card.get('note'):
            lines.append(f'  note: {card["note"]}')
        if card.get('warning'):
            lines.append(f'  WARNING: {card["warning"]}')
        lines.append(f'  {"height mm":>10}{"opens deg":>11}{"closes deg":>11}'
                     f'{"dur cam":>10}{"dur crank":>11}{"centre deg":>11}')
        for e in card.get('heights', []):
            lines.append(f'  {e["height_mm"]:>10.4f}{_fixed(e["opening_deg"], ">11.3f")}'
                         f'{_fixed(e["closing_deg"], ">11.3f")}{e["duration_cam_deg"]:>10.3f}'
                         f'{e["duration_crank_deg"]:>11.3f}'
                         f'{_fixed(e["centreline_deg"], ">11.4f")}')
        if 'velocity_max_mm_per_deg' in card:
            lines.append(f'  velocity {_fixed(card["velocity_min_mm_per_deg"], ".5f")} .. '
                         f'{_fixed(card["velocity_max_mm_per_deg"], ".5f")} mm/deg, '
                         f'acceleration {_fixed(card["acceleration_min_mm_per_deg2"], ".6f")}'
                         f' .. {_fixed(card["acceleration_max_mm_per_deg2"], ".6f")} mm/deg^2,'
                         f' jerk {_fixed(card["jerk_min_mm_per_deg3"], ".3e")} .. '
                         f'{_fixed(card["jerk_max_mm_per_deg3"], ".3e")} mm/deg^3')
        crank = card.get('crank')
        if crank:
            for e in crank['events']:
                words = ', '.join(f'{k.split("_")[0]} {v:.2f} {k.split("_")[1].upper()}'
                                  for k, v in e.items() if k != 'height_m')
                lines.append(f'  at {e["height_m"] * 1e3:.3f} mm: {words}')
    return '\n'.join(lines)
