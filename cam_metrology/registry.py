"""Node cores by node name, as ``'module:Class'`` strings (imported on demand)."""
from __future__ import annotations

import importlib
from typing import Any

CORES: dict[str, str] = {
    'metrology': 'cam_metrology.metrology.core:MetrologyCore',
    'reconstruction': 'cam_metrology.reconstruction.core:ReconstructionCore',
    'dynamics': 'cam_metrology.dynamics.core:DynamicsCore',
}


def load_core_class(node: str) -> Any:
    """The core class of ``node``; ModuleNotFoundError if it is not written yet."""
    module_name, class_name = CORES[node].split(':')
    return getattr(importlib.import_module(module_name), class_name)


def available_cores() -> dict[str, Any]:
    """Node name -> core class, for every core that exists in this tree."""
    found = {}
    for node in CORES:
        try:
            found[node] = load_core_class(node)
        except ModuleNotFoundError:
            continue
    return found
