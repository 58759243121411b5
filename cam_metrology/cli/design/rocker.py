"""`cam-bench design rocker`: CG rocker optimum dimension synthesis (Song et al.).

The optimum frame length L of a rocker follower cam (docs/lift_laws.md, erratum 1
applied); lengths in m, the swing in degrees.
"""
from __future__ import annotations

import argparse
import math


def register(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add ``rocker`` to the ``design`` group."""
    p = sub.add_parser('rocker', help='CG rocker optimum dimension synthesis (Song et al.)',
                       description='Optimum frame length L of a rocker follower cam (S1, '
                                   'docs/lift_laws.md, erratum 1 applied). Lengths in m.')
    p.add_argument('--json', metavar='FILE|-',
                   help='write the results as JSON (- for standard output)')
    p.add_argument('--arm-length', type=float, required=True, help='rocker length l [m]')
    p.add_argument('--base-radius', type=float, required=True, help='base radius R_b [m]')
    p.add_argument('--max-swing-deg', type=float, required=True, help='max swing [deg]')
    p.add_argument('--eccentricity', type=float, help='eccentric adjustment e [m]')
    return p


def run(args: argparse.Namespace) -> int:
    """Handler of ``cam-bench design rocker``: the optimum frame length, printed or
    written as JSON (0; 2 for bad input)."""
    from cam_design.errors import InputError, require_length, require_positive
    from cam_design.lift_laws.params import MAX_RADIUS_M
    from cam_design.rocker import sampled_deviation, synthesize

    psi = math.radians(require_positive('--max-swing-deg', args.max_swing_deg))
    arm = require_length('--arm-length', args.arm_length, MAX_RADIUS_M)
    base = require_length('--base-radius', args.base_radius, MAX_RADIUS_M, what='a radius')
    ecc = (None if args.eccentricity is None
           else require_positive('--eccentricity', args.eccentricity, allow_zero=True))
    try:
        r = synthesize(arm, base, psi, ecc)
    except InputError as exc:     # name the option the user typed, in its unit
        flag = {'arm_length': '--arm-length', 'base_radius': '--base-radius',
                'eccentricity': '--eccentricity'}.get(exc.key)
        if exc.key == 'max_swing':
            raise InputError('--max-swing-deg', args.max_swing_deg,
                             exc.expected.replace(' (in rad)', '')) from None
        if flag:
            raise InputError(flag, exc.value, exc.expected) from None
        raise
    lo, hi = sampled_deviation(r, 20001)
    out = {'eta_deg': math.degrees(r.eta), 'delta_deg': math.degrees(r.delta),
           'frame_length_m': r.frame_length,
           'cam_centre_m': [r.geometry.x_o1, r.geometry.y_o1],
           'sampled_delta_deg': [math.degrees(lo), math.degrees(hi)]}
    if r.projected_frame_length is not None:
        out['eccentricity_m'] = r.eccentricity
        out['projected_frame_length_m'] = r.projected_frame_length
    if args.json:
        from cam_metrology.report.json_out import write_json
        write_json(args.json, out, '--json')
    else:
        for k, v in out.items():
            print(f'{k:26s} {v}')
    return 0
