"""The scene file named on the command line (a path, or ``-`` for standard input)."""
from __future__ import annotations

from typing import Any


def load_scene_arg(path: str) -> Any:
    """The validated scene of ``path`` (``-``: YAML text on stdin)."""
    from cam_metrology.scene.parse import load_scene, parse_scene

    if path == '-':
        from cam_metrology.inputs.files import read_text_file
        return parse_scene(read_text_file('-', 'scene (YAML text)', 'FILE -'),
                           source='<stdin>')
    return load_scene(path)
