"""Integrity of MCAP bag files: a bounded record walker, chunk CRC checks, damage ranges.

The MCAP format (mcap.dev specification) stores records as opcode (u8), length (u64),
content. Chunk records carry their records compressed ('' , 'zstd' or 'lz4') with the
uncompressed size and, optionally, the CRC-32 of the uncompressed records (0 = none);
the DataEnd record optionally carries the CRC-32 of the whole data section. Writers
differ: the C++ writer of ``ros2 bag record`` fills the chunk CRCs, rosbags leaves them
0. ``BagWriter`` (bagio) fills them in when it closes a bag (``fill_chunk_crcs``), so
bags written by cam-bench can be verified.

``walk(path)`` reads a file record by record, never trusting a length field further
than the bytes the file has and never decompressing past ``MAX_CHUNK_BYTES``, and
yields what it finds: schemas, channels, chunks (verified: size, CRC where present,
framing of the records inside) and messages outside chunks. A damaged chunk is yielded
with its ``Damage`` (file byte range, log-time range, messages per topic from the
chunk's message indexes, reason) and the walk goes on with the next record; when the
framing itself is broken the walk resumes at the next chunk listed in the file's
summary, if the summary is readable, else the rest of the file is one damaged range
(the torn tail of an interrupted recording).

``check_bag(path)`` returns the damage of every MCAP file of a bag; ``require_intact``
raises an InputError naming the first damaged range. Results are cached per file
(path, size, mtime), so the readers of bagio can call it on every open.
"""
from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, BinaryIO, Iterator

from cam_design.errors import InputError

__all__ = ['Damage', 'ChunkRecord', 'walk', 'parse_schema', 'parse_channel', 'parse_message',
           'iter_records', 'check_bag', 'require_intact', 'mcap_files',
           'fill_chunk_crcs', 'describe', 'MAX_CHUNK_BYTES', 'scan_bag', 'FileScan',
           'clear_cache']

MAGIC = b'\x89MCAP0\r\n'
#: largest uncompressed chunk accepted [bytes] (writers use 1-4 MiB; ros2 bag: 768 KiB)
MAX_CHUNK_BYTES = 1 << 30
_OP_HEADER, _OP_FOOTER, _OP_SCHEMA, _OP_CHANNEL, _OP_MESSAGE, _OP_CHUNK = 1, 2, 3, 4, 5, 6
_OP_MESSAGE_INDEX, _OP_CHUNK_INDEX, _OP_DATA_END = 7, 8, 15
_U16, _U32, _U64 = struct.Struct('<H'), struct.Struct('<I'), struct.Struct('<Q')


@dataclass
class Damage:
    """A damaged range of one MCAP file: bytes [start, end), log times [ns] of the
    messages it held (None when unknown), messages per topic (when the file's indexes
    say), and why."""

    file: Path
    start: int
    end: int
    reason: str
    log_start_ns: int | None = None
    log_end_ns: int | None = None
    topics: dict[str, int] = field(default_factory=dict)


@dataclass
class ChunkRecord:
    """A chunk of a file: its byte range, header fields and (when intact) the
    uncompressed records; ``damage`` is set when it failed a check."""

    start: int
    end: int
    log_start_ns: int
    log_end_ns: int
    crc: int
    records: bytes | None
    damage: Damage | None = None


class _Bad(Exception):
    """A check failed (the message is the reason)."""


def _string(buf: bytes, off: int) -> tuple[str, int]:
    n = _U32.unpack_from(buf, off)[0]
    if off + 4 + n > len(buf):
        raise _Bad('string longer than its record')
    return buf[off + 4:off + 4 + n].decode('utf-8', errors='replace'), off + 4 + n


def parse_schema(body: bytes) -> tuple[int, str, str, bytes]:
    sid = _U16.unpack_from(body, 0)[0]
    name, off = _string(body, 2)
    encoding, off = _string(body, off)
    n = _U32.unpack_from(body, off)[0]
    if off + 4 + n > len(body):
        raise _Bad('schema data longer than its record')
    return sid, name, encoding, body[off + 4:off + 4 + n]


def parse_channel(body: bytes) -> tuple[int, int, str, str, dict[str, str]]:
    cid, sid = struct.unpack_from('<HH', body, 0)
    topic, off = _string(body, 4)
    encoding, off = _string(body, off)
    n = _U32.unpack_from(body, off)[0]
    off += 4
    end = off + n
    if end > len(body):
        raise _Bad('channel metadata longer than its record')
    meta: dict[str, str] = {}
    while off < end:
        key, off = _string(body, off)
        meta[key], off = _string(body, off)
    return cid, sid, topic, encoding, meta


