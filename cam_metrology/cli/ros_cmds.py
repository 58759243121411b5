"""`cam-bench demo | record | replay | run`: the live ROS 2 commands.

Thin argparse glue over ``cam_metrology.nodes`` (rclpy is imported only inside the
handlers, so ``cam-bench --help`` and the numeric commands never load ROS).
"""
from __future__ import annotations

import argparse
from typing import Any

NODE_CHOICES = ('metrology', 'reconstruction', 'dynamics', 'rig', 'bench-sim', 'recorder')


def _positive_or_zero(text: str) -> float:
    """argparse type: a finite number >= 0."""
    try:
        value = float(text)
    except ValueError:
        value = float('nan')
    if not 0.0 <= value < float('inf'):
        raise argparse.ArgumentTypeError(f'got {text!r}; expected a finite number >= 0')
    return value


def _count(text: str) -> int:
    """argparse type: an integer >= 0."""
    try:
        value = int(text)
    except ValueError:
        value = -1
    if value < 0:
        raise argparse.ArgumentTypeError(f'got {text!r}; expected an integer >= 0')
    return value


def register(subparsers: Any) -> None:
    """Add the ``demo``, ``record``, ``replay`` and ``run`` subcommands."""
    fmt = argparse.RawDescriptionHelpFormatter

    p = subparsers.add_parser(
        'demo', formatter_class=fmt,
        help='simulate a bench, run the nodes live over ROS 2, record a bag, print the report',
        description='In an isolated ROS domain (claimed 1..100, localhost discovery, '
                    'temporary ROS_LOG_DIR) start the recorder, the metrology, '
                    'reconstruction and dynamics nodes (whichever cores exist; missing ones '
                    'are reported) and the bench simulator as `cam-bench run` subprocesses; '
                    'wait for the metrology report; stop everything (SIGINT, then SIGTERM); '
                    'print where the bag is and a per-feature report against /bench/truth.')
    p.add_argument('--scene', help='scene YAML (default: config/default_scene.yaml)')
    p.add_argument('--out', help='bag directory to create (default: demo-out/demo_<UTC time>)')
    p.add_argument('--rate', type=_positive_or_zero,
                   help='samples/s of the simulator (default: config/bench_sim.yaml)')
    p.add_argument('--timeout', type=float, default=0.0,
                   help='overall deadline in s (default 600)')
    p.add_argument('--json', metavar='FILE', help="also write the metrology report JSON ('-': "
                                                  'stdout)')
    p.add_argument('--sim', action='append', default=[], metavar='NAME:=VALUE',
                   help='a bench-sim parameter (SimParams field), e.g. --sim seed:=3 '
                        '--sim probe_noise:=1e-6 (repeatable)')
    p.add_argument('--recorder-executor', choices=('single', 'events'), default='single',
                   help='executor of the recorder: single (SingleThreadedExecutor, default: '
                        'log times = publication times, so the bag keeps the order the '
                        'bench published in) or events (rclpy.experimental.EventsExecutor: '
                        'cheaper, receive-time log stamps)')
    p.add_argument('--keep-logs', action='store_true', help='keep the node logs directory')
    p.add_argument('--rig', action='store_true',
                   help='the valve-train rig loop instead: bench-sim in rig mode '
                        '(its own process) publishes rig runs of config/rig_scene.yaml (or '
                        '--scene) with its rig.true_valve_train in blocks to the rig node '
                        'and the recorder; calibrate on the recorded bag, print the jump '
                        'speed nominal vs calibrated')
    p.set_defaults(func=_demo)

    p = subparsers.add_parser(
        'record', formatter_class=fmt, help='record live topics to a new bag until Ctrl-C',
        description='Record the bench topics and every node output topic (raw CDR, bytes '
                    'unchanged) to a new rosbag2/MCAP directory until SIGINT/SIGTERM; the '
                    'bag is always closed with its metadata.yaml.')
    p.add_argument('out', help='bag directory to create (must not exist)')
    p.add_argument('--topics', nargs='+', default=[], metavar='TOPIC',
                   help='extra topics: /topic or /topic:pkg/msg/Type (type taken from the '
                        'graph when omitted)')
    p.add_argument('--only', action='store_true',
                   help='record only --topics, not the default bench/output topics')
    p.add_argument('--compression', action=argparse.BooleanOptionalAction, default=True,
                   help='zstd chunk compression (default on; --no-compression: plain chunks)')
    p.add_argument('--events-executor', action='store_true',
                   help='use rclpy.experimental.EventsExecutor (5-7x cheaper per message)')
    p.set_defaults(func=_record)

    p = subparsers.add_parser(
        'replay', formatter_class=fmt, help='republish a bag with its timing scaled by R',
        description='Republish the recorded CDR bytes of a bag (latched topics first, '
                    'transient local), wait until every expected subscriber is matched '
                    '(--expect, default: the metrology node and the recorder; deadline '
                    '--match-timeout, then exit 4 with nothing streamed unless '
                    '--start-anyway), then stream the '
                    'rest with the original timing divided by --rate.')
    p.add_argument('bag', help='rosbag2 directory')
    p.add_argument('--rate', type=_positive_or_zero, default=1.0,
                   help='time scale: 2 = twice as fast; 0 = as fast as possible (default 1)')
    p.add_argument('--loop', action='store_true', help='replay again until Ctrl-C')
    p.add_argument('--topics', nargs='+', metavar='TOPIC', help='only these topics')
    p.add_argument('--expect', nargs='+', default=['metrology', 'recorder'], metavar='NODE',
                   help='nodes that must subscribe before the first sample goes out: NODE '
                        '(on the busiest topic, the samples) or NODE:/topic; "none" for no '
                        'node (default: metrology recorder)')
    p.add_argument('--wait-subscribers', type=_count, default=1,
                   help='also at least this many subscriptions on the busiest topic '
                        '(default 1)')
    p.add_argument('--match-timeout', type=_positive_or_zero, default=10.0,
                   help='s to wait for them (default 10; then exit 4, nothing replayed)')
    p.add_argument('--start-anyway', action='store_true',
                   help='at the deadline replay anyway (with a warning naming who is missing)')
    p.set_defaults(func=_replay)

    p = subparsers.add_parser(
        'run', formatter_class=fmt, help='run one node',
        description='Run one node until SIGINT/SIGTERM (bench-sim exits when done). '
                    'Parameters from --params (ROS parameter YAML; default '
                    'config/<node>.yaml) and --ros-args (e.g. --ros-args -p rate:=5000).')
    p.add_argument('node', choices=NODE_CHOICES)
    p.add_argument('--params', metavar='FILE', help='ROS parameter YAML')
    p.add_argument('--events-executor', action='store_true', default=None,
                   help='spin with rclpy.experimental.EventsExecutor')
    p.add_argument('--ros-args', dest='ros_args', nargs=argparse.REMAINDER, default=[],
                   help='ROS arguments (everything after it)')
    p.set_defaults(func=_run)


