"""The recorder node: raw CDR from the live graph into a rosbag2/MCAP bag.

* One ``raw=True`` subscription per topic: the callback gets the bytes exactly as they
  came off the wire and writes them unchanged with ``bagio.BagWriter`` (never
  ``serialize_message``, docs/ros.md).
* Topics: the bench inputs (/bench/scene, /bench/truth, /bench/joint_states,
  /bench/joint_trajectory (blocks of samples: loss counted per block and per sample),
  /bench/feature_done), every output and plot topic of ``wire.topics`` (not
  /diagnostics: the recorder writes its own status there), plus extras
  (``/topic`` or ``/topic:pkg/msg/Type``).
* QoS: the bench topics from ``wire.topics`` (transient local for /bench/scene and
  /bench/truth, so a late recorder still gets the latched scene; reliable keep all
  for samples, ``wire.topics.SAMPLES``: a busy machine must not overrun it). Output
  and extra topics are subscribed once a publisher is in the graph, transient local
  if every publisher offers it (``topics.AdaptiveSubscriptions``, as ``ros2 bag
  record`` does): our nodes offer their outputs transient local depth 100, so a
  recorder that matched a node late still records every result.
* Log time = publication time: the DDS ``source_timestamp`` of the sample (MessageInfo,
  the publisher's clock; same host), falling back to the receive time when absent.
  rosbag2 logs the receive time instead, but ROS orders messages only within a topic,
  and SingleThreadedExecutor takes one message per ready subscription in turn: with
  receive times a /bench/feature_done can land in the bag before the last samples of
  its feature, and an offline analysis would then split that feature. Publication
  times keep the bag in the order the bench produced it (a latched scene delivered
  late keeps its original, earlier stamp). The acquisition time stays in each
  message's header.
* Single-threaded: a callback also takes what else is already waiting on its topic
  (``take_message``, up to ``TAKE_BATCH``), which skips the executor's ~95 us per
  message; the publication-time log stamps keep the bag in order regardless.
* With ``events_executor`` the log time is the receive time (``time.time_ns()`` in the
  callback): rclpy 7.1.6's EventsExecutor raises ``SystemError: null argument to
  internal routine`` for every raw message whose callback takes MessageInfo (20 000 of
  20 000 in a probe). Its callbacks run in event-arrival order across topics, which
  keeps the publish order of one publisher in practice, but not by contract.
* Loss is never silent: every topic deeper than 1 (not the latched ones) is counted
  against the DDS publication sequence numbers of MessageInfo
  (``cam_metrology.wire.loss``). The recorder's status ("lost N samples on TOPIC", or "no
  loss") goes to /diagnostics every second and whenever a new hole appears, into the
  bag itself (its /diagnostics topic, the same DiagnosticArray, final one at close),
  and into the "bag closed" line; ``cam-bench record`` exits 1 when samples were lost
  in the stream. (EventsExecutor: no MessageInfo in rclpy 7.1.6, so no sequence
  numbers: the status says the loss was not checked.)
* Stop (SIGINT/SIGTERM or end of a run): drain what already arrived for at most
  ``STOP_DRAIN_S`` (so a publisher that keeps sending cannot hold the recorder), then
  ``writer.close()`` in ``finally`` so that metadata.yaml is always written.
"""
from __future__ import annotations

import functools
import re
import struct
import time
from pathlib import Path
from typing import Any, Sequence

from rclpy.node import Node

from cam_metrology.bagio import BagWriter, block_sample_count
from cam_metrology.wire.loss import OK, WARN, SequenceLoss, loss_status, loss_values
from cam_metrology.nodes.adapter import RX_LINGER
from cam_metrology.nodes.topics import AdaptiveSubscriptions, message_class, profile
from cam_metrology.wire.layouts import encode_statuses
from cam_metrology.wire.topics import (BENCH_TOPICS, BLOCK_TOPICS, DIAGNOSTICS,
                                       JOINT_STATES, RIG_TOPICS, STATUS, TOPICS, QosSpec,
                                       qos_of)
from cam_metrology.cores.outputs import Status

