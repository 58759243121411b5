"""`cam-bench dynamics SCENE|BAG|TABLE`: valve motion, contact force and stress, events
and jump speed of a valve train (see docs/dynamics.md).

* SCENE (YAML, docs/contract.md): the design lift of every lobe (``lift`` table or
  ``lift_law``) drives the scene's ``valve_train`` model.
* BAG (rosbag2 directory or .mcap): replayed in-process through the metrology,
  reconstruction and dynamics cores (the live code path); the reconstructed profile of
  each lobe drives the model (the design law when a lobe has no profile: then the
  feature has a ``note`` and a warning goes to stderr).
* TABLE (CSV, gauge nominal file, or the JSON of ``cam-bench reconstruct``) with
  ``--valve-train`` (a scene or a YAML of the valve_train block): a CSV/gauge table goes
  through the reconstruction spline (said in the feature's ``note``).

JSON (``--json FILE`` or ``-``): ``{"input", "kind", "model", "features": {ID:
{"source", "runs": [...], "jump_speed_rpm", "jump_bracket_rpm", "bounce_onset_rpm",
"bounce_bracket_rpm", "sweep" (null without --sweep), "jump_speed_uncertainty_rpm" (a
table's: the jump speed's uncertainty from its noise; null otherwise)}}, "skipped"}``. Each run has
``cam_speed_rpm``, the arrays on the ``--step-deg`` grid, the events, ``settled``,
``left_cam``, ``periodic_residual_m`` and ``note`` when the reader must know something
(no periodic state, the valve leaves the cam, no seating). ``sweep``: every speed a full
periodic run at ``--step-deg``; ``status`` per speed clean | separated | unsettled;
``no_open_speed_rpm`` / ``no_open_bracket_rpm``: null for a cam-driven train (with
``no_open_note``), for the hydraulic gear the speed above which it no longer opens the
valve fully (``cam_design.hydraulic.speed_limit``; its ``sweep`` has the per-speed lift,
pressure, relief spill and cavitation).
Limits: ``--step-deg`` in [0.01, 5], speeds in (0, 1e5] rpm.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from cam_metrology.cli.conventions import add_table_units, table_units


def register(subparsers: Any) -> argparse.ArgumentParser:
    """Add the ``dynamics`` subcommand."""
    p = subparsers.add_parser(
        'dynamics', help='valve-train dynamics: valve motion, contact force, jump speed',
        description='Single-DOF (exact piecewise-linear solver, penalty or hard seat) or '
                    '4+N1+N2 valve-train dynamics of a scene\'s lobes, from the design '
                    'lift (SCENE) or the reconstructed measured profile (BAG).')
    p.add_argument('input', metavar='SCENE|BAG|TABLE',
                   help='scene YAML, rosbag2 directory/.mcap, or a lift TABLE (CSV, gauge '
                        'nominal file, or the JSON of cam-bench reconstruct) with '
                        '--valve-train')
    p.add_argument('--valve-train', metavar='YAML',
                   help='with a TABLE: the valve train, from a scene (its valve_train '
                        'block) or a YAML holding only that block')
    add_table_units(p)
    p.add_argument('--json', metavar='FILE|-',
                   help='write the JSON result (- for standard output)')
    p.add_argument('--plot', metavar='DIR',
                   help='write <feature>.png (valve lift and contact force) to DIR')
    p.add_argument('--lobe', metavar='ID', dest='feature',
                   help='only this lobe (default: all lobes)')
    p.add_argument('--feature', dest='feature', help=argparse.SUPPRESS)   # old spelling
    p.add_argument('--model', choices=('sdof', 'mdof', 'hydraulic'),
                   help="model (default: the scene's valve_train.model)")
    p.add_argument('--rpm', type=float, action='append', metavar='R',
                   help="camshaft speed [rpm]; repeat for several (default: the scene's "
                        'valve_train.cam_speed_rpm)')
    p.add_argument('--sweep', metavar='LO:HI:STEP',
                   help='also sweep these speeds [rpm] (SDOF or MDOF: full periodic runs at '
                        '--step-deg, jump_speed_rpm and bounce_onset_rpm with their '
                        'brackets; hydraulic: one lobe pass per speed, no_open_speed_rpm, '
                        'the speed above which the gear cannot open the valve fully)')
    p.add_argument('--step-deg', type=float, default=0.1, metavar='D',
                   help='step of the output grid [deg], 0.01 to 5 (default 0.1)')
    p.add_argument('--cam-width', type=float, default=0.012, metavar='M',
                   help='contact width [m] for the Hertz stress of lobes without a scene '
                        'lobes[].width (default 0.012)')
    return p


def _core_params(args: argparse.Namespace, source: str) -> dict[str, Any]:
    from cam_design.errors import require_positive
    from cam_design.valve_train.params import require_rpm, require_step_deg

    params: dict[str, Any] = {'source': source,
                              'step_deg': require_step_deg('--step-deg', args.step_deg),
                              'cam_width': require_positive('--cam-width', args.cam_width)}
    if args.rpm:
        for i, r in enumerate(args.rpm):
            require_rpm(f'--rpm[{i}]', r)
        params['cam_speeds_rpm'] = ','.join(repr(float(r)) for r in args.rpm)
    if args.model:
        params['model'] = args.model
    return params


def run(args: argparse.Namespace) -> int:
    """Handler of ``cam-bench dynamics``."""
    from cam_design.errors import InputError
    from cam_metrology.dynamics.core import DynamicsCore

    path = Path(args.input)
    if not path.exists():
        raise FileNotFoundError(f'no such scene or bag: {path}')
    _core_params(args, 'auto')          # validate the options before any replay
    sweep_speeds = None
    if args.sweep:
        from cam_design.valve_train.sweep import parse_range
        sweep_speeds = parse_range(args.sweep)
    from cam_metrology.bagio import looks_like_bag
    is_bag = looks_like_bag(path)
    if not is_bag and path.suffix.lower() not in ('.yaml', '.yml'):
        core = _table_core(path, args)
        kind = 'table'
    elif args.valve_train or args.angle_unit or args.length_unit:
        opt = ('--valve-train' if args.valve_train else
               '--angle-unit' if args.angle_unit else '--length-unit')
        raise InputError(opt, getattr(args, opt[2:].replace('-', '_')),
                         'no value with a SCENE or BAG (only with a TABLE)')
    elif is_bag:
        core = DynamicsCore(_core_params(args, 'auto'))
        _replay(path, core)
        kind = 'bag'
        if core.scene is None:
            raise InputError('input', str(path), 'a bag with a /bench/scene message')
    else:
        from types import SimpleNamespace

        from cam_metrology.scene.parse import load_scene

        scene = load_scene(path)
        if args.feature is not None and args.feature not in [lb.id for lb in scene.lobes]:
            raise InputError('--lobe', args.feature,
                             'one of ' + ', '.join(lb.id for lb in scene.lobes))
        core = DynamicsCore(_core_params(args, 'design'))
        if scene.valve_train is None:
            raise InputError('valve_train', None, 'a valve_train block in the scene')
        from cam_metrology.wire.topics import SCENE
        text = scene.text if scene.camshaft is not None else _scene_text(scene, args.feature)
        core.handle(SCENE, SimpleNamespace(data=text), 0)   # the shaft carries every lobe
        kind = 'scene'
    result = _result(core, args, kind, sweep_speeds)
    shaft_sweep = _camshaft_block(core, args, result, sweep_speeds)
    _write(result, args)
    if args.plot:
        import matplotlib.pyplot as plt

        from cam_design.hydraulic.plot import plot_pressures
        from cam_design.valve_train.sweep import runs_figure
        from cam_metrology.inputs.files import output_dir, safe_name, save_figure
        folder = output_dir(args.plot, '--plot')
        for feature, runs in core.runs.items():
            if args.feature and feature != args.feature:
                continue
            hydraulic = [r for r in runs if hasattr(r, 'pump_pressure')]
            figures = [(runs_figure(runs, title=feature), '')] + (
                [(plot_pressures(hydraulic, title=f'{feature}: hydraulic valve gear'),
                  '_pressure')] if hydraulic else [])
            for fig, suffix in figures:
                try:
                    save_figure(fig, folder / f'{safe_name(feature)}{suffix}.png', '--plot',
                                dpi=110)
                finally:
                    plt.close(fig)
        if getattr(core, 'camshaft_runs', None):
            from cam_design.camshaft.report import camshaft_figure
            shafts = [(core.camshaft_runs, 'camshaft', '')] + (
                [(shaft_sweep, 'camshaft_sweep', ': sweep')] if shaft_sweep else [])
            for shaft_runs, name, what in shafts:
                fig = camshaft_figure(shaft_runs, title=f'camshaft {scene_id(core)}{what}')
                try:
                    save_figure(fig, folder / f'{name}.png', '--plot', dpi=110)
                finally:
                    plt.close(fig)
    return 1 if any('failures' in e for e in result['features'].values()) else 0


def scene_id(core: Any) -> str:
    """The scene's camshaft_id (or '')."""
    return str(getattr(core.scene, 'camshaft_id', '') or '')