def _run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from cam_design.errors import InputError
    from cam_metrology.nodes import run_node
    if args.params and not Path(args.params).is_file():
        raise InputError('--params', args.params, 'an existing ROS parameter YAML file')
    return run_node(args.node, args.params, args.ros_args,
                    events_executor=args.events_executor)


def _record(args: argparse.Namespace) -> int:
    from pathlib import Path

    from cam_design.errors import InputError
    from cam_metrology.nodes.recorder import run_recorder
    if Path(args.out).exists():
        raise InputError('OUT', args.out, 'a path that does not exist yet')
    if args.only and not args.topics:
        raise InputError('--only', 'without --topics', 'some --topics to record')
    from cam_metrology.nodes.recorder import parse_topic_specs
    parse_topic_specs(args.topics, '--topics')   # reject bad names before starting ROS
    ros_args = ['cam-bench', '--ros-args', '-p', f'record_defaults:={str(not args.only).lower()}',
                '-p', f'compression:={str(args.compression).lower()}']
    return run_recorder(ros_args, output=args.out, topics=args.topics,
                        events_executor=args.events_executor)


def _replay(args: argparse.Namespace) -> int:
    from cam_metrology.nodes.replayer import run_replay
    from cam_metrology.nodes.replayer import parse_expect
    parse_expect(args.expect)   # a malformed name: one line, exit 2, before ROS starts
    return run_replay(args.bag, args.rate, loop=args.loop, topics=args.topics,
                      wait_subscribers=args.wait_subscribers, match_timeout=args.match_timeout,
                      expect=args.expect, start_anyway=args.start_anyway)


def _demo(args: argparse.Namespace) -> int:
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
