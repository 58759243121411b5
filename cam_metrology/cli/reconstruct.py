"""`cam-bench reconstruct BAG|TABLE`: lift, velocity, acceleration and jerk of measured
lobes by the smoothing spline with the rebound method and by the N-harmonic series
(see docs/reconstruction.md).

* BAG (a rosbag2 directory or .mcap): replayed in-process through the metrology core
  and the reconstruction core (the live code path); the scene in the bag gives the
  design lift, the probe and the design follower.
* TABLE: a CSV with header ``alpha_rad,lift_m[,design_lift_m]`` (units from the
  column names: ``alpha_deg``, ``lift_mm``, ``lift_um`` also work), or a gauge
  nominal-profile file (probe radius, number of steps, rows ``angle lift [marker]``;
  degrees and millimetres unless ``--angle-unit``/``--length-unit`` say otherwise).

JSON (``--json FILE`` or ``-``): ``{"input", "kind", "follower", "features":
{ID: {METHOD: {...}}}, "skipped"}``; each method has ``alpha_rad``, ``lift_m``,
``velocity_m_per_rad``, ``acceleration_m_per_rad2``, ``jerk_m_per_rad3`` (arrays on the
uniform grid), ``rms_residual_m``, ``residual_m`` at ``residual_alpha_rad`` (the kept
samples), ``order`` (harmonic) or ``smoothing`` (spline, lam [rad^5]) with ``why``, the
per-second arrays with ``--rpm``, ``design_errors`` when the design is known,
``spectrum`` (harmonic), ``warnings`` and ``notes``.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from cam_metrology.cli.conventions import add_table_units, table_units


def register(subparsers: Any) -> argparse.ArgumentParser:
    """Add the ``reconstruct`` subcommand."""
    p = subparsers.add_parser(
        'reconstruct', help='reconstruct lift and derivatives from measured lift tables',
        description='Smoothing spline (rebound method, quintic) and N-harmonic '
                    'reconstruction of measured cam lifts from a bag or a lift table.')
    p.add_argument('input', metavar='BAG|TABLE',
                   help='rosbag2 directory (or .mcap), CSV table or gauge profile file')
    add_table_units(p)
    p.add_argument('--json', metavar='FILE|-',
                   help='write the JSON result (- for standard output)')
    p.add_argument('--plot', metavar='DIR', help='write one PNG per feature to DIR')
    p.add_argument('--nominal', metavar='FILE',
                   help='write the reconstructed lift of --lobe (or the only lobe) as a '
                        'gauge nominal-profile file, -180..180 deg every --step-deg, from '
                        'the first method that succeeded (--method to choose)')
    p.add_argument('--lobe', metavar='ID', dest='feature',
                   help='only this lobe (default: all lobes)')
    p.add_argument('--feature', dest='feature', help=argparse.SUPPRESS)   # old spelling
    p.add_argument('--method', choices=('spline', 'harmonic', 'both'), default='both',
                   help='reconstruction method (default both)')
    p.add_argument('--harmonics', type=int, metavar='N',
                   help='harmonic order, >= 2 (default: automatic)')
    p.add_argument('--basis', choices=('section', 'full'), default='section',
                   help='harmonic basis: working-section cosines (default) or rFFT over '
                        'the revolution')
    p.add_argument('--smoothing', type=float, metavar='X',
                   help='spline smoothing lam [rad^5] (default: automatic, GCV)')
    p.add_argument('--criterion', choices=('gcv', 'risk'), default='gcv',
                   help='automatic spline smoothing criterion (default gcv)')
    p.add_argument('--rebound-threshold', type=float, metavar='T',
                   help='rebound outlier tolerance [noise standard deviations x the '
                        'rebound factor] (default 4.5); raise it for tables coarser than '
                        '1 deg, where the rebound of the lift itself exceeds the noise')
    p.add_argument('--step-deg', type=float, default=0.1, metavar='D',
                   help='step of the output grid [deg] (default 0.1; 0.001 to 10)')
    p.add_argument('--follower', choices=('flat', 'roller', 'knife'),
                   help='TABLE: follower that measured the lift (default flat; a gauge '
                        'file: roller with its probe radius)')
    p.add_argument('--radius', type=float, metavar='M', help='TABLE: roller radius [m]')
    p.add_argument('--rpm', type=float, metavar='R',
                   help='cam speed [rpm] for per-second velocity, acceleration, jerk')
    p.add_argument('--center-nose', action='store_true',
                   help='TABLE: re-centre the angles on the lobe axis (gauge files whose '
                        'zero is not the nose)')
    return p


def _params(args: argparse.Namespace) -> dict[str, Any]:
    from cam_metrology.reconstruction.core import check_step_deg

    methods = 'spline,harmonic' if args.method == 'both' else args.method
    params: dict[str, Any] = {'methods': methods,
                              'step_deg': check_step_deg('--step-deg', args.step_deg),
                              'harmonic_basis': args.basis,
                              'smoothing_criterion': args.criterion}
    if args.rebound_threshold is not None:
        from cam_design.errors import require_positive
        params['rebound_threshold'] = require_positive('--rebound-threshold',
                                                       args.rebound_threshold)
    if args.smoothing is not None:
        from cam_design.errors import require_positive
        params['smoothing'] = require_positive('--smoothing', args.smoothing, allow_zero=True)
    if args.harmonics is not None:
        from cam_design.errors import InputError
        from cam_metrology.reconstruction.harmonic import MIN_ORDER, ORDER_EXPECTED
        if args.harmonics < MIN_ORDER:
            raise InputError('--harmonics', args.harmonics, ORDER_EXPECTED)
        params['harmonics'] = args.harmonics
    if args.rpm is not None:
        from cam_design.errors import require_positive
        params['cam_speed_rpm'] = require_positive('--rpm', args.rpm)
    return params


def run(args: argparse.Namespace) -> int:
    """Handler of ``cam-bench reconstruct``."""
    from cam_metrology.reconstruction.core import ReconstructionCore

    path = Path(args.input)
    if not path.exists():
        raise FileNotFoundError(f'no such bag or table: {path}')
    core = ReconstructionCore(_params(args))
    from cam_metrology.bagio import looks_like_bag
    skipped: list[dict[str, str]] = []
    if looks_like_bag(path):
        _reject_table_options(args)
        kind = 'bag'
        follower, problems = _bag(path, core)
    else:
        kind, problems = 'table', []
        follower, skipped = _table(path, core, args)
    skipped += _skips(core)
    if not core.results:
        _nothing_reconstructed(path, kind, skipped, problems)
    rpm = args.rpm or core.cam_speed()
    from cam_metrology.reconstruction.profile import summary

    features = {fid: {m: summary(o, rpm=rpm) for m, o in outcomes.items()}
                for fid, outcomes in core.results.items()
                if args.feature is None or fid == args.feature}
    if args.feature is not None and args.feature not in features:
        from cam_design.errors import InputError
        raise InputError('--lobe', args.feature,
                         'one of ' + (', '.join(sorted(core.results)) or '(no feature)'))
    result = {'input': str(path), 'kind': kind, 'follower': follower,
              'features': features, 'skipped': skipped}
    if args.json:
        from cam_metrology.report.json_out import write_json
        if kind == 'table':   # the rows' lobe law, the one every table route reads
            result['lobes'] = {fid: lobe_entry(core.tables[fid], fid) for fid in features}
        write_json(args.json, result, '--json')
        if args.json != '-':
            done = [f'{fid}/{m}' for fid, ms in features.items() for m, v in ms.items()
                    if isinstance(v, dict) and v.get('ok')]
            print(f'wrote {args.json}: ' + (', '.join(done) or 'no reconstruction')
                  + f' ({len(skipped)} skipped)' * bool(skipped))
    else:
        print(_human(result))
    if args.plot:
        _plots(core, Path(args.plot), args.feature)
    if getattr(args, 'nominal', None):
        write_nominal(core, args, follower)
    ok = any(m.get('ok') for f in features.values() for m in f.values())
    return 0 if ok else 1


def lobe_entry(table: Any, key: str) -> dict[str, Any]:
    """``lobes.<id>`` of the JSON: the table's lobe law (``lobe_table``) on a
    0.1 deg grid over its support, as the methods' arrays (what `dynamics r.json`
    reads first), with its note and warnings; or ``ok: false`` and the refusal."""
    import numpy as np

    from cam_design.cam_card import law_peak
    from cam_design.errors import InputError
    from cam_design.lift_table.lobe_table import lobe_law

    try:
        law = lobe_law(table.alpha, table.lift, key=key, allow_steps=True)
    except InputError as exc:
        return {'ok': False, 'error': str(exc)}
    lo, hi = law.support
    grid = np.linspace(lo, hi, int(np.ceil(np.degrees(hi - lo) / 0.1)) + 1)
    jets = law.derivatives(grid)
    names = ('lift_m', 'velocity_m_per_rad', 'acceleration_m_per_rad2', 'jerk_m_per_rad3')
    out: dict[str, Any] = {'ok': True, 'method': law.lobe.method, 'note': law.lobe.note(),
                           'warnings': list(law.lobe.warnings),
                           'max_lift_m': law_peak(law)[1], 'alpha_rad': grid.tolist()}
    out.update({n: v.tolist() for n, v in zip(names, jets)})
    return out


def write_nominal(core: Any, args: argparse.Namespace, follower: dict[str, Any]) -> None:
    """``--nominal``: the reconstructed lift (as seen by the measuring probe) as a gauge
    nominal-profile file (cam_metrology.report.nominal_file); the gauge format knows a roller
    (its radius) or a point (radius 0), not a flat follower."""
    import numpy as np

    from cam_design.errors import InputError
    from cam_metrology.inputs.files import write_output
    from cam_metrology.report.nominal_file import gauge_text

    ids = [f for f in core.results if args.feature is None or f == args.feature]
    if len(ids) != 1:
        raise InputError('--nominal', args.nominal, 'one lobe: --lobe ID (one of '
                         + ', '.join(ids) + ')')
    fid = ids[0]
    outcome = next((o for o in core.results[fid].values()
                    if o.reconstruction is not None), None)
    if outcome is None:
        raise InputError('--nominal', args.nominal, f'a reconstruction of {fid} (none '
                         'succeeded)')
    probe = follower.get('probe') or follower
    kind, radius = probe.get('kind'), float(probe.get('radius_m') or 0.0)
    if kind == 'flat':
        raise InputError('--nominal', args.nominal, 'a roller or knife probe: the gauge '
                         'nominal-profile format has no flat follower')
    n = 360.0 / args.step_deg
    if abs(n - round(n)) > 1e-9 * n:
        raise InputError('--step-deg', args.step_deg, 'a step that divides 360 deg for '
                         '--nominal (e.g. 0.1, 0.25, 0.5)')
    rec = outcome.reconstruction
    # a table over part of the turn: its fit has a gap wider than the rows' own steps
    gaps = np.diff(np.concatenate([rec.alpha, rec.alpha[:1] + 2.0 * np.pi]))
    widest = int(np.argmax(gaps))
    row_step = float(np.median(np.diff(rec.data_alpha))) if rec.data_alpha.size > 1 else 0.0
    if gaps[widest] > 2.0 * (row_step + np.radians(args.step_deg)) + 1e-9:
        start, stop = (np.degrees(rec.alpha[widest]),
                       np.degrees(rec.alpha[(widest + 1) % rec.alpha.size]))
        raise InputError('--nominal', f'a reconstruction of {fid} without rows from '
                         f'{start:.1f} to {stop:.1f} deg',
                         'a table over the whole turn: a gauge nominal file covers '
                         '-180..180 deg, and no lift is made up where no row was measured')
    grid = np.linspace(-180.0, 180.0, int(round(n)) + 1)
    lift = np.interp(grid, np.degrees(rec.alpha), rec.derivatives()[0], period=360.0)
    method = next(m for m, o in core.results[fid].items() if o is outcome)
    text = gauge_text(grid, lift, radius if kind == 'roller' else 0.0,
                      [f'reconstructed lift of {fid} from {args.input} ({method}), as seen '
                       f'by the measuring {kind}; deg and mm'])
    write_output(args.nominal, text, '--nominal')


#: options that describe a TABLE (a bag's scene gives the probe and the angles)
TABLE_OPTIONS = ('follower', 'radius', 'angle_unit', 'length_unit', 'center_nose')


def _reject_table_options(args: argparse.Namespace) -> None:
    """InputError for a TABLE-only option given with a BAG (it would be ignored)."""
    from cam_design.errors import InputError

    for name in TABLE_OPTIONS:
        value = getattr(args, name)
        if value is not None and value is not False:
            raise InputError('--' + name.replace('_', '-'), value,
                             'no value with a BAG (only for a TABLE: the scene in the bag '
                             'gives the probe, the units are SI and the angles are '
                             'aligned on the fitted nose)')


def _table(path: Path, core: Any, args: argparse.Namespace) -> tuple[dict[str, Any], list]:
    from cam_metrology.inputs.lift_tables import read_table_file

    table = read_table_file(path, **table_units(args))
    if args.feature:
        from dataclasses import replace
        table = replace(table, feature=args.feature)
    if args.center_nose:
        from cam_design.lift_table.samples import centre_on_nose
        table, _ = centre_on_nose(table)
    kind, radius = table.follower or ('flat', 0.0)
    if args.radius is not None:   # 12.5 meant as mm is a 12.5 m roller: refuse it
        from cam_design.errors import require_length
        from cam_design.lift_laws.params import MAX_RADIUS_M
        require_length('--radius', args.radius, MAX_RADIUS_M, allow_zero=True, what='a radius')
    if args.follower:
        kind = args.follower
        radius = args.radius if args.radius is not None else (
            radius if kind == 'roller' else 0.0)
    elif args.radius is not None:
        kind, radius = 'roller', args.radius
    from cam_design.follower import Follower
    Follower(kind, radius)   # validates
    from cam_design.lift_table.samples import clean_samples
    clean_samples(table.alpha, table.lift, key=path.name)   # too few rows: InputError
    core.results.clear()
    core.process_table(table, 0, note='table input: lift as seen by the measuring '
                                      f'follower ({kind}); no scene, no conversion')
    return {'kind': kind, 'radius_m': radius,
            'note': 'no scene: no design follower conversion'}, []


#: what a bag needs for a reconstruction (the metrology core makes the lift tables)
BAG_NEEDS = ('a bag with the scene (/bench/scene) and the measured samples '
             '(/bench/joint_states)')


def _bag(path: Path, core: Any) -> tuple[dict[str, Any], list[str]]:
    """Replay the bag through the metrology and reconstruction cores: (follower
    description, metrology errors). InputError when the bag lacks the scene or the
    samples."""
    from cam_design.errors import InputError
    from cam_metrology.bagio import bag_topics
    from cam_metrology.metrology.core import MetrologyCore
    from cam_metrology.offline.replay import run_offline
    from cam_metrology.wire.topics import (JOINT_STATES, METROLOGY_RESULT,
                                           RECONSTRUCTION_RESULT, SCENE)

    topics = bag_topics(path)
    for topic in (SCENE, JOINT_STATES):
        if topics.get(topic, ('', 0))[1] <= 0:
            raise InputError(str(path), f'no {topic} messages', BAG_NEEDS)
    result = run_offline(path, [MetrologyCore(), core])
    scene = core.scene
    if scene is None:
        raise InputError(str(path), 'no valid scene', BAG_NEEDS)
    problems = [f"{s['name']}: {s['message']}"
                for topic in (METROLOGY_RESULT, RECONSTRUCTION_RESULT)
                for out in result.by_topic(topic)
                for s in _statuses(out) if s['level'] == 'ERROR']
    follower = {'probe': {'kind': scene.probe.kind, 'radius_m': scene.probe.radius}}
    follower['design'] = {lobe.id: lobe.follower.kind for lobe in scene.lobes}
    return follower, problems


def _statuses(output: Any) -> list[dict[str, str]]:
    """name, level (OK/WARN/ERROR) and message of the statuses of a StatusOutput."""
    from cam_metrology.cores.outputs import ERROR, WARN

    names = {ERROR: 'ERROR', WARN: 'WARN'}
    return [{'name': s.name, 'level': names.get(s.level, 'OK'), 'message': s.message}
            for s in getattr(output, 'statuses', ())]


def _nothing_reconstructed(path: Path, kind: str, skipped: list[dict[str, str]],
                           problems: list[str]) -> None:
    """Raise InputError: no feature was reconstructed (nor failed); say why."""
    from cam_design.errors import InputError

    why = [f"{s['what']}: {s['why']}" for s in skipped] + problems
    raise InputError(str(path), 'nothing to reconstruct' + (
        f" ({'; '.join(why)})" if why else ''),
        'at least one lobe with measured lift' + (' (a bag with /bench/joint_states '
                                                  'samples of a lobe)' if kind == 'bag'
                                                  else ''))


def _skips(core: Any) -> list[dict[str, str]]:
    return [{'what': f'reconstruction/{name}', 'why': why}
            for name, why in getattr(core, 'skipped', {}).items()]


#: notes of the data cleaning (samples.clean_samples) shown in the human output too
CLEANING_NOTES = ('dropped ', 'wrapped ', 'merged ', 'columns: ', 'angles: ', 'rounded ')


def _human(result: dict[str, Any]) -> str:
    lines = [f"reconstruct {result['input']} ({result['kind']})"]
    for fid, methods in result['features'].items():
        cleaning = dict.fromkeys(n for r in methods.values() for n in r.get('notes', ())
                                 if n.startswith(CLEANING_NOTES))
        lines += [f'  {fid}: data: {n}' for n in cleaning]
        for m, r in methods.items():
            if not r.get('ok'):
                lines.append(f'  {fid}/{m}: FAILED: {r["error"]}')
                continue
            key = 'order' if m == 'harmonic' else 'smoothing'
            val = r[key]
            val_s = f'{val}' if key == 'order' else f'{val:.4g} rad^5'
            line = (f'  {fid}/{m}: {key} {val_s}; rms residual '
                    f'{r["rms_residual_m"] * 1e6:.3f} µm; noise sigma '
                    f'{r["noise_sigma_m"] * 1e6:.4g} µm; max lift '
                    f'{max(r["lift_m"]) * 1e3:.4f} mm')
            err = r.get('design_errors')
            if err:
                line += (f'; vs design: lift {err["rms_error_lift_m"] * 1e6:.3f} µm, '
                         f'acc {err["rms_error_acceleration_m_per_rad2"] * 1e3:.4f} '
                         'mm/rad^2 rms')
            lines.append(line)
            lines.append(f'    why: {r["why"]}')
            if 'acceleration_m_per_s2' in r:
                lines.append(f"    at {r['cam_speed_rpm']:g} rpm: max |v| "
                             f"{max(map(abs, r['velocity_m_per_s'])):.4g} m/s, max |a| "
                             f"{max(map(abs, r['acceleration_m_per_s2'])):.4g} m/s^2")
            if r.get('engine_follower'):
                lines.append(f"    follower: {r['engine_follower']}")
            for w in r['warnings']:
                lines.append(f'    warning: {w}')
    for s in result['skipped']:
        lines.append(f"  skipped {s['what']}: {s['why']}")
    return '\n'.join(lines)


def _plots(core: Any, folder: Path, feature: str | None) -> None:
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    import numpy as np

    from cam_metrology.inputs.files import output_dir, safe_name, save_figure
    from cam_metrology.report.plots import scale_to_curve
    from cam_metrology.reconstruction.profile import design_from_table

    folder = output_dir(folder, '--plot')
    names = ('lift [mm]', 'velocity [mm/rad]', 'acceleration [mm/rad^2]', 'jerk [mm/rad^3]')
    for fid, outcomes in core.results.items():
        if feature is not None and fid != feature:
            continue
        fig, axes = plt.subplots(4, 1, figsize=(9, 11), sharex=True)
        spans: dict[int, list[float]] = {}
        table = core.tables.get(fid)
        first = next((o.reconstruction for o in outcomes.values()
                      if o.reconstruction is not None), None)
        rows = None
        if table is not None:
            # the rows in the turn of the fits (the one centred on a lobe that lies
            # outside (-180, 180]), by whole turns, in angle order
            rows = table.alpha
            if first is not None and first.alpha.size:
                mid = 0.5 * float(first.alpha[0] + first.alpha[-1])
                rows = rows + 2.0 * np.pi * np.round((mid - rows) / (2.0 * np.pi))
            order = np.argsort(rows, kind='stable')
            rows = (rows[order], table.lift[order])
            axes[0].plot(np.degrees(rows[0]), rows[1] * 1e3, 'o', ms=1.5, mew=0,
                         color='0.35', zorder=4, label='measured')
            design = design_from_table(table)
            if design is not None and first is not None:
                for nu, ax in enumerate(axes):
                    ax.plot(np.degrees(first.alpha), design(first.alpha, nu) * 1e3, 'k--',
                            lw=0.8, label='design (probe)' if nu == 0 else None)
        for m, o in outcomes.items():
            rec = o.reconstruction
            if rec is None:
                continue
            for k, (ax, values) in enumerate(zip(axes, rec.derivatives())):
                ax.plot(np.degrees(rec.alpha), values * 1e3, lw=1, label=m)
                spans.setdefault(k, []).extend([float(np.min(values)), float(np.max(values))])
            if rec.outliers_alpha.size and m == next(iter(outcomes)):
                axes[0].plot(np.degrees(rec.outliers_alpha),
                             np.interp(rec.outliers_alpha, *rows) * 1e3
                             if rows is not None else np.zeros(rec.outliers_alpha.size),
                             'rx', label='outliers')
        for k, (ax, name) in enumerate(zip(axes, names)):
            ax.set_ylabel(name)
            ax.grid(True, lw=0.3)
            if k and spans.get(k):   # derivatives scaled to the reconstruction
                scale_to_curve(ax, np.array(spans[k]) * 1e3)
        axes[0].legend(fontsize=8)
        axes[-1].set_xlabel('cam angle from the lobe centre [deg]')
        fig.suptitle(f'{fid}: reconstruction')
        fig.tight_layout()
        try:
            save_figure(fig, folder / f'{safe_name(fid)}.png', '--plot', dpi=110)
        finally:
            plt.close(fig)


if __name__ == '__main__':   # pragma: no cover
    from cam_metrology.cli import main
    sys.exit(main(['reconstruct', *sys.argv[1:]]))
