"""`cam-bench run NODE`: run one node until SIGINT/SIGTERM.

Thin argparse glue over ``cam_metrology.nodes.run_node`` (rclpy is imported only inside
the handler).
"""
from __future__ import annotations

import argparse

NODE_CHOICES = ('metrology', 'reconstruction', 'dynamics', 'rig', 'bench-sim', 'recorder')


def register(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add the ``run`` parser."""
    p = sub.add_parser(
        'run', formatter_class=argparse.RawDescriptionHelpFormatter, help='run one node',
        description='Run one node until SIGINT/SIGTERM (bench-sim exits when done). '
                    'Parameters from --params (ROS parameter YAML; default '
                    'config/<node>.yaml) and --ros-args (e.g. --ros-args -p rate:=5000).')
    p.add_argument('node', choices=NODE_CHOICES)
    p.add_argument('--params', metavar='FILE', help='ROS parameter YAML')
    p.add_argument('--events-executor', action='store_true', default=None,
                   help='spin with rclpy.experimental.EventsExecutor')
    p.add_argument('--ros-args', dest='ros_args', nargs=argparse.REMAINDER, default=[],
                   help='ROS arguments (everything after it)')
    return p


def run(args: argparse.Namespace) -> int:
    """Handler of ``cam-bench run``: the node's exit code."""
    from pathlib import Path

    from cam_design.errors import InputError
    from cam_metrology.nodes import run_node
    if args.params and not Path(args.params).is_file():
        raise InputError('--params', args.params, 'an existing ROS parameter YAML file')
    return run_node(args.node, args.params, args.ros_args,
                    events_executor=args.events_executor)
