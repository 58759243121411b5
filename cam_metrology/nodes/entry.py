"""Console-script entry points, one per node (for ``setup.py`` / ``ros2 run``).

``ros2 run cam_metrology metrology --ros-args --params-file FILE`` would call
``metrology()``; each passes its argv (the ``--ros-args ...``) to ``run_node``.
"""
from __future__ import annotations

import sys

from cam_metrology.nodes import run_node


def _main(name: str) -> None:
    argv = sys.argv[1:]
    try:
        code = run_node(name, None, argv)
    except KeyboardInterrupt:
        code = 130
    sys.exit(code)


def metrology() -> None:
    """The metrology node."""
    _main('metrology')


def reconstruction() -> None:
    """The reconstruction node."""
    _main('reconstruction')


def dynamics() -> None:
    """The dynamics node."""
    _main('dynamics')


def bench_sim() -> None:
    """The bench simulator node."""
    _main('bench-sim')


def recorder() -> None:
    """The recorder node."""
    _main('recorder')


def rig() -> None:
    """The valve-train rig node."""
    _main('rig')