def _camshaft_block(core: Any, args: argparse.Namespace, result: dict[str, Any],
                    sweep_speeds: Any) -> list[Any]:
    """With a ``camshaft:`` block: the result's ``camshaft`` (per-speed arrays of the
    runs' speeds; ``sweep``: the same over the --sweep speeds) and the sweep's runs."""
    spec = getattr(core.scene, 'camshaft', None) if core.scene is not None else None
    if spec is None or not getattr(core, 'active', False):
        result['camshaft'] = None
        return []
    from cam_design.camshaft.report import camshaft_summary

    block = camshaft_summary(spec, core.camshaft_runs, core.camshaft_failures)
    runs: list[Any] = []
    if sweep_speeds is not None:
        from cam_design.train.run import train_from_valve_train
        from cam_metrology.dynamics.camshaft import run_speeds
        from cam_metrology.dynamics.core import lobe_key

        scene = core.scene
        train = train_from_valve_train(scene.valve_train, args.model)
        runs, failures = run_speeds(scene, train, sweep_speeds, step_deg=core.step_deg,
                                    cam_width=core.cam_width, youngs=core.youngs,
                                    max_revolutions=core.max_revolutions,
                                    keys={lb.id: lobe_key(scene, lb.id) for lb in scene.lobes},
                                    laws={lid: law for lid, (law, _) in core.laws.items()})
        block['sweep'] = camshaft_summary(spec, runs, failures)
    result['camshaft'] = block
    return runs


