"""The lobe law of a table for the routes that are not a table reader themselves:
the ``table`` family of the lift-law registry (``table_from_spec``, what
``cam_design.lift_laws.from_spec`` builds for ``{family: table, alpha, h}``), and what
the reconstruction, which keeps its own fits, is told about the same rows
(``lobe_warnings``, ``beyond_rows``). The rules are ``lobe_table``'s.
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cam_design.errors import InputError
from cam_design.lift_table.lobe_frame import part_turn_centre
from cam_design.lift_table.lobe_table import TableLobe, lobe_law

#: a fit rising this share of the lift above every row and the lobe law left the rows
BEYOND_ROWS = 0.01


def table_from_spec(spec: Mapping[str, Any], key: str) -> TableLobe:
    """``family: table`` of the lift-law registry: ``alpha`` [rad] and ``h`` [m] lists of
    a design table (``check_design_table``'s rules) through ``lobe_law``, so that a table
    given to the Python API, a scene or the design commands is the same lobe as on every
    other route. What the lobe law did and saw is in ``law.lobe`` (``note()``,
    ``warnings``)."""
    from cam_design.lift_laws import params as P
    from cam_design.lift_laws.base import check_design_table

    P.reject_unknown(spec, key, ('alpha', 'h'))
    a, v = check_design_table(P.numbers(spec, key, 'alpha'), P.numbers(spec, key, 'h'), key)
    return lobe_law(a, v, key=key, turn_from=-math.pi)   # alpha from the centreline


def lobe_warnings(alpha: ArrayLike, lift: ArrayLike, key: str = 'table', *,
                  design_known: bool = False) -> tuple[TableLobe | None, list[str]]:
    """(lobe law or None, warnings) of a table for a route that keeps its own fit (the
    reconstruction's spline and harmonic series): what the lobe law of the same rows
    says about them (mid-lobe ends, a crank-degree suspicion, several lobes), or why no
    lobe law can be drawn through them. The law's frame (``law.lobe.offset``) is the
    one such a route fits in: a fit over (-180, 180] would cut a lobe across +-180 deg.
    ``design_known``: the lobe's design is given, which settles its shape (several lobes,
    a lobe wider than a cam lobe usually is, as a dual-peak EGR cam): those warnings go."""
    try:
        law = lobe_law(alpha, lift, key=key, allow_steps=True)
    except InputError as exc:
        return None, [f'no lobe law from these rows: {exc}']
    out = [w for w in law.lobe.warnings if not w.startswith('rows:')]
    if design_known:
        out = [w for w in out if 'crank_deg' not in w and not w.startswith('the table holds')]
    return law, out


def fit_turn(alpha: ArrayLike, law: TableLobe | None) -> float:
    """The angle [rad] by which a route that fits the rows over (-pi, pi] turns them
    first (fit angle = wrap(alpha - turn)), so that no fit is cut inside the lobe or
    bridges a gap: a table over part of the turn, the middle of its rows in their own
    contiguous angles (``part_turn_centre``); a whole turn whose lobe crosses +-180 deg,
    its lobe law's frame (the seam in the middle of the longest base-circle run); else
    0."""
    centre = part_turn_centre(alpha)
    if centre:
        return centre
    if law is not None and not law.lobe.periodic:
        return float(law.lobe.offset)
    return 0.0


def fit_window(alpha: ArrayLike, law: TableLobe | None) -> float | None:
    """The start w [rad] of the turn (w, w + 2 pi] over which a route that fits a whole
    turn gives its curve back: (-pi, pi] when the lobe law's lobe lies in it (or there
    is no lobe law, or it is periodic); else the turn centred on the lobe's middle, to
    the whole degree (a -180..180 deg table with its nose at 180 deg: -360..0 deg, the
    lobe where the card and the dynamics put it). None for a table over part of the
    turn (its own contiguous angles)."""
    if part_turn_centre(alpha):
        return None
    if law is None or law.lobe.periodic or law.lobe.middle is None:
        return -math.pi
    lo, hi = law.support
    if lo > -math.pi and hi <= math.pi:
        return -math.pi
    return math.radians(round(math.degrees(law.lobe.middle))) - math.pi


def beyond_rows(law: TableLobe | None, lift: NDArray[np.float64], rows: ArrayLike) -> str:
    """A warning when a fit's ``lift`` [m] rises above every row and the lobe law by
    more than ``BEYOND_ROWS`` of the lift (a gap bridged by the fit), else ''."""
    h = np.asarray(rows, dtype=float)
    h = h[np.isfinite(h)]
    if law is None or not h.size or not lift.size:
        return ''
    top = float(np.max(lift))
    limit = float(np.max(law(np.linspace(*law.support, 4001), 0)))
    allowed = max(limit, float(np.max(h))) + max(3.0 * law.lobe.sigma, law.lobe.quantum,
                                                 BEYOND_ROWS * float(np.max(h)))
    if top <= allowed:
        return ''
    return (f'max lift {top * 1e3:.4f} mm is above every row ({float(np.max(h)) * 1e3:.4f} '
            'mm) and above the lobe law of the same rows '
            f'({limit * 1e3:.4f} mm): the fit bridges a gap in the table; not the cam')
