"""``CoreNode``: the generic rclpy adapter around any ``NodeCore`` (core.py).

* declares the core's ``PARAMETERS`` as ROS parameters (with descriptors) and builds
  the core from their values (so ``--params-file config/<node>.yaml`` sets them);
* subscribes to ``core.subscriptions``: bench topics with the QoS of ``topics.TOPICS``
  (/bench/scene transient local depth 1, created first; /bench/joint_states reliable
  keep-last 20 000, see ``topics.SAMPLES``), other nodes' outputs once their
  publisher is in the graph, transient local when it offers it
  (``topics.AdaptiveSubscriptions``: a node that matched late still gets the last 100
  outputs); every callback calls ``core.handle(topic, msg, receive_time_ns)``;
* publishes the returned outputs on their topics, reliable, transient local (depth 1
  for the report, 100 for the others: ``topics.RESULTS``), converted by
  ``convert.to_message``;
* cross-topic order: ROS keeps order within a topic only, so a /bench/feature_done
  can overtake the last samples of its feature (seen live: the feature was split in
  two). When the core consumes /bench/joint_states, every other message is held and
  released in publication order (DDS ``source_timestamp`` from MessageInfo): just
  before the first sample published after it, or once the sample reader is empty and
  neither a sample nor a held message has arrived for ``order_hold`` s (0.5 s: five
  heartbeat periods of our Fast DDS profile, so a lost tail sample is repaired first).
  Samples already waiting in the reader are taken at once (``take_message``) so
  nothing overtakes them;
* bulk samples: when the core has ``handle_samples`` (the bulk path of the offline
  replay), /bench/joint_states is subscribed raw; each callback drains the reader
  (up to ``MAX_BATCH`` messages), decodes the CDR with numpy
  (``bagio.decode_joint_states``, joints by name) and hands the block to the core in
  one call. This removes the per-message executor dispatch, deserialization and core
  call that limited the live node to a few thousand samples/s. Under the
  EventsExecutor (``with_info=False``) this is off: rclpy 7.1.6's EventsExecutor
  raises SystemError for any callback taking MessageInfo, and it runs callbacks in
  event-arrival order anyway;
* a timer calls ``core.tick(now_ns)`` (idle timeouts);
* on shutdown, after draining what already arrived, calls ``core.finish()``,
  publishes that, and waits (deadline) until every subscriber acknowledged.
A core that raises is logged with its traceback and counted (non-zero exit), the node
keeps running: one bad message must not take the live graph down.
"""
from __future__ import annotations

import functools
import heapq
import time
import traceback
from typing import Any, Sequence

from rcl_interfaces.msg import ParameterDescriptor
from rclpy.node import Node

from cam_metrology.nodes import convert
from cam_metrology.nodes.topics import (BENCH_TOPICS, JOINT_STATES, SCENE,
                                        AdaptiveSubscriptions, QosSpec, message_class, qos_of)
from cam_metrology.outputs import Output, msgtype_of


#: most raw samples handed to a core in one callback (keeps timers responsive)
MAX_BATCH = 4000


class CoreMissing(RuntimeError):
    """The core of a node is not written yet (registry entry without a module)."""


def load_core(name: str) -> Any:
    """The core class registered for node ``name``; CoreMissing if absent."""
    from cam_metrology.registry import CORES, load_core_class
    if name not in CORES:
        raise CoreMissing(f'no core registered for node {name!r}; known: {sorted(CORES)}')
    try:
        return load_core_class(name)
    except ModuleNotFoundError as exc:
        module = CORES[name].split(':')[0]
        if exc.name and module.startswith(exc.name):
            raise CoreMissing(f'core of node {name!r} is missing: {CORES[name]} '
                              'is not in this tree') from None
        raise
    except AttributeError:
        raise CoreMissing(f'core of node {name!r} is missing: {CORES[name]} '
                          'has no such class') from None


def descriptor(name: str, default: Any, description: str) -> ParameterDescriptor:
    """ParameterDescriptor; dynamic typing when the default says nothing about the type,
    and for floats (so that ``-p rate:=5000``, parsed as an integer, is accepted and
    converted by ``declare_parameters``)."""
    untyped = default is None or (isinstance(default, (list, tuple)) and not default)
    return ParameterDescriptor(name=name, description=description,
                               dynamic_typing=untyped or isinstance(default, float))


def declare_parameters(node: Node, table: dict[str, tuple[Any, str]]) -> dict[str, Any]:
    """Declare ``{name: (default, description)}`` on ``node``; returns the values in force.

    Float parameters given as integers are converted; anything else of the wrong type
    raises InputError naming the parameter, its value and the expected type.
    """
    from rclpy.exceptions import InvalidParameterTypeException

    from cam_metrology.nodes.params import check_value, expected_type

    values: dict[str, Any] = {}
    for name, (default, description) in table.items():
        value = list(default) if isinstance(default, tuple) else default
        key = f'{node.get_name()}.{name}'
        try:
            param = node.declare_parameter(name, value, descriptor(name, default, description))
        except InvalidParameterTypeException:
            from cam_design.errors import InputError
            given = getattr(node, '_parameter_overrides', {}).get(name)
            raise InputError(key, getattr(given, 'value', given),
                             expected_type(default) or 'a valid value') from None
        values[name] = check_value(key, param.value, default)
    return values


