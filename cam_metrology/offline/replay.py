"""In-process replay of a bag through node cores (no ROS graph): ``cam-bench analyze``.

``run_offline(bag, cores)`` feeds the bag's messages in log-time order to every core
that subscribes to their topic, exactly as the live adapters would, and routes each
output a core returns to the other cores that subscribe to its topic (metrology ->
``/metrology/lift`` -> reconstruction -> ``/reconstruction/profile`` -> dynamics).
Outputs are collected with the log time at which they were produced.

Delivery rules (what a core sees):

* ``handle(topic, msg, stamp_ns)``: ``msg`` decoded by rosbags (same fields as the
  rclpy message), ``stamp_ns`` the bag's log time (receive time) [ns]. A JointState
  sample and another message with the same log time: the sample comes first.
* ``/bench/joint_states`` is decoded with the fast numpy path, streamed in blocks
  (``bagio.iter_joint_states``): memory does not grow with the bag. A core
  with a bulk method ``handle_samples(frame_ids, stamp_ns, theta, s[, rx_ns])`` gets
  contiguous runs of samples as arrays (``stamp_ns`` header stamps, ``rx_ns`` the log
  time of the run's last sample); otherwise it gets one ``handle`` call per sample
  with a light JointState look-alike (``header.frame_id``, ``header.stamp.sec/
  nanosec``, ``name`` = (camshaft, probe), ``position`` = (theta, s); NaN where the
  message lacked the joint). Runs are cut at every other message, at log-time gaps
  longer than ``tick_period`` and at the end of a block, so per-sample and bulk
  delivery see the same order.
* ``tick(now_ns)`` is called on a grid of ``tick_period`` inside every log-time gap
  (as the live timer would fire; at most ``MAX_TICKS_PER_GAP`` per gap, plus one just
  before the next message), so idle timeouts end features as they would live.
* Outputs are routed at once (FIFO) to the *other* cores subscribing to their topic,
  as decoded messages. Topics that one of the cores publishes are not fed from the bag
  (a recorded bag of a live run already holds outputs: they are regenerated, not
  doubled).
* At the end ``finish()`` is called on every core, upstream cores first (the order
  follows the publish/subscribe graph), and their outputs are routed too.
"""
from __future__ import annotations

import heapq
import inspect
import json
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable, Sequence

import numpy as np

from cam_design.errors import InputError
from cam_metrology import bagio
from cam_metrology.cores.outputs import Output, TableOutput, TextOutput
from cam_metrology.wire.cdr import decode
from cam_metrology.wire.layouts import encode_output, msgtype_of
from cam_metrology.wire.plots import plot_messages
from cam_metrology.wire.topics import (JOINT_STATES, JOINT_TRAJECTORY, METROLOGY_REPORT,
                                       PLOT_TOPICS)

__all__ = ['StampedOutput', 'OfflineResult', 'run_offline', 'write_outputs',
           'OutputBagWriter', 'regenerated_topics',
           'order_cores', 'TICK_PERIOD_NS', 'MAX_TICKS_PER_GAP']

#: default period of the emulated live timer [ns] (0.05 s)
TICK_PERIOD_NS = 50_000_000
#: at most this many grid ticks per log-time gap (then one tick just before the next)
MAX_TICKS_PER_GAP = 200
#: a chain of routed outputs longer than this is a routing loop
MAX_ROUTED = 1_000_000


@dataclass(frozen=True)
class StampedOutput:
    """An output, the core (``source`` = its name) that produced it and its log time."""

    stamp_ns: int
    source: str
    output: Output


