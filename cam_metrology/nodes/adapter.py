"""``CoreNode``: the generic rclpy adapter around any ``NodeCore`` (core.py).

* declares the core's ``PARAMETERS`` as ROS parameters (with descriptors) and builds
  the core from their values (so ``--params-file config/<node>.yaml`` sets them);
* subscribes to ``core.subscriptions``: bench topics with the QoS of ``wire.topics``
  (/bench/scene transient local depth 1, created first; /bench/joint_states reliable
  keep all, ``wire.topics.SAMPLES``), other nodes' outputs once their
  publisher is in the graph, transient local when it offers it
  (``topics.AdaptiveSubscriptions``: a node that matched late still gets the last 100
  outputs); every callback calls ``core.handle(topic, msg, receive_time_ns)``;
* publishes the returned outputs on their topics, reliable, transient local (depth 1
  for the report, 100 for the others: ``wire.topics.RESULTS``), encoded by
  ``wire.layouts.encode_output`` and published as serialized bytes, each with its plot
  views (``wire.plots``: curves, per-part values, statuses on /diagnostics);
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
* blocks of samples (``wire.topics.BLOCK_TOPICS``: ``/bench/joint_trajectory``,
  ``/rig/joint_trajectory``; JointTrajectory, when the core subscribes one): always
  subscribed raw, one callback per block (a block of 1000
  samples costs what one JointState costs), decoded by ``bagio.decode_joint_blocks``
  (joints by the core's names) and handed to the core's ``handle_samples`` in order
  with the held messages like the JointState batches (with the lift velocity and
  further joints when the core sets ``block_extras``); lost blocks are counted per
  block and per sample (``loss.SequenceLoss(blocks=True)``); damaged blocks are
  reported in the input status (WARN, the first one named) and not used;
* a timer calls ``core.tick(now_ns)`` (idle timeouts);
* on shutdown, after draining what already arrived, calls ``core.finish()``,
  publishes that, and waits (deadline) until every subscriber acknowledged.
A core that raises is logged with its traceback and counted (non-zero exit), the node
keeps running: one bad message must not take the live graph down.
"""
from __future__ import annotations

import functools
import heapq
import queue
import threading
import time
import traceback
from typing import Any, Sequence

from rcl_interfaces.msg import ParameterDescriptor
from rclpy.node import Node

from cam_metrology.wire.loss import (FeatureLoss, SequenceLoss, loss_status, loss_values,
                                     mark_partial)
from cam_metrology.nodes.topics import AdaptiveSubscriptions, message_class, profile
from cam_metrology.cores.outputs import Output, Status, StatusOutput
from cam_metrology.wire.layouts import encode_output, msgtype_of
from cam_metrology.wire.plots import plot_messages, view_topics
from cam_metrology.wire.topics import (BENCH_TOPICS, BLOCK_TOPICS, DIAGNOSTICS, FEATURE_DONE,
                                       JOINT_STATES, RIG_TOPICS, SCENE,
                                       STATUS, QosSpec, qos_of)

#: raw sample messages kept, before the first scene, for the joint names it may give
#: (scene ``channels``); beyond, they are decoded with the names in force
BEFORE_SCENE_LIMIT = 200_000


#: most raw samples handed to a core in one call (keeps the worker responsive)
MAX_BATCH = 4000
#: most raw samples taken from the reader in one callback of the receiving thread
TAKE_BATCH = 20000
#: bounded queue between the receiving thread and the worker [items of <= TAKE_BATCH]:
#: when full the receiver stops taking, the keep-all reader fills and the publisher is
#: held back (back-pressure; a keep-last publisher then loses samples, counted)
QUEUE_ITEMS = 64
#: s between /diagnostics statuses of the node's input
DIAG_PERIOD = 1.0
#: s the receiving thread waits after the first sample of a callback before taking the
#: rest (fewer, bigger batches; adds at most this to the latency)
RX_LINGER = 0.005


