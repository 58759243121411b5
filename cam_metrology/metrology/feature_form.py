"""Form of a measured lobe over the revolution (report fields ``harmonics``,
``roundness_um``, ``waviness``): its lift error (base-circle referenced, as the verdict
uses it) as a closed profile against the encoder angle, analysed by ``form``."""
from __future__ import annotations

from typing import Any, Mapping

import numpy as np

from cam_design.errors import InputError
from cam_metrology.metrology.form import analyze_form
from cam_metrology.metrology.lift_error import BASE_MARGIN, referenced_rows
from cam_metrology.metrology.lobe_columns import column_of, mask_of
from cam_metrology.metrology.spill import release, walk
from cam_metrology.scene.model import FormSettings


def lobe_form(table: Any, values: Mapping[str, Any], direction: int,
              settings: FormSettings) -> dict[str, Any]:
    """The form fields of a lobe from its lift table (alpha from the fitted nose [rad],
    measured and design lift [m]) and report values (``angle_deg``, ``runout_fitted``):
    the deviation measured - design at the encoder angle
    ``direction * alpha + nose angle``; roundness over the base circle (``BASE_MARGIN``
    outside the lobe). A band the sampling does not resolve gives ``form_error`` (the
    one-line reason) instead: the lobe's other results stand."""
    rows = referenced_rows(table, values)   # spilled when long: read a block at a time
    n = rows.shape[0]
    nose = np.radians(values['angle_deg'])
    theta = column_of(n, lambda a, b: np.mod(direction * rows[a:b, 0] + nose, 2 * np.pi), rows)
    dev = column_of(n, lambda a, b: rows[a:b, 1] - rows[a:b, 2], rows)
    first = last = -1
    for a, b in walk(n, rows):
        on = np.flatnonzero(rows[a:b, 2] > 0)
        if on.size:
            first = a + int(on[0]) if first < 0 else first
            last = a + int(on[-1])
    circle = np.ones(n, bool)
    if first >= 0:
        lo, hi = rows[first, 0] - BASE_MARGIN, rows[last, 0] + BASE_MARGIN
        circle = mask_of(n, lambda a, b: (rows[a:b, 0] < lo) | (rows[a:b, 0] > hi), rows)
    release(rows)   # the form needs the angle and the deviation only
    try:
        res = analyze_form(theta, dev, cutoff_upr=settings.cutoff_upr,
                           band=settings.waviness_band_upr, circle=circle, key='form')
    except InputError as exc:
        return {'form_error': str(exc)}
    return res.as_dict()
