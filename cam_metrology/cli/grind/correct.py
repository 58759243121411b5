"""`cam-bench grind correct FILE --measured CSV|BAG`: measure -> correct.

Least-squares fit of the machining errors to a measured lift error, then the
wheel-centre table that pre-compensates them.
"""
from __future__ import annotations

import argparse
from typing import Any

from cam_metrology.cli.grind.inputs import (add_file, add_lobe_base, add_outputs, add_probe,
                                            add_wheel_step, angle_grid, load, machine_of,
                                            one_wheel, probe_follower, step_of, warn_bridged,
                                            write_columns)


def register(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add ``correct`` to the ``grind`` group."""
    p = sub.add_parser('correct', help='fit a measured lift error, write a corrected table',
                       description='Measure -> correct: least-squares fit of the machining '
                                   'errors to a measured lift error, then the wheel-centre '
                                   'table that pre-compensates them. Exit 1 and no table '
                                   'when the fit is ill-conditioned; exit 1 with the table '
                                   'when the sources explain < 80 % of the error.')
    add_file(p)
    p.add_argument('--measured', required=True, metavar='CSV|BAG',
                   help='CSV with alpha_rad and lift_error_m, or alpha_rad, lift_m and '
                        'design_lift_m (the columns of /metrology/lift); or a measurement '
                        'bag: the lobe (--lobe, or the only/first lobe) is analysed as '
                        '`analyze` does and its base-circle-referenced lift error is used '
                        '(alpha from the fitted nose: an index error shows in the report\'s '
                        'phase, not in this lift error)')
    add_outputs(p)
    add_lobe_base(p)
    add_wheel_step(p)
    add_probe(p)
    p.add_argument('--sources', default='wheel_radius,index,run_out_x,run_out_y',
                   metavar='NAME[,NAME...]',
                   help='comma-separated error sources to fit (default: wheel_radius,index,'
                        'run_out_x,run_out_y)')
    p.add_argument('--exact-iterations', type=int, default=3, metavar='N',
                   help='Gauss-Newton steps on the exact grinding simulation after the linear '
                        'fit (default 3; 0: linear fit only)')
    return p


def run(args: argparse.Namespace) -> int:
    """Handler of ``cam-bench grind correct``: fit the machining errors to a
    measured lift error; the corrected wheel-centre table (0; 1 not settled or with
    warnings; 2 for bad input)."""
    import sys

    from cam_design.grinding.correction import corrected_curve, curve_table, fit_errors
    from cam_design.grinding.wheel_path import WheelPath

    law, base, design, section = load(args)
    path = WheelPath(law, base, design, one_wheel(args, section), key=args.file)
    warn_bridged(path.wheel_radius, path.bridged)
    cradle, master = machine_of(path, section)
    alpha, error = _measured(args.measured, lobe=args.lobe)
    sources = tuple(s.strip() for s in args.sources.split(',') if s.strip())
    fit = fit_errors(path, alpha, error, sources=sources, cradle=cradle, master=master,
                     probe=probe_follower(args), key=args.measured,
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
        table = curve_table(curve, base + radius, angle_grid(step_of(args, section)))
        cols = {'wheel_radius_m': table['angle_rad'] * 0.0 + radius}
        cols.update(table)
        summary['table_wheel_radius_m'] = radius
    else:
        summary['table'] = 'not written: the fit is not settled'
    summary['fit']['std'] = {k: (None if v != v else v) for k, v in fit.std.items()}
    wrote = write_columns(args, cols, summary) if cols else False
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
