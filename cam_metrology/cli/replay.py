"""`cam-bench replay BAG`: republish a bag with its timing scaled.

Thin argparse glue over ``cam_metrology.nodes.replayer`` (rclpy is imported only inside
the handler).
"""
from __future__ import annotations

import argparse

from cam_metrology.cli.arg_types import count, non_negative


def register(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add the ``replay`` parser."""
    p = sub.add_parser(
        'replay', formatter_class=argparse.RawDescriptionHelpFormatter,
        help='republish a bag with its timing scaled by R',
        description='Republish the recorded CDR bytes of a bag (latched topics first, '
                    'transient local), wait until every expected subscriber is matched '
                    '(--expect, default: the metrology node and the recorder; deadline '
                    '--match-timeout, then exit 4 with nothing streamed unless '
                    '--start-anyway), then stream the '
                    'rest with the original timing divided by --rate.')
    p.add_argument('bag', metavar='BAG', help='rosbag2 directory')
    p.add_argument('--topics', nargs='+', metavar='TOPIC', help='only these topics')
    p.add_argument('--rate', type=non_negative, default=1.0, metavar='R',
                   help='time scale: 2 = twice as fast; 0 = as fast as possible (default 1)')
    p.add_argument('--loop', action='store_true', help='replay again until Ctrl-C')
    p.add_argument('--expect', nargs='+', default=['metrology', 'recorder'], metavar='NODE',
                   help='nodes that must subscribe before the first sample goes out: NODE '
                        '(on the busiest topic, the samples) or NODE:/topic; "none" for no '
                        'node (default: metrology recorder)')
    p.add_argument('--wait-subscribers', type=count, default=1, metavar='N',
                   help='also at least this many subscriptions on the busiest topic (default 1)')
    p.add_argument('--match-timeout', type=non_negative, default=10.0, metavar='S',
                   help='time to wait for them [s] (default 10; then exit 4, nothing replayed)')
    p.add_argument('--start-anyway', action='store_true',
                   help='at the deadline replay anyway (with a warning naming who is missing)')
    return p


def run(args: argparse.Namespace) -> int:
    """Handler of ``cam-bench replay``: the replayer's exit code."""
    from cam_metrology.nodes.replayer import parse_expect, run_replay
    parse_expect(args.expect)   # a malformed name: one line, exit 2, before ROS starts
    return run_replay(args.bag, args.rate, loop=args.loop, topics=args.topics,
                      wait_subscribers=args.wait_subscribers, match_timeout=args.match_timeout,
                      expect=args.expect, start_anyway=args.start_anyway)
