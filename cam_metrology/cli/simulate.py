"""`cam-bench simulate OUT_BAG`: a bench measurement simulated offline into a new bag.

The bag holds /bench/scene, /bench/truth, /bench/joint_states (or
/bench/joint_trajectory blocks) and /bench/feature_done as the live bench-sim node would
publish them; the truth (true nose and pin angles, probe zero, noise) is printed.
"""
from __future__ import annotations

import argparse
import math
import sys
from typing import Any

from cam_metrology.cli.conventions import add_compression
from cam_metrology.cli.scene_input import load_scene_arg


def register(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add the ``simulate`` parser."""
    p = sub.add_parser(
        'simulate', help='simulate a bench measurement into a new bag (offline)',
        description='Simulate the measuring bench on a scene and write a rosbag2/MCAP bag '
                    'with /bench/scene, /bench/truth, /bench/joint_states and '
                    '/bench/feature_done, as the live bench-sim node would publish them. '
                    'The truth (true nose and pin angles, probe zero, noise) is printed.')
    p.add_argument('out', metavar='OUT_BAG', help='new bag directory (must not exist)')
    p.add_argument('--scene', metavar='FILE',
                   help='scene file (default: the embedded config/default_scene.yaml)')
    p.add_argument('--samples-per-rev', type=int, default=3600, metavar='N',
                   help='encoder samples per camshaft revolution (default 3600)')
    p.add_argument('--revolutions', type=float, default=1.0, metavar='N',
                   help='revolutions measured per feature [rev] (default 1)')
    p.add_argument('--rounds', type=int, default=1, metavar='N',
                   help='every feature measured N times in a row, each round later by '
                        'the run\'s duration (a long bag of repeated measurements; '
                        'default 1)')
    p.add_argument('--noise-um', type=float, default=0.0, metavar='X',
                   help='probe noise standard deviation [µm] (default 0)')
    p.add_argument('--encoder-noise-deg', type=float, default=0.0, metavar='X',
                   help='encoder noise standard deviation [deg] (default 0)')
    p.add_argument('--seed', type=int, default=0, metavar='N',
                   help='random seed: true angles and noise (default 0)')
    p.add_argument('--direction', type=int, choices=(1, -1), default=None,
                   help='override the scene\'s direction of rotation')
    p.add_argument('--wrapped', action='store_true',
                   help='encoder angles wrapped to [0, 2 pi) instead of unwrapped')
    p.add_argument('--reverse', action='store_true',
                   help='shaft turned backwards: encoder angle decreasing with time')
    p.add_argument('--start-deg', type=float, default=0.0, metavar='DEG',
                   help='encoder angle at the first sample [deg] (default 0)')
    p.add_argument('--zero-mm', type=float, default=0.5, metavar='MM',
                   help='probe reading on the base circle [mm] (arbitrary zero; default 0.5)')
    p.add_argument('--runout-um', type=float, default=0.0, metavar='X',
                   help='base-circle run-out amplitude [µm] (default 0)')
    p.add_argument('--rate', type=float, default=1000.0, metavar='HZ',
                   help='sample rate for the stamps [1/s] (default 1000)')
    p.add_argument('--samples-per-message', type=int, default=1, metavar='N',
                   help='N > 1: the samples in blocks of N per message on '
                        '/bench/joint_trajectory (trajectory_msgs/JointTrajectory) instead '
                        'of one per /bench/joint_states message (default 1)')
    add_compression(p)
    p.add_argument('--quiet', action='store_true', help='no progress output')
    return p


def run(args: argparse.Namespace) -> int:
    """Handler of ``cam-bench simulate``: simulate the bench into a new bag and print the
    truth (0; 2 for bad input)."""
    import json

    from cam_design.errors import InputError
    from cam_metrology.host.paths import default_scene_path
    from cam_metrology.simulation.bench import SimParams, scene_with_direction, write_sim_bag

    scene = load_scene_arg(args.scene or str(default_scene_path()))
    if args.direction is not None:
        scene = scene_with_direction(scene, args.direction)
    if args.samples_per_rev < 8:
        raise InputError('--samples-per-rev', args.samples_per_rev, 'at least 8')
    if args.rounds < 1:
        raise InputError('--rounds', args.rounds, 'an integer >= 1 (times every feature '
                         'is measured)')
    if args.samples_per_message < 1:
        raise InputError('--samples-per-message', args.samples_per_message,
                         'an integer >= 1 (1: one sample per JointState message)')
    params = SimParams(samples_per_rev=args.samples_per_rev, revolutions=args.revolutions,
                       wrapped=args.wrapped, reverse=args.reverse,
                       start_theta=math.radians(args.start_deg),
                       probe_noise=args.noise_um * 1e-6,
                       probe_zero_offset=args.zero_mm * 1e-3,
                       runout=args.runout_um * 1e-6, rate=args.rate,
                       encoder_noise=math.radians(args.encoder_noise_deg), seed=args.seed)
    try:
        params.validated()
    except InputError as exc:   # name the option and the value the user typed
        option = SIM_OPTIONS.get(exc.key)
        if option is None:
            raise
        raise InputError(option, getattr(args, option[2:].replace('-', '_')),
                         exc.expected) from None
    progress = None if args.quiet else _progress_printer()
    from cam_metrology.inputs.files import atomic_dir
    with atomic_dir(args.out, 'OUT_BAG') as tmp:   # complete bag or nothing (Ctrl-C too)
        result = write_sim_bag(tmp, scene, params, compression=args.compression,
                               progress=progress, rounds=args.rounds,
                               samples_per_message=args.samples_per_message)
    rounds = f' x {args.rounds} rounds' if args.rounds > 1 else ''
    print(f'wrote {args.out}: {result.sample_count * args.rounds} samples in '
          f'{len(result.features)} features{rounds}')
    print(json.dumps(result.truth, indent=2, sort_keys=True))
    return 0


# SimParams field -> the simulate option that sets it (in the option's own unit)
SIM_OPTIONS = {'samples_per_rev': '--samples-per-rev', 'revolutions': '--revolutions',
               'start_theta': '--start-deg', 'probe_zero_offset': '--zero-mm',
               'probe_noise': '--noise-um', 'encoder_noise': '--encoder-noise-deg',
               'rate': '--rate', 'runout': '--runout-um'}


def _progress_printer() -> Any:
    """A progress callback (done, total) printing at most every 5 % to stderr."""
    state = {'last': -1}

    def progress(done: int, total: int) -> None:
        if total < 50_000:
            return
        pct = int(100 * done / max(total, 1)) // 5 * 5
        if pct != state['last']:
            state['last'] = pct
            print(f'  simulate: {done}/{total} samples ({pct} %)', file=sys.stderr,
                  flush=True)
    return progress