def load_core(name: str) -> Any:
    """The core class registered for node ``name`` (ValueError for another name)."""
    from cam_metrology.offline.registry import CORES, RIG_CORES, load_core_class
    if name not in CORES and name not in RIG_CORES:
        raise ValueError(f'no core registered for node {name!r}; known: '
                         f'{sorted(CORES) + sorted(RIG_CORES)}')
    return load_core_class(name)


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

    from cam_metrology.inputs.params import check_value, expected_type

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
                 with_info: bool = True, samples_qos: QosSpec | None = None,
                 threaded: bool = True) -> None:
        super().__init__(node_name or core_cls.name, context=context)
        self.params = declare_parameters(self, dict(getattr(core_cls, 'PARAMETERS', {})))
        self.core = core_cls(self.params)
        self.errors = 0
        self.callbacks_run = 0
        self.published: dict[str, int] = {}
        self._pubs: dict[str, Any] = {}
        for topic, type_name in self.core.publications.items():
            self._publisher(topic, type_name)
            for view, view_type in view_topics(topic).items():   # matched before use
                self._publisher(view, view_type)
        self._subs: dict[str, Any] = {}
        self._held: list[tuple[int, int, str, Any]] = []   # (source ns, seq, topic, msg)
        #: raw sample batches (and their topic) received before the first scene
        self._before_scene: list[tuple[list[tuple[bytes, int, int]], str]] = []
        self._seq = 0
        self._order_hold = order_hold
        self._last_sample = 0.0        # monotonic s of the last sample handled
        self._last_held = 0.0          # monotonic s of the last message put on hold
        self._samples_qos = samples_qos
        # loss accounting (DDS publication sequence numbers, cam_metrology.wire.loss)
        self.losses: dict[str, SequenceLoss] = {}
        self.feature_loss = FeatureLoss()
        self._diag_pub: Any = None
        self._diag_last = 0.0
        self._diag_said: tuple[int, str] | None = None
        self.lock = threading.RLock()   # the core and the publishers: one user at a time
        self._done_seen = False         # the bench announces the end of its features
        # the scene first: with several ready subscriptions, rclpy's executor takes
        # them in creation order, so the scene is handled before samples.
        topics = sorted(self.core.subscriptions.items(), key=lambda item: item[0] != SCENE)
        self._with_info = with_info
        self._ordered = with_info and JOINT_STATES in self.core.subscriptions
        self._bulk = self._ordered and callable(getattr(self.core, 'handle_samples', None))
        # the core takes the blocks' lift velocity and further joints (the rig's)
        self._extras = bool(getattr(self.core, 'block_extras', False))
        self._block_issues: Any = None   # bagio.JointSummary of damaged blocks
        self._adaptive = AdaptiveSubscriptions(self, self._subscribe)
        for topic, type_name in topics:
            if topic in BENCH_TOPICS or topic in RIG_TOPICS:   # inputs: our QoS (keep all)
                self._subscribe(topic, type_name, qos_of(topic))
            else:   # another node's output: QoS from its publishers (late joiners)
                self._adaptive.add(topic, type_name, qos_of(topic).depth)
        # bulk samples: received on the executor's thread, handled by a worker thread
        # (decode, core, analysis, publishing) fed through a bounded queue
        self._queue: queue.Queue[Any] | None = None
        self._worker: threading.Thread | None = None
        self._busy = False
        self.worker_items = 0
        if self._bulk and threaded:
            self._queue = queue.Queue(QUEUE_ITEMS)
            self._worker = threading.Thread(target=self._work, name=f'{self.get_name()}-worker',
                                            daemon=True)
            self._worker.start()
        self._timer = self.create_timer(tick_period, self._on_tick)
        if self._ordered:
            self._order_timer = self.create_timer(0.05, self._on_order_timer)

    def _subscribe(self, topic: str, type_name: str, qos: QosSpec) -> None:
        raw = False
        if (topic == JOINT_STATES or topic in BLOCK_TOPICS) and self._samples_qos is not None:
            qos = self._samples_qos
        if topic in BLOCK_TOPICS:   # blocks: raw, decoded with numpy
            callback = functools.partial(
                self._on_blocks_raw if self._with_info else self._on_blocks_plain, topic)
            raw = True
        elif topic == JOINT_STATES and self._bulk:
            callback: Any = self._on_sample_raw
            raw = True
        elif topic == JOINT_STATES and self._ordered:
            callback = self._on_sample
        elif self._ordered:
            callback = functools.partial(self._on_held, topic)
        elif self._with_info:
            callback = functools.partial(self._on_message_info, topic)
        else:
            callback = functools.partial(self._on_message, topic)
        if self._with_info and qos.depth > 1 and topic not in self.losses:
            # latched depth-1 topics: not counted
            self.losses[topic] = SequenceLoss(topic, blocks=topic in BLOCK_TOPICS)
        self._subs[topic] = self.create_subscription(
            message_class(type_name), topic, callback, profile(qos), raw=raw)

    # -- publishing -----------------------------------------------------------------
    def _publisher(self, topic: str, type_name: str) -> Any:
        pub = self._pubs.get(topic)
        if pub is None:
            pub = self.create_publisher(message_class(type_name), topic,
                                        profile(qos_of(topic)))
            self._pubs[topic] = pub
        return pub

    def publish_outputs(self, outputs: Sequence[Output] | None) -> None:
        """Convert and publish core outputs (lazily creating undeclared publishers);
        features computed on partial input are marked (``loss.mark_partial``)."""
        if outputs and (self.feature_loss.seen or self.losses):
            outputs = mark_partial(outputs, self.feature_loss, list(self.losses.values()))
            for out in outputs:
                if isinstance(out, StatusOutput):
                    for st in out.statuses:
                        self.feature_loss.result_published(st.name)
        for out in outputs or ():
            now = self.now_ns()
            self._publisher(out.topic, msgtype_of(out)).publish(encode_output(out, now))
            self.published[out.topic] = self.published.get(out.topic, 0) + 1
            for view in plot_messages(out, now):   # curves, values, /diagnostics
                self._publisher(view.topic, view.msgtype).publish(view.cdr)
                self.published[view.topic] = self.published.get(view.topic, 0) + 1

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
        with self.lock:
            self._guarded(f'handle({topic})', self.core.handle, topic, msg, self.now_ns())

    def _on_message_info(self, topic: str, msg: Any, info: Any) -> None:
        self._count(topic, [_seq(info)])
        self._on_message(topic, msg)

    def _count(self, topic: str, seqs: list[int]) -> list[tuple[int, int]]:
        """Loss accounting of ``topic``; returns the holes (loss.SequenceLoss.add)."""
        acc = self.losses.get(topic)
        if acc is None or not seqs or seqs[0] < 0:
            return []
        holes = acc.add(seqs)
        if holes:
            self._diag_last = 0.0   # say it at the next tick
        return holes

    # -- /diagnostics: the node's input (received, lost) ------------------------------
    def input_status(self) -> Status:
        """OK/WARN/ERROR status of what this node received ('lost N samples on TOPIC')."""
        losses = list(self.losses.values())
        split = {f: n for f, n in self.feature_loss.parts.items() if n > 1}
        level, msg = loss_status(losses, '; '.join(
            f'feature {f} received in {n} parts (paused longer than the idle timeout)'
            for f, n in split.items()))
        if split:
            level = max(level, 1)
        if self._block_issues is not None and self._block_issues.issues:
            level = max(level, 1)
            msg += '; damaged blocks not used: ' + '; '.join(
                i.text(self._block_issues.count) for i in self._block_issues.issues)
        if not self._with_info:   # EventsExecutor: no MessageInfo, no sequence numbers
            level, msg = max(level, 1), 'loss not checked (EventsExecutor: no MessageInfo)'
        backlog = self._queue.qsize() if self._queue is not None else 0
        values = {**loss_values(losses), 'queue_items': str(backlog),
                  'callbacks': str(self.callbacks_run), 'core_errors': str(self.errors)}
        return Status(f'{self.get_name()}: input', level, msg, values, self.get_name())

    def publish_diagnostics(self, force: bool = False) -> None:
        """Publish ``input_status`` on /diagnostics (every DIAG_PERIOD s, or now)."""
        now = time.monotonic()
        if not force and now - self._diag_last < DIAG_PERIOD:
            return
        self._diag_last = now
        st = self.input_status()
        if self._diag_pub is None:   # the same publisher as the results' statuses
            self._diag_pub = self._publisher(DIAGNOSTICS, STATUS)
        self._diag_pub.publish(encode_output(StatusOutput(DIAGNOSTICS, (st,)), self.now_ns()))
        said = (st.level, st.message)
        if st.level and said != self._diag_said:
            self.get_logger().warning(f'{self.core.name}: {st.message}')
        self._diag_said = said

    # -- cross-topic ordering (only when the core consumes /bench/joint_states) -------
    def _on_held(self, topic: str, msg: Any, info: Any) -> None:
        self.callbacks_run += 1
        self._count(topic, [_seq(info)])
        if self._queue is not None:   # threaded: the worker orders; samples first
            self._enqueue_samples(self._drain_samples(TAKE_BATCH))
            self._queue.put(('held', (_source_ns(info), topic, msg)))
            return
        with self.lock:
            self._hold(topic, msg, _source_ns(info))
            self._take_waiting_samples()

    def _hold(self, topic: str, msg: Any, source_ns: int) -> None:
        if topic == FEATURE_DONE:
            self._done_seen = True
        self._seq += 1
        heapq.heappush(self._held, (source_ns, self._seq, topic, msg))
        self._last_held = time.monotonic()

    def _on_sample(self, msg: Any, info: Any) -> None:
        self.callbacks_run += 1
        holes = self._count(JOINT_STATES, [_seq(info)])
        if holes:
            forced = getattr(self.core, 'feature_id', '')
            self.feature_loss.add([forced or msg.header.frame_id], holes)
        with self.lock:
            self._deliver_sample(msg, _source_ns(info))

    def _deliver_sample(self, msg: Any, source_ns: int) -> None:
        while self._held and self._held[0][0] <= source_ns:
            self._release_one()
        self._last_sample = time.monotonic()
        self._guarded(f'handle({JOINT_STATES})', self.core.handle, JOINT_STATES, msg,
                      self.now_ns())

    def _on_sample_raw(self, data: bytes, info: Any) -> None:
        self.callbacks_run += 1
        batch = [(data, _source_ns(info), _seq(info))]
        if self._queue is not None:
            # linger: let a batch gather (at 20 000/s, 100 samples in 5 ms) so that the
            # executor wakes ~200 times a second, not once per burst of the publisher
            # (each wake costs ~0.1-0.3 ms of Python); the keep-all reader holds them
            time.sleep(RX_LINGER)
            batch.extend(self._drain_samples(TAKE_BATCH - 1))
            self._enqueue_samples(batch)
            return
        batch.extend(self._drain_samples(MAX_BATCH - 1))
        with self.lock:
            self._deliver_batch(batch)

    def _on_blocks_raw(self, topic: str, data: bytes, info: Any) -> None:
        """One block (JointTrajectory CDR) of ``topic``: to the worker, or handled now."""
        self.callbacks_run += 1
        item = [(data, _source_ns(info), _seq(info))]
        if self._queue is not None:
            self._queue.put((topic, item))
            return
        with self.lock:
            self._deliver_batch(item, topic)

    def _on_blocks_plain(self, topic: str, data: bytes) -> None:
        """A block under the EventsExecutor (no MessageInfo: no loss count)."""
        self._on_blocks_raw(topic, data, None)

    def _drain_samples(self, limit: int) -> list[tuple[Any, int, int]]:
        """Take up to ``limit`` samples already waiting in the reader, in order:
        (raw CDR, source time [ns], publication sequence number)."""
        sub = self._subs.get(JOINT_STATES)
        taken_all: list[tuple[Any, int, int]] = []
        if sub is None:
            return taken_all
        take, msg_type, raw = sub.handle.take_message, sub.msg_type, sub.raw
        append = taken_all.append
        try:
            with sub.handle:
                while len(taken_all) < limit:
                    taken = take(msg_type, raw)
                    if taken is None:
                        break
                    info = taken[1]
                    append((taken[0], info['source_timestamp'],
                            info.get('publication_sequence_number') or -1))
        except Exception:  # noqa: BLE001 (destroyed handle at shutdown)
            pass
        return taken_all

    def _enqueue_samples(self, batch: list[tuple[Any, int, int]]) -> None:
        """Receiving thread -> worker; blocks while the queue is full (back-pressure)."""
        if batch and self._queue is not None:
            self._queue.put(('samples', batch))

    # -- the worker thread (threaded bulk path) ---------------------------------------
    def _work(self) -> None:
        """Handle queued samples, held messages and ticks in arrival order."""
        assert self._queue is not None
        pending: Any = None
        while True:
            if pending is not None:
                kind, item, pending = pending[0], pending[1], None
            else:
                try:
                    kind, item = self._queue.get(timeout=0.05)
                except queue.Empty:
                    with self.lock:
                        self._release_quiet()
                    continue
            extra = 0
            while (kind == 'samples' or kind in BLOCK_TOPICS) and len(item) < TAKE_BATCH:
                # merge the sample batches (or blocks) queued behind this one: one
                # decode and one core call per merge instead of per receive callback
                try:
                    nxt = self._queue.get_nowait()
                except queue.Empty:
                    break
                if nxt[0] != kind:
                    pending = nxt
                    break
                item = item + nxt[1]
                extra += 1
            self._busy = True
            try:
                with self.lock:
                    if kind == 'samples':
                        self._deliver_batch(item)
                    elif kind in BLOCK_TOPICS:   # blocks of that topic
                        self._deliver_batch(item, kind)
                    elif kind == 'held':
                        self._hold(item[1], item[2], item[0])
                    elif kind == 'tick':
                        self._tick(item)
                        self.publish_diagnostics()
                    elif kind == 'stop':
                        return
            finally:
                self._busy = False
                if kind != 'tick':
                    self.worker_items += 1 + extra   # data progress (drain), not ticks
                for _ in range(1 + extra):
                    self._queue.task_done()

    def _release_quiet(self) -> None:
        """Release held messages once no sample arrived for ``order_hold`` s."""
        quiet = time.monotonic() - max(self._last_sample, self._last_held)
        if self._held and quiet >= self._order_hold:
            while self._held:
                self._release_one()

    def idle(self) -> bool:
        """Nothing queued and the worker not busy (always true when not threaded)."""
        return self._queue is None or (self._queue.unfinished_tasks == 0 and not self._busy)

    def stop_worker(self, timeout: float = 30.0) -> None:
        """Let the worker handle everything queued, then stop it."""
        if self._worker is not None and self._worker.is_alive() and self._queue is not None:
            self._queue.put(('stop', None))
            self._worker.join(timeout)
        self._worker = None

    def _deliver_batch(self, batch: list[tuple[bytes, int, int]],
                       topic: str = JOINT_STATES, scene_or_not: bool = False) -> None:
        """Hand raw messages of ``topic`` (JointStates, or JointTrajectory blocks) to
        the core in blocks, releasing each held message just before the first message
        published after it (the same order as one by one). Losses (sequence holes)
        are counted and charged to features first, so a feature that completes in this
        batch is already marked."""
        import numpy as np

        from cam_metrology.bagio import JointSummary, decode_joint_blocks, decode_joint_states
        while self._held and self._held[0][0] <= batch[0][1]:
            self._release_one()   # a scene before the batch may name the joints
        if not scene_or_not and self._names_await_scene() and \
                sum(len(b) for b, _ in self._before_scene) < BEFORE_SCENE_LIMIT:
            self._before_scene.append((batch, topic))   # decoded once the scene names them
            return
        joints = getattr(self.core, 'joints', None) or (None, None)
        named = {'joints': joints} if joints[0] else {}
        raws = [b[0] for b in batch]
        if topic in BLOCK_TOPICS:
            js = decode_joint_blocks(raws, topic=topic, extras=self._extras, **named)
            sizes = js.block_sizes if js.block_sizes is not None else np.zeros(0, np.int64)
            bounds = np.concatenate(([0], np.cumsum(sizes))).tolist()
            frames = _message_frames(js.frame_id, sizes)
            if js.issues:
                if self._block_issues is None:
                    self._block_issues = JointSummary()
                self._block_issues.add(js)
                self._diag_last = 0.0   # say it at the next tick
        else:
            js = decode_joint_states(raws, **named)
            bounds, frames = list(range(len(batch) + 1)), js.frame_id
        forced = getattr(self.core, 'feature_id', '')
        if forced:   # the core gives every sample this feature: charge losses to it
            frames = [forced] * len(frames)
        holes = self._count(topic, [b[2] for b in batch])
        acc = self.losses.get(topic)
        if acc is not None and acc.blocks:
            acc.add_samples(len(js))
            holes = [(i, int(round(n * acc.samples_per_message))) for i, n in holes]
        if holes or len(frames):
            self.feature_loss.add(frames, holes)
        i = 0
        while i < len(batch):
            while self._held and self._held[0][0] <= batch[i][1]:
                self._release_one()
            limit = self._held[0][0] if self._held else None
            j = i + 1
            while j < len(batch) and (limit is None or batch[j][1] < limit):
                j += 1
            if bounds[j] > bounds[i]:
                self._guarded(f'handle_samples({topic})', self._handle_block, js,
                              bounds[i], bounds[j])
            i = j
        self._last_sample = time.monotonic()

    def _names_await_scene(self) -> bool:
        """True while the core has no scene and its joint names may come from the
        scene's ``channels`` (its parameters keep the default names)."""
        from cam_metrology.scene.channels import DEFAULT_JOINTS

        given = getattr(self.core, 'joints_param', None)
        return given is not None and tuple(given) == DEFAULT_JOINTS and \
            getattr(self.core, 'scene', None) is None

    def _handle_block(self, js: Any, i: int, j: int) -> list[Output]:
        more: dict[str, Any] = {}
        if self._extras and (js.lift_velocity is not None or js.others):
            more = {'velocity': None if js.lift_velocity is None else js.lift_velocity[i:j],
                    'others': {k: v[i:j] for k, v in js.others.items()}}
        return self.core.handle_samples(js.frame_id[i:j], js.stamp_ns[i:j], js.theta[i:j],
                                        js.s[i:j], rx_ns=self.now_ns(), **more)

    def _release_one(self) -> None:
        _, _, topic, msg = heapq.heappop(self._held)
        self._guarded(f'handle({topic})', self.core.handle, topic, msg, self.now_ns())
        if topic == SCENE and self._before_scene and not self._names_await_scene():
            early, self._before_scene = self._before_scene, []
            for batch, samples_topic in early:   # in the order they came
                self._deliver_batch(batch, samples_topic)

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
        if self._queue is not None:   # threaded: take what waits; the worker orders
            self._enqueue_samples(self._drain_samples(TAKE_BATCH))
            return
        if not self._held:
            return
        with self.lock:
            self._take_waiting_samples()
            self._release_quiet()

    def release_held(self) -> None:
        """Hand every held message to the core (shutdown)."""
        if self._queue is not None:
            self._enqueue_samples(self._drain_samples(TAKE_BATCH))
            self.stop_worker()
        with self.lock:
            self._take_waiting_samples()
            while self._held:
                self._release_one()

    def _on_tick(self) -> None:
        if self._queue is not None and self._worker is not None:
            self._queue.put(('tick', self.now_ns()))
            return
        with self.lock:
            self._tick(self.now_ns())
            self.publish_diagnostics()

    def _tick(self, now_ns: int) -> None:
        """``core.tick`` (idle timeouts), except while a bench that announces the end of
        its features (it has a /bench/feature_done publisher, or one was received) is
        still publishing samples: then a pause in the stream (back-pressure, a busy
        machine) must not end a feature early and split it; its /bench/feature_done
        or the next feature ends it (and ``finish`` at shutdown)."""
        sub = self._subs.get(JOINT_STATES)
        if sub is not None and FEATURE_DONE in self._subs and sub.get_publisher_count() > 0 \
                and (self._done_seen or self.count_publishers(FEATURE_DONE) > 0):
            return
        self._guarded('tick', self.core.tick, now_ns)

    def finish(self, ack_timeout: float = 5.0) -> bool:
        """Release held messages, call ``core.finish()``, publish its outputs and the
        final input status, and wait (deadline) until they are acknowledged."""
        self.release_held()
        with self.lock:
            early, self._before_scene = self._before_scene, []
            for batch, samples_topic in early:   # no scene came: the names in force
                self._deliver_batch(batch, samples_topic, scene_or_not=True)
            self._guarded('finish', self.core.finish)
            self.publish_diagnostics(force=True)
        pubs = list(self._pubs.values())   # /diagnostics included (_publisher)
        from cam_metrology.nodes.runtime import wait_all_acked
        return wait_all_acked(pubs, ack_timeout)

    def wait_acked(self, timeout: float) -> bool:
        """Wait (deadline) until every matched subscriber acknowledged every message."""
        from cam_metrology.nodes.runtime import wait_all_acked
        return wait_all_acked(self._pubs.values(), timeout)


