"""Streamed reads: ``iter_joint_states`` yields the samples in blocks of whole MCAP
chunks (chunks that overlap in log time stay together), so the reader's memory does not
grow with the bag; ``JointSummary`` merges what the blocks report."""
from __future__ import annotations

import struct
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable, Iterator, NamedTuple, Sequence

import numpy as np
from numpy.typing import NDArray

from cam_design.errors import InputError
from cam_metrology.bagio.joints import (NO_CHANNELS, JointIssue, JointSamples, chunk_records,
                                        chunked_summary, decode_joint_buffer,
                                        decode_joint_states, direct_mcap_files,
                                        indexed_messages, walk_messages)
from cam_metrology.bagio.opening import open_reader
from cam_metrology.wire.topics import CAMSHAFT_JOINT, JOINT_STATES


#: uncompressed MCAP chunk bytes decoded at once by ``iter_joint_states`` (on the
#: rosbags path: message bytes); the reader's memory is a few times this, whatever
#: the size of the bag
STREAM_BLOCK_BYTES = 4 << 20


def iter_joint_states(path: str | Path, topic: str = JOINT_STATES, *, direct: bool = True,
                      block_bytes: int = STREAM_BLOCK_BYTES) -> Iterator[JointSamples]:
    """The samples of ``topic`` as consecutive blocks, in memory bounded by
    ``block_bytes`` whatever the size of the bag.

    Concatenated, the blocks are exactly what ``read_joint_states`` returns (same
    order: log time, ties in recorded order). Each block is a ``JointSamples`` of its
    own messages: its ``names``, ``features`` and ``issues`` are the block's, and an
    issue or an error names a message by its index on the topic in the whole bag;
    ``JointSummary`` merges them into those of the whole topic. MCAP chunks whose
    log-time ranges overlap are decoded together (their messages are sorted across
    them), so a bag whose chunks all overlap is read as one block.
    """
    if block_bytes < 1:
        raise InputError('block_bytes', block_bytes, 'a block size >= 1 byte')
    reader = open_reader(path)
    close = True
    try:
        conns = [c for c in reader.connections if c.topic == topic]
        for conn in conns:
            if conn.msgtype != 'sensor_msgs/msg/JointState':
                raise InputError(f'topic {topic}', conn.msgtype, 'sensor_msgs/msg/JointState')
        if not conns:
            return
        plan = _mcap_stream_plan(Path(path), [topic]) if direct else None
        if plan is None:   # rosbags' reader, in blocks of messages
            close = False
            yield from _iter_reader_blocks(reader, conns, block_bytes)
            return
    finally:
        if close:
            reader.close()
    yield from _iter_mcap_blocks(plan, block_bytes)


def _iter_reader_blocks(reader: Any, conns: Sequence[Any], block_bytes: int,
                        ) -> Iterator[JointSamples]:
    """Blocks of about ``block_bytes`` of messages from a rosbags reader (closed at the
    end)."""
    try:
        chunks: list[bytes] = []
        logs: list[int] = []
        size = first = 0
        for _, stamp, data in reader.messages(connections=conns):
            chunks.append(data)
            logs.append(stamp)
            size += len(data)
            if size >= block_bytes:
                yield decode_joint_states(chunks, np.asarray(logs, dtype=np.int64), first)
                first += len(chunks)
                chunks, logs, size = [], [], 0
        if chunks:
            yield decode_joint_states(chunks, np.asarray(logs, dtype=np.int64), first)
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
                      block_bytes: int) -> Iterator[JointSamples]:
    """Decode the planned chunks' JointStates in blocks (``_iter_chunk_blocks``)."""
    first = 0
    for data, starts, lengths, logs in _iter_chunk_blocks(plan, block_bytes):
        samples = decode_joint_buffer(data, starts, lengths, logs, first)
        first += len(samples)
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
            channels = make_reader(f).get_summary().channels
    except Exception:   # noqa: BLE001 - any mcap error: let the rosbags reader decide
        return None
    topic_of = {cid: ch.topic for cid, ch in channels.items()}

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
    ``read_joint_states`` gives them) merged from blocks of ``iter_joint_states``, and
    ``count``: the messages seen."""

    count: int = 0
    names: tuple[tuple[str, ...], ...] = ()
    features: tuple[str, ...] = ()
    issues: tuple[JointIssue, ...] = ()

    def add(self, block: JointSamples) -> None:
        """Merge one block (blocks in stream order)."""
        self.count += len(block)
        self.names = self.names + tuple(x for x in block.names if x not in self.names)
        self.features = self.features + tuple(x for x in block.features
                                              if x not in self.features)
        merged = {_issue_kind(i): i for i in self.issues}
        for issue in block.issues:
            old = merged.get(_issue_kind(issue))
            merged[_issue_kind(issue)] = issue if old is None else \
                old._replace(count=old.count + issue.count)
        self.issues = tuple(merged[k] for k in sorted(merged))


def _issue_kind(issue: JointIssue) -> tuple[bool, bool]:
    """Sort key and identity of an issue, in the order ``_joint_issues`` lists them:
    no camshaft joint, no probe joint, too few positions."""
    return issue.key.endswith('.position'), f'{CAMSHAFT_JOINT!r}' not in issue.expected