class CoreNode(Node):
    """A ROS node that feeds a node core and publishes its outputs."""

    def __init__(self, core_cls: Any, *, context: Any = None, node_name: str | None = None,
                 tick_period: float = 0.1, order_hold: float = 0.5,
                 with_info: bool = True) -> None:
        super().__init__(node_name or core_cls.name, context=context)
        self.params = declare_parameters(self, dict(getattr(core_cls, 'PARAMETERS', {})))
        self.core = core_cls(self.params)
        self.errors = 0
        self.callbacks_run = 0
        self.published: dict[str, int] = {}
        self._pubs: dict[str, Any] = {}
        for topic, type_name in self.core.publications.items():
            self._publisher(topic, type_name)
        self._subs: dict[str, Any] = {}
        self._held: list[tuple[int, int, str, Any]] = []   # (source ns, seq, topic, msg)
        self._seq = 0
        self._order_hold = order_hold
        self._last_sample = 0.0        # monotonic s of the last sample handled
        self._last_held = 0.0          # monotonic s of the last message put on hold
        # the scene first: with several ready subscriptions, rclpy's executor takes
        # them in creation order, so the scene is handled before samples.
        topics = sorted(self.core.subscriptions.items(), key=lambda item: item[0] != SCENE)
        self._ordered = with_info and JOINT_STATES in self.core.subscriptions
        self._bulk = self._ordered and callable(getattr(self.core, 'handle_samples', None))
        self._adaptive = AdaptiveSubscriptions(self, self._subscribe)
        for topic, type_name in topics:
            if topic in BENCH_TOPICS:
                self._subscribe(topic, type_name, qos_of(topic))
            else:   # another node's output: QoS from its publishers (late joiners)
                self._adaptive.add(topic, type_name, qos_of(topic).depth)
        self._timer = self.create_timer(tick_period, self._on_tick)
        if self._ordered:
            self._order_timer = self.create_timer(0.05, self._on_order_timer)

    def _subscribe(self, topic: str, type_name: str, qos: QosSpec) -> None:
        raw = False
        if topic == JOINT_STATES and self._bulk:
            callback: Any = self._on_sample_raw
            raw = True
        elif topic == JOINT_STATES and self._ordered:
            callback = self._on_sample
        elif self._ordered:
            callback = functools.partial(self._on_held, topic)
        else:
            callback = functools.partial(self._on_message, topic)
        self._subs[topic] = self.create_subscription(
            message_class(type_name), topic, callback, qos.profile(), raw=raw)

    # -- publishing -----------------------------------------------------------------
    def _publisher(self, topic: str, type_name: str) -> Any:
        pub = self._pubs.get(topic)
        if pub is None:
            pub = self.create_publisher(message_class(type_name), topic,
                                        qos_of(topic).profile())
            self._pubs[topic] = pub
        return pub

    def publish_outputs(self, outputs: Sequence[Output] | None) -> None:
        """Convert and publish core outputs (lazily creating undeclared publishers)."""
        for out in outputs or ():
            pub = self._publisher(out.topic, msgtype_of(out))
            pub.publish(convert.to_message(out, self.now_ns()))
            self.published[out.topic] = self.published.get(out.topic, 0) + 1

    def subscription_count(self, topic: str) -> int:
        """Matched subscriptions of this node's publisher on ``topic`` (0 if none)."""
        pub = self._pubs.get(topic)
        return pub.get_subscription_count() if pub is not None else 0

    def now_ns(self) -> int:
        """Node clock [ns]."""
        return int(self.get_clock().now().nanoseconds)

    # -- callbacks ------------------------------------------------------------------
    def _guarded(self, what: str, fn: Any, *args: Any) -> None:
        try:
            self.publish_outputs(fn(*args))
        except Exception:  # noqa: BLE001 (log, count, keep the graph alive)
            self.errors += 1
            self.get_logger().error(f'{self.core.name} {what} failed:\n{traceback.format_exc()}')

    def _on_message(self, topic: str, msg: Any) -> None:
        self.callbacks_run += 1
        self._guarded(f'handle({topic})', self.core.handle, topic, msg, self.now_ns())

    # -- cross-topic ordering (only when the core consumes /bench/joint_states) -------
    def _on_held(self, topic: str, msg: Any, info: Any) -> None:
        self.callbacks_run += 1
        self._seq += 1
        heapq.heappush(self._held, (_source_ns(info), self._seq, topic, msg))
        self._last_held = time.monotonic()
        self._take_waiting_samples()

    def _on_sample(self, msg: Any, info: Any) -> None:
        self.callbacks_run += 1
        self._deliver_sample(msg, _source_ns(info))

    def _deliver_sample(self, msg: Any, source_ns: int) -> None:
        while self._held and self._held[0][0] <= source_ns:
            self._release_one()
        self._last_sample = time.monotonic()
        self._guarded(f'handle({JOINT_STATES})', self.core.handle, JOINT_STATES, msg,
                      self.now_ns())

    def _on_sample_raw(self, data: bytes, info: Any) -> None:
        self.callbacks_run += 1
        batch = [(data, _source_ns(info))]
        batch.extend(self._drain_samples(MAX_BATCH - 1))
        self._deliver_batch(batch)

    def _drain_samples(self, limit: int) -> list[tuple[Any, int]]:
        """Take up to ``limit`` samples already waiting in the reader, in order."""
        sub = self._subs.get(JOINT_STATES)
        taken_all: list[tuple[Any, int]] = []
        while sub is not None and len(taken_all) < limit:
            try:
                with sub.handle:
                    taken = sub.handle.take_message(sub.msg_type, sub.raw)
            except Exception:  # noqa: BLE001 (destroyed handle at shutdown)
                break
            if taken is None:
                break
            taken_all.append((taken[0], _source_ns(taken[1])))
        return taken_all

    def _deliver_batch(self, batch: list[tuple[bytes, int]]) -> None:
        """Hand raw samples to the core in blocks, releasing each held message just
        before the first sample published after it (the same order as one by one)."""
        i = 0
        while i < len(batch):
            while self._held and self._held[0][0] <= batch[i][1]:
                self._release_one()
            limit = self._held[0][0] if self._held else None
            j = i + 1
            while j < len(batch) and (limit is None or batch[j][1] < limit):
                j += 1
            self._guarded(f'handle_samples({JOINT_STATES})', self._handle_block,
                          [data for data, _ in batch[i:j]])
            i = j
        self._last_sample = time.monotonic()

    def _handle_block(self, chunks: list[bytes]) -> list[Output]:
        from cam_metrology.bagio import decode_joint_states
        js = decode_joint_states(chunks)
        return self.core.handle_samples(js.frame_id, js.stamp_ns, js.theta, js.s,
                                        rx_ns=self.now_ns())

    def _release_one(self) -> None:
        _, _, topic, msg = heapq.heappop(self._held)
        self._guarded(f'handle({topic})', self.core.handle, topic, msg, self.now_ns())

    def _take_waiting_samples(self) -> None:
        """Handle the samples already in the reader (in order) while messages are held:
        in blocks on the bulk path, one at a time otherwise (each may release some)."""
        while self._held:
            batch = self._drain_samples(MAX_BATCH if self._bulk else 1)
            if not batch:
                return
            self.callbacks_run += 1
            if self._bulk:
                self._deliver_batch(batch)
            else:
                self._deliver_sample(*batch[0])

    def _on_order_timer(self) -> None:
        if not self._held:
            return
        self._take_waiting_samples()
        quiet = time.monotonic() - max(self._last_sample, self._last_held)
        if self._held and quiet >= self._order_hold:
            while self._held:
                self._release_one()

    def release_held(self) -> None:
        """Hand every held message to the core (shutdown)."""
        self._take_waiting_samples()
        while self._held:
            self._release_one()

    def _on_tick(self) -> None:
        self._guarded('tick', self.core.tick, self.now_ns())

    def finish(self, ack_timeout: float = 5.0) -> bool:
        """Release held messages, call ``core.finish()``, publish its outputs, and wait
        (deadline) until they are acknowledged."""
        self.release_held()
        self._guarded('finish', self.core.finish)
        return self.wait_acked(ack_timeout)

    def wait_acked(self, timeout: float) -> bool:
        """Wait (deadline) until every matched subscriber acknowledged every message."""
        from cam_metrology.nodes.runtime import wait_all_acked
        return wait_all_acked(self._pubs.values(), timeout)


