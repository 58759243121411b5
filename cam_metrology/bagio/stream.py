"""Streamed reads: ``iter_joint_states`` yields the samples in blocks of whole MCAP
chunks (chunks that overlap in log time stay together), so the reader's memory does not
grow with the bag; ``JointSummary`` merges what the blocks report. Both forms of the
sample stream are read: one sample per ``sensor_msgs/JointState`` and blocks of
samples (``trajectory_msgs/JointTrajectory``, ``blocks.decode_joint_blocks``), merged
in log-time order."""
from __future__ import annotations

import struct
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable, Iterator, NamedTuple, Sequence

import numpy as np
from numpy.typing import NDArray

from cam_design.errors import InputError
from cam_metrology.bagio.blocks import decode_block_buffer, decode_joint_blocks
from cam_metrology.bagio.joints import (DEFAULT_JOINTS, NO_CHANNELS, JointIssue, JointSamples,
                                        chunk_records, chunked_summary, decode_joint_buffer,
                                        decode_joint_states, direct_mcap_files,
                                        indexed_messages, walk_messages)
from cam_metrology.bagio.opening import open_reader
from cam_metrology.wire.topics import (JOINT_STATE, JOINT_STATES, JOINT_TRAJECTORY,
                                       JOINT_TRAJECTORY_TYPE)


#: uncompressed MCAP chunk bytes decoded at once by ``iter_joint_states`` (on the
#: rosbags path: message bytes); the reader's memory is a few times this, whatever
#: the size of the bag
STREAM_BLOCK_BYTES = 4 << 20


def iter_joint_states(path: str | Path, topic: str = JOINT_STATES, *, direct: bool = True,
                      block_bytes: int = STREAM_BLOCK_BYTES,
                      joints: tuple[str, str] = DEFAULT_JOINTS,
                      blocks_topic: str | None = JOINT_TRAJECTORY, extras: bool = False,
                      ) -> Iterator[JointSamples]:
    """The samples of ``topic`` (JointState) and of ``blocks_topic`` (JointTrajectory
    blocks; None: not read) as consecutive blocks, in memory bounded by
    ``block_bytes`` whatever the size of the bag; joints looked up by name
    (``joints``: angle, lift). When the bag holds both topics their samples are merged
    in log-time order (ties: the JointState sample first).

    Concatenated, the blocks are exactly what ``read_joint_states`` returns (same
    order: log time, ties in recorded order). Each block is a ``JointSamples`` of its
    own messages: its ``names``, ``features`` and ``issues`` are the block's, and an
    issue or an error names a message by its index on the topic in the whole bag;
    ``JointSummary`` merges them into those of the whole topic. MCAP chunks whose
    log-time ranges overlap are decoded together (their messages are sorted across
    them), so a bag whose chunks all overlap is read as one block. ``extras``: the
    blocks also give the lift velocity and further joints (``decode_joint_blocks``;
    kept when the bag holds blocks only).
    """
    if block_bytes < 1:
        raise InputError('block_bytes', block_bytes, 'a block size >= 1 byte')
    streams = [s for s in (
        _iter_topic(path, topic, JOINT_STATE, direct, block_bytes, joints),
        _iter_topic(path, blocks_topic, JOINT_TRAJECTORY_TYPE, direct, block_bytes, joints,
                    extras) if blocks_topic else None) if s is not None]
    if len(streams) == 1:
        yield from streams[0]
    elif streams:
        yield from _merged(streams)


#: the decoder of each sample message type: (CDR chunks, buffer) decoders
_DECODERS: dict[str, Any] = {
    JOINT_STATE: (
        lambda chunks, logs, first, topic, joints, extras: decode_joint_states(
            chunks, logs, first, joints=joints),
        lambda data, st, ln, logs, first, topic, joints, extras: decode_joint_buffer(
            data, st, ln, logs, first, joints=joints)),
    JOINT_TRAJECTORY_TYPE: (
        lambda chunks, logs, first, topic, joints, extras: decode_joint_blocks(
            chunks, logs, first, topic=topic, joints=joints, extras=extras),
        lambda data, st, ln, logs, first, topic, joints, extras: decode_block_buffer(
            data, st, ln, logs, first, topic=topic, joints=joints, extras=extras)),
}