PARAMETERS: dict[str, tuple[Any, str]] = {
    'output': ('', 'bag directory to create (must not exist); empty: '
                   'out/rec_<UTC time> under the current directory'),
    'topics': ('', 'extra topics, comma or space separated, each /topic or '
                   '/topic:pkg/msg/Type'),
    'record_defaults': (True, 'record the bench topics and every node output topic'),
    'compression': (True, 'zstd chunk compression of the MCAP file'),
    'events_executor': (False, 'spin with rclpy.experimental.EventsExecutor '
                               '(5-7x cheaper per message; experimental)'),
    'status_period': (0.0, 'log a line with the message counts every N s (0: never)'),
}


#: messages taken per callback beyond the one the executor handed over (single-threaded)
TAKE_BATCH = 2000
#: s between the recorder's /diagnostics statuses (also written to the bag)
DIAG_PERIOD = 1.0


#: a ROS topic name: absolute, tokens of letters, digits and '_' not starting with a digit
TOPIC_RULE = '/topic or /topic:pkg/msg/Type (absolute name: /-separated tokens of letters, ' \
             'digits and _, not starting with a digit)'
_TOPIC_RE = re.compile(r'^(/[A-Za-z_][A-Za-z0-9_]*)+$')
_TYPE_RE = re.compile(r'^[A-Za-z_][A-Za-z0-9_]*/(msg/)?[A-Za-z_][A-Za-z0-9_]*$')


def parse_topic_specs(text: str | Sequence[str],
                      key: str = 'topics') -> dict[str, str | None]:
    """``'/a, /b:std_msgs/msg/String'`` -> {topic: type or None}; InputError(key, item,
    TOPIC_RULE) on a relative or malformed name or type."""
    from cam_design.errors import InputError
    items = text.replace(',', ' ').split() if isinstance(text, str) else list(text)
    out: dict[str, str | None] = {}
    for item in items:
        topic, sep, type_name = item.partition(':')
        if not _TOPIC_RE.match(topic) or (sep and not _TYPE_RE.match(type_name)):
            raise InputError(key, item, TOPIC_RULE)
        out[topic] = type_name or None
    return out


_MCAP_MESSAGE = struct.Struct('<BQHIQQ')   # MCAP Message record: op, length, channel,
#                                             sequence, log time, publish time


class BatchWriter:
    """Append many raw messages of one topic to a ``bagio.BagWriter`` at once.

    The recorder's per-message cost was dominated by rosbags' pure-Python MCAP writer
    (~10 us a message: a BytesIO and five int-to-bytes per record). This packs the
    same MCAP Message records (op 0x05, length, channel id, sequence 0, log time =
    publish time) with one ``struct`` call each, appends them to the open chunk in one
    write and updates the chunk index and statistics exactly as rosbags' ``write``
    does (``rosbags.rosbag2.storage_mcap.McapWriter``), so readers see an ordinary bag
    (checked by the recorder tests with rosbags and with mcap). Any other storage or
    compression mode than rosbags' MCAP writer with chunk (or no) compression falls
    back to ``BagWriter.write`` per message.
    """

    def __init__(self, bag: BagWriter) -> None:
        self.bag = bag
        writer = getattr(bag, '_writer', None)
        storage = getattr(writer, 'storage', None)
        self._fast = (storage is not None and hasattr(storage, 'chunk')
                      and hasattr(storage, 'close_chunk')
                      and getattr(getattr(writer, 'compression_mode', None), 'name', '')
                      != 'MESSAGE')
        self._writer, self._storage = writer, storage

    def write(self, topic: str, stamps: list[int], datas: list[Any]) -> None:
        """Write ``datas`` (CDR) with log times ``stamps`` [ns] on ``topic``."""
        bag = self.bag
        conn = bag._connections.get(topic) if self._fast else None
        if conn is None or bag.closed:
            for t, d in zip(stamps, datas):
                bag.write(topic, t, d)
            return
        st = self._storage
        chunk = st.chunk
        cid = conn.id
        off = chunk.bio.tell()
        index = chunk.msgs[cid]
        pack = _MCAP_MESSAGE.pack
        parts: list[Any] = []
        for t, d in zip(stamps, datas):
            n = len(d)
            parts.append(pack(5, 22 + n, cid, 0, t, t))
            parts.append(d)
            index.append((t, off))
            off += 31 + n
        chunk.bio.write(b''.join(parts))
        lo, hi = min(stamps), max(stamps)
        st.message_start_time = min(lo, st.message_start_time)
        st.message_end_time = max(hi, st.message_end_time)
        st.channel_stats[cid] += len(stamps)
        chunk.message_start_time = min(lo, chunk.message_start_time)
        chunk.message_end_time = max(hi, chunk.message_end_time)
        self._writer.counts[cid] += len(stamps)
        bag.counts[topic] += len(stamps)
        if chunk.bio.tell() > 2**20:
            st.close_chunk()


