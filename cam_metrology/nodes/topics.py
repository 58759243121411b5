"""Topics, message types and QoS of the ROS graph (architecture.md, docs/contract.md).

One table, used by every node, the recorder and replay, so that publishers and
subscribers always agree. QoS is kept as a plain ``QosSpec`` (reliable or not,
transient local or volatile, keep-last depth) that converts both to an rclpy
``QoSProfile`` and to the rosbag2 ``offered_qos_profiles`` YAML stored in bags.
The table agrees with ``bagio.TOPIC_TYPES`` / ``bagio.LATCHED_TOPICS`` (checked by
test/test_ros_adapter.py).
"""
from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Any, Callable

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy


@dataclass(frozen=True)
class QosSpec:
    """Reliability, durability and keep-last depth of a topic."""

    reliable: bool = True
    transient_local: bool = False
    depth: int = 10
    keep_all: bool = False   # subscriptions/publishers: KEEP_ALL (bags still say depth)

    def profile(self) -> QoSProfile:
        """The rclpy QoS profile (keep last ``depth``, or keep all)."""
        return QoSProfile(
            history=HistoryPolicy.KEEP_ALL if self.keep_all else HistoryPolicy.KEEP_LAST,
            depth=self.depth,
            reliability=(ReliabilityPolicy.RELIABLE if self.reliable
                         else ReliabilityPolicy.BEST_EFFORT),
            durability=(DurabilityPolicy.TRANSIENT_LOCAL if self.transient_local
                        else DurabilityPolicy.VOLATILE))

    def bag_yaml(self) -> str:
        """rosbag2 ``offered_qos_profiles`` YAML of this QoS (``bagio.qos_yaml``)."""
        from cam_metrology.bagio import qos_yaml
        return qos_yaml(transient_local=self.transient_local, depth=self.depth,
                        reliable=self.reliable)


LATCHED = QosSpec(reliable=True, transient_local=True, depth=1)
#: /bench/joint_states: reliable keep last 20 000 on both sides (a bench publisher asks
#: for depth >= 1000). Measured on this 2-core machine under a load of 5-6 from other
#: jobs: with 1000 the demo lost 28-38 % of the samples in the recorder, both ways a
#: keep-last history can drop: the reader's queue overflows when the Python callback
#: falls behind, and the writer overwrites samples a starved reader process never
#: received (Fast DDS re-sends only from the writer history). 20 000 samples (~3 MB)
#: are 10 s of slack at 2 kHz.
SAMPLES = QosSpec(reliable=True, transient_local=False, depth=20000, keep_all=True)
EVENTS = QosSpec(reliable=True, transient_local=False, depth=10)
#: node outputs: reliable depth 100 as in architecture.md, offered *transient local*
#: (compatible with every volatile subscriber): a subscriber that matches late, e.g. the
#: recorder on a loaded machine where discovery between two nodes took seconds and a
#: demo bag missed every /metrology/result, still gets the last 100 messages.
RESULTS = QosSpec(reliable=True, transient_local=True, depth=100)

STRING = 'std_msgs/msg/String'
TABLE = 'std_msgs/msg/Float64MultiArray'
STATUS = 'diagnostic_msgs/msg/DiagnosticArray'
JOINT_STATE = 'sensor_msgs/msg/JointState'

SCENE = '/bench/scene'
JOINT_STATES = '/bench/joint_states'
FEATURE_DONE = '/bench/feature_done'
TRUTH = '/bench/truth'
METROLOGY_REPORT = '/metrology/report'
METROLOGY_RESULT = '/metrology/result'
DIAGNOSTICS = '/diagnostics'

#: topic -> (ROS type name, QoS); the bench inputs first, then every node output.
TOPICS: dict[str, tuple[str, QosSpec]] = {
    SCENE: (STRING, LATCHED),
    JOINT_STATES: (JOINT_STATE, SAMPLES),
    FEATURE_DONE: (STRING, EVENTS),
    TRUTH: (STRING, LATCHED),
    METROLOGY_RESULT: (STATUS, RESULTS),
    '/metrology/lift': (TABLE, RESULTS),
    METROLOGY_REPORT: (STRING, LATCHED),
    '/reconstruction/profile': (TABLE, RESULTS),
    '/reconstruction/result': (STATUS, RESULTS),
    '/dynamics/valve_motion': (TABLE, RESULTS),
    '/dynamics/result': (STATUS, RESULTS),
}
#: every node's own health (input received and lost) on /diagnostics, the ROS
#: convention; not a bench topic or output of the contract's table, recorded too
DIAGNOSTICS_QOS = QosSpec(reliable=True, transient_local=True, depth=10)

BENCH_TOPICS = (SCENE, TRUTH, JOINT_STATES, FEATURE_DONE)
OUTPUT_TOPICS = tuple(t for t in TOPICS if t not in BENCH_TOPICS)


def keep_all_profile(transient_local: bool = False) -> QoSProfile:
    """Reliable KEEP_ALL: nothing is overwritten; a full history blocks the writer
    (back-pressure) instead (bounded by the Fast DDS resource limits of
    ``runtime.FASTDDS_PROFILE``)."""
    return QoSProfile(history=HistoryPolicy.KEEP_ALL, depth=1,
                      reliability=ReliabilityPolicy.RELIABLE,
                      durability=(DurabilityPolicy.TRANSIENT_LOCAL if transient_local
                                  else DurabilityPolicy.VOLATILE))


def qos_of(topic: str, default: QosSpec = RESULTS) -> QosSpec:
    """QoS of a known topic (as published and stored in bags), ``default`` for others."""
    if topic == DIAGNOSTICS:
        return DIAGNOSTICS_QOS
    return TOPICS[topic][1] if topic in TOPICS else default


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
