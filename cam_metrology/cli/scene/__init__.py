"""`cam-bench scene ...`: scene files (docs/scene.md); ``scene check`` in ``check``."""
from __future__ import annotations

import argparse

from cam_metrology.cli.groups import add_group


def register(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add the ``scene`` group."""
    return add_group(sub, 'scene', 'validate a scene file',
                     'Scene files (docs/scene.md): validation and summary.')
