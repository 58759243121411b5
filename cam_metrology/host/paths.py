"""Where the package finds its config files, without the ament index.

In a source tree (editable install) the ``config/`` folder sits beside the package;
after ``pip install .`` or ``colcon build`` it is installed to
``<prefix>/share/cam_metrology/config``.
"""
from __future__ import annotations

import sys
from pathlib import Path

PACKAGE = 'cam_metrology'


def config_dir() -> Path:
    """The directory holding the default scene and the node parameter files."""
    source = Path(__file__).resolve().parents[2] / 'config'
    if source.is_dir():
        return source
    installed = Path(sys.prefix) / 'share' / PACKAGE / 'config'
    if installed.is_dir():
        return installed
    raise FileNotFoundError(f'no config directory: looked in {source} and {installed}')


def default_scene_path() -> Path:
    """The embedded default scene used by ``cam-bench demo``."""
    return config_dir() / 'default_scene.yaml'
