"""Form of a measured lobe over the revolution (report fields ``harmonics``,
``roundness_um``, ``waviness``): its lift error (base-circle referenced, as the verdict
uses it) as a closed profile against the encoder angle, analysed by ``form``."""
from __future__ import annotations

from typing import Any, Mapping

import numpy as np

from cam_design.errors import InputError
from cam_metrology.metrology.form import analyze_form
from cam_metrology.metrology.lift_error import BASE_MARGIN, referenced_rows
from cam_metrology.scene.model import FormSettings


def lobe_form(table: Any, values: Mapping[str, Any], direction: int,
              settings: FormSettings) -> dict[str, Any]:
    """The form fields of a lobe from its lift table (alpha from the fitted nose [rad],
    measured and design lift [m]) and report values (``angle_deg``, ``runout_fitted``):
    the deviation measured - design at the encoder angle
    ``direction * alpha + nose angle``; roundness over the base circle (``BASE_MARGIN``
    outside the lobe). A band the sampling does not resolve gives ``form_error`` (the
    one-line reason) instead: the lobe's other results stand."""
    rows = referenced_rows(table, values)
    alpha, measured, design = rows[:, 0], rows[:, 1], rows[:, 2]
    theta = np.mod(direction * alpha + np.radians(values['angle_deg']), 2 * np.pi)
    lobe = np.flatnonzero(design > 0)
    circle = np.ones(alpha.size, bool)
    if lobe.size:
        circle = (alpha < alpha[lobe[0]] - BASE_MARGIN) | (alpha > alpha[lobe[-1]] + BASE_MARGIN)
    del lobe
    dev = measured - design
    del rows, alpha, measured, design   # the form needs the angle and the deviation only
    try:
        res = analyze_form(theta, dev, cutoff_upr=settings.cutoff_upr,
                           band=settings.waviness_band_upr, circle=circle, key='form')
    except InputError as exc:
        return {'form_error': str(exc)}
    return res.as_dict()
