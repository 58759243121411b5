"""`cam-bench grind master FILE`: master-cam follower lift and master profile of a
rocking-cradle copy grinder (needs ``grinding.cradle`` and ``grinding.master_follower``).
"""
from __future__ import annotations

import argparse
import math
from typing import Any

from cam_metrology.cli.grind.inputs import (add_file, add_lobe_base, add_outputs,
                                            add_wheel_step, angle_grid, load, one_wheel,
                                            step_of, write_columns)


def register(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add ``master`` to the ``grind`` group."""
    p = sub.add_parser('master', help='master-cam follower lift and master profile (cradle)',
                       description='Rocking-cradle copy grinder: the master-follower lift '
                                   'against the spindle angle, exact and as the small-swing '
                                   'magnified copy with its error, and the master profile '
                                   '(envelope of the master follower) with its curvature and '
                                   'undercut check. Needs grinding.cradle and '
                                   'grinding.master_follower.')
    add_file(p)
    add_outputs(p)
    p.add_argument('--profile-csv', metavar='FILE|-',
                   help='write the master profile (x, y, pitch, rho, undercut) as CSV (- for '
                        'standard output)')
    add_lobe_base(p)
    add_wheel_step(p)
    return p


def run(args: argparse.Namespace) -> int:
    """Handler of ``cam-bench grind master``: the master-follower lift table and
    the master profile summary (0; 2 for bad input)."""
    import numpy as np

    from cam_design.grinding.master_cam import master_from_section
    from cam_design.grinding.wheel_path import WheelPath

    law, base, design, section = load(args)
    path = WheelPath(law, base, design, one_wheel(args, section), key=args.file)
    master = master_from_section(path, section)
    theta = angle_grid(step_of(args, section))
    n = theta.size
    cols = master.lift_table(theta)
    prof = master.profile(max(n, 360))
    psum: dict[str, Any] = prof.summary()
    summary: dict[str, Any] = {
        'design': design.kind, 'wheel_radius_m': path.wheel_radius,
        'master_follower': master.kind, 'master_follower_radius_m': master.radius,
        'magnification': master.magnification,
        'master_base_value_m': master.base_value,
        'master_lift_max_m': float(np.max(cols['master_lift_m'])),
        'approx_error_max_m': float(np.max(np.abs(cols['approx_error_m']))),
        'cradle_swing_deg': float(np.degrees(np.ptp(cols['cradle_angle_rad']))),
        'profile': psum}
    if args.profile_csv:
        pcols: dict[str, Any] = prof.columns()
        names = [k for k in pcols if k != 'face_offset_m' or master.kind == 'flat']
        from cam_metrology.inputs.files import write_output
        lines = [','.join(names)] + [','.join(f'{float(v):.15g}' for v in row)
                                     for row in zip(*(pcols[k] for k in names))]
        write_output(args.profile_csv, '\n'.join(lines) + '\n', '--profile-csv')
    if not write_columns(args, cols, summary) and not args.profile_csv:
        print(f"master {master.kind}: magnification {master.magnification:.9f}, max lift "
              f"{summary['master_lift_max_m'] * 1e3:.6f} mm, cradle swing "
              f"{summary['cradle_swing_deg']:.4f} deg; small-swing copy error up to "
              f"{summary['approx_error_max_m'] * 1e6:.3f} µm")
        spans = ', '.join(f'{math.degrees(a):.3f} .. {math.degrees(b):.3f} deg'
                          for a, b in psum['undercut_intervals_rad'])
        tail = f'; UNDERCUT at {spans}' if psum['undercut'] else '; no undercut'
        print(f"master profile: min radius of curvature {psum['rho_min_m'] * 1e3:.4f} mm"
              + tail)
    return 0
