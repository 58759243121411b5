"""The fast path of ``/bench/joint_states``: the JointState CDR of a whole topic (or of a
block of MCAP chunks) decoded with numpy, joints looked up by name, unusable messages
named (``JointSamples``, ``JointIssue``, ``read_joint_states``,
``decode_joint_states``), and light JointState look-alikes for per-message cores.
Units: stamps ns, angles rad, lifts m."""
from __future__ import annotations

import struct
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator, NamedTuple, Sequence

import numpy as np
from numpy.typing import NDArray

from cam_design.errors import InputError
from cam_metrology.bagio.opening import open_reader
from cam_metrology.wire.topics import CAMSHAFT_JOINT, JOINT_STATES, PROBE_JOINT

#: the (angle, lift) joint names looked up in every sample message unless told others
DEFAULT_JOINTS = (CAMSHAFT_JOINT, PROBE_JOINT)
#: ``JointIssue.order`` of the first block issue (``blocks.py``); below: JointState ones
BLOCK_ISSUES = 20


@dataclass
class JointSamples:
    """The samples of a JointState topic as arrays (one entry per message).

    ``frame_id`` (str array; an object array of shared str when an id is longer than
    64 characters, so memory does not grow as n x the longest id), ``stamp_ns`` header
    stamps [ns] (int64), ``log_ns`` bag log times [ns], ``theta`` [rad] and ``s`` [m]
    found by joint name (NaN where a message lacks the joint or its position);
    ``names``: the distinct joint-name lists seen, in order of first appearance;
    ``features``: the distinct frame ids in order of first appearance; ``issues``:
    what made messages unusable (``JointIssue``).
    """

    frame_id: NDArray[np.str_]
    stamp_ns: NDArray[np.int64]
    log_ns: NDArray[np.int64]
    theta: NDArray[np.float64]
    s: NDArray[np.float64]
    names: tuple[tuple[str, ...], ...] = ()
    features: tuple[str, ...] = field(default=())
    issues: tuple[JointIssue, ...] = ()
    #: samples of each message, for blocks (``blocks.decode_joint_blocks``); None for
    #: one sample per message
    block_sizes: NDArray[np.int64] | None = None
    #: blocks decoded with ``extras``: the lift joint's velocity [m/s] (NaN where a block
    #: carries no velocities; None when none does)
    lift_velocity: NDArray[np.float64] | None = None
    #: blocks decoded with ``extras``: the position of every further joint by name (NaN
    #: where a block lacks the joint), in order of first appearance
    others: dict[str, NDArray[np.float64]] = field(default_factory=dict)

    def __len__(self) -> int:
        return int(self.theta.size)


class JointIssue(NamedTuple):
    """Messages of a sample topic that cannot give a sample: ``key`` names the
    field of the first such message (``/bench/joint_states[i].name`` or
    ``.position``), ``value`` what it held, ``expected`` what would work, ``count``
    how many messages have the problem (their samples are NaN: dropped and counted);
    ``order``: the kind of problem (issues are listed by it)."""

    key: str
    value: Any
    expected: str
    count: int
    order: int = 0

    def error(self, total: int) -> InputError:
        """The InputError of this issue (``total``: messages on the topic)."""
        if self.order >= BLOCK_ISSUES:   # a block: its samples (if any) are NaN
            return InputError(self.key, self.value,
                              f'{self.expected} ({self.count} block'
                              f'{"s" if self.count > 1 else ""} not used)')
        return InputError(self.key, self.value,
                          f'{self.expected} ({self.count} of {total} messages)')

    def text(self, total: int) -> str:
        """One line: the error text of ``error(total)``."""
        return str(self.error(total))


