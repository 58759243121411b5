"""`cam-bench rig simulate SCENE OUT --rpm R [--rpm R ...]`: synthetic runs of the
scene's ``rig.true_valve_train`` (CSV files in the folder OUT, or a bag with ``--bag``)."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path


def register(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add ``simulate`` to the ``rig`` group."""
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
    return s


def run(args: argparse.Namespace) -> int:
    """Handler of ``cam-bench rig simulate`` (0; 2 for bad input)."""
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
