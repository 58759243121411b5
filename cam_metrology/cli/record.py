"""`cam-bench record OUT`: record live topics to a new bag until Ctrl-C.

Thin argparse glue over ``cam_metrology.nodes.recorder`` (rclpy is imported only inside
the handler).
"""
from __future__ import annotations

import argparse

from cam_metrology.cli.conventions import add_compression


def register(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add the ``record`` parser."""
    p = sub.add_parser(
        'record', formatter_class=argparse.RawDescriptionHelpFormatter,
        help='record live topics to a new bag until Ctrl-C',
        description='Record the bench topics and every node output topic (raw CDR, bytes '
                    'unchanged) to a new rosbag2/MCAP directory until SIGINT/SIGTERM; the '
                    'bag is always closed with its metadata.yaml.')
    p.add_argument('out', metavar='OUT', help='bag directory to create (must not exist)')
    p.add_argument('--topics', nargs='+', default=[], metavar='TOPIC',
                   help='extra topics: /topic or /topic:pkg/msg/Type (type taken from the '
                        'graph when omitted)')
    p.add_argument('--only', action='store_true',
                   help='record only --topics, not the default bench/output topics')
    add_compression(p)
    p.add_argument('--events-executor', action='store_true',
                   help='use rclpy.experimental.EventsExecutor (5-7x cheaper per message)')
    return p


def run(args: argparse.Namespace) -> int:
    """Handler of ``cam-bench record``: 0 when the bag was closed, 2 for bad input."""
    from pathlib import Path

    from cam_design.errors import InputError
    from cam_metrology.nodes.recorder import parse_topic_specs, run_recorder
    if Path(args.out).exists():
        raise InputError('OUT', args.out, 'a path that does not exist yet')
    if args.only and not args.topics:
        raise InputError('--only', 'without --topics', 'some --topics to record')
    parse_topic_specs(args.topics, '--topics')   # reject bad names before starting ROS
    ros_args = ['cam-bench', '--ros-args', '-p', f'record_defaults:={str(not args.only).lower()}',
                '-p', f'compression:={str(args.compression).lower()}']
    return run_recorder(ros_args, output=args.out, topics=args.topics,
                        events_executor=args.events_executor)