def read_joint_states(path: str | Path, topic: str = JOINT_STATES, *,
                      direct: bool = True, joints: tuple[str, str] = DEFAULT_JOINTS,
                      ) -> JointSamples:
    """Fast decode of every ``sensor_msgs/JointState`` on ``topic`` (numpy, no objects).

    Messages are taken in log-time order (ties in recorded order, as AnyReader).
    Joints are looked up by name (``joints``: angle, lift) per message, so other joint
    orders and extra joints are fine. CDR in either byte order is accepted.
    ``direct``: read the MCAP chunks directly (no per-message Python objects); bags it
    cannot read that way (SQLite storage, file compression, unindexed MCAP) go through
    AnyReader's raw iteration. Both give identical results.
    """
    reader = open_reader(path)
    try:
        conns = [c for c in reader.connections if c.topic == topic]
        for conn in conns:
            if conn.msgtype != 'sensor_msgs/msg/JointState':
                raise InputError(f'topic {topic}', conn.msgtype, 'sensor_msgs/msg/JointState')
        if not conns:
            return decode_joint_states([])
        raw = _read_mcap_direct(Path(path), topic) if direct else None
        if raw is not None:
            return decode_joint_buffer(*raw, joints=joints)
        chunks: list[bytes] = []
        logs: list[int] = []
        for _, stamp, data in reader.messages(connections=conns):
            chunks.append(data)
            logs.append(stamp)
    finally:
        reader.close()
    return decode_joint_states(chunks, np.asarray(logs, dtype=np.int64), joints=joints)


_MSG_HEAD = struct.Struct('<BQHIQ')   # opcode, record length, channel, sequence, log_time


#: what ``chunked_summary`` returns for an MCAP file without channels (nothing in it)
NO_CHANNELS = object()


def chunked_summary(f: Any) -> Any:
    """The MCAP summary of the open file ``f`` when the direct readers can take it (its
    chunks are indexed); ``NO_CHANNELS`` for a file without channels (skip it); None
    otherwise (the caller falls back to AnyReader)."""
    from mcap.reader import make_reader

    try:
        summary = make_reader(f).get_summary()
    except Exception:   # noqa: BLE001 - any mcap error: let AnyReader decide
        return None
    if summary is None or not summary.chunk_indexes:
        return NO_CHANNELS if summary is not None and not summary.channels else None
    return summary


def _read_mcap_direct(bag: Path, topic: str,
                      ) -> tuple[bytes, NDArray[np.int64], NDArray[np.int64],
                                 NDArray[np.int64]] | None:
    """(buffer, message starts, lengths, log times) of ``topic`` in log-time order, read
    straight from the MCAP chunks of a rosbag2 directory; None if the bag is not an
    indexed, chunked MCAP bag without file compression (the caller falls back)."""

    found_files = direct_mcap_files(bag)
    if found_files is None:
        return None
    bag, files = found_files
    parts: list[bytes] = []
    starts: list[NDArray[np.int64]] = []
    lengths: list[NDArray[np.int64]] = []
    logs: list[NDArray[np.int64]] = []
    base = 0
    for name in files:
        try:
            f = open(bag / name, 'rb')
        except OSError:
            return None
        with f:
            summary = chunked_summary(f)
            if summary is NO_CHANNELS:
                continue
            if summary is None:
                return None
            chans = {cid for cid, ch in summary.channels.items() if ch.topic == topic}
            if not chans:
                continue
            for index in sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset):
                indexed = index.message_index_offsets
                wanted = sorted(c for c in chans if indexed.get(c))
                if indexed and not wanted:
                    continue   # no message of the topic in this chunk
                f.seek(index.chunk_start_offset)
                records = chunk_records(f.read(index.chunk_length))
                if records is None:
                    return None
                found = indexed_messages(f, index, wanted, records) if wanted else None
                if found is None:
                    found = walk_messages(records, chans)
                for arr, out in zip(found, (starts, lengths, logs)):
                    out.append(arr + base if out is starts else arr)
                parts.append(records)
                base += len(records)
    if not starts:
        return b'', *(np.zeros(0, dtype=np.int64) for _ in range(3))
    start_arr = np.concatenate(starts)
    log_arr = np.concatenate(logs)
    order = np.lexsort((start_arr, log_arr))   # log time, then recorded order
    return (b''.join(parts), start_arr[order], np.concatenate(lengths)[order],
            log_arr[order])


def direct_mcap_files(bag: Path) -> tuple[Path, list[str]] | None:
    """(directory, MCAP file names) of a bag the direct readers can take: a bare
    ``.mcap`` file, or a rosbag2 directory with MCAP storage and no file compression;
    None otherwise (the caller goes through the rosbags reader)."""
    import yaml

    if bag.is_file():
        return bag.parent, [bag.name]
    try:
        from cam_metrology.inputs.yaml_input import load_yaml
        info = load_yaml((bag / 'metadata.yaml').read_text(), 'metadata.yaml')[
            'rosbag2_bagfile_information']
    except (OSError, KeyError, TypeError, yaml.YAMLError, InputError):
        return None
    if info.get('storage_identifier') != 'mcap' or info.get('compression_mode') not in (
            '', None, 'none', 'NONE'):
        return None
    return bag, list(info.get('relative_file_paths') or [f.get('path')
                                                         for f in info.get('files', [])])