def _message_frames(frame_id: Any, sizes: Any) -> list[str]:
    """The frame id of each block message from its samples' (``sizes`` samples each;
    an empty block takes the previous block's, '' at the start)."""
    out: list[str] = []
    k = 0
    for n in sizes.tolist():
        out.append(str(frame_id[k]) if n else (out[-1] if out else ''))
        k += n
    return out


def _seq(info: Any) -> int:
    """DDS publication sequence number of a received message (-1 if absent)."""
    try:
        return int(info['publication_sequence_number'] or -1)
    except (TypeError, KeyError):
        return -1


def _source_ns(info: Any) -> int:
    """Publication time [ns] of a received message (MessageInfo dict; 0 if absent)."""
    try:
        return int(info['source_timestamp'])
    except (TypeError, KeyError):
        return 0


def run_core_node(name: str, args: Sequence[str] | None = None, *,
                  events_executor: bool = False) -> int:
    """Run node ``name`` (metrology | reconstruction | dynamics) until SIGINT/SIGTERM.

    Returns 0, or 1 if the core raised.
    """
    from cam_metrology.nodes.runtime import RosProcess
    core_cls = load_core(name)
    proc = RosProcess(args, events_executor=events_executor)
    node = None
    try:
        node = proc.add(CoreNode(core_cls, context=proc.context,
                                 with_info=not events_executor))
        node.get_logger().info(f'{name} node up: subscribes {sorted(node.core.subscriptions)}'
                               f', publishes {sorted(node.core.publications)}')
        proc.spin_until()
        proc.drain(lambda: node.callbacks_run + node.worker_items, limit=60.0)
        if not node.finish():
            node.get_logger().warning('not every subscriber acknowledged the last outputs')
        st = node.input_status()
        log = node.get_logger().warning if st.level else node.get_logger().info
        log(f'{name} node stopped ({proc.stop_reason}); input: {st.message}; published '
            f'{node.published}; errors {node.errors}')
        return 1 if node.errors else 0
    finally:
        proc.close()
