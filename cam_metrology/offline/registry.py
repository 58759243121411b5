"""The node cores by node name (the pure-Python cores the ROS nodes and ``analyze`` run)."""
from __future__ import annotations

from typing import Any

from cam_metrology.dynamics.core import DynamicsCore
from cam_metrology.metrology.core import MetrologyCore
from cam_metrology.reconstruction.core import ReconstructionCore
from cam_metrology.rig.core import RigCore

CORES: dict[str, Any] = {
    'metrology': MetrologyCore,
    'reconstruction': ReconstructionCore,
    'dynamics': DynamicsCore,
}
#: cores of nodes that run on their own input (``cam-bench run rig``), not part of the
#: bench pipeline that ``analyze`` and ``demo`` run
RIG_CORES: dict[str, Any] = {'rig': RigCore}


def load_core_class(node: str) -> Any:
    """The core class of node ``node`` (KeyError for a name in neither ``CORES`` nor
    ``RIG_CORES``)."""
    return CORES[node] if node in CORES else RIG_CORES[node]


def available_cores() -> dict[str, Any]:
    """Node name -> core class, for every core."""
    return dict(CORES)
