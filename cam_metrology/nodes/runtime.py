"""Process plumbing shared by every node: context, executor, signals, waiting.

* ``RosProcess`` owns one rclpy ``Context`` (domain from ``ROS_DOMAIN_ID`` unless
  given), installs its own SIGINT/SIGTERM handlers (rclpy's would shut the context
  down at once, and a node could then no longer publish its last outputs), and spins
  an executor in short steps until a stop is requested or a condition holds.
* ``drain`` spins until the subscriptions have been idle for a moment, so messages
  that arrived before a stop are still handled (the demo stops nodes upstream first).
* rclpy.init() is not a context manager on Jazzy: ``close()`` does the
  ``destroy_node`` / ``try_shutdown`` of docs/ros.md
* Fast DDS caps every history at its default resource limit ``max_samples = 5000``
  whatever the keep-last depth rclpy asks for (measured: depth 20 000, 15 000 samples
  published before spinning -> 5000 received). ``use_fastdds_profile`` points
  ``FASTRTPS_DEFAULT_PROFILES_FILE`` (unless the user set it) at a profile raising the
  limits to ``HISTORY_LIMIT`` so that the 20 000-deep /bench/joint_states QoS is real
  (-> 15 000 of 15 000; RSS unchanged, histories allocate on demand). The profile also
  sets the reliable writers' heartbeat period to 0.1 s (Fast DDS default 3 s): readers
  acknowledge, and ask for lost samples, on heartbeats, so ``wait_for_all_acked``
  took 3.0 s per call before and takes ~0.1 s now, and a lost sample is repaired
  within ~0.1 s.
"""
from __future__ import annotations

import hashlib
import os
import signal
import tempfile
import threading
import time
from pathlib import Path
from typing import Any, Callable, Sequence

import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.signals import SignalHandlerOptions


HISTORY_LIMIT = 25000
HEARTBEAT_NS = 100_000_000   # reliable writers' heartbeat period (Fast DDS default: 3 s)
FASTDDS_PROFILE = f'''<?xml version="1.0" encoding="UTF-8" ?>
<!-- cam-bench: raise Fast DDS's default history limit (5000) above the 20 000-deep
     /bench/joint_states QoS; written by cam_metrology.nodes.runtime -->
<profiles xmlns="http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles">
  <data_writer profile_name="cam_bench_writer" is_default_profile="true">
    <topic><resourceLimitsQos>
      <max_samples>{HISTORY_LIMIT}</max_samples><max_instances>1</max_instances>
      <max_samples_per_instance>{HISTORY_LIMIT}</max_samples_per_instance>
    </resourceLimitsQos></topic>
    <times><heartbeatPeriod><sec>0</sec><nanosec>{HEARTBEAT_NS}</nanosec></heartbeatPeriod></times>
  </data_writer>
  <data_reader profile_name="cam_bench_reader" is_default_profile="true">
    <topic><resourceLimitsQos>
      <max_samples>{HISTORY_LIMIT}</max_samples><max_instances>1</max_instances>
      <max_samples_per_instance>{HISTORY_LIMIT}</max_samples_per_instance>
    </resourceLimitsQos></topic>
  </data_reader>
</profiles>
'''


def use_fastdds_profile() -> str:
    """Set FASTRTPS_DEFAULT_PROFILES_FILE to our profile unless already set; returns it.

    Must run before the first participant of the process exists (before rclpy.init);
    child processes inherit it.
    """
    current = os.environ.get('FASTRTPS_DEFAULT_PROFILES_FILE')
    if current:
        return current
    digest = hashlib.sha256(FASTDDS_PROFILE.encode()).hexdigest()[:12]
    path = Path(tempfile.gettempdir()) / f'cam_bench_fastdds_{digest}.xml'
    if not path.is_file():
        tmp = path.with_suffix(f'.{os.getpid()}.tmp')
        tmp.write_text(FASTDDS_PROFILE, encoding='utf-8')
        os.replace(tmp, path)   # atomic: concurrent processes never read half a file
    os.environ['FASTRTPS_DEFAULT_PROFILES_FILE'] = str(path)
    return str(path)