def _table_core(path: Path, args: argparse.Namespace) -> Any:
    """A stand-in for the node core holding the runs of a TABLE (``--valve-train``)."""
    from types import SimpleNamespace

    from cam_design.errors import InputError
    from cam_design.train.run import run_train, train_from_valve_train
    from cam_metrology.dynamics.core import parse_speeds, rpm_label
    from cam_metrology.dynamics.tables import table_input
    from cam_metrology.scene.parse import load_valve_train

    if not args.valve_train:
        raise InputError('--valve-train', None, 'a scene or valve-train YAML with a TABLE '
                         '(the table gives only the lift)')
    vt, scene = load_valve_train(Path(args.valve_train))
    feature, law, source, note = table_input(path, feature=args.feature, **table_units(args))
    geom = None
    if scene is not None:
        from cam_design.valve_train.report import ContactGeometry
        lobe = next((lb for lb in scene.lobes if lb.id == feature), scene.lobes[0])
        geom = ContactGeometry(base_radius=scene.base_circle_radius,
                               follower=lobe.follower.kind, radius=lobe.follower.radius,
                               width=lobe.width or args.cam_width)
    core = SimpleNamespace(
        scene=SimpleNamespace(valve_train=vt, camshaft_id=getattr(scene, 'camshaft_id', None),
                              wants=lambda what: True),
        laws={feature: (law, source)}, runs={feature: []}, failures={},
        notes={feature: note}, keys={feature: path.name}, table_note=True)
    speeds = parse_speeds([float(r) for r in args.rpm], '--rpm') if args.rpm else \
        tuple(vt.cam_speed_rpm)
    try:        # a refusal of the train fails each of its speeds
        train: Any = train_from_valve_train(vt, args.model)
    except (InputError, RuntimeError, ValueError) as exc:
        train = exc
    for rpm in speeds:
        try:
            if isinstance(train, Exception):
                raise train
            run = run_train(law, train, rpm, step_deg=args.step_deg, geometry=geom,
                            key=path.name)
        except (InputError, RuntimeError, ValueError) as exc:
            core.failures[f'{feature}/{rpm_label(rpm)}rpm'] = str(exc)
            continue
        run.events['source'] = source
        core.runs[feature].append(run)
    return core