def _source_ns(info: Any) -> int:
    """Publication time [ns] of a received message (MessageInfo dict; 0 if absent)."""
    try:
        return int(info['source_timestamp'])
    except (TypeError, KeyError):
        return 0


def run_core_node(name: str, args: Sequence[str] | None = None, *,
                  events_executor: bool = False) -> int:
    """Run node ``name`` (metrology | reconstruction | dynamics) until SIGINT/SIGTERM.

    Returns 0, 1 if the core raised, 3 if the core is missing (printed, never faked).
    """
    import sys

    from cam_metrology.nodes.runtime import RosProcess
    try:
        core_cls = load_core(name)
    except CoreMissing as exc:
        print(f'cam-bench run {name}: {exc}', file=sys.stderr)
        return 3
    proc = RosProcess(args, events_executor=events_executor)
    node = None
    try:
        node = proc.add(CoreNode(core_cls, context=proc.context,
                                 with_info=not events_executor))
        node.get_logger().info(f'{name} node up: subscribes {sorted(node.core.subscriptions)}'
                               f', publishes {sorted(node.core.publications)}')
        proc.spin_until()
        proc.drain(lambda: node.callbacks_run)
        if not node.finish():
            node.get_logger().warning('not every subscriber acknowledged the last outputs')
        node.get_logger().info(f'{name} node stopped ({proc.stop_reason}); published '
                               f'{node.published}; errors {node.errors}')
        return 1 if node.errors else 0
    finally:
        proc.close()
