"""`cam-bench design ...`: the cam_design library on the command line (one module per
sub-command: ``law``, ``check``, ``rocker``, ``profile``, ``optimize``)."""
from __future__ import annotations

import argparse

from cam_metrology.cli.groups import add_group


def register(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add the ``design`` group."""
    return add_group(
        sub, 'design', 'evaluate lift laws, cam profiles, design checks, rocker synthesis',
        'Design side of cam-bench: lift laws (h, h\', h\'\', h\'\'\'), cam profile '
        'coordinates for flat/roller/rocker followers, the design checks of '
        'Shang (1988) §2.1, the CG rocker optimum dimension synthesis and the '
        'optimisation of a lift law under design constraints.')
