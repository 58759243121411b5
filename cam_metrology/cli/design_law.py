"""`cam-bench design law|check|rocker`: lift laws, §2.1 design checks, rocker synthesis.

* ``design law FILE.yaml``: evaluate a lift law (``lift_law:`` mapping, or the file
  is the mapping itself) -> table of alpha, h, h', h'', h''' (CSV/JSON/plot).
* ``design check FILE.yaml``: all design checks of Shang (1988) §2.1 (docs/lift_laws.md).
* ``design rocker``: CG rocker optimum frame length (Song et al.).
"""
from __future__ import annotations

import argparse
import math
from typing import Any

COLUMNS = ('alpha_deg', 'h_mm', 'h1_mm_per_rad', 'h2_mm_per_rad2', 'h3_mm_per_rad3')


def register(sub: argparse._SubParsersAction) -> None:
    """Add ``law``, ``check`` and ``rocker`` to the ``design`` group."""
    p = sub.add_parser('law', help='evaluate a lift law from a YAML file',
                       description='Evaluate a lift law (YAML: a `lift_law:` mapping or the '
                                   'mapping itself, see docs/lift_laws.md) and print a table '
                                   'of alpha [deg], h [mm], h\' [mm/rad], h\'\' [mm/rad^2], '
                                   'h\'\'\' [mm/rad^3].')
    p.add_argument('file', help='YAML file with the lift law (or a scene file)')
    p.add_argument('--lobe', metavar='ID', help='with a scene file: the lobe id (default '
                                                'the first lobe)')
    p.add_argument('--step-deg', type=float, default=1.0, help='angle step [deg] (default 1)')
    p.add_argument('--csv', metavar='FILE|-', help='write the table as CSV')
    p.add_argument('--json', metavar='FILE|-', help='write summary and table as JSON')
    p.add_argument('--plot', metavar='PNG', help='plot h, h\', h\'\' and h\'\'\' to a PNG')
    p.add_argument('--nominal', metavar='FILE', help='write a gauge nominal-profile file '
                   '(-180..180 deg every --nominal-step-deg; with a scene: the lift as seen '
                   'by its probe, whose radius heads the file)')
    p.add_argument('--nominal-step-deg', type=float, default=0.5,
                   help='angle step of --nominal [deg] (default 0.5)')
    p.set_defaults(func=cmd_law)

    p = sub.add_parser('check', help='run the design checks of Shang (1988) §2.1',
                       description='Design checks (Shang §2.1): flow area, time-area, fullness, '
                                   'rho1, Hertz stress, equivalent mass, separation, oil film, '
                                   'valve-piston clearance. Input format: docs/lift_laws.md.')
    p.add_argument('file', help='YAML check input, or a scene file')
    p.add_argument('--lobe', metavar='ID', help='with a scene file: the lobe id (default '
                                                'the first lobe)')
    p.add_argument('--rpm', type=float, help='camshaft speed [rpm] (overrides the file)')
    p.add_argument('--json', metavar='FILE|-', help='write the results as JSON')
    p.set_defaults(func=cmd_check)

    p = sub.add_parser('rocker', help='CG rocker optimum dimension synthesis (Song et al.)',
                       description='Optimum frame length L of a rocker follower cam (S1, '
                                   'docs/lift_laws.md, erratum 1 applied). Lengths in m.')
    p.add_argument('--arm-length', type=float, required=True, help='rocker length l [m]')
    p.add_argument('--base-radius', type=float, required=True, help='base radius R_b [m]')
    p.add_argument('--max-swing-deg', type=float, required=True, help='max swing [deg]')
    p.add_argument('--eccentricity', type=float, help='eccentric adjustment e [m]')
    p.add_argument('--json', metavar='FILE|-', help='write the results as JSON')
    p.set_defaults(func=cmd_rocker)


def load_yaml(path: str) -> Any:
    """Parse a YAML file; InputError naming the file if it is not valid YAML."""
    import yaml

    from cam_design.errors import InputError
    from cam_metrology.inputs.files import read_text_file

    text = read_text_file(path, 'YAML file', key=path)
    try:
        from cam_metrology.inputs.yaml_input import load_yaml, syntax_error_text
        return load_yaml(text, path)
    except yaml.YAMLError as exc:
        raise InputError(path, 'invalid YAML',
                         f'a YAML document ({syntax_error_text(exc, text)})') from None


def write_text(target: str, text: str, key: str = 'output') -> None:
    """Write ``text`` to the file ``target`` (all or nothing), or to stdout for '-';
    errors name ``key`` (the option)."""
    from cam_metrology.inputs.files import write_output

    write_output(target, text, key)


def law_spec(doc: Any, path: str, lobe: str | None = None) -> tuple[Any, str]:
    """(lift_law mapping, key) from a YAML document: ``lift_law: {...}``, the mapping
    itself, or a scene (``lobes: [...]``; ``lobe`` selects one by id, default the first)."""
    from cam_design.errors import InputError

    if isinstance(doc, dict) and isinstance(doc.get('lobes'), list) and doc['lobes']:
        ids = [lb.get('id') if isinstance(lb, dict) else None for lb in doc['lobes']]
        i = ids.index(lobe) if lobe in ids else 0
        if lobe is not None and lobe not in ids:
            raise InputError('--lobe', lobe, 'one of ' + ', '.join(map(str, ids)))
        item = doc['lobes'][i]
        if isinstance(item, dict) and 'lift_law' in item:
            return item['lift_law'], f'lobes[{i}].lift_law'
        if isinstance(item, dict) and isinstance(item.get('lift'), dict):
            # a tabulated lobe (lift: {alpha, h}) is the `table` family
            return dict(item['lift'], family='table'), f'lobes[{i}].lift'
        raise InputError(f'lobes[{i}]', ids[i], 'a lobe with a lift_law mapping or a lift '
                                                'table {alpha, h}')
    if isinstance(doc, dict) and 'lift_law' in doc:
        return doc['lift_law'], 'lift_law'
    if isinstance(doc, dict) and 'family' in doc:
        return doc, 'lift_law'
    raise InputError(path, type(doc).__name__, 'a mapping with lift_law: {family: ...}')


