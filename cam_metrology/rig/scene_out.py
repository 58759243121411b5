"""The scene with calibrated values (``rig calibrate --scene-out``): the valve_train
keys that were fitted (and ``rig.nose_angle_deg``) replaced, everything else kept."""
from __future__ import annotations

import math
from typing import Any

SEAT_KEYS = {'seat_stiffness': 'stiffness', 'seat_damping': 'damping'}


def calibrated_scene_text(scene_text: str, fit: Any) -> str:
    """YAML text of the scene with the fitted values of ``fit`` (validated again)."""
    import yaml

    from cam_metrology.scene.parse import parse_scene

    doc = yaml.safe_load(scene_text)
    vt = doc['valve_train']
    for name, value in fit.value.items():
        if name == 'nose_angle':
            doc['rig']['nose_angle_deg'] = math.degrees(value) % 360.0
        elif name in SEAT_KEYS:
            vt.setdefault('seat', {})[SEAT_KEYS[name]] = float(value)
        else:
            vt[name] = float(value)
    names = ', '.join(f'{n} +- {fit.std[n]:.3g}' for n in fit.names)
    text = ('# calibrated by cam-bench rig calibrate (standard uncertainties: ' + names
            + ')\n' + yaml.safe_dump(doc, sort_keys=False))
    parse_scene(text, '--scene-out')
    return text