@dataclass
class OfflineResult:
    """What a replay produced: every output in order, and message counts per topic."""

    bag: Path
    outputs: list[StampedOutput] = field(default_factory=list)
    delivered: dict[str, int] = field(default_factory=dict)   # bag messages fed, per topic
    samples: int = 0
    elapsed_s: float = 0.0
    regenerated_topics: tuple[str, ...] = ()
    #: JointState messages that could not give a sample (bagio.JointIssue)
    joint_issues: tuple[Any, ...] = ()
    usable_samples: int = 0   # samples with a finite angle and lift

    def by_topic(self, topic: str) -> list[Output]:
        """The outputs published on ``topic``, in order."""
        return [o.output for o in self.outputs if o.output.topic == topic]

    def report(self, topic: str = METROLOGY_REPORT) -> dict[str, Any] | None:
        """The last JSON report published on ``topic`` (None if there is none)."""
        texts = [o for o in self.by_topic(topic) if isinstance(o, TextOutput)]
        return json.loads(texts[-1].text) if texts else None


def order_cores(cores: Sequence[Any]) -> list[Any]:
    """Cores sorted upstream first (a core before those that subscribe to what it
    publishes); stable for independent cores; cycles keep the given order."""
    remaining = list(cores)
    ordered: list[Any] = []
    while remaining:
        for core in remaining:
            feeds_me = [c for c in remaining if c is not core and
                        set(getattr(c, 'publications', {})) & set(core.subscriptions)]
            if not feeds_me:
                break
        else:
            core = remaining[0]
        ordered.append(core)
        remaining.remove(core)
    return ordered


class _Router:
    """Delivers messages and routes outputs between cores; records the outputs."""

    def __init__(self, cores: Sequence[Any], result: OfflineResult,
                 superseded_tables: bool = True,
                 sink: Callable[[StampedOutput], None] | None = None) -> None:
        self.cores = list(cores)
        self.result = result
        self.sink = sink
        #: False: a table output replaces the earlier one of its topic and label
        self.superseded_tables = superseded_tables
        self._table_at: dict[tuple[str, str], int] = {}
        self._holes = 0
        self.subscribers: dict[str, list[Any]] = {}
        for core in self.cores:
            for topic in core.subscriptions:
                self.subscribers.setdefault(topic, []).append(core)
        self.routed = 0

    def deliver(self, topic: str, msg: Any, stamp_ns: int) -> None:
        """Give a bag message to every subscriber, then route what they return."""
        for core in self.subscribers.get(topic, ()):
            self.emit(core, core.handle(topic, msg, stamp_ns), stamp_ns)

    def emit(self, source: Any, outputs: Iterable[Output] | None, stamp_ns: int) -> None:
        """Record ``outputs`` of ``source`` and route them (FIFO) to other subscribers."""
        queue = [(source, o) for o in (outputs or ())]
        while queue:
            src, out = queue.pop(0)
            self.record(StampedOutput(stamp_ns, src.name, out))
            targets = [c for c in self.subscribers.get(out.topic, ()) if c is not src]
            if not targets:
                continue
            self.routed += 1
            if self.routed > MAX_ROUTED:
                raise InputError('cores', out.topic, 'cores whose outputs do not loop')
            msg = decode(encode_output(out, stamp_ns), msgtype_of(out))
            for core in targets:
                queue += [(core, o) for o in (core.handle(out.topic, msg, stamp_ns) or ())]

    def record(self, item: StampedOutput) -> None:
        """Append an output; without ``superseded_tables``, drop the earlier table of
        the same topic and label (a feature measured again), so that what is kept does
        not grow with the number of measurements."""
        if self.sink is not None:
            self.sink(item)
        outputs = self.result.outputs
        if not self.superseded_tables and isinstance(item.output, TableOutput):
            key = (item.output.topic, item.output.label)
            old = self._table_at.get(key)
            if old is not None:
                outputs[old] = None   # type: ignore[call-overload]
                self._holes += 1
            self._table_at[key] = len(outputs)
        outputs.append(item)
        if self._holes > 64 and 2 * self._holes > len(outputs):
            self.compact()

    def compact(self) -> None:
        """Remove the places of dropped tables from the output list."""
        if self._holes:
            kept = [o for o in self.result.outputs if o is not None]
            self.result.outputs[:] = kept
            self._table_at = {(o.output.topic, o.output.label): i
                              for i, o in enumerate(kept) if isinstance(o.output, TableOutput)}
            self._holes = 0

    def tick(self, now_ns: int) -> None:
        for core in self.cores:
            self.emit(core, core.tick(now_ns), now_ns)


