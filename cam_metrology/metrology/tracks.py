"""Lobes measured on several tracks across their width: taper and twist (pure numerics;
docs/metrology.md "Taper and twist").

A track is named by its ``frame_id``: ``<lobe id>@<z>``, z the track's axial offset
across the lobe's width in mm from the lobe's mid-plane (``lobe_1@-4``, ``lobe_1@4.5``).
Each track is measured as a lobe of its own (the lobe's design and tolerances). Over the
tracks of a lobe: the taper is the slope of the nose lift error against z (least
squares; µm of lift per mm of width), the twist the slope of the nose angle against z
(deg per mm), and the nose-angle difference between the outermost tracks.
"""
from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np

from cam_design.errors import InputError
from cam_metrology.metrology.lift_error import feature_referenced, referenced_rows
from cam_metrology.metrology.spill import walk

#: nose zone [rad] over which a track's lift error at the nose is averaged (+-1 deg)
NOSE_HALF_WIDTH = math.radians(1.0)


def track_label(frame_id: str) -> tuple[str, float] | None:
    """(lobe id, z [mm]) of a track's ``frame_id`` ``<lobe id>@<z mm>``; None when the id
    has no ``@``; InputError naming the frame_id when it does not parse."""
    if '@' not in frame_id:
        return None
    lobe, _, z = frame_id.partition('@')
    try:
        value = float(z)
    except ValueError:
        value = math.nan
    if not lobe or not math.isfinite(value):
        raise InputError('frame_id', frame_id, '<lobe id>@<track offset across the width in '
                         'mm>, e.g. lobe_1@-4.5')
    return lobe, value


def nose_lift_error_um(table: Any, values: Mapping[str, Any]) -> float | None:
    """Mean measured - design lift [um] within ``NOSE_HALF_WIDTH`` of the fitted nose of a
    lobe's (alpha, measured, design) table, base-circle referenced as the verdict does;
    None without samples there. A long (spilled) table is read a block of rows at a time
    (the mean summed by blocks: equal to rounding)."""
    if isinstance(table, np.memmap):
        rows = referenced_rows(table, values)   # the kept rows, spilled
        total, count = 0.0, 0
        for a, b in walk(rows.shape[0], rows):
            part = rows[a:b][np.abs(rows[a:b, 0]) <= NOSE_HALF_WIDTH]
            total += float(np.sum(part[:, 1] - part[:, 2]))
            count += part.shape[0]
        return total / count * 1e6 if count else None
    ref, good = feature_referenced(table, values)
    near = good & (np.abs(ref[:, 0]) <= NOSE_HALF_WIDTH)
    if not np.any(near):
        return None
    return float(np.mean(ref[near, 1] - ref[near, 2]) * 1e6)


def taper_and_twist(tracks: Mapping[str, Mapping[str, Any]]) -> dict[str, Any] | None:
    """Taper and twist of one lobe from its tracks' report entries (``track_mm``,
    ``angle_deg``, ``nose_lift_error_um``; status ok); None with fewer than 2 tracks."""
    ok = sorted((f['track_mm'], fid, f) for fid, f in tracks.items()
                if f.get('status') == 'ok' and f.get('angle_deg') is not None)
    if len(ok) < 2:
        return None
    z = np.array([t[0] for t in ok])
    if np.ptp(z) == 0.0:
        return None
    angle = np.array([t[2]['angle_deg'] for t in ok])
    angle = angle[0] + (angle - angle[0] + 180.0) % 360.0 - 180.0   # unwrapped near the first
    out: dict[str, Any] = {'tracks': [t[1] for t in ok], 'tracks_mm': z.tolist(),
                           'twist_deg_per_mm': float(np.polyfit(z, angle, 1)[0]),
                           'nose_angle_difference_deg': float(angle[-1] - angle[0])}
    lift = [t[2].get('nose_lift_error_um') for t in ok]
    if all(v is not None for v in lift):
        values = np.array(lift, dtype=float)
        out['taper_um_per_mm'] = float(np.polyfit(z, values, 1)[0])
        out['nose_lift_error_um'] = values.tolist()
    return out