def _scene_text(scene: Any, feature: str | None) -> str:
    """The scene YAML, restricted to one lobe when ``--lobe`` is given."""
    if feature is None:
        return scene.text
    import yaml

    doc = yaml.safe_load(scene.text)
    doc['lobes'] = [lb for lb in doc['lobes'] if lb.get('id') == feature]
    return yaml.safe_dump(doc, sort_keys=False)


def _replay(path: Path, core: Any) -> None:
    """Feed the bag through metrology -> reconstruction -> dynamics (what exists)."""
    from cam_metrology.offline.registry import available_cores
    from cam_metrology.offline.replay import run_offline

    cores = [cls() for name, cls in available_cores().items() if name != 'dynamics']
    run_offline(path, [*cores, core])


def _result(core: Any, args: argparse.Namespace, kind: str,
            sweep_speeds: Any) -> dict[str, Any]:
    from cam_metrology.report.json_out import json_safe

    scene = core.scene
    out: dict[str, Any] = {'input': str(args.input), 'kind': kind,
                           'camshaft_id': getattr(scene, 'camshaft_id', None),
                           'model': args.model or getattr(scene.valve_train, 'model', None)
                           if scene is not None and scene.valve_train is not None else None,
                           'features': {}, 'skipped': []}
    if scene is not None and scene.valve_train is None:
        out['skipped'].append({'what': 'dynamics', 'why': 'scene has no valve_train'})
    elif scene is not None and not scene.wants('dynamics'):
        out['skipped'].append({'what': 'dynamics', 'why': 'dynamics not in compute'})
    for feature, (law, source) in core.laws.items():
        if args.feature and feature != args.feature:
            continue
        entry: dict[str, Any] = {'source': source,
                                 'runs': [r.as_dict() for r in core.runs.get(feature, [])]}
        if feature in core.notes:
            entry['note'] = core.notes[feature]
        failed = {k: v for k, v in core.failures.items() if k.startswith(feature + '/')}
        if failed:
            entry['failures'] = failed
        if sweep_speeds is not None and _model(scene.valve_train, args) == 'hydraulic':
            entry.update(_hydraulic_sweep(law, scene.valve_train, args, sweep_speeds))
        elif sweep_speeds is not None:
            from cam_design.train.run import sweep_train, train_from_valve_train

            train = train_from_valve_train(scene.valve_train, args.model)
            params = train.sweep_params('--sweep', args.sweep)
            res = sweep_train(law, train, sweep_speeds, step_deg=args.step_deg,
                              key=_law_key(core, feature))
            entry['jump_speed_rpm'] = res.jump_speed_rpm
            unc = None
            if str(source).startswith('table:') and res.jump_speed_rpm is not None:
                from cam_metrology.dynamics.tables import jump_uncertainty
                unc = jump_uncertainty(law, params, res.jump_speed_rpm, args.step_deg)
            entry['jump_speed_uncertainty_rpm'] = None if unc is None else unc[0]
            if unc is not None:
                entry['jump_uncertainty_note'] = unc[1]
            entry['jump_bracket_rpm'] = res.jump.bracket
            entry['bounce_onset_rpm'] = res.bounce_onset_rpm
            entry['bounce_bracket_rpm'] = res.bounce.bracket
            entry['sweep'] = res.as_dict()
            entry['jump_text'] = res.jump.text(float(sweep_speeds[0]), float(sweep_speeds[-1]))
            entry['bounce_text'] = res.bounce.text(float(sweep_speeds[0]),
                                                   float(sweep_speeds[-1]))
            entry.update(no_open_speed_rpm=None, no_open_bracket_rpm=None,
                         no_open_note=MECHANICAL_NO_OPEN)
        else:       # the documented keys are always there: null without --sweep
            entry.update(jump_speed_rpm=None, jump_bracket_rpm=None, bounce_onset_rpm=None,
                         bounce_bracket_rpm=None, sweep=None, jump_speed_uncertainty_rpm=None,
                         no_open_speed_rpm=None, no_open_bracket_rpm=None)
        out['features'][feature] = entry
    return json_safe(out)