def indexed_messages(f: Any, index: Any, chans: list[int], records: bytes,
                     ) -> tuple[NDArray[np.int64], ...] | None:
    """(starts, lengths, log times) of the channels' messages in one chunk's records,
    from the chunk's MessageIndex records (vectorised); None if they are unusable."""
    offs: list[NDArray[np.int64]] = []
    logs: list[NDArray[np.int64]] = []
    for chan in chans:
        f.seek(index.message_index_offsets[chan])
        head = f.read(9)
        if len(head) < 9 or head[0] != 0x07:
            return None
        body = f.read(int.from_bytes(head[1:9], 'little'))
        if len(body) < 6 or int.from_bytes(body[0:2], 'little') != chan:
            return None
        nbytes = int.from_bytes(body[2:6], 'little')
        pairs = np.frombuffer(body, dtype='<u8', count=nbytes // 8, offset=6).reshape(-1, 2)
        logs.append(pairs[:, 0].astype(np.int64))
        offs.append(pairs[:, 1].astype(np.int64))
    off = np.concatenate(offs)
    buf = np.frombuffer(records, dtype=np.uint8)
    if off.size and (off.max() + 31 > buf.size or np.any(buf[off] != 0x05)):
        return None
    length = np.zeros(off.size, dtype=np.int64)
    for k in range(8):
        length |= buf[off + 1 + k].astype(np.int64) << (8 * k)
    if np.any(length < 22) or np.any(off + 9 + length > buf.size):
        return None
    return off + 31, length - 22, np.concatenate(logs)


def walk_messages(records: bytes, chans: set[int]) -> tuple[NDArray[np.int64], ...]:
    """(starts, lengths, log times) of the channels' messages, walking every record."""
    starts: list[int] = []
    lengths: list[int] = []
    logs: list[int] = []
    view = memoryview(records)
    off, end = 0, len(records)
    unpack = _MSG_HEAD.unpack_from
    while off + 9 <= end:
        op, length = records[off], int.from_bytes(view[off + 1:off + 9], 'little')
        if op == 0x05 and length >= 22 and off + 31 <= end:
            _, _, chan, _, log = unpack(records, off)
            if chan in chans:
                starts.append(off + 31)
                lengths.append(length - 22)
                logs.append(log)
        off += 9 + length
    return (np.asarray(starts, dtype=np.int64), np.asarray(lengths, dtype=np.int64),
            np.asarray(logs, dtype=np.int64))


def chunk_records(raw: bytes) -> bytes | None:
    """The (decompressed) records of one MCAP Chunk record; None if unsupported."""
    if len(raw) < 9 or raw[0] != 0x06:
        return None
    off = 9 + 8 + 8
    size = int.from_bytes(raw[off:off + 8], 'little')
    off += 8 + 4
    clen = int.from_bytes(raw[off:off + 4], 'little')
    compression = raw[off + 4:off + 4 + clen].decode('ascii', errors='replace')
    off += 4 + clen
    rlen = int.from_bytes(raw[off:off + 8], 'little')
    data = raw[off + 8:off + 8 + rlen]
    if compression == '':
        return bytes(data)
    if compression == 'zstd':
        import zstandard

        return zstandard.ZstdDecompressor().decompress(data, max_output_size=size)
    if compression == 'lz4':
        import lz4.frame

        return lz4.frame.decompress(data)
    return None


def decode_joint_states(chunks: Sequence[bytes], log_ns: NDArray[np.int64] | None = None,
                        first: int = 0, *, joints: tuple[str, str] = DEFAULT_JOINTS,
                        ) -> JointSamples:
    """Vectorised CDR decode of JointState messages (see ``read_joint_states``);
    ``first``: index on the topic of the first message (named in errors); ``joints``:
    the (angle, lift) joint names."""
    n = len(chunks)
    if log_ns is None:
        log_ns = np.zeros(n, dtype=np.int64)
    if n == 0:
        empty = np.zeros(0)
        return JointSamples(np.zeros(0, dtype='<U1'), np.zeros(0, dtype=np.int64),
                            np.asarray(log_ns, dtype=np.int64), empty, empty.copy())
    lengths = np.fromiter((len(c) for c in chunks), dtype=np.int64, count=n)
    start = np.zeros(n, dtype=np.int64)
    np.cumsum(lengths[:-1], out=start[1:])
    return decode_joint_buffer(b''.join(chunks), start, lengths,
                               np.asarray(log_ns, dtype=np.int64), first, joints=joints)


def decode_joint_buffer(data: bytes | bytearray, start: NDArray[np.int64],
                        lengths: NDArray[np.int64],
                        log_ns: NDArray[np.int64], first: int = 0, *,
                        joints: tuple[str, str] = DEFAULT_JOINTS) -> JointSamples:
    """Decode the JointState messages at ``data[start:start+lengths]`` (numpy).

    ``first``: index of the first of these messages on the topic (a block of a
    streamed read), so that errors and issues name the message's index in the bag."""
    n = int(start.size)
    if n == 0:
        return decode_joint_states([])
    if isinstance(data, bytearray):   # a streamed block: padded in place, not copied
        data.extend(b'\0' * 16)
        buf = np.frombuffer(data, dtype=np.uint8)
    else:
        buf = np.frombuffer(data + b'\0' * 16, dtype=np.uint8)
    kind = buf[start + 1]
    bad = (buf[start] != 0) | (kind > 1) | (lengths < 4)
    if np.any(bad):
        i = int(np.argmax(bad))
        raise InputError(f'{JOINT_STATES}[{first + i}]',
                         bytes(buf[start[i]:start[i] + 4]).hex(),
                         'plain CDR encapsulation (00 00 big-endian or 00 01 '
                         'little-endian) as ROS 2 writes it')
    big = kind == 0   # encapsulation CDR_BE = 00 00, CDR_LE = 00 01
    base = start + 4            # CDR alignment is relative to the payload start
    end = start + lengths

    # unaligned views with a 1-byte stride: element k is the value starting at byte k
    any_big = bool(np.any(big))
    u32_le = _byte_strided(buf, '<u4')
    u32_be = _byte_strided(buf, '>u4') if any_big else u32_le
    f64_le = _byte_strided(buf, '<f8')
    f64_be = _byte_strided(buf, '>f8') if any_big else f64_le

    def u32(off: NDArray[np.int64]) -> NDArray[np.int64]:
        le = u32_le[off].astype(np.int64)
        return np.where(big, u32_be[off], le) if any_big else le

    def f64(off: NDArray[np.int64], swap: NDArray[np.bool_]) -> NDArray[np.float64]:
        le = f64_le[off]
        return np.where(swap, f64_be[off], le) if any_big else le

    def align(off: NDArray[np.int64], k: int) -> NDArray[np.int64]:
        return off + (-(off - base)) % k

    def check(off: NDArray[np.int64]) -> None:
        if np.any(off > end):
            bad = int(np.argmax(off > end))
            raise InputError(f'{JOINT_STATES}[{first + bad}]', f'{int(lengths[bad])} bytes',
                             'a complete sensor_msgs/JointState CDR message')

    sec = u32(base).astype(np.int64)
    sec = np.where(sec >= 2**31, sec - 2**32, sec)
    nsec = u32(base + 4)
    stamp = sec * 1_000_000_000 + nsec
    flen = u32(base + 8)
    check(base + 12 + flen)
    frame_ids, features = _strings(buf, base + 12, flen, first)
    off = align(base + 12 + flen, 4)
    check(off + 4)
    count = u32(off)
    off = off + 4
    cam_idx = np.full(n, -1, dtype=np.int64)
    probe_idx = np.full(n, -1, dtype=np.int64)
    name_codes: list[NDArray[np.int64]] = []
    name_texts: list[NDArray[np.str_]] = []
    max_count = int(count.max()) if n else 0
    if max_count > 64:
        bad = int(np.argmax(count))
        raise InputError(f'{JOINT_STATES}[{first + bad}].name', f'{max_count} names',
                         'a JointState message (at most 64 joints)')
    for j in range(max_count):
        has = count > j
        off = np.where(has, align(off, 4), off)
        check(np.where(has, off + 4, 0))
        nlen = np.where(has, u32(np.where(has, off, 0)), 0)
        check(np.where(has, off + 4 + nlen, 0))
        for target, idx in ((joints[0], cam_idx), (joints[1], probe_idx)):
            raw = target.encode() + b'\0'
            hit = has & (nlen == len(raw)) & (idx < 0)
            if np.any(hit):
                got = buf[off[hit, None] + 4 + np.arange(len(raw))]
                eq = np.all(got == np.frombuffer(raw, dtype=np.uint8), axis=1)
                rows = np.nonzero(hit)[0][eq]
                idx[rows] = j
        texts, codes = _string_codes(buf, off + 4, np.where(has, nlen, 0), 'name', first)
        name_codes.append(np.where(has, codes, -1))
        name_texts.append(texts)
        off = np.where(has, off + 4 + nlen, off)
    off = align(off, 4)
    check(off + 4)
    pcount = u32(off)
    pos0 = np.where(pcount > 0, align(off + 4, 8), off + 4)
    check(pos0 + 8 * pcount)

    def pick(idx: NDArray[np.int64]) -> NDArray[np.float64]:
        ok = (idx >= 0) & (idx < pcount)
        out = np.full(n, np.nan)
        if np.any(ok):
            out[ok] = f64(pos0[ok] + 8 * idx[ok], big[ok])
        return out

    names = _distinct_name_lists(name_codes, name_texts, n)
    issues = _joint_issues(cam_idx, probe_idx, count, pcount, name_codes, name_texts, first,
                           joints)
    return JointSamples(frame_id=frame_ids, stamp_ns=stamp.astype(np.int64),
                        log_ns=np.asarray(log_ns, dtype=np.int64),
                        theta=pick(cam_idx), s=pick(probe_idx), names=names,
                        features=features, issues=issues)


def _joint_issues(cam_idx: NDArray[np.int64], probe_idx: NDArray[np.int64],
                  count: NDArray[np.int64], pcount: NDArray[np.int64],
                  codes: list[NDArray[np.int64]], texts: list[NDArray[np.str_]],
                  first: int = 0, joints: tuple[str, str] | None = None,
                  ) -> tuple[JointIssue, ...]:
    """What makes messages unusable: a missing ``camshaft`` or ``probe`` joint, fewer
    positions than names (docs/contract.md §2), naming the first message of each."""
    def names_of(i: int) -> list[str]:
        return [str(texts[j][c[i]]) for j, c in enumerate(codes) if c[i] >= 0]

    out = []
    for order, joint, idx in ((0, (joints or DEFAULT_JOINTS)[0], cam_idx),
                              (1, (joints or DEFAULT_JOINTS)[1], probe_idx)):
        bad = idx < 0
        if np.any(bad):
            i = int(np.argmax(bad))
            out.append(JointIssue(f'{JOINT_STATES}[{first + i}].name', names_of(i),
                                  f'a joint named {joint!r} (joints are looked up by name)',
                                  int(bad.sum()), order))
    short = pcount < count
    if np.any(short):
        i = int(np.argmax(short))
        out.append(JointIssue(f'{JOINT_STATES}[{first + i}].position',
                              f'{int(pcount[i])} values for {int(count[i])} names '
                              f'{names_of(i)}', 'one position per name', int(short.sum()),
                              2))
    return tuple(out)


#: longest frame id or joint name decoded [bytes]; a longer one is an InputError
MAX_NAME_BYTES = 4096
#: bytes of the gather matrix of one block of strings (bounds the decoder's memory)
STRING_BLOCK_BYTES = 1 << 24


def _string_codes(buf: NDArray[np.uint8], off: NDArray[np.int64], nlen: NDArray[np.int64],
                  field_name: str = 'string', first: int = 0,
                  ) -> tuple[NDArray[np.str_], NDArray[np.int64]]:
    """Per-message CDR strings at ``off`` (byte count ``nlen`` incl. the NUL) as
    (distinct texts, code per message into them). Vectorised: the bytes are gathered
    into a (rows, maxlen) matrix, in blocks of at most ``STRING_BLOCK_BYTES``, and made
    unique as fixed-width byte strings; a string over ``MAX_NAME_BYTES`` is refused
    (InputError naming the message and ``field_name``), so memory stays bounded
    whatever length fields a bag holds."""
    n = int(off.size)
    if n and int(nlen.max()) - 1 > MAX_NAME_BYTES:
        i = int(np.argmax(nlen))
        raise InputError(f'{JOINT_STATES}[{first + i}].{field_name}',
                         f'{int(nlen[i]) - 1} bytes',
                         f'a string of at most {MAX_NAME_BYTES} bytes')
    width = max(int(nlen.max()) - 1, 1) if n else 1
    rows = max(1, STRING_BLOCK_BYTES // (9 * width))   # int64 index + byte matrix
    cols = np.arange(width)
    index: dict[bytes, int] = {}
    codes = np.zeros(n, dtype=np.int64)
    for a in range(0, n, rows):
        b = min(n, a + rows)
        mat = buf[off[a:b, None] + cols]
        mat = np.where(cols[None, :] < (nlen[a:b, None] - 1), mat, 0).astype(np.uint8)
        keys = np.ascontiguousarray(mat).view(f'S{width}').reshape(-1)
        # strings come in runs (one frame_id per feature, the same names in every
        # message): make only the run heads unique
        change = np.ones(keys.size, dtype=bool)
        change[1:] = keys[1:] != keys[:-1]
        uniq, inverse = np.unique(keys[change], return_inverse=True)
        remap = np.array([index.setdefault(bytes(u), len(index)) for u in uniq],
                         dtype=np.int64)
        codes[a:b] = remap[inverse.reshape(-1)[np.cumsum(change) - 1]]
    texts = np.array([u.decode('utf-8', errors='replace') for u in index] or [''])
    return texts, codes


def _byte_strided(buf: NDArray[np.uint8], dtype: str) -> NDArray[Any]:
    """A read-only view of ``buf`` whose element k is the ``dtype`` value at byte k."""
    size = np.dtype(dtype).itemsize
    return np.ndarray(shape=(max(buf.size - size + 1, 0),), dtype=dtype, buffer=buf,
                      offset=0, strides=(1,))


def _strings(buf: NDArray[np.uint8], off: NDArray[np.int64], nlen: NDArray[np.int64],
             first: int = 0) -> tuple[NDArray[np.str_], tuple[str, ...]]:
    """Per-message strings as a numpy str array, and the distinct ones in order of
    first appearance."""
    texts, codes = _string_codes(buf, off, nlen, 'header.frame_id', first)
    first = np.unique(codes, return_index=True)[1]
    order = tuple(str(texts[codes[i]]) for i in np.sort(first))
    if texts.dtype.itemsize > 4 * 64:   # long ids: shared str objects, not n fixed-width
        return texts.astype(object)[codes], order
    return texts[codes], order


def _distinct_name_lists(codes: list[NDArray[np.int64]], texts: list[NDArray[np.str_]],
                         n: int) -> tuple[tuple[str, ...], ...]:
    """The distinct joint-name lists (in order of first appearance) from per-position
    name codes (-1: the message has fewer names)."""
    if not codes:
        return ((),) if n else ()
    mat = np.stack(codes, axis=1)
    _, first = np.unique(mat, axis=0, return_index=True)
    return tuple(tuple(str(texts[j][c]) for j, c in enumerate(mat[i]) if c >= 0)
                 for i in np.sort(first))


def light_joint_states(samples: JointSamples) -> Iterator[Any]:
    """JointState-like objects (header.frame_id, header.stamp.sec/nanosec, name,
    position) for the samples, for cores without a bulk ``handle_samples`` path."""
    for fid, stamp, theta, s in zip(samples.frame_id.tolist(), samples.stamp_ns.tolist(),
                                    samples.theta.tolist(), samples.s.tolist()):
        yield LightJointState(fid, stamp, theta, s)


class _Stamp:
    __slots__ = ('sec', 'nanosec')

    def __init__(self, stamp_ns: int) -> None:
        self.sec, self.nanosec = divmod(stamp_ns, 1_000_000_000)


class _Header:
    __slots__ = ('frame_id', 'stamp')

    def __init__(self, frame_id: str, stamp_ns: int) -> None:
        self.frame_id = frame_id
        self.stamp = _Stamp(stamp_ns)


class LightJointState:
    """A minimal JointState look-alike: ``header.frame_id``, ``header.stamp.sec``/
    ``nanosec``, ``name`` = (camshaft, probe), ``position`` = (theta, s), empty
    ``velocity``/``effort``."""

    __slots__ = ('header', 'position')
    name = (CAMSHAFT_JOINT, PROBE_JOINT)
    velocity = ()
    effort = ()

    def __init__(self, frame_id: str, stamp_ns: int, theta: float, s: float) -> None:
        self.header = _Header(frame_id, stamp_ns)
        self.position = (theta, s)
