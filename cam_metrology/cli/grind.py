"""`cam-bench grind ...`: the cam-grinding computations of cam_design.grinding.

FILE holds a lift law (as ``design profile``: ``lift_law:`` or an ``alpha``/``h``
table, ``base_radius``) and a ``grinding:`` section (docs/grinding.md), or it is a scene
(``--lobe`` picks the lobe; the ``grinding:`` section then comes from ``--machine``).
Subcommands: ``table`` (wheel-centre table for the CNC grinder), ``master`` (master-cam
follower lift and master profile on a rocking cradle), ``errors`` (machining-error
sensitivities), ``correct`` (fit a measured lift error, write a corrected table).
"""
from __future__ import annotations

import argparse
import math
from typing import Any


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``grind`` group."""
    parser = sub.add_parser(
        'grind', help='cam grinding: wheel-centre table, master cam, machining errors',
        description='Cam grinding (docs/grinding.md): the wheel-centre path of a grinding '
                    'wheel on the cam, the master-cam follower lift of a rocking-cradle '
                    'grinder, machining-error sensitivities and a measure -> correct loop. '
                    'Lengths in m, angles in rad in the files.')
    gsub = parser.add_subparsers(dest='grind_command', metavar='WHAT')
    p = gsub.add_parser('table', help='wheel-centre distance and contact point vs angle',
                        description='Wheel-centre table: the distance of the wheel centre from '
                                    'the cam axis against its polar angle in the cam frame '
                                    '(angle_rad), with the contact point, for one or several '
                                    'wheel radii (long format: one block per radius).')
    _common(p)
    p.add_argument('--wheel-radius', type=float, action='append', metavar='M',
                   help='wheel radius [m]; repeat for several (default: grinding.wheel_radius)')
    p.add_argument('--step-deg', type=float,
                   help='angle step [deg] over the full turn (default grinding.step_deg or 0.5)')
    p.set_defaults(func=cmd_table)
    p = gsub.add_parser('master', help='master-cam follower lift and master profile (cradle)',
                        description='Rocking-cradle copy grinder: the master-follower lift '
                                    'against the spindle angle, exact and as the small-swing '
                                    'magnified copy with its error, and the master profile '
                                    '(envelope of the master follower) with its curvature and '
                                    'undercut check. Needs grinding.cradle and '
                                    'grinding.master_follower.')
    _common(p)
    p.add_argument('--wheel-radius', type=float, metavar='M',
                   help='wheel radius [m] (default: the first grinding.wheel_radius)')
    p.add_argument('--step-deg', type=float,
                   help='spindle-angle step [deg] (default grinding.step_deg or 0.5)')
    p.add_argument('--profile-csv', metavar='FILE|-',
                   help='write the master profile (x, y, pitch, rho, undercut) as CSV')
    p.set_defaults(func=cmd_master)
    p = gsub.add_parser('errors', help='machining-error sensitivities of the lift vs angle',
                        description='Lift error of the design follower (or --probe) per unit '
                                    'of each machining error (wheel radius, centre distance, '
                                    'index, run-out x/y, master-roller radius with a cradle) '
                                    'against the design angle; with grinding.errors also the '
                                    'predicted (linear) and the exactly simulated lift error.')
    _common(p)
    _wheel_step(p)
    _probe(p)
    p.set_defaults(func=cmd_errors)
    p = gsub.add_parser('correct', help='fit a measured lift error, write a corrected table',
                        description='Measure -> correct: least-squares fit of the machining '
                                    'errors to a measured lift error, then the wheel-centre '
                                    'table that pre-compensates them. Exit 1 and no table '
                                    'when the fit is ill-conditioned; exit 1 with the table '
                                    'when the sources explain < 80 % of the error.')
    _common(p)
    _wheel_step(p)
    _probe(p)
    p.add_argument('--measured', required=True, metavar='CSV|BAG',
                   help='CSV with alpha_rad and lift_error_m, or alpha_rad, lift_m and '
                        'design_lift_m (the columns of /metrology/lift); or a measurement '
                        'bag: the lobe (--lobe, or the only/first lobe) is analysed as '
                        '`analyze` does and its base-circle-referenced lift error is used '
                        '(alpha from the fitted nose: an index error shows in the report\'s '
                        'phase, not in this lift error)')
    p.add_argument('--sources', default='wheel_radius,index,run_out_x,run_out_y',
                   help='comma-separated error sources to fit (default: wheel_radius,index,'
                        'run_out_x,run_out_y)')
    p.add_argument('--exact-iterations', type=int, default=3, metavar='N',
                   help='Gauss-Newton steps on the exact grinding simulation after the linear '
                        'fit (default 3; 0: linear fit only)')
    p.set_defaults(func=cmd_correct)
    parser.set_defaults(func=lambda args: parser.print_help() or 2)


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument('file', help='YAML: lift law + base_radius + grinding: section, or a scene')
    p.add_argument('--lobe', metavar='ID', help='FILE is a scene: use this lobe')
    p.add_argument('--machine', metavar='YAML',
                   help='a file whose grinding: section replaces the one of FILE')
    p.add_argument('--base-radius', type=float, help='base-circle radius [m] (else '
                                                     'base_radius in the file)')
    p.add_argument('--csv', metavar='FILE|-', help='write the table as CSV')
    p.add_argument('--json', metavar='FILE|-', help='write summary and table as JSON')


def load(args: argparse.Namespace) -> tuple[Any, float, Any, dict[str, Any]]:
    """(lift law, base radius [m], Design, grinding section) of the arguments."""
    from cam_design.errors import InputError
    from cam_design.grinding import spec as gs
    from cam_design.grinding.wheel_path import Design
    from cam_metrology.cli.design_law import load_yaml
    from cam_metrology.cli.design_profile import base_radius_of, load_law, scene_lobe

    doc = load_yaml(args.file)
    if args.machine:
        machine = load_yaml(args.machine)
        if not isinstance(machine, dict) or 'grinding' not in machine:
            raise InputError('--machine', args.machine, 'a YAML file with a grinding: section')
        section = dict(gs.section(machine))
    else:
        section = dict(gs.section(doc))
    if isinstance(doc, dict) and 'lobes' in doc:
        law, follower, base = scene_lobe(args)
        if args.base_radius is not None:
            raise InputError('--base-radius', args.base_radius,
                             'no value with a scene (its base_circle_radius is used)')
        if 'design' in section:
            raise InputError('grinding.design', section['design'],
                             'no design with a scene (the lobe\'s follower is used)')
        design = Design(follower.kind, follower.radius if follower.kind == 'roller' else 0.0)
    else:
        if args.lobe is not None:
            raise InputError('--lobe', args.lobe, 'a scene file (with lobes:)')
        law = load_law(doc, args.file)
        base = base_radius_of(args, doc)
        design = gs.design(section.get('design', 'flat'))
    return law, base, design, section


def _write(args: argparse.Namespace, columns: dict[str, Any], summary: dict[str, Any]
           ) -> bool:
    """CSV (15 significant digits) and/or JSON of ``columns`` with ``summary``."""
    import numpy as np

    from cam_metrology.cli.design_law import write_text

    names = list(columns)
    table = np.column_stack([np.asarray(columns[k], dtype=float) for k in names])
    wrote = False
    if args.csv:
        lines = [','.join(names)] + [','.join(f'{v:.15g}' for v in row) for row in table]
        write_text(args.csv, '\n'.join(lines) + '\n', '--csv')
        wrote = True
    if args.json:
        from cam_metrology.report.json_out import write_json
        write_json(args.json, dict(summary, columns=names, rows=table), '--json')
        wrote = True
    return wrote


def cmd_table(args: argparse.Namespace) -> int:
    """Wheel-centre table for one or several wheel radii."""
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
    if args.step_deg is not None:
        step = gs.step_rad(args.step_deg, '--step-deg')
    else:
        step = gs.step_rad(section.get('step_deg', 0.5))
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
        _warn_bridged(rw, bridged)
    summary['wheels'] = per
    if not _write(args, cols, summary):
        for w in per:
            print(f"wheel {w['wheel_radius_m'] * 1e3:.4f} mm: centre distance "
                  f"{w['distance_min_m'] * 1e3:.6f} .. {w['distance_max_m'] * 1e3:.6f} mm, "
                  f"max wheel pressure angle {w['wheel_pressure_angle_max_deg']:.4f} deg")
    return 0


def _wheel_step(p: argparse.ArgumentParser) -> None:
    p.add_argument('--wheel-radius', type=float, metavar='M',
                   help='wheel radius [m] (default: the first grinding.wheel_radius)')
    p.add_argument('--step-deg', type=float,
                   help='angle step [deg] (default grinding.step_deg or 0.5)')


def _probe(p: argparse.ArgumentParser) -> None:
    p.add_argument('--probe', choices=('flat', 'roller', 'knife'),
                   help='the follower whose lift is measured (default: the design follower)')
    p.add_argument('--probe-radius', type=float, default=0.0, help='probe roller radius [m]')


def _probe_follower(args: argparse.Namespace) -> Any:
    from cam_design.errors import InputError, require_positive
    from cam_design.follower import Follower

    if args.probe is None:
        return None
    r = require_positive('--probe-radius', args.probe_radius, allow_zero=True)
    if (args.probe == 'roller') != (r > 0):
        raise InputError('--probe-radius', r, 'a radius > 0 for --probe roller, 0 otherwise')
    return Follower(args.probe, r)


def _machine(path: Any, section: dict[str, Any]) -> tuple[Any, Any]:
    """(cradle or None, master or None) of the grinding section."""
    from cam_design.grinding.master_cam import master_from_section

    if 'cradle' not in section:
        return None, None
    master = master_from_section(path, section)
    return master.cradle, master


def _grid(step: float) -> Any:
    import numpy as np

    n = int(round(2 * math.pi / step))
    return -math.pi + 2 * math.pi * np.arange(n) / n


def _warn_bridged(rw: float, bridged: list[tuple[float, float]]) -> None:
    """One stderr line when the wheel cannot enter a hollow of the design."""
    import sys

    if bridged:
        spans = ', '.join(f'{math.degrees(a):.3f} .. {math.degrees(b):.3f} deg'
                          for a, b in bridged)
        print(f'WARNING: wheel {rw * 1e3:.4f} mm bridges concave flanks of radius below its '
              f'own at {spans}: the ground cam is not the design there', file=sys.stderr)


def _one_wheel(args: argparse.Namespace, section: dict[str, Any]) -> float:
    from cam_design.errors import InputError
    from cam_design.grinding import spec as gs

    if args.wheel_radius is not None:
        return gs.wheel_radii(args.wheel_radius, '--wheel-radius')[0]
    if 'wheel_radius' not in section:
        raise InputError('--wheel-radius', None, 'a wheel radius [m] (or grinding.wheel_'
                                                 'radius in the file)')
    return gs.wheel_radii(section['wheel_radius'])[0]


def _step(args: argparse.Namespace, section: dict[str, Any]) -> float:
    from cam_design.grinding import spec as gs

    if args.step_deg is not None:
        return gs.step_rad(args.step_deg, '--step-deg')
    return gs.step_rad(section.get('step_deg', 0.5))


def cmd_master(args: argparse.Namespace) -> int:
    """Master-follower lift table and master profile summary."""
    import numpy as np

    from cam_design.grinding.master_cam import master_from_section
    from cam_design.grinding.wheel_path import WheelPath

    law, base, design, section = load(args)
    path = WheelPath(law, base, design, _one_wheel(args, section), key=args.file)
    master = master_from_section(path, section)
    step = _step(args, section)
    n = int(round(2 * math.pi / step))
    theta = -math.pi + 2 * math.pi * np.arange(n) / n
    cols = master.lift_table(theta)
    prof = master.profile(max(n, 360))
    psum = prof.summary()
    summary = {'design': design.kind, 'wheel_radius_m': path.wheel_radius,
               'master_follower': master.kind, 'master_follower_radius_m': master.radius,
               'magnification': master.magnification,
               'master_base_value_m': master.base_value,
               'master_lift_max_m': float(np.max(cols['master_lift_m'])),
               'approx_error_max_m': float(np.max(np.abs(cols['approx_error_m']))),
               'cradle_swing_deg': float(np.degrees(np.ptp(cols['cradle_angle_rad']))),
               'profile': psum}
    if args.profile_csv:
        pcols = prof.columns()
        names = [k for k in pcols if k != 'face_offset_m' or master.kind == 'flat']
        from cam_metrology.cli.design_law import write_text
        lines = [','.join(names)] + [','.join(f'{float(v):.15g}' for v in row)
                                     for row in zip(*(pcols[k] for k in names))]
        write_text(args.profile_csv, '\n'.join(lines) + '\n', '--profile-csv')
    if not _write(args, cols, summary) and not args.profile_csv:
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


def cmd_errors(args: argparse.Namespace) -> int:
    """Sensitivity table (and predicted / simulated error with grinding.errors)."""
    import numpy as np

    from cam_design.follower import convert_lift
    from cam_design.grinding import spec as gs
    from cam_design.grinding.machining_error import (UNITS, GroundCam, MachineErrors,
                                                     sensitivities)
    from cam_design.grinding.wheel_path import WheelPath

    law, base, design, section = load(args)
    path = WheelPath(law, base, design, _one_wheel(args, section), key=args.file)
    _warn_bridged(path.wheel_radius, path.bridged)
    probe = _probe_follower(args)
    cradle, master = _machine(path, section)
    alpha = _grid(_step(args, section))
    sens = sensitivities(path, alpha, cradle=cradle, master=master, probe=probe)
    ref = path.design_law if probe is None else convert_lift(
        path.design_law, base, path.design_follower, probe, key='--probe')
    cols: dict[str, Any] = {'alpha_rad': alpha, 'lift_m': ref(alpha)}
    unit = {'m': 'm_per_m', 'rad': 'm_per_rad'}
    for name, value in sens.items():
        cols[f'{name}_{unit[UNITS[name]]}'] = value
    summary: dict[str, Any] = {
        'design': design.kind, 'wheel_radius_m': path.wheel_radius,
        'probe': None if probe is None else {'kind': probe.kind, 'radius_m': probe.radius},
        'machine': 'cradle' if cradle is not None else 'cnc',
        'reproduces_design': not path.bridged,
        'max_abs_sensitivity': {n: float(np.max(np.abs(v))) for n, v in sens.items()}}
    if 'errors' in section:
        spec = gs._mapping(section['errors'], 'grinding.errors', gs.ERROR_KEYS)
        errors = MachineErrors(**gs.floats(spec, 'grinding.errors', gs.ERROR_KEYS))
        pred = sum(getattr(errors, n) * v for n, v in sens.items())
        sim = GroundCam(path, errors, cradle=cradle, probe=probe).lift(alpha)[0] - ref(alpha)
        if errors.master_follower_radius:
            summary['note'] = ('master_follower_radius enters the prediction only; the exact '
                               'simulation leaves it out')
        cols['predicted_error_m'] = pred
        cols['simulated_error_m'] = sim
        summary.update(errors={n: getattr(errors, n) for n in gs.ERROR_KEYS},
                       predicted_error_max_m=float(np.max(np.abs(pred))),
                       simulated_error_max_m=float(np.max(np.abs(sim))),
                       linearisation_error_max_m=float(np.max(np.abs(pred - sim))))
    if not _write(args, cols, summary):
        for n, v in summary['max_abs_sensitivity'].items():
            print(f'{n}: max |d lift / d {n}| = {v:.6g} {unit[UNITS[n]].replace("_", " ")}')
        if 'errors' in summary:
            print(f"lift error: predicted max {summary['predicted_error_max_m'] * 1e6:.4f} µm, "
                  f"simulated max {summary['simulated_error_max_m'] * 1e6:.4f} µm")
    return 0


def _measured_bag(bag: str, lobe: str | None, key: str = '--measured') -> tuple[Any, Any]:
    """(alpha [rad] from the fitted nose, lift error [m] referenced to the base circle)
    of one lobe of a measurement bag, through the offline metrology (as ``analyze``)."""
    from cam_design.errors import InputError
    from cam_metrology.metrology.lift_error import feature_referenced
    from cam_metrology.offline.analyze import make_cores, replay

    cores, _ = make_cores({}, True)
    replay(bag, cores)
    results = {f: r for f, r in cores[0].results.items() if r.kind == 'lobe'}
    if not results:
        raise InputError(key, bag, 'a bag with at least one measured lobe')
    fid = lobe if lobe is not None else next(iter(results))
    if fid not in results:
        raise InputError('--lobe', fid, 'one of the measured lobes: ' + ', '.join(results))
    res = results[fid]
    if res.table is None or res.failed is not None:
        raise InputError(key, bag, f'a bag where lobe {fid} was measured '
                         f'({res.failed or "no lift table"})')
    table, good = feature_referenced(res.table, res.values)
    return table[good, 0], table[good, 1] - table[good, 2]


def _measured(path_text: str, key: str = '--measured',
              lobe: str | None = None) -> tuple[Any, Any]:
    """(alpha [rad], lift error [m]) from a CSV with a header row, or from a bag."""
    import numpy as np

    from cam_design.errors import InputError
    from cam_metrology.bagio import looks_like_bag
    from cam_metrology.inputs.files import read_text_file

    if looks_like_bag(path_text):
        return _measured_bag(path_text, lobe, key)

    numbered = [(n, ln) for n, ln in enumerate(
        read_text_file(path_text, 'CSV file', key=key).splitlines(), start=1) if ln.strip()]
    lines = [ln for _, ln in numbered]
    if len(lines) < 2:
        raise InputError(key, path_text, 'a CSV with a header row and data rows')
    head = [h.strip() for h in lines[0].split(',')]
    values = []
    for number, ln in numbered[1:]:
        try:
            values.append([float(v) for v in ln.split(',')])
        except ValueError:
            raise InputError(f'{key} {path_text}:{number}', ln.strip(),
                             f'numbers separated by commas ({",".join(head)})') from None
    rows = np.array(values)
    if rows.ndim != 2 or rows.shape[1] != len(head):
        raise InputError(key, path_text, f'{len(head)} values in every row')
    col = {h: rows[:, i] for i, h in enumerate(head)}
    if 'alpha_rad' not in col:
        raise InputError(key, ','.join(head), 'an alpha_rad column')
    if 'lift_error_m' in col:
        return col['alpha_rad'], col['lift_error_m']
    if 'lift_m' in col and 'design_lift_m' in col:
        return col['alpha_rad'], col['lift_m'] - col['design_lift_m']
    raise InputError(key, ','.join(head), 'lift_error_m, or lift_m and design_lift_m')


def _iterations(value: int) -> int:
    from cam_design.errors import InputError

    if not 0 <= value <= 20:
        raise InputError('--exact-iterations', value, 'an integer in [0, 20]')
    return value


def cmd_correct(args: argparse.Namespace) -> int:
    """Fit the machining errors to a measured lift error; corrected wheel-centre table."""
    import sys

    from cam_design.grinding.correction import corrected_curve, curve_table, fit_errors
    from cam_design.grinding.wheel_path import WheelPath

    law, base, design, section = load(args)
    path = WheelPath(law, base, design, _one_wheel(args, section), key=args.file)
    _warn_bridged(path.wheel_radius, path.bridged)
    cradle, master = _machine(path, section)
    alpha, error = _measured(args.measured, lobe=args.lobe)
    sources = tuple(s.strip() for s in args.sources.split(',') if s.strip())
    fit = fit_errors(path, alpha, error, sources=sources, cradle=cradle, master=master,
                     probe=_probe_follower(args), key=args.measured,
                     exact_iterations=_iterations(args.exact_iterations))
    summary: dict[str, Any] = {'fit': fit.summary(), 'wheel_radius_m': path.wheel_radius}
    if 'master_follower_radius' in fit.values:
        fit.warnings.append(f"master_follower_radius ({fit.values['master_follower_radius']:.4g}"
                            ' m) is not compensated in the table: check or replace the master '
                            'roller')
    for w in fit.warnings:
        print(f'WARNING: {w}', file=sys.stderr)
    cols: dict[str, Any] = {}
    if fit.settled:
        curve, radius = corrected_curve(path, fit, cradle=cradle)
        table = curve_table(curve, base + radius, _grid(_step(args, section)))
        cols = {'wheel_radius_m': table['angle_rad'] * 0.0 + radius}
        cols.update(table)
        summary['table_wheel_radius_m'] = radius
    else:
        summary['table'] = 'not written: the fit is not settled'
    summary['fit']['std'] = {k: (None if v != v else v) for k, v in fit.std.items()}
    wrote = _write(args, cols, summary) if cols else False
    if not cols and args.json:
        from cam_metrology.report.json_out import write_json
        write_json(args.json, summary, '--json')
        wrote = True
    if not wrote:
        for k, v in fit.values.items():
            s = fit.std[k]
            print(f'{k}: {v:.6g} +- {s:.3g}')
        print(f'offset {fit.offset_m * 1e6:.4f} µm, residual rms '
              f'{fit.residual_rms_m * 1e6:.4f} µm over {fit.points} points, condition '
              f'{fit.condition:.3g}' + ('' if fit.settled else ' (NOT settled)'))
    return 0 if fit.settled and not fit.warnings else 1