def _iter_topic(path: str | Path, topic: str, msgtype: str, direct: bool, block_bytes: int,
                joints: tuple[str, str], extras: bool = False,
                ) -> Iterator[JointSamples] | None:
    """The blocks of one sample topic of type ``msgtype``; None if the bag has none
    (InputError for a topic of another type)."""
    reader = open_reader(path)
    close = True
    try:
        conns = [c for c in reader.connections if c.topic == topic]
        for conn in conns:
            if conn.msgtype != msgtype:
                raise InputError(f'topic {topic}', conn.msgtype, msgtype)
        if not conns:
            return None
        plan = _mcap_stream_plan(Path(path), [topic]) if direct else None
        if plan is None:   # rosbags' reader, in blocks of messages
            close = False
            return _iter_reader_blocks(reader, conns, block_bytes, topic, msgtype, joints,
                                       extras)
    finally:
        if close:
            reader.close()
    return _iter_mcap_blocks(plan, block_bytes, topic, msgtype, joints, extras)


def _merged(streams: list[Iterator[JointSamples]]) -> Iterator[JointSamples]:
    """Blocks of several streams (each in log-time order) merged in log-time order
    (ties: the earlier stream first); each source block's names, features and issues
    go with the next block yielded."""
    its: list[Iterator[JointSamples] | None] = list(streams)
    bufs = [_slice(None, 0, 0)] * len(its)
    meta: list[JointSamples] = []
    while True:
        for k, it in enumerate(its):
            while it is not None and not len(bufs[k]):
                nxt = next(it, None)
                if nxt is None:
                    its[k] = it = None
                else:
                    meta.append(nxt)
                    bufs[k] = nxt
        open_ = [k for k, it in enumerate(its) if it is not None]
        if not open_ and not any(len(b) for b in bufs):
            if meta:
                yield _combine([], meta)
            return
        limit = min(int(bufs[k].log_ns[-1]) for k in open_) if open_ else None
        parts = []
        for k, buf in enumerate(bufs):
            cut = len(buf) if limit is None else int(
                np.searchsorted(buf.log_ns, limit, side='right'))
            parts.append(_slice(buf, 0, cut))
            bufs[k] = _slice(buf, cut, len(buf))
        yield _combine(parts, meta)
        meta = []


def _slice(js: JointSamples | None, i: int, j: int) -> JointSamples:
    """Samples [i, j) of ``js`` (an empty JointSamples for None), no metadata."""
    if js is None:
        return decode_joint_states([])
    return JointSamples(js.frame_id[i:j], js.stamp_ns[i:j], js.log_ns[i:j], js.theta[i:j],
                        js.s[i:j])


def _combine(parts: list[JointSamples], meta: list[JointSamples]) -> JointSamples:
    """The samples of ``parts`` sorted by log time (stable), with the names, features
    and issues of the source blocks ``meta``."""
    parts = [p for p in parts if len(p)]
    names = tuple(dict.fromkeys(n for m in meta for n in m.names))
    features = tuple(dict.fromkeys(f for m in meta for f in m.features))
    issues = tuple(i for m in meta for i in m.issues)
    if not parts:
        empty = decode_joint_states([])
        return JointSamples(empty.frame_id, empty.stamp_ns, empty.log_ns, empty.theta,
                            empty.s, names, features, issues)
    log = np.concatenate([p.log_ns for p in parts])
    order = np.argsort(log, kind='stable')
    frames = [p.frame_id for p in parts]
    if any(f.dtype == object for f in frames):
        frames = [f.astype(object) for f in frames]
    return JointSamples(np.concatenate(frames)[order],
                        np.concatenate([p.stamp_ns for p in parts])[order], log[order],
                        np.concatenate([p.theta for p in parts])[order],
                        np.concatenate([p.s for p in parts])[order], names, features, issues)


def _iter_reader_blocks(reader: Any, conns: Sequence[Any], block_bytes: int,
                        topic: str = JOINT_STATES, msgtype: str = JOINT_STATE,
                        joints: tuple[str, str] = DEFAULT_JOINTS, extras: bool = False,
                        ) -> Iterator[JointSamples]:
    """Blocks of about ``block_bytes`` of messages from a rosbags reader (closed at the
    end)."""
    decode = _DECODERS[msgtype][0]
    try:
        chunks: list[bytes] = []
        logs: list[int] = []
        size = first = 0
        for _, stamp, data in reader.messages(connections=conns):
            chunks.append(data)
            logs.append(stamp)
            size += len(data)
            if size >= block_bytes:
                yield decode(chunks, np.asarray(logs, dtype=np.int64), first, topic, joints,
                             extras)
                first += len(chunks)
                chunks, logs, size = [], [], 0
        if chunks:
            yield decode(chunks, np.asarray(logs, dtype=np.int64), first, topic, joints,
                         extras)
    finally:
        reader.close()


