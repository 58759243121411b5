"""`cam-bench rig analyze|calibrate|simulate`: the valve-train test rig
(docs/contract.md "Valve-train rig", docs/methods.md "Valve-train rig").

* ``rig analyze RUN... --scene SCENE [--json OUT] [--plot DIR] [--report FILE]``: per run
  the measured speed and revolutions, the cycle-averaged lift with its scatter, the
  measured events (opening/closing at the checking height, maximum lift, seating
  velocity, bounces, separation from the cam), the prediction of the scene's valve train
  at the measured speed and the residual measured - predicted.
* ``rig calibrate RUN... --scene SCENE --fit NAME[,NAME...] [--json OUT] [--scene-out
  FILE]``: weighted least squares of the named parameters over all runs through the
  same dynamics solver; values with standard uncertainties, correlation matrix, residual
  before/after, identifiability warnings, jump speed nominal vs calibrated.
* ``rig simulate SCENE OUT --rpm R [--rpm R ...]``: synthetic runs of the scene's
  ``rig.true_valve_train`` (CSV files in the folder OUT, or a bag with ``--bag``).

RUN: a CSV file (header ``time_s,cam_angle_rad,valve_lift_m[,valve_velocity_m_per_s,
...]``) or a bag with ``/rig/joint_states`` (one run per ``frame_id``).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from cam_metrology.cli.conventions import add_report

FIT_HELP = ('comma-separated parameters to fit: stiffness, damping, mass, spring_rate, '
            'spring_preload, lash, valve_damping, seat_stiffness, seat_damping, nose_angle')


def register(subparsers: Any) -> None:
    """Add the ``rig`` command group."""
    p = subparsers.add_parser(
        'rig', help='valve-train test rig: analyse runs, calibrate the dynamics, simulate',
        description='Measured valve motion of a motored rig (encoder + laser on a time '
                    'clock) against the valve-train dynamics: analyse, calibrate, simulate.')
    sub = p.add_subparsers(dest='rig_command', metavar='ACTION')
    for name, helptext in (('analyze', 'measured events and residual against the nominal '
                                       'train, per run'),
                           ('calibrate', 'fit valve-train parameters to the runs by weighted '
                                         'least squares through the dynamics solver')):
        q = sub.add_parser(name, help=helptext, description=helptext)
        q.add_argument('runs', nargs='+', metavar='RUN',
                       help='CSV file (time_s,cam_angle_rad,valve_lift_m[,...]) or bag with '
                            '/rig/joint_states')
        q.add_argument('--scene', metavar='SCENE',
                       help='scene YAML with lobes, valve_train and rig: {lobe, '
                            'nose_angle_deg} (default: the scene recorded in the bag)')
        q.add_argument('--json', metavar='FILE|-',
                       help='write the JSON result (- for standard output)')
        q.add_argument('--plot', metavar='DIR',
                       help='write <run>.png (overlay and residual) to DIR')
        add_report(q, 'write an HTML report with the plots', aliases=('--html',))
        if name == 'calibrate':
            q.add_argument('--scene-out', metavar='FILE',
                           help='write the scene with the calibrated values')
            q.add_argument('--fit', required=True, metavar='NAME[,NAME...]', help=FIT_HELP)
        q.add_argument('--no-jump', action='store_true',
                       help='skip the jump-speed sweeps (faster)')
        q.set_defaults(func=run_analyze if name == 'analyze' else run_calibrate)
    s = sub.add_parser('simulate', help="synthetic rig runs of the scene's "
                                        'rig.true_valve_train',
                       description='Simulate rig runs: the periodic valve motion of the '
                                   "scene's rig.true_valve_train (else its valve_train) at "
                                   'each speed, on a time clock with a speed ripple, a '
                                   'quantised encoder and a noisy laser with an arbitrary '
                                   'zero.')
    s.add_argument('scene', metavar='SCENE')
    s.add_argument('out', metavar='OUT', help='folder for <run>.csv (or the bag with --bag)')
    s.add_argument('--rpm', type=float, action='append', required=True, metavar='R',
                   help='mean camshaft speed [rpm]; repeat for several runs')
    s.add_argument('--revolutions', type=float, default=4.0,
                   help='revolutions per run [rev] (default 4)')
    s.add_argument('--sample-rate', type=float, default=50_000.0,
                   help='laser and encoder sample rate [Hz] (default 50000)')
    s.add_argument('--noise-um', type=float, default=1.0,
                   help='laser noise rms [um] (default 1)')
    s.add_argument('--encoder-counts', type=int, default=3600,
                   help='encoder counts per revolution, 0 for exact angles (default 3600)')
    s.add_argument('--ripple', type=float, default=0.005,
                   help='speed ripple amplitude [fraction of the mean] (default 0.005)')
    s.add_argument('--vibrometer', action='store_true', help='also record valve velocity')
    s.add_argument('--seed', type=int, default=0, help='random seed (default 0)')
    s.add_argument('--bag', action='store_true',
                   help='write one bag (scene + /rig/joint_states) instead of CSV files')
    s.set_defaults(func=run_simulate)
    p.set_defaults(func=lambda args: (p.print_help(), 2)[1])


def _scene_and_runs(args: argparse.Namespace) -> tuple[Any, list[Any]]:
    from cam_design.errors import InputError
    from cam_metrology.rig.runs import read_runs
    from cam_metrology.scene.parse import load_scene, parse_scene

    runs, bag_scene = read_runs(args.runs)
    if args.scene:
        scene = load_scene(args.scene)
    elif bag_scene is not None:
        scene = parse_scene(bag_scene, 'the bag /bench/scene')
    else:
        raise InputError('--scene', None, 'a scene YAML with a rig block (the runs carry '
                                          'no scene)')
    return scene, runs


def _emit(outcome: Any, args: argparse.Namespace, title: str) -> None:
    from cam_metrology.inputs.files import write_output

    result = outcome.result
    if args.plot:
        from cam_metrology.rig.report import write_plots
        write_plots(outcome.curves, args.plot)
    if args.report:
        from cam_metrology.rig.report import html_report
        write_output(args.report, html_report(result, outcome.curves, title), '--report')
    if args.json:
        from cam_metrology.report.json_out import write_json
        write_json(args.json, result, '--json')
    for w in result.get('warnings', []):
        print(f'warning: {w}', file=sys.stderr)
    if args.json == '-':
        return
    from cam_metrology.rig.report import summary_lines
    for line in summary_lines(result):
        print(line)


def run_analyze(args: argparse.Namespace) -> int:
    """Handler of ``cam-bench rig analyze``."""
    from cam_metrology.rig.session import analyze

    scene, runs = _scene_and_runs(args)
    outcome = analyze(scene, runs, jump=not args.no_jump)
    _emit(outcome, args, 'cam-bench rig analyze')
    return 0


def run_calibrate(args: argparse.Namespace) -> int:
    """Handler of ``cam-bench rig calibrate``."""
    from cam_metrology.rig.model import parse_fit_names
    from cam_metrology.rig.session import calibrate_runs

    names = parse_fit_names(args.fit)
    scene, runs = _scene_and_runs(args)
    outcome, fit = calibrate_runs(scene, runs, names, jump=not args.no_jump)
    if args.scene_out:
        from cam_metrology.inputs.files import write_output
        from cam_metrology.rig.scene_out import calibrated_scene_text
        write_output(args.scene_out, calibrated_scene_text(scene.text, fit), '--scene-out')
    _emit(outcome, args, 'cam-bench rig calibrate')
    return 0


def run_simulate(args: argparse.Namespace) -> int:
    """Handler of ``cam-bench rig simulate``."""
    from cam_design.errors import InputError, require_positive
    from cam_metrology.rig.simulate import RigNoise, simulate_scene_runs
    from cam_metrology.scene.parse import load_scene

    scene = load_scene(args.scene)
    require_positive('--revolutions', args.revolutions)
    noise = RigNoise(laser_noise=require_positive('--noise-um', args.noise_um,
                                                  allow_zero=True) * 1e-6,
                     encoder_counts=args.encoder_counts, ripple=args.ripple,
                     sample_rate=args.sample_rate, vibrometer=args.vibrometer)
    runs, note = simulate_scene_runs(scene, args.rpm, revolutions=args.revolutions,
                                     noise=noise, seed=args.seed)
    if note:
        print(f'note: {note}', file=sys.stderr)
    out = Path(args.out)
    if args.bag:
        from cam_metrology.rig.bag import write_rig_bag
        write_rig_bag(out, scene.text, runs)
        print(f'wrote {out} ({len(runs)} runs on /rig/joint_states)')
        return 0
    from cam_metrology.inputs.files import output_dir
    from cam_metrology.rig.runs import write_csv_run
    folder = output_dir(out, 'OUT')
    for r in runs:
        path = folder / f'{r.name}.csv'
        if path.exists():
            raise InputError('OUT', str(path), 'a folder without earlier runs of this name '
                                               '(runs are never overwritten)')
        write_csv_run(r, path)
        print(f'wrote {path}')
    return 0
