"""`cam-bench bag ...`: offline bag utilities (``info``, ``check``, ``recover``)."""
from __future__ import annotations

import argparse

from cam_metrology.cli.groups import add_group


def register(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add the ``bag`` group."""
    return add_group(sub, 'bag', 'inspect a bag, check its chunks, recover what is intact',
                     'Offline bag utilities (rosbags/mcap; no ROS graph).')
