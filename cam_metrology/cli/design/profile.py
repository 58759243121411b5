"""`cam-bench design profile FILE.yaml`: cam profile coordinates for a follower.

The YAML file holds a lift law: a ``lift_law:`` mapping (or the mapping itself, see
docs/lift_laws.md), or a table ``{alpha: [...], h: [...]}`` (also under ``lift:``), and
optionally ``base_radius`` [m] (the base circle of the profile); or it is a scene and
``--lobe ID`` picks a lobe (default: the first, as ``design law``/``design check``).
Output: per-sample profile and pitch coordinates, radius of curvature, pressure angle,
undercut flags and the lift used (CSV/JSON, SI units in the column names; an infinite
radius of a straight piece is ``inf`` in CSV, ``null`` in JSON), a summary with the
undercut report, and a plot. See docs/follower.md.
"""
from __future__ import annotations

import argparse
import contextlib
import math
from typing import Any, Iterator

from cam_metrology.cli.law_input import base_radius_of, load_law, load_yaml, scene_lobe
from cam_metrology.cli.table_out import write_table

FOLLOWERS = ('flat', 'roller', 'knife', 'offset-roller', 'rocker')
#: the lift used for the profile (converted with --design-follower) and its derivatives
LIFT_COLUMNS = ('lift_m', 'velocity_m_per_rad', 'acceleration_m_per_rad2', 'jerk_m_per_rad3')
#: allowed --step-deg [deg]. Narrower than ``design law`` ([1e-4, 90]), which only
#: tabulates the lift: a profile needs at least 36 points per turn for its curvature and
#: undercut report, and its per-point envelope work makes 1e-4 deg (3.6 million points)
#: a memory problem rather than a result
STEP_DEG = (1e-3, 10.0)