class RosProcess:
    """One rclpy context and executor; stop requested by SIGINT/SIGTERM or ``stop()``."""

    def __init__(self, args: Sequence[str] | None = None, *, domain_id: int | None = None,
                 events_executor: bool = False, handle_signals: bool = True) -> None:
        use_fastdds_profile()
        self.context = Context()
        rclpy.init(args=list(args) if args is not None else None, context=self.context,
                   domain_id=domain_id, signal_handler_options=SignalHandlerOptions.NO)
        if events_executor:
            from rclpy.experimental import EventsExecutor
            self.executor: Any = EventsExecutor(context=self.context)
        else:
            self.executor = SingleThreadedExecutor(context=self.context)
        self.events_executor = events_executor
        self.nodes: list[Any] = []
        self.stop_reason = ''
        self._stop = threading.Event()
        self._old_handlers: dict[int, Any] = {}
        if handle_signals and threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM):
                self._old_handlers[sig] = signal.signal(sig, self._on_signal)

    def _on_signal(self, signum: int, _frame: Any) -> None:
        self.stop(signal.Signals(signum).name)

    def stop(self, reason: str = 'stop requested') -> None:
        """Ask ``spin_until`` to return (safe from signal handlers and other threads)."""
        if not self._stop.is_set():
            self.stop_reason = reason
        self._stop.set()

    @property
    def stopping(self) -> bool:
        """True once a stop was requested."""
        return self._stop.is_set()

    def add(self, node: Any) -> Any:
        """Add a node to the executor; returns it."""
        self.nodes.append(node)
        self.executor.add_node(node)
        return node

    def spin_once(self, timeout: float = 0.05) -> None:
        """Run at most one round of ready callbacks, waiting up to ``timeout`` s."""
        self.executor.spin_once(timeout_sec=timeout)

    def spin_until(self, condition: Callable[[], bool] | None = None,
                   timeout: float | None = None, step: float = 0.05) -> bool:
        """Spin until ``condition()`` is true (True), a stop, or ``timeout`` s (False)."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            if condition is not None and condition():
                return True
            if self.stopping:
                return False
            if deadline is not None and time.monotonic() >= deadline:
                return False
            self.spin_once(step if deadline is None else
                           max(0.0, min(step, deadline - time.monotonic())))

    def drain(self, counter: Callable[[], int], idle: float = 0.2, limit: float = 5.0) -> None:
        """Spin until ``counter()`` (callbacks run) stays unchanged for ``idle`` s, at most
        ``limit`` s: handles what had already arrived when a stop was requested."""
        end = time.monotonic() + limit
        last, quiet_since = counter(), time.monotonic()
        while time.monotonic() < end and time.monotonic() - quiet_since < idle:
            self.spin_once(0.02)
            now = counter()
            if now != last:
                last, quiet_since = now, time.monotonic()

    def close(self) -> None:
        """Destroy the nodes, shut the context down, restore the signal handlers."""
        for node in self.nodes:
            try:
                self.executor.remove_node(node)
            except Exception:  # noqa: BLE001 (tearing down: keep going)
                pass
            node.destroy_node()
        self.nodes.clear()
        if hasattr(self.executor, 'shutdown'):
            self.executor.shutdown()
        rclpy.try_shutdown(context=self.context)
        for sig, old in self._old_handlers.items():
            signal.signal(sig, old)
        self._old_handlers.clear()


def wait_for_matches(process: RosProcess, counts: Callable[[], Sequence[int]], need: int,
                     timeout: float) -> bool:
    """Spin until every value of ``counts()`` is >= ``need``; False at the deadline."""
    return process.spin_until(lambda: all(c >= need for c in counts()), timeout)


def wait_all_acked(publishers: Any, timeout: float) -> bool:
    """Wait until every matched subscriber acknowledged everything sent on each of
    ``publishers``, one shared deadline of ``timeout`` s; False if any did not."""
    from rclpy.duration import Duration
    deadline = time.monotonic() + timeout
    ok = True
    for pub in publishers:
        left = max(0.0, deadline - time.monotonic())
        ok = bool(pub.wait_for_all_acked(Duration(seconds=left))) and ok
    return ok


def publish_retrying(pub: Any, msg: Any, timeout: float) -> int:
    """``pub.publish(msg)``, retried while it raises RCLError (a reliable writer blocked
    longer than Fast DDS's max_blocking_time, docs/ros.md) until ``timeout`` s;
    returns the number of retries."""
    from rclpy._rclpy_pybind11 import RCLError
    deadline = time.monotonic() + timeout
    retries = 0
    while True:
        try:
            pub.publish(msg)
            return retries
        except RCLError:
            retries += 1
            if time.monotonic() > deadline:
                raise
            time.sleep(0.0005)


def ros_time_ns(node: Any) -> int:
    """The node clock in ns (system time unless use_sim_time)."""
    return int(node.get_clock().now().nanoseconds)