def _decompress(compression: str, data: bytes, size: int) -> bytes:
    if size > MAX_CHUNK_BYTES:
        raise _Bad(f'uncompressed size {size} bytes over the {MAX_CHUNK_BYTES}-byte limit')
    if compression == '':
        return data
    if compression == 'zstd':
        import zstandard

        import io

        # a stream read stops at size + 1 bytes whatever the frame header claims
        with zstandard.ZstdDecompressor().stream_reader(io.BytesIO(data)) as reader:
            parts, got = [], 0
            while got <= size:
                part = reader.read(size + 1 - got)
                if not part:
                    break
                parts.append(part)
                got += len(part)
        out = b''.join(parts)
    elif compression == 'lz4':
        import lz4.frame

        out = lz4.frame.LZ4FrameDecompressor().decompress(data, max_length=size + 1)
    else:
        raise _Bad(f'unknown chunk compression {compression!r}')
    return out


def _chunk(body: bytes, start: int, end: int, path: Path) -> ChunkRecord:
    """Parse and verify one Chunk record's content."""
    t0, t1, size, crc = struct.unpack_from('<QQQI', body, 0)
    chunk = ChunkRecord(start, end, t0, t1, crc, None)
    try:
        compression, off = _string(body, 28)
        n = _U64.unpack_from(body, off)[0]
        if off + 8 + n > len(body):
            raise _Bad('compressed data longer than the chunk record')
        try:
            records = _decompress(compression, body[off + 8:off + 8 + n], size)
        except _Bad:
            raise
        except Exception as exc:   # noqa: BLE001 - zstd/lz4 raise their own types
            raise _Bad(f'{compression} data do not decompress ({exc})') from None
        if len(records) != size:
            raise _Bad(f'{len(records)} bytes uncompressed, the header says {size}')
        if crc and zlib.crc32(records) != crc:
            raise _Bad(f'CRC-32 mismatch (stored {crc:08x}, computed '
                       f'{zlib.crc32(records):08x})')
        _check_framing(records)
        chunk.records = records
    except (_Bad, struct.error) as exc:
        reason = str(exc) if isinstance(exc, _Bad) else 'chunk header cut short'
        chunk.damage = Damage(path, start, end, f'damaged chunk: {reason}', t0, t1)
    return chunk


def _check_framing(records: bytes) -> None:
    """Every record inside a chunk ends inside it; messages have their 22-byte head."""
    off, end = 0, len(records)
    while off < end:
        if off + 9 > end:
            raise _Bad(f'record head cut at byte {off} of the chunk')
        op, length = records[off], _U64.unpack_from(records, off + 1)[0]
        if off + 9 + length > end:
            raise _Bad(f'record at byte {off} of the chunk runs past its end')
        if op == _OP_MESSAGE and length < 22:
            raise _Bad(f'message record at byte {off} of the chunk is too short')
        off += 9 + length


def iter_records(records: bytes) -> Iterator[tuple[int, bytes]]:
    """(opcode, content) of the records inside a verified chunk."""
    off, end = 0, len(records)
    while off + 9 <= end:
        op, length = records[off], _U64.unpack_from(records, off + 1)[0]
        yield op, records[off + 9:off + 9 + length]
        off += 9 + length


def parse_message(body: bytes) -> tuple[int, int, bytes]:
    """(channel id, log time [ns], data) of a Message record's content."""
    cid, _, log = struct.unpack_from('<HIQ', body, 0)
    return cid, log, body[22:]


@dataclass
class _Summary:
    """What a readable summary section lists: chunk indexes by start offset
    (log start, log end, {channel: message index offset}), schemas, channels."""

    chunks: dict[int, tuple[int, int, dict[int, int]]] = field(default_factory=dict)
    schemas: dict[int, tuple[int, str, str, bytes]] = field(default_factory=dict)
    channels: dict[int, tuple[int, int, str, str, dict[str, str]]] = field(
        default_factory=dict)