def write_table(args: argparse.Namespace, columns: list[str], table: Any,
                summary: dict[str, Any]) -> bool:
    """Write ``table`` (rows x columns) to ``args.csv`` and/or ``args.json`` (with
    ``summary``); returns True if anything was written."""
    wrote = False
    if getattr(args, 'csv', None):
        lines = [','.join(columns)] + [','.join(f'{v:.12g}' for v in row) for row in table]
        write_text(args.csv, '\n'.join(lines) + '\n', '--csv')
        wrote = True
    if getattr(args, 'json', None):
        doc = dict(summary, columns=list(columns), rows=table.tolist())
        from cam_metrology.report.json_out import write_json
        write_json(args.json, doc, '--json')
        wrote = True
    return wrote


# kept for callers of the former private names (cli/design_profile.py)
def cmd_law(args: argparse.Namespace) -> int:
    """Evaluate the law on a grid."""
    import numpy as np

    from cam_design.errors import InputError
    from cam_design.lift_laws import from_spec

    spec, key = law_spec(load_yaml(args.file), args.file, args.lobe)
    law = from_spec(spec, key)
    step = args.step_deg
    if not (math.isfinite(step) and 1e-4 <= step <= 90):
        raise InputError('--step-deg', step, 'a step in [1e-4, 90] deg')
    lo, hi = law.support
    n = int(math.floor((hi - lo) / math.radians(step) + 1e-9)) + 1
    alpha = lo + np.arange(n) * math.radians(step)
    if alpha[-1] < hi - 1e-12:
        alpha = np.append(alpha, hi)
    d = law.derivatives(alpha)
    table = np.column_stack([np.degrees(alpha), d.T * 1e3])
    summary = {'family': spec.get('family'), 'support_deg': [math.degrees(lo), math.degrees(hi)],
               'max_lift_mm': max(float(d[0].max()), law.max_lift()) * 1e3,
               'continuity_order': int(law.continuity_order),
               'junctions_deg': [math.degrees(j) for j in law.junctions]}
    wrote = write_table(args, list(COLUMNS), table, summary)
    if getattr(args, 'nominal', None):
        write_nominal(args, law, key)
        wrote = True
    if args.plot:
        _plot(args.plot, table, str(spec.get('family')))
    if not wrote:
        print(f"{summary['family']}: support {summary['support_deg'][0]:.4f} .. "
              f"{summary['support_deg'][1]:.4f} deg, max lift {summary['max_lift_mm']:.6f} mm, "
              f"continuous to order {summary['continuity_order']}")
        print(' '.join(f'{c:>16}' for c in COLUMNS))
        for row in table:
            print(' '.join(f'{v:16.9g}' for v in row))
    return 0


def write_nominal(args: argparse.Namespace, law: Any, key: str) -> None:
    """``--nominal``: the gauge file of the law; for a scene lobe, converted to the
    scene's probe (the gauge measures with it), else the law's own lift with probe
    radius 0 and a comment naming that."""
    from cam_metrology.inputs.files import write_output
    from cam_metrology.report.nominal_file import law_gauge_text

    doc = load_yaml(args.file)
    radius, notes = 0.0, [f'nominal lift of {args.file} ({key}), deg and mm']
    if isinstance(doc, dict) and isinstance(doc.get('lobes'), list) and 'probe' in doc:
        from cam_metrology.metrology.analysis import seen_lift
        from cam_metrology.scene.parse import load_scene

        scene = load_scene(args.file)
        lobe = scene.lobe(args.lobe) if args.lobe else scene.lobes[0]
        law = seen_lift(lobe, scene.probe, scene.base_circle_radius, tabulate_step=None)
        radius = scene.probe.radius if scene.probe.kind == 'roller' else 0.0
        notes.append(f'as seen by the scene probe ({scene.probe.kind}); lobe {lobe.id} '
                     f'designed for a {lobe.follower.kind} follower')
    else:
        notes.append('lift of the law as written (probe radius 0: not converted)')
    write_output(args.nominal, law_gauge_text(law, args.nominal_step_deg, radius, notes),
                 '--nominal')


def _plot(path: str, table: Any, title: str) -> None:
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(4, 1, sharex=True, figsize=(7, 9))
    labels = ('h [mm]', "h' [mm/rad]", "h'' [mm/rad²]", "h''' [mm/rad³]")
    for i, ax in enumerate(axes):
        ax.plot(table[:, 0], table[:, i + 1], lw=1)
        ax.set_ylabel(labels[i])
        ax.grid(True, alpha=0.3)
    axes[-1].set_xlabel('alpha [deg] (rise flank < 0)')
    axes[0].set_title(title)
    fig.tight_layout()
    from cam_metrology.inputs.files import save_figure
    try:
        save_figure(fig, path, '--plot', dpi=110)
    finally:
        plt.close(fig)


def cmd_check(args: argparse.Namespace) -> int:
    """Run the §2.1 checks."""
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


def cmd_rocker(args: argparse.Namespace) -> int:
    """Rocker synthesis."""
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
