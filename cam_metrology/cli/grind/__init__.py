"""`cam-bench grind ...`: the cam-grinding computations of cam_design.grinding (one
module per sub-command: ``table``, ``master``, ``errors``, ``correct``; the shared inputs
in ``inputs``)."""
from __future__ import annotations

import argparse

from cam_metrology.cli.groups import add_group


def register(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add the ``grind`` group."""
    return add_group(
        sub, 'grind', 'cam grinding: wheel-centre table, master cam, machining errors',
        'Cam grinding (docs/grinding.md): the wheel-centre path of a grinding wheel on the '
        'cam, the master-cam follower lift of a rocking-cradle grinder, machining-error '
        'sensitivities and a measure -> correct loop. Lengths in m, angles in rad in the '
        'files.')