#: why a cam-driven train has no no-open speed (JSON ``no_open_note``)
MECHANICAL_NO_OPEN = ('the cam drives the valve open at every speed (model sdof or mdof): '
                      'no speed limit against the spring and the gas force; the force the '
                      'train must overcome at the opening is sweep.opening_force_n')


def _model(vt: Any, args: argparse.Namespace) -> str:
    """The model a run or sweep uses: ``--model`` or the scene's (default sdof)."""
    return args.model or getattr(vt, 'model', None) or 'sdof'


def _hydraulic_sweep(law: Any, vt: Any, args: argparse.Namespace,
                     speeds: Any) -> dict[str, Any]:
    """The feature's sweep fields for the hydraulic gear: the per-speed table and the
    no-open speed (``cam_design.hydraulic.speed_limit``); the mechanical trains' jump
    and bounce speeds are null (the gear has no cam contact to lose)."""
    from cam_design.train.run import sweep_train, train_from_valve_train

    res = sweep_train(law, train_from_valve_train(vt, args.model), speeds)
    lo, hi = float(speeds[0]), float(speeds[-1])
    return {'no_open_speed_rpm': res.no_open.speed,
            'no_open_bracket_rpm': res.no_open.bracket,
            'no_open_text': res.no_open.text(lo, hi),
            'jump_speed_rpm': None, 'jump_bracket_rpm': None, 'bounce_onset_rpm': None,
            'bounce_bracket_rpm': None, 'jump_speed_uncertainty_rpm': None,
            'sweep': {'model': 'hydraulic', **res.as_dict()}}


def _law_key(core: Any, feature: str) -> str:
    """The key naming a feature's lift in refusals (scene key, table file, profile)."""
    keys = getattr(core, 'keys', None)
    if keys and feature in keys:
        return keys[feature]
    from cam_metrology.dynamics.core import lobe_key
    if getattr(core, 'scene', None) is not None and hasattr(core.scene, 'lobes'):
        return lobe_key(core.scene, feature)
    return 'lift'


