"""Replay of a bag on live ROS 2 topics: the recorded CDR bytes, republished unchanged.

* Publishers per topic with the bag's type; reliable KEEP_ALL (lossless replay with
  back-pressure, docs/ros.md) and transient local for the latched topics
  (/bench/scene, /bench/truth, /metrology/report, or any topic the bag recorded as
  transient local).
* The latched topics' first messages are published first, then the player waits
  (deadline ``match_timeout``) for **every subscriber the user expects**: each node
  of ``expect`` (default ``metrology`` and ``recorder``; ``NODE:/topic`` for a node
  that does not take the busiest topic) must show a subscription in the graph and be
  matched by the player's publisher, and at least ``wait_subscribers`` subscriptions
  must match the busiest topic (the sample stream); then until the latched messages
  are acknowledged. A subscriber still missing at the deadline stops the replay before
  the first sample (exit 4, naming it) unless ``start_anyway``: starting as soon as
  *one* subscriber matched once left a recorder with 681 of 18 000 samples. Then the
  rest streams in log-time order at ``t_wall0 + (t_bag - t_bag0) / rate`` (``rate``
  <= 0: as fast as possible).
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
from cam_metrology.nodes.topics import message_class
from cam_metrology.wire.topics import TOPICS


@dataclass
class ReplayStats:
    """What a replay did: messages per topic, wall time [s], lateness of the schedule."""

    counts: dict[str, int] = field(default_factory=dict)
    wall_s: float = 0.0
    bag_span_s: float = 0.0
    max_late_s: float = 0.0
    retries: int = 0
    matched: bool = True
    missing: list[str] = field(default_factory=list)   # expected, not there in time
    streamed: bool = False

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
    from cam_metrology.bagio import open_reader   # shared validation of the bag path

    reader = open_reader(path)
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


#: nodes ``cam-bench replay`` waits for by default (the metrology node and the recorder)
DEFAULT_EXPECT = ('metrology', 'recorder')


def parse_expect(items: Sequence[str]) -> list[tuple[str, str | None]]:
    """``['metrology', 'reconstruction:/metrology/lift']`` -> [(node, topic or None)];
    ``['none']`` -> []. InputError('--expect', item, ...) on a malformed item."""
    from cam_design.errors import InputError
    out: list[tuple[str, str | None]] = []
    for item in items:
        for part in str(item).replace(',', ' ').split():
            if part == 'none':
                continue
            node, sep, topic = part.partition(':')
            node = node.lstrip('/')
            if not node or not all(c.isalnum() or c in '_/' for c in node) or (
                    sep and not topic.startswith('/')):
                raise InputError('--expect', part, "a node name, NODE:/topic, or 'none'")
            out.append((node, topic if sep else None))
    return out


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

    def missing_subscribers(self, expect: Sequence[tuple[str, str | None]],
                            wait_subscribers: int) -> list[str]:
        """Expected subscribers not (yet) matched: 'NODE on /topic' or 'N of M
        subscriptions on /topic'."""
        missing: list[str] = []
        need: dict[str, int] = {}
        for node, topic in expect:
            topic = topic or self.main_topic
            if topic not in self.pubs:
                missing.append(f'{node} on {topic} (not a replayed topic)')
                continue
            names = {i.node_name for i in self.get_subscriptions_info_by_topic(topic)}
            if node.split('/')[-1] not in names:
                missing.append(f'{node} on {topic}')
            need[topic] = need.get(topic, 0) + 1
        if self.main_topic is not None:
            need[self.main_topic] = max(need.get(self.main_topic, 0), wait_subscribers)
        if missing:   # named ones first; the counts only once every name is there
            return missing
        for topic, n in need.items():
            have = self.pubs[topic].get_subscription_count()
            if have < n:
                missing.append(f'{n - have} of {n} subscriptions on {topic} not matched')
        return missing

    def play(self, rate: float = 1.0, wait_subscribers: int = 1, match_timeout: float = 10.0,
             should_stop: Callable[[], bool] | None = None,
             progress: Callable[[ReplayStats], None] | None = None,
             expect: Sequence[tuple[str, str | None]] = (),
             start_anyway: bool = False) -> ReplayStats:
        """Replay the bag once; see the module docstring for the order and timing.
        ``stats.streamed`` is False when an expected subscriber was missing at the
        deadline (and not ``start_anyway``): nothing after the latched messages went out."""
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
        # 2. wait for every expected subscriber, then for the latched data to be taken
        if wait_subscribers > 0 or expect:
            deadline = time.monotonic() + match_timeout
            while True:
                stats.missing = self.missing_subscribers(expect, wait_subscribers)
                if not stats.missing:
                    break
                if time.monotonic() >= deadline or (should_stop and should_stop()):
                    stats.matched = False
                    break
                time.sleep(0.01)
            if not stats.matched and not start_anyway:
                return stats
            for topic in first_done:
                left = max(0.1, deadline - time.monotonic())
                self.pubs[topic].wait_for_all_acked(Duration(seconds=left))
        stats.streamed = True
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
               quiet: bool = False, expect: Sequence[str] = DEFAULT_EXPECT,
               start_anyway: bool = False) -> int:
    """Replay ``bag`` (``loop``: again until SIGINT). Exit 0; 4 when an expected
    subscriber was missing at the deadline (nothing streamed) unless ``start_anyway``
    (then a warning naming it, and the replay)."""
    from cam_design.errors import InputError
    from cam_metrology.nodes.runtime import RosProcess

    if not (match_timeout >= 0 and math.isfinite(match_timeout)):
        raise InputError('--match-timeout', match_timeout, 'a finite number of s >= 0')
    if wait_subscribers < 0:
        raise InputError('--wait-subscribers', wait_subscribers, 'a count >= 0')
    select_topics(list(bag_connections(bag)), topics)   # before any ROS set-up
    expected = parse_expect(expect)
    proc = RosProcess(args)
    try:
        node = proc.add(ReplayNode(bag, context=proc.context, topics=topics))
        if not quiet:
            print(f'replaying {bag} ({len(node.pubs)} topics) at rate '
                  f'{rate if rate > 0 else "max"}', flush=True)
        if not quiet and (expected or wait_subscribers):
            print('waiting for ' + ', '.join(
                [f'{n} on {t or node.main_topic}' for n, t in expected]
                + ([f'{wait_subscribers} subscription(s) on {node.main_topic}']
                   if wait_subscribers else [])) + f' (deadline {match_timeout:g} s)',
                flush=True)
        first = True
        while True:
            stats = node.play(rate, wait_subscribers if first else 0, match_timeout,
                              should_stop=lambda: proc.stopping,
                              expect=expected if first else (), start_anyway=start_anyway)
            first = False
            if not stats.streamed:
                import sys
                print(f'cam-bench replay: expected subscribers missing after '
                      f'{match_timeout:g} s: {"; ".join(stats.missing)}; nothing replayed '
                      '(start them, or change --expect / --wait-subscribers, or '
                      '--start-anyway)', file=sys.stderr, flush=True)
                return 4
            node.wait_acked(5.0)
            if not stats.matched:
                print(f'replay: warning: started anyway without {"; ".join(stats.missing)}',
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