def register(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add ``profile`` to the ``design`` group."""
    p = sub.add_parser(
        'profile', help='cam profile coordinates, curvature, pressure angle, undercut',
        description='Cam profile for a follower (docs/follower.md): flat tappet (Shang eq. 2.15), '
                    'in-line roller or knife (2.16), offset translating roller and oscillating '
                    'roller (thesis reverse-method forms). Lengths in m, angles in rad in the '
                    'files; the summary adds _deg fields.')
    p.add_argument('file', metavar='FILE',
                   help='YAML with a lift law (lift_law: {family: ...} or alpha/h table), or '
                        'a scene with --lobe')
    p.add_argument('--csv', metavar='FILE|-',
                   help='write the per-sample table as CSV (- for standard output)')
    p.add_argument('--json', metavar='FILE|-',
                   help='write summary and table as JSON (- for standard output)')
    p.add_argument('--plot', metavar='PNG', help='plot profile, curvature and pressure angle')
    p.add_argument('--lobe', metavar='ID',
                   help='FILE is a scene: use this lobe (its lift, design follower and the '
                        'scene base_circle_radius; default: the first lobe)')
    p.add_argument('--follower', choices=FOLLOWERS, default='flat',
                   help='follower the profile is cut for (default flat)')
    p.add_argument('--radius', type=float, default=0.0, metavar='M',
                   help='roller radius [m] (default 0: knife)')
    p.add_argument('--base-radius', type=float,
                   help='base-circle radius of the profile [m] (else base_radius in the file)')
    p.add_argument('--offset', type=float, default=0.0, metavar='M',
                   help='offset e of the guide line [m] (default 0)')
    p.add_argument('--eta', type=int, default=1, choices=(1, -1),
                   help='+1 clockwise cam, -1 counter-clockwise (offset-roller, rocker; '
                        'default +1)')
    p.add_argument('--delta', type=int, default=1, choices=(1, -1, 0),
                   help='offset side (offset-roller) or swing direction in the rise (rocker; '
                        'default +1)')
    p.add_argument('--centre-distance', type=float, help='rocker: cam centre to pivot a [m]')
    p.add_argument('--arm-length', type=float,
                   help='rocker: arm length l [m]; the swing is psi = h / l')
    p.add_argument('--polar', action='store_true',
                   help='rocker: add the CG paper polar form (rho, theta; counter-directional '
                        'for --delta -1, co-directional for --delta 1; needs --eta 1)')
    p.add_argument('--design-follower', choices=('flat', 'roller', 'knife'),
                   help='the follower the lift law was written for, if not --follower: the '
                        'lift is converted through the cam profile first (flat/roller/knife)')
    p.add_argument('--design-radius', type=float, default=0.0,
                   help='roller radius of --design-follower [m] (default 0)')
    p.add_argument('--step-deg', type=float, default=0.5,
                   help=f'angle step [deg] over the full turn, {STEP_DEG[0]:g} to '
                        f'{STEP_DEG[1]:g} (default 0.5)')
    return p


def _follower_radius(args: argparse.Namespace) -> float:
    from cam_design.errors import InputError, require_length
    from cam_design.lift_laws.params import MAX_RADIUS_M

    r = require_length('--radius', args.radius, MAX_RADIUS_M, allow_zero=True, what='a radius')
    if args.follower == 'knife' and r != 0:
        raise InputError('--radius', r, '0 for a knife follower (or --follower roller)')
    if args.follower == 'roller' and r == 0:
        raise InputError('--radius', r, 'a roller radius > 0 (or --follower knife)')
    return r


def _design_law(args: argparse.Namespace, law: Any, base: float, radius: float) -> Any:
    """Convert the file's lift to the profile's follower when --design-follower differs."""
    from cam_design.errors import InputError, require_length
    from cam_design.follower import Follower, convert_lift
    from cam_design.lift_laws.params import MAX_RADIUS_M

    if args.design_follower is None:
        return law
    dr = require_length('--design-radius', args.design_radius, MAX_RADIUS_M, allow_zero=True,
                        what='a radius')
    if (args.design_follower == 'roller') != (dr > 0):
        raise InputError('--design-radius', dr, 'a radius > 0 for --design-follower roller '
                         'and none (0) for flat or knife')
    if args.design_follower == args.follower and (args.follower == 'flat' or dr == radius):
        return law
    if args.follower not in ('flat', 'roller', 'knife'):
        raise InputError('--design-follower', args.design_follower,
                         'no conversion for offset-roller/rocker (give their own lift)')
    source = Follower(args.design_follower, dr)
    target = Follower(args.follower, radius if args.follower == 'roller' else 0.0)
    return convert_lift(law, base, source, target, key=args.file)


def compute(args: argparse.Namespace) -> tuple[Any, Any, float]:
    """(Profile, the lift law used, base radius [m]) for the parsed arguments."""
    import numpy as np

    from cam_design import cam_profile as fl
    from cam_design.errors import InputError

    doc = load_yaml(args.file)
    radius = _follower_radius(args) if args.follower != 'flat' else 0.0
    if isinstance(doc, dict) and 'lobes' in doc:
        law, design, base = scene_lobe(args)
        if args.base_radius is not None:
            raise InputError('--base-radius', args.base_radius,
                             'no value with a scene (its base_circle_radius is used)')
        if args.design_follower is None:
            args.design_follower, args.design_radius = design.kind, design.radius
    else:
        if args.lobe is not None:
            raise InputError('--lobe', args.lobe, 'a scene file (with lobes:)')
        base = base_radius_of(args, doc)   # the options before the (costlier) table
        law = load_law(doc, args.file)
    step = args.step_deg
    if not (math.isfinite(step) and STEP_DEG[0] <= step <= STEP_DEG[1]):
        raise InputError('--step-deg', step, f'a step in [{STEP_DEG[0]:g}, {STEP_DEG[1]:g}] '
                         'deg (a profile needs >= 36 points per turn)')
    n = int(round(360.0 / step))
    alpha = -math.pi + 2.0 * math.pi * np.arange(n) / n
    law = _design_law(args, law, base, radius)
    if args.follower == 'flat':
        return fl.flat_profile(law, base, alpha), law, base
    if args.follower in ('roller', 'knife'):
        return fl.roller_profile(law, base, radius, alpha), law, base
    if args.follower == 'offset-roller':
        with _option_keys():
            return fl.offset_roller_profile(law, base, radius, args.offset, alpha,
                                            eta=args.eta, delta=args.delta), law, base
    for name in ('centre_distance', 'arm_length'):
        if getattr(args, name) is None:
            raise InputError('--' + name.replace('_', '-'), None, 'a length [m] for a rocker')
    if args.delta == 0:
        raise InputError('--delta', 0, '+1 or -1 (the swing direction during the rise)')
    with _option_keys():
        return fl.rocker_profile(law, base, radius, args.centre_distance, args.arm_length,
                                 alpha, eta=args.eta, delta=args.delta), law, base


# the follower functions' parameter names -> the options as typed
OPTION_KEYS = {'offset': '--offset', 'centre_distance': '--centre-distance',
               'arm_length': '--arm-length', 'eta': '--eta', 'delta': '--delta'}


@contextlib.contextmanager
def _option_keys() -> Iterator[None]:
    """Re-raise an InputError of a follower function under the CLI option's name
    (``offset`` -> ``--offset``, ``centre_distance`` -> ``--centre-distance``, ...)."""
    from cam_design.errors import InputError

    try:
        yield
    except InputError as exc:
        flag = OPTION_KEYS.get(exc.key)
        if flag is None:
            raise
        raise InputError(flag, exc.value, exc.expected) from None


def run(args: argparse.Namespace) -> int:
    """Handler of ``cam-bench design profile``: compute the profile and write the
    requested outputs (text summary by default; 0, or 2 for bad input)."""
    import numpy as np

    prof, law, base = compute(args)
    summary = prof.summary()
    if args.lobe is not None:
        summary['lobe'] = args.lobe
    summary['rho_min_alpha_deg'] = math.degrees(summary['rho_min_alpha_rad'])
    summary['undercut_intervals_deg'] = [[math.degrees(a), math.degrees(b)]
                                         for a, b in summary['undercut_intervals_rad']]
    cols = prof.columns()
    cols.update(zip(LIFT_COLUMNS, law.derivatives(prof.alpha)))
    if args.polar:
        cols.update(_polar_columns(args, prof, law, base))
    names = list(cols)
    table = np.column_stack([cols[k] for k in names])
    # CSV: an infinite radius of a straight piece is inf; JSON: null
    wrote = write_table(args.csv, args.json, names, table, summary)
    if args.plot:
        _plot(args.plot, prof)
    if not wrote:
        lobe = f"{args.lobe} " if args.lobe is not None else ''
        print(f"{lobe}{prof.kind}: {summary['points']} points, min radius of curvature "
              f"{summary['rho_min_m'] * 1e3:.6f} mm at {summary['rho_min_alpha_deg']:.3f} deg, "
              f"max pressure angle {summary['pressure_angle_max_deg']:.4f} deg, "
              f"max face offset {summary['face_offset_max_m'] * 1e3:.6f} mm")
        if summary['undercut']:
            spans = ', '.join(f'{a:.3f} .. {b:.3f} deg'
                              for a, b in summary['undercut_intervals_deg'])
            print(f'UNDERCUT (envelope cusp / rho <= 0): {spans}')
        else:
            print('no undercut')
    return 0


def _polar_columns(args: argparse.Namespace, prof: Any, law: Any, base: float
                   ) -> dict[str, Any]:
    """S1 polar form of the rocker pitch curve (docs/follower.md) for the same samples."""
    from cam_design.errors import InputError
    from cam_design.cam_profile import rocker_polar

    if args.follower != 'rocker' or args.eta != 1:
        raise InputError('--polar', True, 'a rocker follower with --eta 1 (S1 polar form)')
    rho, theta = rocker_polar(law, base, args.radius, args.centre_distance, args.arm_length,
                              prof.alpha, co_directional=args.delta == 1)
    return {'polar_rho_m': rho, 'polar_theta_rad': theta}


def _plot(path: str, prof: Any) -> None:
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    import numpy as np

    fig = plt.figure(figsize=(10, 5))
    ax = fig.add_subplot(1, 2, 1)
    ax.plot(prof.x * 1e3, prof.y * 1e3, lw=1.2, label='profile')
    if prof.kind != 'flat':
        ax.plot(prof.pitch_x * 1e3, prof.pitch_y * 1e3, '--', lw=0.8, label='pitch curve')
    if np.any(prof.undercut):
        ax.plot(prof.x[prof.undercut] * 1e3, prof.y[prof.undercut] * 1e3, 'r.', ms=2,
                label='undercut')
    ax.set_aspect('equal')
    ax.set_xlabel('x [mm]')
    ax.set_ylabel('y [mm]')
    ax.legend(fontsize=8)
    ax.set_title(prof.kind)
    deg = np.degrees(prof.alpha)
    ax2 = fig.add_subplot(2, 2, 2)
    ax2.plot(deg, np.clip(prof.rho * 1e3, -200, 200), lw=1)
    ax2.set_ylabel('rho [mm] (clipped)')
    ax2.grid(True, alpha=0.3)
    ax3 = fig.add_subplot(2, 2, 4, sharex=ax2)
    ax3.plot(deg, np.degrees(prof.pressure_angle), lw=1)
    ax3.set_ylabel('pressure angle [deg]')
    ax3.set_xlabel('alpha [deg]')
    ax3.grid(True, alpha=0.3)
    fig.tight_layout()
    from cam_metrology.inputs.files import save_figure
    try:
        save_figure(fig, path, '--plot', dpi=110)
    finally:
        plt.close(fig)