def _bulk_method(core: Any) -> tuple[Callable[..., Any] | None, bool]:
    """(handle_samples or None, whether it accepts rx_ns)."""
    method = getattr(core, 'handle_samples', None)
    if method is None or not callable(method):
        return None, False
    try:
        accepts_rx = 'rx_ns' in inspect.signature(method).parameters
    except (TypeError, ValueError):
        accepts_rx = False
    return method, accepts_rx


def sample_joints_of(bag: Path, cores: Sequence[Any]) -> tuple[str, str] | None:
    """(angle, lift) joint names of the samples, from the first core that has them:
    its parameters, or the channels of the bag's first scene when the parameters keep
    the default names (``scene.channels.joints_in_force``, as the core does live)."""
    core = next((c for c in cores if getattr(c, 'joints', None)), None)
    if core is None:
        return None
    given = getattr(core, 'joints_param', None)
    if given is None:
        return tuple(core.joints)
    from cam_metrology.scene.channels import DEFAULT_JOINTS, joints_in_force
    if tuple(given) != DEFAULT_JOINTS:
        return tuple(given)
    from cam_metrology.scene.recorded import bag_scenes
    first = next((sc.scene for sc in bag_scenes(bag) if sc.scene is not None), None)
    return joints_in_force(given, first)


def run_offline(bag_path: str | Path, cores: Sequence[Any],
                progress: Callable[[int, int], None] | None = None, *,
                tick_period_ns: int = TICK_PERIOD_NS, bulk: bool = True,
                block_bytes: int = bagio.STREAM_BLOCK_BYTES,
                superseded_tables: bool = True,
                sink: Callable[[StampedOutput], None] | None = None) -> OfflineResult:
    """Replay ``bag_path`` through ``cores`` in-process (see the module doc).

    ``progress(done, total)`` is called as messages are fed (counting samples and
    other messages). ``bulk=False`` forces per-sample ``handle`` calls even for cores
    with ``handle_samples`` (to compare both paths). ``block_bytes``: size of the
    blocks in which samples are read (``bagio.iter_joint_states``).
    ``superseded_tables=False`` keeps, of the table outputs with the same topic and
    label (a feature measured again), only the last one, so that memory does not grow
    with a bag of repeated measurements; ``write_outputs`` needs them all (True).
    ``sink``: called with every output as it is produced (``OutputBagWriter.add``:
    a bag written during the replay, whatever is kept).
    """
    if tick_period_ns <= 0:
        raise InputError('tick_period_ns', tick_period_ns, 'a period > 0 ns')
    t_start = time.perf_counter()
    bag = Path(bag_path)
    cores = order_cores(cores)
    published = {t for c in cores for t in getattr(c, 'publications', {})}
    wanted = {t for c in cores for t in c.subscriptions} - published
    topics = bagio.bag_topics(bag)
    result = OfflineResult(bag=bag, regenerated_topics=tuple(sorted(published & set(topics))))
    router = _Router(cores, result, superseded_tables, sink)
    joints = JOINT_STATES
    # both forms of the sample stream (one per JointState, blocks) feed the sample
    # subscribers; joint names (angle, lift) from the first core that has them
    feed_joints = joints in wanted and (joints in topics or JOINT_TRAJECTORY in topics)
    names = sample_joints_of(bag, cores)
    blocks = iter(()) if not feed_joints else \
        bagio.iter_joint_states(bag, block_bytes=block_bytes, joints=names) if names else \
        bagio.iter_joint_states(bag, block_bytes=block_bytes)
    others = bagio.iter_messages(bag, sorted(wanted - {joints, JOINT_TRAJECTORY})) \
        if wanted - {joints, JOINT_TRAJECTORY} else iter(())
    total = sum(topics[t][1] for t in wanted if t in topics)
    summary = bagio.JointSummary()
    joint_cores = router.subscribers.get(joints, [])
    done = 0
    last_t: int | None = None

    def ticks_until(t: int) -> None:
        if last_t is not None and t - last_t > tick_period_ns:
            grid = last_t + tick_period_ns * np.arange(1, MAX_TICKS_PER_GAP + 1)
            grid = grid[grid < t - 1]
            for now in grid.tolist():
                router.tick(int(now))
            router.tick(t - 1)

    def feed_samples(samples: bagio.JointSamples, i0: int, i1: int) -> None:
        """Samples [i0, i1) of a block to the JointState subscribers, cut at log-time
        gaps."""
        nonlocal last_t, done
        if i1 <= i0:
            return
        log = samples.log_ns
        cuts = np.nonzero(np.diff(log[i0:i1]) > tick_period_ns)[0] + 1 + i0
        for a, b in zip([i0, *cuts.tolist()], [*cuts.tolist(), i1]):
            ticks_until(int(log[a]))
            for core in joint_cores:
                method, accepts_rx = _bulk_method(core) if bulk else (None, False)
                rx = int(log[b - 1])
                if method is not None:
                    args = (samples.frame_id[a:b], samples.stamp_ns[a:b],
                            samples.theta[a:b], samples.s[a:b])
                    outs = method(*args, rx_ns=rx) if accepts_rx else method(*args)
                    router.emit(core, outs, rx)
                else:
                    chunk = bagio.JointSamples(
                        samples.frame_id[a:b], samples.stamp_ns[a:b], log[a:b],
                        samples.theta[a:b], samples.s[a:b])
                    for msg, t in zip(bagio.light_joint_states(chunk), log[a:b].tolist()):
                        router.emit(core, core.handle(joints, msg, t), t)
            last_t = int(log[b - 1])
            done += b - a
            if progress is not None:
                progress(done, total)

    def deliver(m: bagio.BagMessage) -> None:
        nonlocal last_t, done
        ticks_until(m.stamp_ns)
        router.deliver(m.topic, m.msg, m.stamp_ns)
        result.delivered[m.topic] = result.delivered.get(m.topic, 0) + 1
        last_t = m.stamp_ns if last_t is None else max(last_t, m.stamp_ns)
        done += 1
        if progress is not None and done % 1000 == 0:
            progress(done, total)

    # two streams in log-time order: sample blocks and the other messages; a sample
    # and a message of the same log time: the sample first
    nxt = next(others, None)
    for samples in blocks:
        summary.add(samples)
        i = 0
        while nxt is not None:
            j = int(np.searchsorted(samples.log_ns, nxt.stamp_ns, side='right'))
            if j == len(samples):
                break   # the message comes after this whole block
            feed_samples(samples, i, j)
            i = j
            deliver(nxt)
            nxt = next(others, None)
        feed_samples(samples, i, len(samples))
        del samples   # one block in memory at a time
    while nxt is not None:
        deliver(nxt)
        nxt = next(others, None)
    result.samples = summary.count
    result.usable_samples = summary.usable
    result.joint_issues = summary.issues
    if summary.count:
        result.delivered[joints] = summary.count
    end = last_t if last_t is not None else 0
    # the live timer keeps running after the stream: idle timeouts can fire first
    for core in cores:
        router.emit(core, core.tick(end + 10**12), end)
    for core in cores:
        router.emit(core, core.finish(), end)
    router.compact()
    if progress is not None:
        progress(total, total)
    result.elapsed_s = time.perf_counter() - t_start
    return result