#: (records, message starts, lengths, log times) of a block of MCAP messages
_RawBlock = tuple[bytearray, NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]


class _PlannedChunk(NamedTuple):
    """One MCAP chunk holding messages of the topic: file number, its ChunkIndex, the
    channels whose MessageIndex it has, and every channel of the topic."""

    file: int
    index: Any
    wanted: list[int]
    chans: set[int]


def _mcap_stream_plan(bag: Path, topics: Iterable[str],
                      ) -> tuple[Path, list[str], list[_PlannedChunk]] | None:
    """(directory, files, chunks holding messages of ``topics``) of a bag the direct
    reader takes (indexed, chunked MCAP, chunks uncompressed, zstd or lz4); None
    otherwise."""
    wanted_topics = set(topics)

    found = direct_mcap_files(bag)
    if found is None:
        return None
    folder, files = found
    plan: list[_PlannedChunk] = []
    for k, name in enumerate(files):
        try:
            with open(folder / name, 'rb') as f:
                summary = chunked_summary(f)
        except OSError:
            return None
        if summary is NO_CHANNELS:
            continue
        if summary is None:
            return None
        chans = {cid for cid, ch in summary.channels.items() if ch.topic in wanted_topics}
        for index in summary.chunk_indexes if chans else ():
            indexed = index.message_index_offsets
            wanted = sorted(c for c in chans if indexed.get(c))
            if indexed and not wanted:
                continue   # no message of the topic in this chunk
            if index.compression not in ('', 'zstd', 'lz4'):
                return None
            plan.append(_PlannedChunk(k, index, wanted, chans))
    return folder, files, plan


def _iter_mcap_blocks(plan: tuple[Path, list[str], list[_PlannedChunk]],
                      block_bytes: int, topic: str = JOINT_STATES,
                      msgtype: str = JOINT_STATE, joints: tuple[str, str] = DEFAULT_JOINTS,
                      extras: bool = False) -> Iterator[JointSamples]:
    """Decode the planned chunks' messages in blocks (``_iter_chunk_blocks``)."""
    decode = _DECODERS[msgtype][1]
    first = 0
    for data, starts, lengths, logs in _iter_chunk_blocks(plan, block_bytes):
        samples = decode(data, starts, lengths, logs, first, topic, joints, extras)
        first += int(starts.size)   # messages (a block message holds many samples)
        yield samples


def _iter_chunk_blocks(plan: tuple[Path, list[str], list[_PlannedChunk]],
                       block_bytes: int,
                       ) -> Iterator[_RawBlock]:
    """(records, message starts, lengths, log times) of the planned chunks' messages,
    block by block, sorted by log time then recorded order. Chunks are taken by the
    start of their log-time range; chunks whose ranges overlap (or touch) stay in one
    group, so no message of a later group can precede one of an earlier group; a
    block is one or more whole groups of about ``block_bytes``."""
    folder, files, chunks = plan
    chunks = sorted(chunks, key=lambda c: (c.index.message_start_time, c.file,
                                           c.index.chunk_start_offset))
    handles: dict[int, Any] = {}
    try:
        block: list[_PlannedChunk] = []
        size, end = 0, None
        for c in chunks:
            if block and c.index.message_start_time > end and size >= block_bytes:
                yield _read_chunk_block(block, folder, files, handles)
                block, size = [], 0
            block.append(c)
            size += int(c.index.uncompressed_size)
            end = c.index.message_end_time if end is None else max(
                end, c.index.message_end_time)
        if block:
            yield _read_chunk_block(block, folder, files, handles)
    finally:
        for f in handles.values():
            f.close()


