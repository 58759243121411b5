"""The contract between node cores (pure Python) and their transports.

A *core* holds a node's logic with no rclpy import. It is fed decoded messages and
returns outputs (``cam_metrology.cores.outputs``). Three transports drive the same cores,
so live and offline results come from one code path:

* the ROS adapter (``cam_metrology.nodes``): one subscription per entry of
  ``subscriptions``; every callback calls ``handle`` and publishes what it returns;
  a timer calls ``tick`` for idle timeouts; shutdown calls ``finish``;
* the in-process replay (``cam_metrology.offline.replay``): reads a bag and calls ``handle``
  in recorded order, routing each output to the other cores that subscribe to it;
* tests, which call the methods directly.

Messages are duck-typed: rclpy message objects and rosbags-decoded dataclasses have
the same field names (``msg.header.frame_id``, ``msg.name``, ``msg.position``,
``msg.data``, ``msg.layout.dim``), and cores must only use those fields.
"""
from __future__ import annotations

from typing import Any, Mapping, Protocol

from cam_design.errors import InputError
from cam_metrology.cores.outputs import Output


class NodeCore(Protocol):
    """What every node core provides."""

    #: node name, e.g. 'metrology'
    name: str
    #: topic -> ROS type name ('sensor_msgs/msg/JointState') the core consumes
    subscriptions: dict[str, str]
    #: topic -> ROS type name the core may publish
    publications: dict[str, str]

    def handle(self, topic: str, msg: Any, stamp_ns: int) -> list[Output]:
        """Consume one message received at ``stamp_ns`` (ns); return outputs to publish."""

    def tick(self, now_ns: int) -> list[Output]:
        """Called periodically (live) or between messages (replay) for timeouts."""

    def finish(self) -> list[Output]:
        """End of the stream: flush pending features; return the last outputs."""


def merged_parameters(node: str, table: Mapping[str, tuple[Any, str]],
                      params: Mapping[str, Any] | None) -> dict[str, Any]:
    """A core's parameters: ``params`` over the defaults of ``table`` (PARAMETERS).

    An unknown name raises InputError naming ``<node>.<name>`` and listing the known
    ones, so a misspelled setting is never silently ignored. Values are not converted
    here; each core validates its own.
    """
    given = dict(params or {})
    unknown = sorted(set(given) - set(table))
    if unknown:
        raise InputError(f'{node}.{unknown[0]}', given[unknown[0]],
                         'one of ' + ', '.join(sorted(table)))
    return {name: given.get(name, default) for name, (default, _doc) in table.items()}
