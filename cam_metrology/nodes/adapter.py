"""``CoreNode``: the generic rclpy adapter around any ``NodeCore`` (core.py).

* declares the core's ``PARAMETERS`` as ROS parameters (with descriptors) and builds
  the core from their values (so ``--params-file config/<node>.yaml`` sets them);
* subscribes to ``core.subscriptions`` with the QoS of ``topics.TOPICS``
  (/bench/scene transient local depth 1, created first; /bench/joint_states reliable
  keep-last 1000); every callback calls ``core.handle(topic, msg, receive_time_ns)``;
* publishes the returned outputs on their topics with the documented QoS (reports
  transient local), converted by ``convert.to_message``;
* a timer calls ``core.tick(now_ns)`` (idle timeouts);
* on shutdown, after draining what already arrived, calls ``core.finish()``,
  publishes that, and waits (deadline) until every subscriber acknowledged.
A core that raises is logged with its traceback and counted (non-zero exit), the node
keeps running: one bad message must not take the live graph down.
"""
from __future__ import annotations

import functools
import traceback
from typing import Any, Sequence

from rcl_interfaces.msg import ParameterDescriptor
from rclpy.duration import Duration
from rclpy.node import Node

from cam_metrology.nodes import convert
from cam_metrology.nodes.topics import SCENE, message_class, qos_of
from cam_metrology.outputs import Output, msgtype_of


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
    """ParameterDescriptor; dynamic typing when the default says nothing about the type."""
    untyped = default is None or (isinstance(default, (list, tuple)) and not default)
    return ParameterDescriptor(name=name, description=description, dynamic_typing=untyped)


def declare_parameters(node: Node, table: dict[str, tuple[Any, str]]) -> dict[str, Any]:
    """Declare ``{name: (default, description)}`` on ``node``; returns the values in force."""
    values: dict[str, Any] = {}
    for name, (default, description) in table.items():
        value = list(default) if isinstance(default, tuple) else default
        param = node.declare_parameter(name, value, descriptor(name, default, description))
        values[name] = param.value
    return values


class CoreNode(Node):
    """A ROS node that feeds a node core and publishes its outputs."""

    def __init__(self, core_cls: Any, *, context: Any = None, node_name: str | None = None,
                 tick_period: float = 0.1) -> None:
        super().__init__(node_name or core_cls.name, context=context)
        self.params = declare_parameters(self, dict(getattr(core_cls, 'PARAMETERS', {})))
        self.core = core_cls(self.params)
        self.errors = 0
        self.callbacks_run = 0
        self.published: dict[str, int] = {}
        self._pubs: dict[str, Any] = {}
        for topic, type_name in self.core.publications.items():
            self._publisher(topic, type_name)
        self._subs = []
        # the scene first: with several ready subscriptions, rclpy's executor takes
        # them in creation order, so the scene is handled before samples.
        topics = sorted(self.core.subscriptions.items(), key=lambda item: item[0] != SCENE)
        for topic, type_name in topics:
            self._subs.append(self.create_subscription(
                message_class(type_name), topic, functools.partial(self._on_message, topic),
                qos_of(topic).profile()))
        self._timer = self.create_timer(tick_period, self._on_tick)

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

    def _on_tick(self) -> None:
        self._guarded('tick', self.core.tick, self.now_ns())

    def finish(self, ack_timeout: float = 5.0) -> bool:
        """Call ``core.finish()``, publish its outputs, wait until they are acknowledged."""
        self._guarded('finish', self.core.finish)
        return self.wait_acked(ack_timeout)

    def wait_acked(self, timeout: float) -> bool:
        """Wait (deadline) until every matched subscriber acknowledged every message."""
        ok = True
        for pub in self._pubs.values():
            ok = pub.wait_for_all_acked(Duration(seconds=timeout)) and ok
        return ok


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
        node = proc.add(CoreNode(core_cls, context=proc.context))
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
