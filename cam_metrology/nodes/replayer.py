"""Replay of a bag on live ROS 2 topics: the recorded CDR bytes, republished unchanged.

* Publishers per topic with the bag's type; reliable KEEP_ALL (lossless replay with
  back-pressure, docs/ros.md) and transient local for the latched topics
  (/bench/scene, /bench/truth, /metrology/report, or any topic the bag recorded as
  transient local).
* The latched topics' first messages are published first, then the player waits
  (deadline) until ``wait_subscribers`` subscriptions matched the busiest topic (the
  sample stream; other topics may legitimately have no subscriber) and acknowledged the
  latched messages, then streams the rest in log-time order at
  ``t_wall0 + (t_bag - t_bag0) / rate`` (``rate`` <= 0: as fast as possible).
* ``publish()`` of bytes sends them as a serialized message (nothing re-encoded); an
  ``RCLError`` from a blocked KEEP_ALL writer is retried until a deadline.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Sequence

from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from cam_metrology.nodes.runtime import publish_retrying, wait_all_acked
from cam_metrology.nodes.topics import TOPICS, message_class


@dataclass
class ReplayStats:
    """What a replay did: messages per topic, wall time [s], lateness of the schedule."""

    counts: dict[str, int] = field(default_factory=dict)
    wall_s: float = 0.0
    bag_span_s: float = 0.0
    max_late_s: float = 0.0
    retries: int = 0
    matched: bool = True

    @property
    def total(self) -> int:
        """Messages published."""
        return sum(self.counts.values())


def _latched_in_bag(conn: Any) -> bool:
    profiles = getattr(getattr(conn, 'ext', None), 'offered_qos_profiles', None) or []
    return any(getattr(p.durability, 'name', '') == 'TRANSIENT_LOCAL' for p in profiles)


def bag_connections(path: str | Path) -> dict[str, tuple[str, bool]]:
    """topic -> (ROS type, latched) of a bag (latched: recorded as transient local or
    latched by architecture.md)."""
    from cam_metrology.bagio import _open_reader   # shared validation of the bag path

    reader = _open_reader(path)
    try:
        out: dict[str, tuple[str, bool]] = {}
        for conn in reader.connections:
            known = TOPICS.get(conn.topic)
            latched = _latched_in_bag(conn) or bool(known and known[1].transient_local)
            out[conn.topic] = (conn.msgtype, latched or out.get(conn.topic, ('', False))[1])
        return out
    finally:
        reader.close()


def replay_qos(latched: bool) -> QoSProfile:
    """Reliable KEEP_ALL; transient local for latched topics."""
    return QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE,
                      durability=(DurabilityPolicy.TRANSIENT_LOCAL if latched
                                  else DurabilityPolicy.VOLATILE))


def select_topics(available: Sequence[str], topics: Sequence[str] | None) -> set[str]:
    """The topics to replay: ``topics`` (all when empty), each of which must be in
    ``available``; InputError('--topics', name, the bag's topics) otherwise."""
    from cam_design.errors import InputError
    if not topics:
        return set(available)
    for topic in topics:
        if topic not in available:
            raise InputError('--topics', topic,
                             f'a topic of the bag: {", ".join(sorted(available))}')
    return set(topics)


class ReplayNode(Node):
    """Publishers for every topic of a bag and the paced replay loop."""

    def __init__(self, bag: str | Path, *, context: Any = None, node_name: str = 'replay',
                 topics: Sequence[str] | None = None) -> None:
        super().__init__(node_name, context=context)
        self.bag = Path(bag)
        conns = bag_connections(self.bag)
        wanted = select_topics(list(conns), topics)
        conns = {t: v for t, v in conns.items() if t in wanted}
        self.latched = {t for t, (_, lat) in conns.items() if lat}
        from cam_metrology.bagio import bag_topics
        counts = {t: n for t, (_, n) in bag_topics(self.bag).items() if t in conns}
        #: the topic with the most messages (the sample stream): the one waited for
        self.main_topic = max(counts, key=lambda t: counts[t]) if counts else None
        self.pubs = {t: self.create_publisher(message_class(type_name), t, replay_qos(lat))
                     for t, (type_name, lat) in conns.items()}

    def matched_counts(self) -> dict[str, int]:
        """topic -> matched subscriptions."""
        return {t: p.get_subscription_count() for t, p in self.pubs.items()}

    def _publish(self, topic: str, data: bytes, stats: ReplayStats, timeout: float) -> None:
        stats.retries += publish_retrying(self.pubs[topic], data, timeout)
        stats.counts[topic] = stats.counts.get(topic, 0) + 1

    def play(self, rate: float = 1.0, wait_subscribers: int = 1, match_timeout: float = 10.0,
             should_stop: Callable[[], bool] | None = None,
             progress: Callable[[ReplayStats], None] | None = None) -> ReplayStats:
        """Replay the bag once; see the module docstring for the order and timing."""
        from cam_metrology.bagio import iter_messages

        stats = ReplayStats()
        messages = iter(iter_messages(self.bag, topics=list(self.pubs), raw=True))
        first_done: set[str] = set()
        held: list[Any] = []
        # 1. latched topics first: publish their messages until the first other message
        for item in messages:
            if item.topic in self.latched and item.topic not in first_done:
                self._publish(item.topic, item.msg, stats, 5.0)
                first_done.add(item.topic)
                continue
            held.append(item)
            break
        # 2. wait for subscribers on every topic, and for the latched data to be taken
        if wait_subscribers > 0:
            deadline = time.monotonic() + match_timeout
            main = self.pubs[self.main_topic] if self.main_topic else None
            while main is not None and main.get_subscription_count() < wait_subscribers:
                if time.monotonic() >= deadline or (should_stop and should_stop()):
                    stats.matched = False
                    break
                time.sleep(0.01)
            for topic in first_done:
                left = max(0.1, deadline - time.monotonic())
                self.pubs[topic].wait_for_all_acked(Duration(seconds=left))
        # 3. the stream, with the original timing scaled by ``rate``
        t_wall0 = time.monotonic()
        t_bag0: int | None = None
        last_stamp = 0
        for k, item in enumerate(_chain(held, messages)):
            if t_bag0 is None:
                t_bag0 = item.stamp_ns
            last_stamp = item.stamp_ns
            if rate > 0:
                due = t_wall0 + (item.stamp_ns - t_bag0) * 1e-9 / rate
                ahead = due - time.monotonic()
                if ahead > 0:
                    time.sleep(ahead)
                else:
                    stats.max_late_s = max(stats.max_late_s, -ahead)
            self._publish(item.topic, item.msg, stats, 10.0)
            if k % 1000 == 999:
                if should_stop and should_stop():
                    break
                if progress:
                    progress(stats)
        stats.wall_s = time.monotonic() - t_wall0
        stats.bag_span_s = (last_stamp - t_bag0) * 1e-9 if t_bag0 is not None else 0.0
        return stats

    def wait_acked(self, timeout: float) -> bool:
        """Wait (deadline) until every subscriber acknowledged every message."""
        return wait_all_acked(self.pubs.values(), timeout)


def _chain(first: list[Any], rest: Any) -> Any:
    yield from first
    yield from rest


def run_replay(bag: str | Path, rate: float = 1.0, *, loop: bool = False,
               wait_subscribers: int = 1, match_timeout: float = 10.0,
               topics: Sequence[str] | None = None, args: Sequence[str] | None = None,
               quiet: bool = False) -> int:
    """Replay ``bag`` (``loop``: again until SIGINT). Exit 0 (a missing subscriber is a
    warning: replay publishes anyway, like ``ros2 bag play``)."""
    from cam_design.errors import InputError
    from cam_metrology.nodes.runtime import RosProcess

    if not (match_timeout >= 0 and math.isfinite(match_timeout)):
        raise InputError('--match-timeout', match_timeout, 'a finite number of s >= 0')
    if wait_subscribers < 0:
        raise InputError('--wait-subscribers', wait_subscribers, 'a count >= 0')
    select_topics(list(bag_connections(bag)), topics)   # before any ROS set-up
    proc = RosProcess(args)
    try:
        node = proc.add(ReplayNode(bag, context=proc.context, topics=topics))
        if not quiet:
            print(f'replaying {bag} ({len(node.pubs)} topics) at rate '
                  f'{rate if rate > 0 else "max"}', flush=True)
        while True:
            stats = node.play(rate, wait_subscribers, match_timeout,
                              should_stop=lambda: proc.stopping)
            node.wait_acked(5.0)
            if not stats.matched:
                print(f'replay: warning: fewer than {wait_subscribers} subscriber(s) on '
                      f'{node.main_topic} after {match_timeout} s: {node.matched_counts()}',
                      flush=True)
            if not quiet:
                print(f'published {stats.total} messages in {stats.wall_s:.2f} s (bag span '
                      f'{stats.bag_span_s:.2f} s, {stats.total / max(stats.wall_s, 1e-9):.0f} '
                      f'msgs/s, max lateness {stats.max_late_s * 1e3:.1f} ms, '
                      f'retries {stats.retries})', flush=True)
            if not loop or proc.stopping:
                return 0
    finally:
        proc.close()
