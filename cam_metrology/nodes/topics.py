"""rclpy side of the wire contract: ``QosSpec`` -> ``QoSProfile``, message classes.

The topics, types and QoS themselves are plain data in ``cam_metrology.wire.topics``
(no rclpy), shared with the bag writer, ``simulate`` and the offline replay; this
module only converts them for rclpy and subscribes to topics with the QoS their
publishers offer.
"""
from __future__ import annotations

import importlib
from typing import Any, Callable

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from cam_metrology.wire.topics import QosSpec


def profile(qos: QosSpec) -> QoSProfile:
    """The rclpy QoS profile of ``qos`` (keep last ``depth``, or keep all)."""
    return QoSProfile(
        history=HistoryPolicy.KEEP_ALL if qos.keep_all else HistoryPolicy.KEEP_LAST,
        depth=qos.depth,
        reliability=(ReliabilityPolicy.RELIABLE if qos.reliable
                     else ReliabilityPolicy.BEST_EFFORT),
        durability=(DurabilityPolicy.TRANSIENT_LOCAL if qos.transient_local
                    else DurabilityPolicy.VOLATILE))


def keep_all_profile(transient_local: bool = False) -> QoSProfile:
    """Reliable KEEP_ALL: nothing is overwritten; a full history blocks the writer
    (back-pressure) instead (bounded by the Fast DDS resource limits of
    ``runtime.FASTDDS_PROFILE``)."""
    return QoSProfile(history=HistoryPolicy.KEEP_ALL, depth=1,
                      reliability=ReliabilityPolicy.RELIABLE,
                      durability=(DurabilityPolicy.TRANSIENT_LOCAL if transient_local
                                  else DurabilityPolicy.VOLATILE))


def message_class(type_name: str) -> Any:
    """The rclpy message class of ``pkg/msg/Type`` (or ``pkg/Type``)."""
    parts = type_name.split('/')
    if len(parts) == 2:
        parts = [parts[0], 'msg', parts[1]]
    if len(parts) != 3 or not all(parts):
        raise ValueError(f'bad ROS type name {type_name!r}; expected pkg/msg/Type')
    return getattr(importlib.import_module(f'{parts[0]}.{parts[1]}'), parts[2])


def type_name_of(cls: Any) -> str:
    """``pkg/msg/Type`` of an rclpy message class."""
    return f'{cls.__module__.split(".")[0]}/msg/{cls.__name__}'


def offered_qos(node: Any, topic: str, depth: int) -> tuple[str, QosSpec] | None:
    """(type, QoS compatible with every publisher now in the graph) or None if none:
    transient local only if all publishers offer it, reliable only if all do."""
    infos = node.get_publishers_info_by_topic(topic)
    if not infos:
        return None
    reliable = all(i.qos_profile.reliability == ReliabilityPolicy.RELIABLE for i in infos)
    latched = all(i.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL for i in infos)
    return infos[0].topic_type, QosSpec(reliable, latched, depth)


class AdaptiveSubscriptions:
    """Subscribe to topics once a publisher is in the graph, with a matching QoS.

    What ``ros2 bag record`` does: a transient-local subscription would not match a
    volatile publisher, and a volatile one gets no history from a transient-local
    publisher, so the durability is chosen from the publishers' offered QoS. Polled
    every 0.1 s by a timer of ``node``; ``subscribe(topic, type, qos)`` does the work.
    """

    def __init__(self, node: Any, subscribe: Callable[[str, str, QosSpec], None]) -> None:
        self.node = node
        self.pending: dict[str, tuple[str | None, int]] = {}
        self._subscribe = subscribe
        self._timer: Any = None

    def add(self, topic: str, type_name: str | None = None, depth: int = 100) -> None:
        """Subscribe to ``topic`` when it has a publisher (type from the graph if None)."""
        self.pending[topic] = (type_name, depth)
        if self._timer is None:
            self._timer = self.node.create_timer(0.1, self.poll)
        self.poll()

    def poll(self) -> None:
        """Subscribe to every pending topic that has publishers now."""
        for topic, (type_name, depth) in list(self.pending.items()):
            found = offered_qos(self.node, topic, depth)
            if found is None:
                continue
            del self.pending[topic]
            self._subscribe(topic, type_name or found[0], found[1])
