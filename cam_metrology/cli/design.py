"""`cam-bench design ...`: the cam_design library on the command line.

The group collects its subcommands from ``design_law`` (law, check, rocker) and
``design_profile`` (profile).
"""
from __future__ import annotations

import argparse

from cam_metrology.cli import register_modules

SUBMODULES = ('cam_metrology.cli.design_law', 'cam_metrology.cli.design_profile',
              'cam_metrology.cli.design_optimize')


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``design`` group."""
    parser = sub.add_parser(
        'design', help='evaluate lift laws, cam profiles, design checks, rocker synthesis',
        description='Design side of cam-bench: lift laws (h, h\', h\'\', h\'\'\'), cam profile '
                    'coordinates for flat/roller/rocker followers, the design checks of '
                    'Shang (1988) §2.1, and the CG rocker optimum dimension synthesis.')
    design_sub = parser.add_subparsers(dest='design_command', metavar='WHAT')
    register_modules(design_sub, SUBMODULES)
    parser.set_defaults(func=lambda args: parser.print_help() or 2)
