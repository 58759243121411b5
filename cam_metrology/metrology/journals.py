"""Journals (bearing seats) of a camshaft as measured features, and the straightness of
the shaft from their run-out (pure numerics, no rclpy; docs/metrology.md "Journals").

A journal is measured like a lobe: the probe reading ``s`` [m] against the encoder angle
``theta`` [rad] over the revolution. Its reading is fitted as
``s = c + a cos theta + b sin theta + form``: ``c`` is the mean reading (a radius with the
probe's ``zero_radius``), ``(a, b)`` the eccentricity of the journal's centre from the
axis of rotation (the datum axis of the bench's centres): run-out TIR = 2 sqrt(a^2 + b^2),
and ``form`` what ``form.analyze_form`` reports (harmonics, roundness about the
least-squares circle, waviness).

Straightness ("cam bent"): the journals' centres (a_i, b_i) at their axial positions z_i,
fitted by a straight line in space (a and b each linear in z, least squares); the
straightness is twice the largest distance of a centre from that line (the diameter of
the smallest coaxial cylinder about the line that holds every centre), and the bow its
largest deviation with its direction (encoder angle).
"""
from __future__ import annotations

from typing import Any, Mapping, Sequence

import numpy as np

from cam_design.errors import InputError
from cam_metrology.metrology import block_lsq
from cam_metrology.metrology.form import analyze_form

UM = 1e6


def analyze_journal(theta: Any, s: Any, radius: float, zero_radius: float | None, *,
                    cutoff_upr: int = 50, band: tuple[int, int] | None = None,
                    key: str = 'journal') -> dict[str, Any]:
    """Report fields of one journal (units in the names): diameter deviation from
    2 ``radius`` [m] (None without the probe's ``zero_radius``), run-out TIR and its
    direction, eccentricity vector, and the form fields (or ``form_error``)."""
    th = np.asarray(theta, dtype=float)
    y = np.asarray(s, dtype=float)
    if th.size < 20:
        raise InputError(key, f'{th.size} samples', 'at least 20 samples over the revolution')
    c, a, b = (float(v) for v in block_lsq.harmonic_lstsq(th, y))
    out: dict[str, Any] = {
        'kind': 'journal', 'nominal_radius_mm': radius * 1e3,
        'mean_reading_mm': c * 1e3,
        'diameter_deviation_um': (None if zero_radius is None
                                  else 2.0 * (c + zero_radius - radius) * UM),
        'runout_um': 2.0 * float(np.hypot(a, b)) * UM,
        'runout_direction_deg': float(np.degrees(np.arctan2(b, a)) % 360.0),
        'eccentricity_um': [a * UM, b * UM],
    }
    try:
        form = analyze_form(th, y - c, cutoff_upr=cutoff_upr, band=band, key='form')
        out.update(form.as_dict())
    except InputError as exc:
        out['form_error'] = str(exc)
    return out


def straightness(positions: Sequence[float], eccentricities: Sequence[Sequence[float]],
                 ) -> dict[str, Any] | None:
    """Straightness of the shaft [um] from the eccentricity vectors [um] of features at
    axial ``positions`` [m] (module doc); None with fewer than 3 features."""
    z = np.asarray(positions, dtype=float)
    e = np.asarray(eccentricities, dtype=float).reshape(-1, 2)
    if z.size < 3:
        return None
    design = np.column_stack([np.ones_like(z), z - z.mean()])
    coef, *_ = np.linalg.lstsq(design, e, rcond=None)
    resid = e - design @ coef
    dist = np.hypot(resid[:, 0], resid[:, 1])
    k = int(np.argmax(dist))
    return {'straightness_um': 2.0 * float(dist[k]), 'bow_um': float(dist[k]),
            'bow_at_mm': float(z[k] * 1e3),
            'bow_direction_deg': float(np.degrees(np.arctan2(resid[k, 1], resid[k, 0]))
                                       % 360.0),
            'features': int(z.size)}


def shaft_straightness(features: Mapping[str, Mapping[str, Any]],
                       positions: Mapping[str, float]) -> dict[str, Any] | None:
    """``straightness`` of the measured journals (status ok, with an eccentricity) at
    their scene ``positions`` [m], with the journal ids used."""
    ids = [f for f in positions if (features.get(f) or {}).get('status') == 'ok'
           and features[f].get('eccentricity_um') is not None]
    out = straightness([positions[f] for f in ids],
                       [features[f]['eccentricity_um'] for f in ids])
    if out is not None:
        out['from'] = ids
    return out