def default_output() -> Path:
    """out/rec_<UTC time> under the current directory (git-ignored)."""
    return Path('out') / time.strftime('rec_%Y%m%dT%H%M%SZ', time.gmtime())


class RecorderNode(Node):
    """Subscribes raw to the configured topics and writes every message to a bag."""

    def __init__(self, *, context: Any = None, output: str | Path | None = None,
                 topics: Sequence[str] | None = None, node_name: str = 'recorder',
                 with_info: bool = True,
                 reader_qos: dict[str, QosSpec] | None = None) -> None:
        super().__init__(node_name, context=context)
        self._with_info = with_info
        self._reader_qos = dict(reader_qos or {})   # tests: a shallow reader to overrun
        from cam_metrology.nodes.adapter import declare_parameters
        params = declare_parameters(self, PARAMETERS)
        self.params = params
        out = Path(output or params['output'] or default_output())
        wanted: dict[str, str | None] = {}
        if params['record_defaults']:
            # /diagnostics: the recorder writes its own status into the bag itself (the
            # last one at close); subscribing too would store it twice
            wanted.update({topic: type_name for topic, (type_name, _) in TOPICS.items()
                           if topic != DIAGNOSTICS})
        wanted.update(parse_topic_specs(params['topics'], f'{node_name}.topics'))
        wanted.update(parse_topic_specs(topics or (), '--topics'))
        self.key = 'OUT' if output else f'{node_name}.output'   # names it in errors
        try:
            out.parent.mkdir(parents=True, exist_ok=True)
            self.writer = BagWriter(out, compression=bool(params['compression']))
        except OSError as exc:
            from cam_metrology.inputs.files import write_error
            raise write_error(self.key, out, exc, 'folder') from None
        self._batch = BatchWriter(self.writer)
        self.path = out
        self.counts: dict[str, int] = {}
        self.callbacks_run = 0
        self.losses: dict[str, SequenceLoss] = {}
        self._diag_pub = self.create_publisher(message_class(STATUS), DIAGNOSTICS,
                                               profile(qos_of(DIAGNOSTICS)))
        self._diag_last = 0.0
        self._diag_said: tuple[int, str] | None = None
        self._subs: dict[str, Any] = {}
        self._adaptive = AdaptiveSubscriptions(self, self._subscribe_found)
        for topic, type_name in wanted.items():
            if topic in BENCH_TOPICS or topic in RIG_TOPICS:
                self._subscribe(topic, type_name or TOPICS[topic][0], qos_of(topic))
            else:   # outputs and extras: QoS (and type if not given) from the publishers
                if type_name:   # in the bag from the start, even with no message
                    self.writer.add_topic(topic, type_name, qos_of(topic).bag_yaml())
                self._adaptive.add(topic, type_name, qos_of(topic).depth)
        period = float(params['status_period'])
        if period > 0:
            self._status = self.create_timer(period, self._log_status)
        self._diag_timer = self.create_timer(DIAG_PERIOD / 2, self.publish_diagnostics)

    def _subscribe_found(self, topic: str, type_name: str, qos: QosSpec) -> None:
        self.get_logger().info(f'recording {topic} ({type_name}, '
                               f'{"transient local" if qos.transient_local else "volatile"})')
        self._subscribe(topic, type_name, qos)

    def _subscribe(self, topic: str, type_name: str, qos: QosSpec,
                   reader: QosSpec | None = None) -> None:
        """Record ``topic``: ``qos`` goes into the bag (unless the topic is registered
        already), ``reader`` (default ``qos``) is the subscription's QoS."""
        if not self.writer.has_topic(topic):
            self.writer.add_topic(topic, type_name, qos.bag_yaml())
        reader = reader or self._reader_qos.get(topic)
        self.counts.setdefault(topic, 0)
        if self._with_info and (reader or qos).depth > 1 and topic != DIAGNOSTICS:
            self.losses.setdefault(topic, SequenceLoss(topic, blocks=topic in BLOCK_TOPICS))
        callback = self._on_message if self._with_info else self._on_message_no_info
        self._subs[topic] = self.create_subscription(
            message_class(type_name), topic, functools.partial(callback, topic),
            profile((reader or qos)), raw=True)

    def _on_message(self, topic: str, data: bytes, info: Any) -> None:
        now = time.time_ns()
        seqs = [info.get('publication_sequence_number') or -1]
        stamps = [info.get('source_timestamp') or now]
        datas = [data]
        # batch: take what else is waiting on this topic now (up to TAKE_BATCH), which
        # skips the executor's ~95 us per message; the log times keep the bag ordered
        sub = self._subs.get(topic)
        if sub is not None and topic == JOINT_STATES:
            time.sleep(RX_LINGER)   # let a batch gather: fewer executor wakes (adapter)
        if sub is not None:
            take, msg_type = sub.handle.take_message, sub.msg_type
            try:
                with sub.handle:
                    for _ in range(TAKE_BATCH):
                        taken = take(msg_type, True)
                        if taken is None:
                            break
                        datas.append(taken[0])
                        info = taken[1]
                        stamps.append(info['source_timestamp'] or now)
                        seqs.append(info['publication_sequence_number'] or -1)
            except Exception:  # noqa: BLE001 (destroyed at shutdown)
                pass
        self._batch.write(topic, stamps, datas)
        self.counts[topic] += len(datas)
        self.callbacks_run += len(datas)
        acc = self.losses.get(topic)
        if acc is not None and acc.blocks:   # blocks: samples counted too
            acc.add_samples(sum(block_sample_count(d) for d in datas))
        if acc is not None and seqs[0] > 0 and acc.add(seqs):
            self._diag_last = 0.0   # a new hole: say it now

    def _write_with_info(self, topic: str, data: bytes, info: Any) -> None:
        stamp = info.get('source_timestamp') or time.time_ns()
        self.writer.write(topic, stamp, data)
        self.counts[topic] += 1
        self.callbacks_run += 1

    # -- loss status: /diagnostics, the bag, the log --------------------------------
    def input_status(self) -> Status:
        """The recorder's status: 'lost N samples on TOPIC ...' or 'no loss'."""
        losses = list(self.losses.values())
        if not self._with_info:
            level, msg = WARN, ('loss not checked (EventsExecutor: no MessageInfo, no '
                                f'sequence numbers); {sum(self.counts.values())} recorded')
        else:
            level, msg = loss_status(losses)
        values = {**loss_values(losses), 'bag': str(self.path),
                  'recorded': str(sum(self.counts.values()))}
        return Status(f'{self.get_name()}: input', level, msg, values, self.get_name())

    def publish_diagnostics(self, force: bool = False) -> None:
        """Status on /diagnostics and into the bag (every DIAG_PERIOD s while something
        changed, at once after a new hole, always when ``force``)."""
        now = time.monotonic()
        if not force and now - self._diag_last < DIAG_PERIOD:
            return
        self._diag_last = now
        st = self.input_status()
        said = (st.level, st.message)
        stamp = time.time_ns()
        self._diag_pub.publish(encode_statuses((st,), stamp))
        if force or said != self._diag_said:
            if not self.writer.closed:
                if not self.writer.has_topic(DIAGNOSTICS):
                    self.writer.add_topic(DIAGNOSTICS, STATUS, qos_of(DIAGNOSTICS).bag_yaml())
                self.writer.write(DIAGNOSTICS, stamp, encode_statuses([st], stamp))
            if st.level != OK and said != self._diag_said:
                self.get_logger().warning(f'recorder: {st.message}')
        self._diag_said = said

    def _on_message_no_info(self, topic: str, data: bytes) -> None:
        self.writer.write(topic, time.time_ns(), data)
        self.counts[topic] += 1
        self.callbacks_run += 1

    def _log_status(self) -> None:
        self.get_logger().info(f'recorded {sum(self.counts.values())} messages: '
                               f'{self.counts}')

    def subscription_counts(self) -> dict[str, int]:
        """topic -> matched publishers of each subscription."""
        return {t: s.get_publisher_count() for t, s in self._subs.items()}

    def close(self) -> None:
        """Write the final status into the bag, close it (metadata.yaml); idempotent."""
        if not self.writer.closed:
            try:
                self.publish_diagnostics(force=True)
            except Exception:  # noqa: BLE001 (closing must not fail on a status)
                pass
        self.writer.close()

    @property
    def lost(self) -> int:
        """Samples lost in the stream (after the first one received), all topics."""
        return sum(x.lost for x in self.losses.values())


