"""Journals (bearing seats) of a camshaft as measured features, and the straightness of
the shaft from their and the lobes' base-circle run-out (pure numerics, no rclpy;
docs/metrology.md "Journals").

A journal is measured like a lobe: the probe reading ``s`` [m] against the encoder angle
``theta`` [rad] over the revolution. Its reading is fitted as
``s = c + a cos theta + b sin theta + form``: ``c`` is the mean reading (a radius with the
probe's ``zero_radius``), ``(a, b)`` the eccentricity of the journal's centre from the
axis of rotation (the datum axis of the bench's centres): run-out TIR = 2 sqrt(a^2 + b^2),
and ``form`` what ``form.analyze_form`` reports (harmonics, roundness about the
least-squares circle, waviness).

Straightness ("cam bent"): the centres (a_i, b_i) of the journals and of the lobes' base
circles (a lobe's from its base-circle samples alone, fitted the same way; lobes with a
scene ``axial_position``) at their axial positions z_i, fitted by a straight line in space
(a and b each linear in z, least squares); the straightness is twice the largest
distance of a centre from that line (the diameter of the smallest coaxial cylinder about
the line that holds every centre), and the bow its largest deviation with its direction
(encoder angle). A base circle ground off-centre on its lobe shows as a bend there: the
gauge sees the base circle's centre, not the shaft's.
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


#: the eccentricity field of each kind of feature [um]: a journal's whole circle, a
#: lobe's (or track's) base circle
ECCENTRICITY = {'journal': 'eccentricity_um', 'lobe': 'base_circle_eccentricity_um'}


def feature_positions(scene: Any, features: Mapping[str, Mapping[str, Any]]
                      ) -> tuple[dict[str, float], list[dict[str, str]]]:
    """({feature id: axial position [m]}, notes of the lobes left out) for the
    straightness: every journal; every lobe with an ``axial_position`` and each of its
    tracks (``<lobe>@<z mm>`` at the lobe's position + z); a lobe without one is left out
    with a note."""
    positions = {j.id: j.axial_position for j in scene.journals}
    notes: list[dict[str, str]] = []
    for lobe in scene.lobes:
        if lobe.axial_position is None:
            notes.append({'feature': lobe.id, 'why': 'no axial_position in the scene'})
            continue
        tracks = {fid: lobe.axial_position + float(f['track_mm']) * 1e-3
                  for fid, f in features.items()
                  if f.get('track_of') == lobe.id and f.get('track_mm') is not None}
        if lobe.id in features or not tracks:
            positions[lobe.id] = lobe.axial_position
        positions.update(tracks)
    return positions, notes


def _eccentricity(feature: Mapping[str, Any] | None) -> tuple[Any, str | None]:
    """(eccentricity vector [um] or None, why it is missing)."""
    if feature is None:
        return None, 'not measured'
    if feature.get('status') != 'ok':
        return None, f"feature {feature.get('status')}: {feature.get('reason', '')}".strip()
    value = feature.get(ECCENTRICITY.get(feature.get('kind', ''), ''))
    if value is None:
        return None, ('fewer than 10 base-circle samples: no base-circle centre'
                      if feature.get('kind') == 'lobe' else 'no eccentricity')
    return value, None


def shaft_straightness(features: Mapping[str, Mapping[str, Any]],
                       positions: Mapping[str, float],
                       notes: Sequence[Mapping[str, str]] = ()) -> dict[str, Any]:
    """``straightness`` of the measured journals and lobes (their eccentricity vectors,
    ``ECCENTRICITY``) at their axial ``positions`` [m], with the ids used (``from``) and
    the features left out with the reason (``left_out``, after ``notes``);
    ``straightness_um`` None (and ``why``) with fewer than 3."""
    left_out = [dict(n) for n in notes]
    ids, centres = [], []
    for fid in sorted(positions, key=lambda f: positions[f]):
        value, why = _eccentricity(features.get(fid))
        if why is not None:
            left_out.append({'feature': fid, 'why': why})
        else:
            ids.append(fid)
            centres.append(value)
    out = straightness([positions[f] for f in ids], centres) or {
        'straightness_um': None,
        'why': f'fewer than 3 journals or lobes with a centre ({len(ids)})'}
    out['from'] = ids
    out['left_out'] = left_out
    return out
