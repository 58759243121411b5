"""The scene's ``form`` block: cut-off of the Gaussian filter and the waviness band [UPR]
(validated with errors naming the key; docs/scene.md)."""
from __future__ import annotations

from typing import Any, Mapping

from cam_design.errors import InputError
from cam_metrology.scene import FormSettings

#: highest cut-off or band edge a scene may ask for [UPR] (a 0.01 deg encoder resolves 18 000)
MAX_UPR = 18_000


def _upr(key: str, value: Any) -> int:
    """A whole number of UPR in [1, MAX_UPR]."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or \
            int(value) != value or not 1 <= value <= MAX_UPR:
        raise InputError(key, value, f'a whole number of undulations per revolution in '
                         f'[1, {MAX_UPR}]')
    return int(value)


def parse_form(block: Mapping[str, Any] | None) -> FormSettings:
    """FormSettings of the scene's ``form`` mapping (defaults when None)."""
    if block is None:
        return FormSettings()
    cutoff = _upr('form.cutoff_upr', block.get('cutoff_upr', FormSettings.cutoff_upr))
    band = block.get('waviness_band_upr')
    if band is None:
        return FormSettings(cutoff, None)
    if not isinstance(band, (list, tuple)) or len(band) != 2:
        raise InputError('form.waviness_band_upr', band, '[lo, hi] in UPR')
    lo = _upr('form.waviness_band_upr[0]', band[0])
    hi = _upr('form.waviness_band_upr[1]', band[1])
    if lo > hi:
        raise InputError('form.waviness_band_upr', list(band), '[lo, hi] with lo <= hi')
    return FormSettings(cutoff, (lo, hi))