class OutputBagWriter:
    """A new bag written while the replay runs (``run_offline(..., sink=writer.add)``):
    every message of the input bag (bytes unchanged, except topics the cores
    regenerate) and every output as it is produced, merged in log-time order (an
    output after the input messages of the same log time; its plot views, stamped at
    or after it, in their order). What is held: the outputs and plot views not yet
    passed by the input stream; an output whose log time is reached is written at
    once, so memory does not grow with the bag. ``close`` writes the rest and returns
    the number of outputs written. Outputs must come in non-decreasing log time (the
    replay's order)."""

    def __init__(self, bag: str | Path, out_bag: str | Path, regenerated: Iterable[str], *,
                 compression: bool = True, plots: bool = True) -> None:
        self.writer = bagio.BagWriter(out_bag, compression=compression)
        skip = set(regenerated) | (set(PLOT_TOPICS) if plots else set())
        topics = bagio.add_topics_like(self.writer, bag, [
            t for t in bagio.bag_topics(bag) if t not in skip])
        self._inputs = ((m.stamp_ns, 0, i, (m.topic, m.msg)) for i, m in enumerate(
            bagio.iter_messages(bag, list(topics), raw=True)))
        self._input: tuple[int, int, int, Any] | None = next(self._inputs, None)
        self._pending: list[tuple[int, int, int, Any]] = []   # heap: outputs, views
        self.plots = plots
        self.outputs = 0
        self._views = 0

    def add(self, item: StampedOutput) -> None:
        """Take one output (and its plot views); write everything that comes before it."""
        key = (item.stamp_ns, 1, self.outputs)
        heapq.heappush(self._pending, (*key, item.output))
        self.outputs += 1
        for p in plot_messages(item.output, item.stamp_ns) if self.plots else ():
            heapq.heappush(self._pending, (p.stamp_ns, 2, self._views, (p.topic, p.cdr)))
            self._views += 1
        self._write_until(key)

    def _write_until(self, key: tuple[int, int, int] | None) -> None:
        """Write input messages and pending items in merged order up to ``key``
        (everything when None)."""
        while True:
            pending = self._pending[0] if self._pending else None
            nxt = self._input
            if nxt is None or (pending is not None and pending[:3] < nxt[:3]):
                nxt = pending
            if nxt is None or (key is not None and nxt[:3] > key):
                return
            stamp, kind, _, item = nxt
            if nxt is pending:
                heapq.heappop(self._pending)
            else:
                self._input = next(self._inputs, None)
            if kind == 1:
                self.writer.write_output(item, stamp)
            else:
                self.writer.write(item[0], stamp, item[1])

    def close(self) -> int:
        """Write what is left and close the bag; returns the number of outputs."""
        self._write_until(None)
        self.writer.close()
        return self.outputs

    def abort(self) -> None:
        """Close the bag as it is (the replay failed: the caller discards it)."""
        self.writer.close()


def regenerated_topics(bag: str | Path, cores: Sequence[Any]) -> tuple[str, ...]:
    """Topics of ``bag`` that ``cores`` publish (regenerated by a replay, not copied)."""
    published = {t for c in cores for t in getattr(c, 'publications', {})}
    return tuple(sorted(published & set(bagio.bag_topics(bag))))


def write_outputs(result: OfflineResult, out_bag: str | Path, *,
                  compression: bool = True, plots: bool = True) -> int:
    """A new bag with every message of the input bag (bytes unchanged, except topics
    the cores regenerated) and every output of ``result``, merged in log-time order
    (``OutputBagWriter``); with ``plots`` also the plot views of every output
    (``wire.plots``: curves, per-part values, statuses on /diagnostics), as the live
    nodes publish them. Returns the number of outputs written. ``analyze --out-bag``
    writes while replaying instead (``run_offline(sink=...)``), holding no outputs."""
    writer = OutputBagWriter(result.bag, out_bag, result.regenerated_topics,
                             compression=compression, plots=plots)
    try:
        for item in result.outputs:
            writer.add(item)
    finally:
        n = writer.close()
    return n