def _read_chunk_block(block: list[_PlannedChunk], folder: Path, files: list[str],
                      handles: dict[int, Any]) -> _RawBlock:
    """(records, starts, lengths, log times) of the planned messages of some chunks,
    sorted by log time then by position in the bag (file, then offset: the recorded
    order)."""
    data = bytearray()   # grown chunk by chunk: the block is held once
    found_all: list[tuple[NDArray[np.int64], ...]] = []
    base = 0
    for c in sorted(block, key=lambda c: (c.file, c.index.chunk_start_offset)):
        if c.file not in handles:
            handles[c.file] = open(folder / files[c.file], 'rb')
        f = handles[c.file]
        f.seek(c.index.chunk_start_offset)
        records = chunk_records(f.read(c.index.chunk_length))
        if records is None:
            raise InputError('bag', str(folder / files[c.file]),
                             f'a readable MCAP chunk at byte {c.index.chunk_start_offset} '
                             '(`cam-bench bag check` names the damaged range)')
        found = indexed_messages(f, c.index, c.wanted, records) if c.wanted else None
        if found is None:
            found = walk_messages(records, c.chans)
        found_all.append((found[0] + base, found[1], found[2]))
        data += records
        base += len(records)
        del records
    starts = np.concatenate([s for s, _, _ in found_all])
    logs = np.concatenate([g for _, _, g in found_all])
    order = np.lexsort((starts, logs))   # log time, then recorded order
    lengths = np.concatenate([n for _, n, _ in found_all])[order]
    return data, starts[order], lengths, logs[order]


def iter_mcap_raw(bag: Path, topics: Iterable[str],
                  ) -> Iterator[tuple[str, int, bytes]] | None:
    """(topic, log time, CDR bytes) of the messages of ``topics`` in log-time order
    (ties in recorded order), read straight from the MCAP chunks that hold them (their
    MessageIndex says which): a topic of a few messages is found without reading the
    rest of the bag. None when the bag is not one the direct reader takes. For a
    single-file bag only (channel ids are per file)."""
    from mcap.reader import make_reader

    plan = _mcap_stream_plan(bag, topics)
    if plan is None or len(plan[1]) != 1:
        return None
    try:
        with open(plan[0] / plan[1][0], 'rb') as f:
            summary = make_reader(f).get_summary()
    except Exception:   # noqa: BLE001 - any mcap error: let the rosbags reader decide
        return None
    if summary is None:          # no summary section: let the rosbags reader decide
        return None
    topic_of = {cid: ch.topic for cid, ch in summary.channels.items()}

    def messages() -> Iterator[tuple[str, int, bytes]]:
        for data, starts, lengths, logs in _iter_chunk_blocks(plan, STREAM_BLOCK_BYTES):
            view = memoryview(data)
            chan = _U16.unpack_from
            for s, n, g in zip(starts.tolist(), lengths.tolist(), logs.tolist()):
                yield topic_of[chan(data, s - 22)[0]], g, bytes(view[s:s + n])

    return messages()


_U16 = struct.Struct('<H')


@dataclass
class JointSummary:
    """The whole topic's ``names``, ``features`` and ``issues`` (as
    ``read_joint_states`` gives them) merged from blocks of ``iter_joint_states``,
    ``count``: the samples seen, ``usable``: those with a finite angle and lift."""

    count: int = 0
    usable: int = 0   # samples with a finite angle and lift
    names: tuple[tuple[str, ...], ...] = ()
    features: tuple[str, ...] = ()
    issues: tuple[JointIssue, ...] = ()

    def add(self, block: JointSamples) -> None:
        """Merge one block (blocks in stream order)."""
        self.count += len(block)
        self.usable += int(np.count_nonzero(np.isfinite(block.theta) & np.isfinite(block.s)))
        self.names = self.names + tuple(x for x in block.names if x not in self.names)
        self.features = self.features + tuple(x for x in block.features
                                              if x not in self.features)
        merged = {_issue_kind(i): i for i in self.issues}
        for issue in block.issues:
            old = merged.get(_issue_kind(issue))
            merged[_issue_kind(issue)] = issue if old is None else \
                old._replace(count=old.count + issue.count)
        self.issues = tuple(merged[k] for k in sorted(merged))


def _issue_kind(issue: JointIssue) -> tuple[int, str]:
    """Sort key and identity of an issue: its kind (``JointIssue.order``: for
    JointState no angle joint, no lift joint, too few positions; then the block
    problems), then its topic."""
    return issue.order, issue.key.split('[')[0]