def _write(result: dict[str, Any], args: argparse.Namespace) -> None:
    if args.json:
        from cam_metrology.report.json_out import write_json
        write_json(args.json, result, '--json')
    for feature, entry in result['features'].items():
        if 'note' in entry:         # stderr: seen also with --json -
            word = 'note' if str(entry.get('source', '')).startswith(
                ('table', 'reconstruct')) else 'warning'
            print(f"{word}: {feature}: {entry['note']}", file=sys.stderr)
    if args.json != '-':
        for feature, entry in result['features'].items():
            for r in entry['runs']:
                print(run_line(feature, r))
                if r.get('note'):
                    print(f"  note: {r['note']}")
            for name, why in entry.get('failures', {}).items():
                print(f'{name}: FAILED: {why}')
            if entry.get('sweep') is not None and entry['sweep'].get('model') == 'hydraulic':
                for line in hydraulic_sweep_lines(feature, entry):
                    print(line)
            elif entry.get('sweep') is not None:
                sw = entry['sweep']
                unc = entry.get('jump_speed_uncertainty_rpm')
                pm = f' +- {unc:.0f} rpm from the table' if unc is not None else ''
                print(f"{feature}: jump speed {entry['jump_text']}{pm}; bounce onset "
                      f"{entry['bounce_text']} (sweep of {len(sw['sweep_rpm'])} speeds at "
                      f"{sw['step_deg']:g} deg)")
                if entry.get('jump_uncertainty_note'):
                    print(f"  note: {entry['jump_uncertainty_note']}")
                for text in sw.get('notes', []):
                    print(f'  note: {text}')
                forces = [f for f in sw.get('opening_force_n', []) if f is not None]
                span = (f' ({min(forces):.1f} to {max(forces):.1f} N over the sweep)'
                        if forces else '')
                print(f"{feature}: no-open speed none: {entry['no_open_note']}{span}")
        for line in camshaft_lines(result.get('camshaft')):
            print(line)
        for s in result['skipped']:
            print(f"skipped {s['what']}: {s['why']}")


def camshaft_lines(block: dict[str, Any] | None) -> list[str]:
    """Human lines of the camshaft: natural frequencies, then per speed the drive torque
    (mean, peak, largest order), the friction loss and the lobes' timing shifts."""
    if not block:
        return []
    freqs = ', '.join(f'{f:.0f}' for f in block['natural_frequencies_hz'][:4])
    lines = [f"camshaft: torsional natural frequencies {freqs} Hz (drive {block['drive']})"]
    for part, label in ((block, 'run'), (block.get('sweep'), 'sweep')):
        if not part:
            continue
        tq = part['drive_torque_nm']
        for i, rpm in enumerate(part['cam_speed_rpm']):
            orders = tq['orders'][i]
            top = max(range(len(orders)), key=lambda n: orders[n])
            shifts = ', '.join(f"{lid} {v['timing_shift_deg'][i]:+.3f}"
                               for lid, v in part['lobes'].items())
            lines.append(
                f"camshaft {label} {rpm:g} rpm: drive torque mean {tq['mean'][i]:.2f} N m, "
                f"peak {tq['peak'][i]:.1f} N m, largest order {top + 1} "
                f"({orders[top]:.1f} N m); friction {part['friction_loss_j_per_rev'][i]:.2f} "
                f"J/rev ({part['friction_power_w'][i]:.0f} W); timing shift [deg] {shifts}"
                + ('' if part['converged'][i] else '; NOT CONVERGED'))
        for name, why in part.get('failures', {}).items():
            lines.append(f'camshaft {label} {name}: FAILED: {why}')
    crossings = [c for c in block['order_crossings'] if c['order'] <= 12][:6]
    if crossings:
        lines.append('camshaft: order crossings ' + ', '.join(
            f"order {c['order']} x mode {c['mode']} at {c['cam_speed_rpm']:.0f} rpm"
            for c in crossings))
    return lines


