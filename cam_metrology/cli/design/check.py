"""`cam-bench design check FILE`: the design checks of Shang (1988) §2.1.

Flow area, time-area, fullness, rho1, Hertz stress, equivalent mass, separation, oil
film, valve-piston clearance of a lift law with its check inputs (docs/lift_laws.md), or
of a scene lobe with the scene's valve train.
"""
from __future__ import annotations

import argparse
from typing import Any

from cam_metrology.cli.law_input import law_spec, load_yaml


def register(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add ``check`` to the ``design`` group."""
    p = sub.add_parser('check', help='run the design checks of Shang (1988) §2.1',
                       description='Design checks (Shang §2.1): flow area, time-area, fullness, '
                                   'rho1, Hertz stress, equivalent mass, separation, oil film, '
                                   'valve-piston clearance. Input format: docs/lift_laws.md.')
    p.add_argument('file', metavar='FILE', help='YAML check input, or a scene file')
    p.add_argument('--json', metavar='FILE|-',
                   help='write the results as JSON (- for standard output)')
    p.add_argument('--lobe', metavar='ID', help='with a scene file: the lobe id (default '
                                                'the first lobe)')
    p.add_argument('--rpm', type=float, help='camshaft speed [rpm] (overrides the file)')
    return p


def run(args: argparse.Namespace) -> int:
    """Handler of ``cam-bench design check``: the §2.1 checks, printed or written as
    JSON (0; 2 for bad input)."""
    from cam_design.checks import run_checks
    from cam_design.errors import InputError
    from cam_design.lift_laws import from_spec

    doc = load_yaml(args.file)
    if not isinstance(doc, dict):
        raise InputError(args.file, type(doc).__name__, 'a mapping (see docs/lift_laws.md)')
    if isinstance(doc.get('lobes'), list):
        spec, key = law_spec(doc, args.file, args.lobe)
        cfg = check_config_from_scene(doc, key)
    else:
        if 'lift_law' not in doc:
            raise InputError('lift_law', None, 'a lift_law mapping')
        spec, key = doc['lift_law'], 'lift_law'
        cfg = {k: v for k, v in doc.items() if k != 'lift_law'}
    if args.rpm is not None:
        cfg['cam_speed_rpm'] = args.rpm
    law = from_spec(spec, key)
    try:
        res = run_checks(law, cfg)
    except InputError as exc:
        raise check_input_error(exc, args.rpm, scene=isinstance(doc.get('lobes'), list),
                                law_key=key) from None
    if args.json:
        from cam_metrology.report.json_out import write_json
        write_json(args.json, res, '--json')
    else:
        for k, v in res.items():
            print(f'{k:34s} {v:.6g}' if isinstance(v, float) else f'{k:34s} {v}')
    return 0


# run_checks keys (prefix 'check.' stripped) -> the scene key they come from
_SCENE_KEYS = {'base_radius': 'base_circle_radius', 'rocker_ratio': 'valve_train.rocker_ratio',
               'lash': 'valve_train.lash', 'spring.preload': 'valve_train.spring_preload',
               'spring.rate': 'valve_train.spring_rate', 'equivalent_mass': 'valve_train.mass',
               'stiffness': 'valve_train.stiffness',
               'cam_speed_rpm': 'valve_train.cam_speed_rpm'}


def check_input_error(exc: Any, rpm: float | None, *, scene: bool, law_key: str) -> Any:
    """The InputError of run_checks re-keyed to what the user wrote: ``--rpm`` for the
    speed given on the command line, the file's own keys (no internal ``check.``
    prefix; ``valve.seat_angle``), or the scene key a check input came from."""
    from cam_design.errors import InputError

    k = exc.key
    if rpm is not None and k.endswith('cam_speed_rpm'):
        return InputError('--rpm', rpm, exc.expected)
    k = k[len('check.'):] if k.startswith('check.') else k
    if k == 'seat_angle':
        k = 'valve.seat_angle'
    if scene:
        lobe = law_key.rsplit('.', 1)[0]
        k = {'follower.radius': f'{lobe}.follower_radius',
             'follower.kind': f'{lobe}.follower'}.get(k, _SCENE_KEYS.get(k, k))
    return InputError(k, exc.value, exc.expected)


def check_config_from_scene(scene: dict[str, Any], law_key: str) -> dict[str, Any]:
    """The check input of a scene lobe: base circle, its design follower, and the
    valve_train (valve-side mass and stiffness times k^2 give the tappet side; the
    highest of cam_speed_rpm is used)."""
    from cam_design.errors import InputError

    i = int(law_key.split('[')[1].split(']')[0])
    lobe = scene['lobes'][i]
    cfg: dict[str, Any] = {'base_radius': scene.get('base_circle_radius')}
    kind = lobe.get('follower', 'flat')
    cfg['follower'] = {'kind': kind}
    if kind == 'roller':
        cfg['follower']['radius'] = lobe.get('follower_radius')
    vt = scene.get('valve_train')
    if isinstance(vt, dict):
        k = vt.get('rocker_ratio', 1.0)
        cfg.update(rocker_ratio=k, lash=vt.get('lash', 0.0),
                   spring={'preload': vt.get('spring_preload'), 'rate': vt.get('spring_rate')})
        try:
            cfg['equivalent_mass'] = float(vt['mass']) * float(k) ** 2
            cfg['stiffness'] = float(vt['stiffness']) * float(k) ** 2
            rpm = vt.get('cam_speed_rpm', [])
            cfg['cam_speed_rpm'] = max(rpm) if isinstance(rpm, list) and rpm else rpm
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError('valve_train', vt, f'mass, stiffness, cam_speed_rpm ({exc})') \
                from None
    return cfg
