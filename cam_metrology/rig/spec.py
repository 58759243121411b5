"""The scene's ``rig`` block: which lobe drives the valve on the rig, its phase on the
encoder, and the limits of the rig analysis (docs/contract.md "Valve-train rig").

``rig.true_valve_train`` (a valve_train block) is read by the rig simulator only: the
analysis and the calibration never look at it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

from cam_design.errors import InputError, require_finite, require_positive

RIG_KEYS = ('lobe', 'nose_angle_deg', 'checking_height_mm', 'max_speed_variation',
            'separation_sigmas', 'separation_min_um', 'step_deg', 'true_valve_train')


@dataclass(frozen=True)
class RigSpec:
    """The rig block, validated.

    lobe: id of the scene lobe that drives the valve; nose_angle: encoder angle [rad]
    of the lobe's nose under the follower (None: fitted); checking_height: valve lift
    [m] of the opening/closing events; max_speed_variation: largest accepted
    (max - min) / mean of the camshaft speed within a run; separation_sigmas and
    separation_min: the valve counts as separated where it is measured above the rigid
    lift by more than max(separation_sigmas * its standard error, separation_min) [m];
    step: width of the cam-angle bins [rad]; true_valve_train: the simulator's valve
    train mapping (None: the nominal one).
    """

    lobe: str
    nose_angle: float | None = None
    checking_height: float = 1.0e-3
    max_speed_variation: float = 0.05
    separation_sigmas: float = 5.0
    separation_min: float = 5.0e-6
    step: float = math.radians(0.5)
    true_valve_train: Mapping[str, Any] | None = None


def rig_block(scene_text: str) -> Mapping[str, Any] | None:
    """The raw ``rig`` mapping of a scene YAML text (None when absent)."""
    import yaml

    from cam_metrology.inputs.yaml_input import load_yaml

    doc = load_yaml(scene_text, 'scene', getattr(yaml, 'CSafeLoader', yaml.SafeLoader))
    if not isinstance(doc, Mapping):
        return None
    return doc.get('rig')


def parse_rig(block: Any, lobe_ids: tuple[str, ...], default_checking_mm: float = 1.0
              ) -> RigSpec:
    """Validate a ``rig`` mapping against the scene's lobe ids (InputError naming the
    ``rig.<key>``)."""
    if block is None:
        raise InputError('rig', None, 'a rig block in the scene: {lobe: ID, '
                         'nose_angle_deg: X} naming the lobe that drives the valve')
    if not isinstance(block, Mapping):
        raise InputError('rig', block, 'a mapping {lobe: ID, nose_angle_deg: X}')
    unknown = [k for k in block if k not in RIG_KEYS]
    if unknown:
        raise InputError(f'rig.{unknown[0]}', block[unknown[0]],
                         'one of the keys ' + ', '.join(RIG_KEYS))
    if 'lobe' not in block:
        raise InputError('rig.lobe', None, 'the id of the lobe that drives the valve (one '
                         'of ' + ', '.join(lobe_ids) + ')')
    lobe = str(block['lobe'])
    if lobe not in lobe_ids:
        raise InputError('rig.lobe', block['lobe'],
                         'a lobe id of the scene: ' + ', '.join(lobe_ids))
    nose = block.get('nose_angle_deg')
    nose_rad = None if nose is None else math.radians(
        require_finite('rig.nose_angle_deg', nose))
    check = require_positive('rig.checking_height_mm',
                             block.get('checking_height_mm', default_checking_mm)) * 1e-3
    var = require_positive('rig.max_speed_variation', block.get('max_speed_variation', 0.05))
    if var >= 1.0:
        raise InputError('rig.max_speed_variation', var, 'a fraction in (0, 1)')
    sig = require_positive('rig.separation_sigmas', block.get('separation_sigmas', 5.0))
    smin = require_positive('rig.separation_min_um', block.get('separation_min_um', 5.0),
                            allow_zero=True) * 1e-6
    step = require_positive('rig.step_deg', block.get('step_deg', 0.5))
    if not 0.05 <= step <= 5.0:
        raise InputError('rig.step_deg', step, 'a bin width in [0.05, 5] deg')
    tvt = block.get('true_valve_train')
    if tvt is not None and not isinstance(tvt, Mapping):
        raise InputError('rig.true_valve_train', tvt, 'a valve_train mapping')
    return RigSpec(lobe=lobe, nose_angle=nose_rad, checking_height=check,
                   max_speed_variation=var, separation_sigmas=sig, separation_min=smin,
                   step=math.radians(step), true_valve_train=tvt)


def rig_of_scene(scene: Any) -> RigSpec:
    """The RigSpec of a parsed scene (``scene.text`` holds the YAML); the default
    checking height is the rig lobe's ``tolerances.checking_height_mm``."""
    block = rig_block(scene.text)
    ids = tuple(lb.id for lb in scene.lobes)
    spec = parse_rig(block, ids)
    if isinstance(block, Mapping) and 'checking_height_mm' not in block:
        tol = getattr(scene.lobe(spec.lobe), 'tolerances', None)
        if tol is not None:
            from dataclasses import replace
            spec = replace(spec, checking_height=tol.checking_height_mm * 1e-3)
    return spec