def hydraulic_sweep_lines(feature: str, entry: dict[str, Any]) -> list[str]:
    """Human lines of a hydraulic sweep: one per speed (peak valve lift and its share of
    the rigid-oil lift, peak pump pressure, relief spill, cavitation, closed), then the
    no-open speed and the sweep's notes."""
    sw = entry['sweep']
    lines = []
    for i, rpm in enumerate(sw['sweep_rpm']):
        spill = sw['relief_spill_before_peak'][i]
        lines.append(
            f"{feature} sweep {rpm:g} rpm (hydraulic): valve lift "
            f"{sw['max_valve_lift_m'][i] * 1e3:.3f} mm = "
            f"{_q(sw['valve_lift_ratio'][i], '.4f', 'x')} rigid oil, peak pump pressure "
            f"{sw['peak_pump_pressure_pa'][i] * 1e-5:.1f} bar, relief "
            + (f"spilled ({spill * 100:.3g} % of the displacement before the peak lift)"
               if sw['relief_spilled'][i] else 'closed')
            + f", cavitation {'yes' if sw['cavitation'][i] else 'no'}"
            + ('' if sw['settled'][i] else ', NOT CLOSED at the end of the pass'))
    tol = f"{sw['spill_tol'] * 100:g} %"
    lines.append(f"{feature}: no-open speed {entry['no_open_text']} (the relief spilled more "
                 f"than {tol} of the plunger displacement before the peak lift and the lift "
                 f"fell more than {tol} short of rigid oil; "
                 f"{len(sw['sweep_rpm'])} speeds, {sw['runs']} passes, "
                 f"{sw['sweep_cpu_seconds']:.1f} s CPU)")
    lines.extend(f'  note: {text}' for text in sw['notes'])
    return lines


def _q(value: Any, fmt: str, unit: str, scale: float = 1.0) -> str:
    """'12.345 unit' with ``fmt``, or 'none' for a missing value."""
    return 'none' if value is None else f'{value * scale:{fmt}} {unit}'


def run_line(feature: str, r: dict[str, Any]) -> str:
    """One human-readable line per run: angles to 0.001 deg, velocity to 1 mm/s,
    heights in µm, stress in MPa, the contact width used in mm."""
    if r.get('model') == 'hydraulic':
        return (f"{feature} {r['cam_speed_rpm']:g} rpm (hydraulic): max valve lift "
                f"{_q(r['max_valve_lift_m'], '.3f', 'mm', 1e3)} (rigid oil "
                f"{_q(r['rigid_valve_lift_m'], '.3f', 'mm', 1e3)}), peak pressure pump "
                f"{_q(r['peak_pump_pressure_pa'], '.1f', 'bar', 1e-5)} / actuator "
                f"{_q(r['peak_actuator_pressure_pa'], '.1f', 'bar', 1e-5)}, seating "
                f"{_q(r['seating_velocity_m_s'], '.3f', 'm/s')}, cavitation "
                f"{'yes' if r['cavitation'] else 'no'}")
    line = (f"{feature} {r['cam_speed_rpm']:g} rpm: opening {_q(r['opening_deg'], '.3f', 'deg')}"
            f", closing {_q(r['closing_deg'], '.3f', 'deg')}, separations "
            f"{len(r['separations'])}, seating {_q(r['seating_velocity_m_s'], '.3f', 'm/s')}, "
            f"bounces {r['bounce_count']}")
    if r['bounce_count']:
        line += f" (max {_q(r['bounce_height_m'], '.2f', 'µm', 1e6)})"
    if r.get('left_cam'):
        line += ', VALVE LEAVES THE CAM'
    elif r.get('settled') is False:
        line += f", NOT SETTLED (residual {r.get('periodic_residual_m', float('nan')):.3g} m)"
    if 'hla_pump_up' in r:
        line += (f", HLA {'PUMP-UP' if r['hla_pump_up'] else 'no pump-up'} (leak-down "
                 f"{r['hla_leak_down_m'] * 1e6:.2f} um, refill {r['hla_refill_m'] * 1e6:.2f} um"
                 f" per revolution)")
    line += f", max stress {_q(r['max_contact_stress_pa'], '.1f', 'MPa', 1e-6)}"
    if r.get('profile_undercut'):
        line += ' (profile undercut)'
    if r.get('cam_width_m') is not None:
        source = r.get('cam_width_source')
        line += f" (W {r['cam_width_m'] * 1e3:.1f} mm" + (f', {source})' if source else ')')
    return line
