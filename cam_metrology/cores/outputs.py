"""Transport-neutral outputs of the node cores.

A node core (see ``core.NodeCore``) returns these plain objects; ``wire.layouts``
encodes them (the one encoder: the live nodes publish its bytes, the bag writer stores
them) and ``wire.plots`` derives their plot views. Each maps onto one standard ROS
message type:

* ``TableOutput``  -> ``std_msgs/msg/Float64MultiArray``: ``layout.dim[0]`` has
  ``label`` = the table's ``label`` (e.g. ``lobe_1`` or ``lobe_1/spline``) and
  ``size`` = rows; ``layout.dim[1]`` has ``label`` = the column names joined by ``,``
  and ``size`` = columns; ``data`` is row-major.
* ``StatusOutput`` -> ``diagnostic_msgs/msg/DiagnosticArray`` with one
  ``DiagnosticStatus`` per ``Status`` (values as key/value strings).
* ``TextOutput``   -> ``std_msgs/msg/String`` (JSON reports, notes).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Union

import numpy as np

OK, WARN, ERROR = 0, 1, 2   # diagnostic_msgs/DiagnosticStatus levels


@dataclass(frozen=True)
class TableOutput:
    """A 2-D table of float64 (rows x columns) published as Float64MultiArray."""

    topic: str
    label: str
    columns: tuple[str, ...]
    data: np.ndarray   # shape (rows, len(columns)), float64


@dataclass(frozen=True)
class Status:
    """One DiagnosticStatus: ``name`` (feature id), ``level`` OK/WARN/ERROR, values."""

    name: str
    level: int
    message: str
    values: dict[str, str] = field(default_factory=dict)
    hardware_id: str = ''


@dataclass(frozen=True)
class StatusOutput:
    """A DiagnosticArray of statuses."""

    topic: str
    statuses: tuple[Status, ...]
    stamp_ns: int = 0


@dataclass(frozen=True)
class TextOutput:
    """A std_msgs/String."""

    topic: str
    text: str


Output = Union[TableOutput, StatusOutput, TextOutput]