def _read_summary(f: BinaryIO, size: int) -> _Summary | None:
    """The summary section of a file with an intact footer, else None."""
    if size < 2 * len(MAGIC) + 29:
        return None
    f.seek(size - len(MAGIC) - 29)
    tail = f.read(29 + len(MAGIC))
    if tail[-len(MAGIC):] != MAGIC or tail[0] != _OP_FOOTER:
        return None
    start = _U64.unpack_from(tail, 9)[0]
    if not len(MAGIC) <= start < size - len(MAGIC) - 29:
        return None
    f.seek(start)
    data = f.read(size - len(MAGIC) - 29 - start)
    out = _Summary()
    off = 0
    try:
        while off + 9 <= len(data):
            op, length = data[off], _U64.unpack_from(data, off + 1)[0]
            body = data[off + 9:off + 9 + length]
            if len(body) != length:
                return None
            if op == _OP_SCHEMA:
                rec = parse_schema(body)
                out.schemas[rec[0]] = rec
            elif op == _OP_CHANNEL:
                ch = parse_channel(body)
                out.channels[ch[0]] = ch
            elif op == _OP_CHUNK_INDEX:
                t0, t1, cstart, _ = struct.unpack_from('<QQQQ', body, 0)
                n = _U32.unpack_from(body, 32)[0]
                idx = {}
                for k in range(n // 10):
                    cid, moff = struct.unpack_from('<HQ', body, 36 + 10 * k)
                    idx[cid] = moff
                out.chunks[cstart] = (t0, t1, idx)
            off += 9 + length
    except (struct.error, _Bad):
        return None
    return out


def walk(path: str | Path) -> Iterator[tuple[str, Any]]:
    """Yield ('schema', (id, name, encoding, data)), ('channel', (id, schema id, topic,
    encoding, metadata)), ('chunk', ChunkRecord), ('message', (channel id, log time,
    data)) for records outside chunks, and ('damage', Damage) for a damaged range that
    is not a chunk (broken framing, data-section CRC), in file order."""
    path = Path(path)
    size = path.stat().st_size
    with open(path, 'rb') as f:
        if f.read(len(MAGIC)) != MAGIC:
            yield 'damage', Damage(path, 0, size, 'not an MCAP file (no magic bytes)')
            return
        summary = _read_summary(f, size)
        channels: dict[int, str] = {}
        if summary is not None:
            for rec in summary.schemas.values():
                yield 'schema', rec
            for ch in summary.channels.values():
                channels[ch[0]] = ch[2]
                yield 'channel', ch
        f.seek(len(MAGIC))
        off = len(MAGIC)
        crc = zlib.crc32(MAGIC)
        crc_valid = True
        last_chunk: ChunkRecord | None = None
        while off < size:
            head = f.read(9)
            op = head[0] if head else 0
            length = _U64.unpack_from(head, 1)[0] if len(head) == 9 else 0
            if len(head) < 9 or op == 0 or 0x0F < op < 0x80 or off + 9 + length > size:
                nxt = (min((c for c in summary.chunks if c > off), default=None)
                       if summary is not None else None)
                end = size if nxt is None else nxt
                why = ('the file ends inside a record (an interrupted or cut copy)'
                       if len(head) < 9 or off + 9 + length > size and nxt is None
                       else f'broken record framing (opcode {op:#04x})')
                yield 'damage', Damage(path, off, end, why, *_times_after(last_chunk))
                crc_valid = False
                if nxt is None:
                    return
                f.seek(nxt)
                off = nxt
                continue
            if op == _OP_FOOTER:
                return
            body = f.read(length)
            if op == _OP_DATA_END:
                stored = _U32.unpack_from(body, 0)[0] if len(body) >= 4 else 0
                if stored and crc_valid and zlib.crc32(head, crc) != stored:
                    yield 'damage', Damage(path, len(MAGIC), off, 'data-section CRC-32 '
                                           'mismatch (the damage is outside the chunks: '
                                           'indexes or metadata)')
                return
            crc = zlib.crc32(body, zlib.crc32(head, crc))
            try:
                if op == _OP_CHUNK:
                    last_chunk = _chunk(body, off, off + 9 + length, path)
                    if summary is not None and off in summary.chunks:
                        t0, t1, _ = summary.chunks[off]
                        last_chunk.log_start_ns, last_chunk.log_end_ns = t0, t1
                        if last_chunk.damage is not None:
                            last_chunk.damage.log_start_ns = t0
                            last_chunk.damage.log_end_ns = t1
                    if summary is None and last_chunk.records is not None:
                        for rop, rbody in iter_records(last_chunk.records):
                            if rop == _OP_CHANNEL:   # names for the damage of later chunks
                                ch = parse_channel(rbody)
                                channels[ch[0]] = ch[2]
                    yield 'chunk', last_chunk
                elif op == _OP_MESSAGE_INDEX and last_chunk is not None \
                        and last_chunk.damage is not None and len(body) >= 6:
                    cid, n = struct.unpack_from('<HI', body, 0)
                    topic = channels.get(cid, f'channel {cid}')
                    topics = last_chunk.damage.topics
                    topics[topic] = topics.get(topic, 0) + n // 16
                elif op == _OP_SCHEMA:
                    yield 'schema', parse_schema(body)
                elif op == _OP_CHANNEL:
                    ch = parse_channel(body)
                    channels[ch[0]] = ch[2]
                    yield 'channel', ch
                elif op == _OP_MESSAGE:
                    if length < 22:
                        raise _Bad('message record too short')
                    yield 'message', parse_message(body)
            except (struct.error, _Bad) as exc:
                yield 'damage', Damage(path, off, off + 9 + length,
                                       f'unreadable record (opcode {op:#04x}: {exc})')
            off += 9 + length
        # every record was whole, but the file stops before its DataEnd and footer
        yield 'damage', Damage(path, size, size, 'the file ends without its DataEnd and '
                               'footer records (an interrupted or cut copy; the records '
                               'before are whole)', *_times_after(last_chunk))


def _times_after(chunk: ChunkRecord | None) -> tuple[int | None, None]:
    """Log-time range of a damaged stretch that follows ``chunk`` (start only)."""
    return (None if chunk is None else chunk.log_end_ns), None


def mcap_files(bag: str | Path) -> list[Path]:
    """The MCAP files of a bag (a rosbag2 directory, or a bare .mcap file)."""
    bag = Path(bag)
    if bag.is_file():
        return [bag] if bag.suffix == '.mcap' else []
    return sorted(bag.glob('*.mcap'))


@dataclass
class FileScan:
    """What ``scan_file`` found in one file: chunks, chunks carrying a CRC, damage."""

    file: Path
    chunks: int = 0
    crc_chunks: int = 0
    damaged: list[Damage] = field(default_factory=list)


_CACHE: dict[tuple[str, int, int], FileScan] = {}


def scan_file(path: Path) -> FileScan:
    """Walk one MCAP file (cached by path, size and mtime)."""
    st = path.stat()
    key = (str(path.resolve()), st.st_size, st.st_mtime_ns)
    if key not in _CACHE:
        scan = FileScan(path)
        for kind, item in walk(path):
            if kind == 'damage':
                scan.damaged.append(item)
            elif kind == 'chunk':
                scan.chunks += 1
                scan.crc_chunks += bool(item.crc)
                if item.damage is not None:
                    scan.damaged.append(item.damage)
        if len(_CACHE) > 64:
            _CACHE.clear()
        _CACHE[key] = scan
    return _CACHE[key]


def clear_cache() -> None:
    """Forget every cached scan (benchmarks; files rewritten within one mtime tick)."""
    _CACHE.clear()


def scan_bag(bag: str | Path) -> list[FileScan]:
    """``scan_file`` of every MCAP file of a bag."""
    return [scan_file(path) for path in mcap_files(bag)]


def check_bag(bag: str | Path) -> list[Damage]:
    """Every damaged range of every MCAP file of a bag (empty: intact, as far as the
    file's CRCs and framing can tell)."""
    return [d for scan in scan_bag(bag) for d in scan.damaged]


def describe(d: Damage) -> str:
    """One line: file, byte range, log times [s], messages per topic, reason."""
    where = f'{d.file.name} bytes {d.start}-{d.end}'
    if d.log_start_ns is not None:
        end = '' if d.log_end_ns is None else f'{d.log_end_ns / 1e9:.6f}'
        where += f', log time {d.log_start_ns / 1e9:.6f}-{end} s'
    if d.topics:
        where += ', ' + ', '.join(f'{n} messages of {t}' for t, n in sorted(d.topics.items()))
    return f'{where}: {d.reason}'


def require_intact(bag: str | Path) -> None:
    """InputError naming the damaged ranges when a file of the bag is damaged."""
    damaged = check_bag(bag)
    if damaged:
        more = f' (and {len(damaged) - 1} more damaged ranges)' if len(damaged) > 1 else ''
        raise InputError('bag', str(bag), f'an intact bag; damaged: {describe(damaged[0])}'
                         f'{more}. `cam-bench bag check BAG` lists the damage, '
                         '`cam-bench bag recover BAG DST` copies what is intact')


def fill_chunk_crcs(path: str | Path) -> int:
    """Write the CRC-32 of every chunk whose CRC field is 0 (rosbags leaves it 0) into
    a closed MCAP file, in place; returns the number of chunks filled. The data-section
    and summary CRCs stay 0 (absent), so nothing else is invalidated."""
    path = Path(path)
    fixes = [(c.start, zlib.crc32(c.records)) for kind, c in walk(path)
             if kind == 'chunk' and c.crc == 0 and c.records is not None]
    if fixes:
        with open(path, 'r+b') as f:
            for start, crc in fixes:
                f.seek(start + 9 + 24)
                f.write(_U32.pack(crc))
        _CACHE.clear()
    return len(fixes)
