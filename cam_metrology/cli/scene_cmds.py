"""`cam-bench scene check`, `cam-bench simulate`, `cam-bench bag info|check|recover`.

All work offline (no ROS graph): ``scene check`` validates a scene file and prints a
summary and its warnings; ``simulate`` writes a bag as the bench simulator would record
it (/bench/scene, /bench/truth, /bench/joint_states, /bench/feature_done); ``bag info``
summarises a bag; ``bag check`` verifies its MCAP chunks (CRC-32, sizes, framing) and
names the damaged ranges; ``bag recover`` saves what is intact of an interrupted or
damaged recording.
"""
from __future__ import annotations

import argparse
import math
import sys
from typing import Any

from cam_metrology.wire.topics import JOINT_TRAJECTORY, SAMPLE_TOPICS


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``scene`` group and the ``simulate`` command."""
    scene_sub = _group(sub, 'scene', 'validate a scene file',
                       'Scene files (docs/scene.md): validation and summary.')
    check = scene_sub.add_parser(
        'check', help='validate a scene file and print a summary',
        description='Validate the whole scene (exit 2 with a message naming the key, the '
                    'value and what was expected); print a summary and the warnings for '
                    'unknown keys.')
    check.add_argument('file', metavar='FILE', help='scene YAML file ("-" for stdin)')
    check.set_defaults(func=cmd_scene_check)

    sim = sub.add_parser(
        'simulate', help='simulate a bench measurement into a new bag (offline)',
        description='Simulate the measuring bench on a scene and write a rosbag2/MCAP bag '
                    'with /bench/scene, /bench/truth, /bench/joint_states and '
                    '/bench/feature_done, as the live bench-sim node would publish them. '
                    'The truth (true nose and pin angles, probe zero, noise) is printed.')
    sim.add_argument('out', metavar='OUT_BAG', help='new bag directory (must not exist)')
    sim.add_argument('--scene', metavar='FILE',
                     help='scene file (default: the embedded config/default_scene.yaml)')
    sim.add_argument('--samples-per-rev', type=int, default=3600, metavar='N',
                     help='encoder samples per camshaft revolution (default 3600)')
    sim.add_argument('--revolutions', type=float, default=1.0, metavar='N',
                     help='revolutions measured per feature (default 1)')
    sim.add_argument('--rounds', type=int, default=1, metavar='N',
                     help='every feature measured N times in a row, each round later by '
                          'the run\'s duration (a long bag of repeated measurements; '
                          'default 1)')
    sim.add_argument('--noise-um', type=float, default=0.0, metavar='X',
                     help='probe noise standard deviation in micrometres (default 0)')
    sim.add_argument('--encoder-noise-deg', type=float, default=0.0, metavar='X',
                     help='encoder noise standard deviation in degrees (default 0)')
    sim.add_argument('--seed', type=int, default=0, metavar='N',
                     help='random seed: true angles and noise (default 0)')
    sim.add_argument('--direction', type=int, choices=(1, -1), default=None,
                     help='override the scene\'s direction of rotation')
    sim.add_argument('--wrapped', action='store_true',
                     help='encoder angles wrapped to [0, 2 pi) instead of unwrapped')
    sim.add_argument('--reverse', action='store_true',
                     help='shaft turned backwards: encoder angle decreasing with time')
    sim.add_argument('--start-deg', type=float, default=0.0, metavar='DEG',
                     help='encoder angle at the first sample, degrees (default 0)')
    sim.add_argument('--zero-mm', type=float, default=0.5, metavar='MM',
                     help='probe reading on the base circle, mm (arbitrary zero; default 0.5)')
    sim.add_argument('--runout-um', type=float, default=0.0, metavar='X',
                     help='base-circle run-out amplitude, micrometres (default 0)')
    sim.add_argument('--rate', type=float, default=1000.0, metavar='HZ',
                     help='sample rate for the stamps, samples/s (default 1000)')
    sim.add_argument('--samples-per-message', type=int, default=1, metavar='N',
                     help='N > 1: the samples in blocks of N per message on '
                          '/bench/joint_trajectory (trajectory_msgs/JointTrajectory) instead '
                          'of one per /bench/joint_states message (default 1)')
    sim.add_argument('--compress', action=argparse.BooleanOptionalAction, default=True,
                     help='zstd chunk compression (default on; --no-compress: plain chunks)')
    sim.add_argument('--quiet', action='store_true', help='no progress output')
    sim.set_defaults(func=cmd_simulate)

    bag_sub = _group(sub, 'bag', 'inspect a bag, check its chunks, recover what is intact',
                     'Offline bag utilities (rosbags/mcap; no ROS graph).')
    info = bag_sub.add_parser(
        'info', help='topics, types, counts, QoS and the features of a bag',
        description='Print every topic with its type, message count and durability, '
                    'the scene\'s camshaft id and the samples per feature.')
    info.add_argument('bag', metavar='BAG', help='rosbag2 directory')
    info.set_defaults(func=cmd_bag_info)
    chk = bag_sub.add_parser(
        'check', help='verify the MCAP chunks of a bag (CRC-32, sizes, framing)',
        description='Read every chunk of every MCAP file of the bag: decompress it, '
                    'compare its size and its CRC-32 (where the writer stored one) and '
                    'check the records inside. Prints each damaged range (file bytes, log '
                    'times, messages per topic, reason); exit 0 intact, 1 damaged.')
    chk.add_argument('bag', metavar='BAG', help='rosbag2 directory or .mcap file')
    chk.set_defaults(func=cmd_bag_check)
    rec = bag_sub.add_parser(
        'recover', help='copy the intact part of an interrupted or damaged recording',
        description='A recording whose writer never closed has no metadata.yaml and no '
                    'MCAP footer; a copied or stored bag may have damaged chunks. This '
                    'copies every intact record (chunks that pass `bag check`) into a '
                    'new, closed bag and lists what was dropped.')
    rec.add_argument('src', metavar='SRC', help='bag directory or .mcap file')
    rec.add_argument('dst', metavar='DST', help='new bag directory (must not exist)')
    rec.set_defaults(func=cmd_bag_recover)


def _group(sub: argparse._SubParsersAction, name: str, help_text: str,
           description: str) -> argparse._SubParsersAction:
    """A command group ``name WHAT``; without WHAT it prints its help (exit 2)."""
    parser = sub.add_parser(name, help=help_text, description=description)
    parser.set_defaults(func=lambda args: parser.print_help() or 2)
    return parser.add_subparsers(dest=f'{name}_command', metavar='WHAT')


def _load(path: str) -> Any:
    from cam_metrology.scene.parse import load_scene, parse_scene

    if path == '-':
        from cam_metrology.inputs.files import read_text_file
        return parse_scene(read_text_file('-', 'scene (YAML text)', 'FILE -'),
                           source='<stdin>')
    return load_scene(path)


def scene_summary(scene: Any) -> list[str]:
    """Human-readable lines describing a validated scene."""
    deg = 180.0 / math.pi
    probe = scene.probe
    lines = [
        f'camshaft_id: {scene.camshaft_id or "(none)"}',
        f'direction: {scene.direction:+d}',
        f'probe: {probe.kind}' + (f' r={probe.radius * 1e3:g} mm' if probe.radius else ''),
        f'base circle radius: {scene.base_circle_radius * 1e3:g} mm',
        f'lobes: {len(scene.lobes)}',
    ]
    for lobe in scene.lobes:
        lo, hi = lobe.lift.support
        source = (f'lift_law {lobe.lift_spec.get("family")}' if lobe.lift_spec
                  else f'nominal file {lobe.nominal_file}' if lobe.nominal_file
                  else 'table')
        phase = ('-' if lobe.nominal_phase is None
                 else f'{lobe.nominal_phase * deg:.3f} deg')
        follower = lobe.follower.kind + (f' r={lobe.follower.radius * 1e3:g} mm'
                                         if lobe.follower.radius else '')
        lines.append(f'  {lobe.id}: {source}, design follower {follower}, '
                     f'max lift {lobe.lift.max_lift() * 1e3:.4f} mm, '
                     f'support [{lo * deg:.2f}, {hi * deg:.2f}] deg, nominal phase {phase}')
        tol = getattr(lobe, 'tolerances', None)
        lines.append(f'    tolerances: {tolerance_text(tol)}')
    pin, kw = scene.dowel_pin, getattr(scene, 'keyway', None)
    if kw is not None:
        depth = 'ball wider than the slot' if kw.depth is None else \
            f'depth {kw.depth * 1e3:g} mm'
        lines.append(f'keyway: width {kw.width * 1e3:g} mm, shaft r={kw.shaft_radius * 1e3:g} '
                     f'mm, ball r={kw.probe_radius * 1e3:g} mm, {depth}')
    elif pin is None:
        lines.append('dowel_pin: none')
    else:
        lines.append(f'dowel_pin: pin r={pin.pin_radius * 1e3:g} mm, circle '
                     f'r={pin.circle_radius * 1e3:g} mm, ball r={pin.probe_radius * 1e3:g} mm')
    crank = getattr(scene, 'crank', None)
    if crank is not None:
        roles = ', '.join(f'{lb.id} {lb.role} cyl {lb.cylinder}' for lb in scene.lobes
                          if lb.role) or 'no lobe has a role'
        lines.append(f'crank: cylinder 1 TDC {crank.tdc_deg:g} cam deg from the '
                     f'{scene.datum_id.replace("_", " ")}; {roles}')
    compute = 'all the data allows' if scene.compute is None else ', '.join(
        sorted(scene.compute))
    lines.append(f'compute: {compute}')
    vt = scene.valve_train
    if vt is None:
        lines.append('valve_train: none')
    else:
        speeds = ', '.join(f'{v:g}' for v in vt.cam_speed_rpm)
        lines.append(f'valve_train: {vt.model}, rocker ratio {vt.rocker_ratio:g}, '
                     f'lash {vt.lash * 1e3:g} mm, cam speeds {speeds} rpm')
    datum = getattr(scene, 'datum_tolerance_deg', None)
    if datum is not None:
        centre = 'keyway' if getattr(scene, 'keyway', None) is not None else 'pin'
        lines.append(f'datum: {centre} centre {_band(datum, "deg")}')
    lines.append(f'idle_timeout: {scene.idle_timeout:g} s')
    return lines


def _band(band: Any, unit: str) -> str:
    """'+-10 um' for a symmetric band (lower, upper), else '[-5, +10] um'."""
    lo, hi = band
    if lo == -hi:
        return f'+-{hi:g} {unit}'
    return f'[{lo:+g}, {hi:+g}] {unit}'


def tolerance_text(tol: Any) -> str:
    """The limits of one lobe in one line ('none' when it has none)."""
    if tol is None or not tol.any():
        return 'none (no verdict for this lobe)'
    parts = []
    if tol.lift_error_um is not None:
        parts.append(f'lift error {_band(tol.lift_error_um, "µm")}')
    for z in tol.lift_error_zones:
        parts.append(f'lift error {_band(z.band_um, "µm")} over {z.from_deg:g}..{z.to_deg:g} deg')
    if tol.max_lift_um is not None:
        parts.append(f'max lift {_band(tol.max_lift_um, "µm")}')
    if tol.centreline_deg is not None:
        parts.append(f'centreline {_band(tol.centreline_deg, "deg")} at '
                     f'{tol.checking_height_mm:g} mm')
    if tol.duration_deg is not None:
        parts.append(f'duration {_band(tol.duration_deg, "deg")} at '
                     f'{tol.checking_height_mm:g} mm')
    if tol.phase_deg is not None:
        parts.append(f'phase {_band(tol.phase_deg, "deg")}')
    if tol.runout_max_um is not None:
        parts.append(f'base-circle run-out <= {tol.runout_max_um:g} µm')
    for name, limit, unit in (('velocity', tol.velocity_error_max_mm_per_rad, 'mm/rad'),
                              ('acceleration', tol.acceleration_error_max_mm_per_rad2,
                               'mm/rad²')):
        if limit is not None:
            parts.append(f'{name} error <= {limit:g} {unit}')
    for z in tol.derivative_error_zones:
        limits = [f'{name} error <= {v:g} {unit}' for name, v, unit in (
            ('velocity', z.velocity_max_mm_per_rad, 'mm/rad'),
            ('acceleration', z.acceleration_max_mm_per_rad2, 'mm/rad²')) if v is not None]
        parts.append(f'{" and ".join(limits)} over {z.from_deg:g}..{z.to_deg:g} deg')
    return '; '.join(parts)


def cmd_scene_check(args: argparse.Namespace) -> int:
    """Validate a scene file; print the summary and the warnings."""
    scene = _load(args.file)
    print(f'{args.file}: valid scene')
    for line in scene_summary(scene):
        print(f'  {line}')
    for warning in scene.warnings:
        print(f'warning: {warning}')
    return 0


def cmd_simulate(args: argparse.Namespace) -> int:
    """Simulate the bench into a new bag and print the truth."""
    import json

    from cam_design.errors import InputError
    from cam_metrology.host.paths import default_scene_path
    from cam_metrology.simulation.bench import SimParams, scene_with_direction, write_sim_bag

    scene = _load(args.scene or str(default_scene_path()))
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
        run = write_sim_bag(tmp, scene, params, compression=args.compress,
                            progress=progress, rounds=args.rounds,
                            samples_per_message=args.samples_per_message)
    rounds = f' x {args.rounds} rounds' if args.rounds > 1 else ''
    print(f'wrote {args.out}: {run.sample_count * args.rounds} samples in '
          f'{len(run.features)} features{rounds}')
    print(json.dumps(run.truth, indent=2, sort_keys=True))
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


def cmd_bag_info(args: argparse.Namespace) -> int:
    """Summarise a bag."""
    from cam_metrology import bagio
    from cam_metrology.wire.topics import SCENE as SCENE_TOPIC

    topics = bagio.bag_topics(args.bag)
    qos = bagio.topic_qos_yaml(args.bag)
    print(f'{args.bag}:')
    for topic, (msgtype, count) in sorted(topics.items()):
        latched = 'transient_local' in qos.get(topic, '')
        print(f'  {topic:28s} {msgtype:40s} {count:9d}' + ('  latched' if latched else ''))
    if SCENE_TOPIC in topics:
        from cam_metrology.scene.recorded import bag_scenes
        for sc in bag_scenes(args.bag):
            if sc.scene is None:
                print(f'scene: invalid: {sc.error}')
                continue
            scene = sc.scene
            print(f'scene: {scene.camshaft_id or "(no id)"}, {len(scene.lobes)} lobes, '
                  f'{_datum_words(scene)}, '
                  f'direction {scene.direction:+d} (log time {sc.stamp_ns / 1e9:.6f} s)')
    if any(t in topics for t in SAMPLE_TOPICS):
        _print_samples(args.bag)
    return 0


def _print_samples(bag: str) -> None:
    """The samples of a bag, per feature, and the unusable ones (streamed: memory
    does not grow with the bag)."""
    import numpy as np

    from cam_metrology import bagio

    summary = bagio.JointSummary()
    counts: dict[str, int] = {}
    first = last = None
    blocks = bagio.bag_topics(bag).get(JOINT_TRAJECTORY, ('', 0))[1]   # messages
    for block in bagio.iter_joint_states(bag):
        summary.add(block)
        if len(block):
            lo, hi = int(block.log_ns.min()), int(block.log_ns.max())
            first = lo if first is None else min(first, lo)
            last = hi if last is None else max(last, hi)
        ids, n = np.unique(block.frame_id, return_counts=True)
        for fid, k in zip(ids.tolist(), n.tolist()):
            counts[str(fid)] = counts.get(str(fid), 0) + int(k)
    if first is not None and last is not None:
        inside = f' (in {blocks} blocks on {JOINT_TRAJECTORY})' if blocks else ''
        print(f'samples: {summary.count}{inside} over {(last - first) / 1e9:.3f} s; '
              f'joints {list(summary.names)}')
    for fid in summary.features:
        print(f'  {fid}: {counts.get(fid, 0)} samples')
    for issue in summary.issues:
        print(f'unusable samples: {issue.text(summary.count)}')


def cmd_bag_check(args: argparse.Namespace) -> int:
    """Verify the MCAP files of a bag; 0 intact, 1 damaged."""
    from pathlib import Path

    from cam_design.errors import InputError
    from cam_metrology.bagio.check import describe, scan_bag

    if not Path(args.bag).exists():
        raise InputError('BAG', args.bag, 'an existing rosbag2 directory or .mcap file')
    scans = scan_bag(args.bag)
    if not scans:
        raise InputError('BAG', args.bag, 'a bag with MCAP storage (.mcap files)')
    damaged = 0
    for scan in scans:
        crc = (f'{scan.crc_chunks} with a CRC-32' if scan.crc_chunks
               else 'none with a CRC-32: payload damage in uncompressed chunks is '
                    'undetectable')
        print(f'{scan.file}: {scan.chunks} chunks ({crc})')
        for d in scan.damaged:
            print(f'  damaged: {describe(d)}')
        damaged += len(scan.damaged)
    if damaged:
        print(f'cam-bench bag check: {damaged} damaged range(s) in {args.bag}; '
              '`cam-bench bag recover` copies what is intact', file=sys.stderr)
        return 1
    print('intact')
    return 0


def cmd_bag_recover(args: argparse.Namespace) -> int:
    """Recover an interrupted or damaged recording."""
    from cam_metrology import bagio
    from cam_metrology.bagio.check import describe

    from cam_metrology.inputs.files import atomic_dir
    with atomic_dir(args.dst, 'DST') as tmp:   # a whole recovered bag or nothing
        counts = bagio.recover_bag(args.src, tmp)
    print(f'recovered into {args.dst}:')
    for topic, n in sorted(counts.items()):
        print(f'  {topic}: {n}')
    for d in counts.damaged:   # an empty range: nothing dropped, only the end missing
        print(f'{"dropped" if d.end > d.start else "note"}: {describe(d)}')
    return 0


def _datum_words(scene: Any) -> str:
    """'a dowel pin', 'a keyway' or 'no dowel pin' (bag info)."""
    if getattr(scene, 'keyway', None) is not None:
        return 'a keyway'
    return 'a dowel pin' if scene.dowel_pin is not None else 'no dowel pin'
