"""The node cores by node name (the pure-Python cores the ROS nodes and ``analyze`` run)."""
from __future__ import annotations

from typing import Any

from cam_metrology.dynamics.core import DynamicsCore
from cam_metrology.metrology.core import MetrologyCore
from cam_metrology.reconstruction.core import ReconstructionCore

CORES: dict[str, Any] = {
    'metrology': MetrologyCore,
    'reconstruction': ReconstructionCore,
    'dynamics': DynamicsCore,
}


def load_core_class(node: str) -> Any:
    """The core class of node ``node`` (KeyError for a name not in ``CORES``)."""
    return CORES[node]


def available_cores() -> dict[str, Any]:
    """Node name -> core class, for every core."""
    return dict(CORES)