def events_flag_from_params(params_file: str | None, node_name: str = 'recorder') -> bool:
    """``events_executor`` from a ROS parameter YAML (the executor is chosen before the
    node exists, so the file is read once here as well)."""
    if not params_file:
        return False
    import yaml
    with open(params_file, encoding='utf-8') as f:
        doc = yaml.safe_load(f) or {}
    for key in (node_name, '/' + node_name, '/**'):
        params = (doc.get(key) or {}).get('ros__parameters') or {}
        if 'events_executor' in params:
            return bool(params['events_executor'])
    return False


#: longest time the recorder keeps writing after SIGINT/SIGTERM [s]
STOP_DRAIN_S = 1.0


def run_recorder(args: Sequence[str] | None = None, *, output: str | Path | None = None,
                 topics: Sequence[str] | None = None, events_executor: bool = False,
                 announce: bool = True) -> int:
    """Record until SIGINT/SIGTERM; the bag is closed (metadata.yaml) in every case.

    A write that fails (disk full, folder removed, I/O error) stops the recording: the
    bag is closed without its index and ``CliError`` says how many samples were
    written before the failure (they stay readable: ``bag recover``)."""
    from cam_metrology.nodes.runtime import RosProcess

    proc = RosProcess(args, events_executor=events_executor)
    node = None
    failure: OSError | None = None
    try:
        node = proc.add(RecorderNode(context=proc.context, output=output, topics=topics,
                                     with_info=not events_executor))
        if announce:
            print(f'recording {len(node.counts) + len(node._adaptive.pending)} topics to '
                  f'{node.path} (Ctrl-C to stop)', flush=True)
        try:
            proc.spin_until()
            # write what had already arrived, but stop within STOP_DRAIN_S even while a
            # publisher keeps sending (a bench left running must not hold the bag open)
            proc.drain(lambda: node.callbacks_run, limit=STOP_DRAIN_S)
        except OSError as exc:
            failure = exc
    finally:
        if node is not None:
            status = node.input_status()
            try:
                node.close()
            except OSError as exc:
                failure = failure or exc
                node.writer.abort()
            if announce and failure is None:
                total = sum(node.counts.values())
                print(f'bag closed: {node.path} ({total} messages: '
                      + ', '.join(f'{t} {n}' for t, n in node.counts.items() if n)
                      + ')', flush=True)
                if status.level != OK:
                    import sys
                    print(f'cam-bench record: {status.message}', file=sys.stderr, flush=True)
        proc.close()
    if failure is not None:
        raise recording_failed(node, failure)
    return 1 if node.lost else 0


def recording_failed(node: RecorderNode, exc: OSError) -> Exception:
    """The one-line error of a recording stopped by a failed write: the option and the
    path, the reason, the samples received and those written before the failure."""
    from cam_design.errors import CliError, InputError
    from cam_metrology.bagio import recover_bag
    from cam_metrology.inputs.files import write_error

    received = node.counts.get(JOINT_STATES, 0)
    try:
        kept = recover_bag(node.path, None).get(JOINT_STATES, 0)
    except (InputError, OSError):
        kept = 0
    reason = str(write_error(node.key, node.path, exc, 'folder'))
    return CliError(f'{reason}: recording stopped; {kept} of the {received} samples '
                    f'received were written before the failure and are kept (closed '
                    f'without its index: `cam-bench bag recover {node.path} NEW_BAG` '
                    'makes a complete bag of them)')
