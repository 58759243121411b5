"""`cam-bench grind table FILE`: the wheel-centre table for the CNC grinder.

The distance of the wheel centre from the cam axis against its polar angle in the cam
frame, with the contact point, for one or several wheel radii (long format: one block
per radius); a wheel that bridges a hollow of the design is warned about.
"""
from __future__ import annotations

import argparse
from typing import Any

from cam_metrology.cli.grind.inputs import (add_file, add_lobe_base, add_outputs, load,
                                            step_of, warn_bridged, write_columns)


def register(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add ``table`` to the ``grind`` group."""
    p = sub.add_parser('table', help='wheel-centre distance and contact point vs angle',
                       description='Wheel-centre table: the distance of the wheel centre from '
                                   'the cam axis against its polar angle in the cam frame '
                                   '(angle_rad), with the contact point, for one or several '
                                   'wheel radii (long format: one block per radius).')
    add_file(p)
    add_outputs(p)
    add_lobe_base(p)
    p.add_argument('--wheel-radius', type=float, action='append', metavar='M',
                   help='wheel radius [m]; repeat for several (default: grinding.wheel_radius)')
    p.add_argument('--step-deg', type=float, metavar='DEG',
                   help='angle step [deg] over the full turn (default: grinding.step_deg, '
                        'else 0.5)')
    return p


def run(args: argparse.Namespace) -> int:
    """Handler of ``cam-bench grind table``: the wheel-centre table for one or
    several wheel radii (0; 2 for bad input)."""
    import numpy as np

    from cam_design.grinding import spec as gs
    from cam_design.grinding.wheel_path import wheel_table

    law, base, design, section = load(args)
    if args.wheel_radius:
        radii = gs.wheel_radii(args.wheel_radius, '--wheel-radius')
    elif 'wheel_radius' in section:
        radii = gs.wheel_radii(section['wheel_radius'])
    else:
        from cam_design.errors import InputError
        raise InputError('--wheel-radius', None, 'a wheel radius [m] (or grinding.wheel_'
                                                 'radius in the file)')
    step = step_of(args, section)
    paths: list[Any] = []
    cols = wheel_table(law, base, design, radii, step, key=args.file, paths=paths)
    summary: dict[str, Any] = {'design': design.kind, 'base_radius_m': base,
                               'wheel_radius_m': radii, 'step_rad': step}
    per = []
    for rw, path in zip(radii, paths):
        sel = cols['wheel_radius_m'] == rw
        d = cols['wheel_centre_distance_m'][sel]
        mu = cols['wheel_pressure_angle_rad'][sel]
        bridged = path.bridged
        per.append({'wheel_radius_m': rw, 'distance_min_m': float(np.min(d)),
                    'distance_max_m': float(np.max(d)),
                    'wheel_pressure_angle_max_deg': float(np.degrees(np.max(np.abs(mu)))),
                    'reproduces_design': not bridged, 'bridged_intervals_rad': bridged})
        warn_bridged(rw, bridged)
    summary['wheels'] = per
    if not write_columns(args, cols, summary):
        for w in per:
            print(f"wheel {w['wheel_radius_m'] * 1e3:.4f} mm: centre distance "
                  f"{w['distance_min_m'] * 1e3:.6f} .. {w['distance_max_m'] * 1e3:.6f} mm, "
                  f"max wheel pressure angle {w['wheel_pressure_angle_max_deg']:.4f} deg")
    return 0
