"""`cam-bench demo`: simulate a bench, run the nodes live over ROS 2, record a bag, print
the report (``--rig``: the valve-train rig loop instead).

Thin argparse glue over ``cam_metrology.nodes`` (rclpy is imported only inside the
handler, so ``cam-bench --help`` and the numeric commands never load ROS).
"""
from __future__ import annotations

import argparse

from cam_metrology.cli.arg_types import non_negative


def register(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add the ``demo`` parser."""
    p = sub.add_parser(
        'demo', formatter_class=argparse.RawDescriptionHelpFormatter,
        help='simulate a bench, run the nodes live over ROS 2, record a bag, print the report',
        description='In an isolated ROS domain (claimed 1..100, localhost discovery, '
                    'temporary ROS_LOG_DIR) start the recorder, the metrology, '
                    'reconstruction and dynamics nodes (whichever cores exist; missing ones '
                    'are reported) and the bench simulator as `cam-bench run` subprocesses; '
                    'wait for the metrology report; stop everything (SIGINT, then SIGTERM); '
                    'print where the bag is and a per-feature report against /bench/truth.')
    p.add_argument('--scene', metavar='FILE',
                   help='scene YAML (default: config/default_scene.yaml)')
    p.add_argument('--out', metavar='DIR',
                   help='bag directory to create (default: demo-out/demo_<UTC time>)')
    p.add_argument('--json', metavar='FILE|-', help='also write the metrology report JSON (- for '
                                                    'standard output)')
    p.add_argument('--rate', type=non_negative, metavar='HZ',
                   help='samples/s of the simulator [1/s] (default: config/bench_sim.yaml)')
    p.add_argument('--timeout', type=float, default=0.0, metavar='S',
                   help='overall deadline [s] (default 600)')
    p.add_argument('--sim', action='append', default=[], metavar='NAME:=VALUE',
                   help='a bench-sim parameter (SimParams field), e.g. --sim seed:=3 '
                        '--sim probe_noise:=1e-6 (repeatable)')
    p.add_argument('--recorder-executor', choices=('single', 'events'), default='single',
                   help='executor of the recorder: single (SingleThreadedExecutor, default: '
                        'log times = publication times, so the bag keeps the order the '
                        'bench published in) or events (rclpy.experimental.EventsExecutor: '
                        'cheaper, receive-time log stamps)')
    p.add_argument('--rig', action='store_true',
                   help='the valve-train rig loop instead: bench-sim in rig mode '
                        '(its own process) publishes rig runs of config/rig_scene.yaml (or '
                        '--scene) with its rig.true_valve_train in blocks to the rig node '
                        'and the recorder; calibrate on the recorded bag, print the jump '
                        'speed nominal vs calibrated')
    p.add_argument('--keep-logs', action='store_true', help='keep the node logs directory')
    return p


def run(args: argparse.Namespace) -> int:
    """Handler of ``cam-bench demo``: the demo's exit code."""
    if args.rig:
        from cam_metrology.nodes.rig_demo import run_rig_demo
        return run_rig_demo(args.scene, args.out, args.timeout or 120.0)
    from cam_metrology.nodes.bench_sim import sim_param_table
    from cam_metrology.nodes.demo import DemoOptions, run_demo
    from cam_metrology.inputs.params import parse_assignments
    # names and types checked before anything starts (bench-sim would ignore an unknown name)
    parse_assignments(args.sim, 'SimParams', sim_param_table(), '--sim')
    return run_demo(DemoOptions(scene=args.scene, out=args.out, rate=args.rate,
                                timeout=args.timeout, json_out=args.json,
                                events_executor=args.recorder_executor == 'events',
                                keep_logs=args.keep_logs, sim_params=list(args.sim)))
