"""rosbag2 (MCAP) bags with rosbags: writing pre-serialized CDR, encoding, reading.

No rclpy here (architecture.md): messages are encoded with the rosbags ROS2_JAZZY
typestore (or, for ``sensor_msgs/JointState``, with an equivalent ``struct`` encoder
checked byte for byte against it in the tests), and bags are written with
``rosbags.rosbag2.Writer(version=9, storage_plugin=MCAP)`` so that they open with
rosbags, with ``mcap`` + ``mcap_ros2`` and with ``ros2 bag`` (docs/ros.md).

Writing: ``BagWriter`` takes CDR bytes as received (the recorder path: nothing is
re-encoded) and writes the rosbag2 QoS metadata of each topic (``/bench/scene``,
``/bench/truth`` and ``/metrology/report`` as transient local, depth 1, so that a
replay latches them). Reading: ``iter_messages`` decodes every message with
rosbags' ``AnyReader`` in log-time order; ``read_joint_states`` is the fast path
for ``/bench/joint_states``: it decodes the JointState CDR of the whole topic with
numpy (no per-message objects), looking the joints up by name.

Units: stamps in ns (int), angles rad, lifts m.
"""
from __future__ import annotations

import struct
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Iterator, NamedTuple, Sequence

import numpy as np
from numpy.typing import NDArray

from cam_design.errors import InputError
from cam_metrology.bagcheck import require_intact
from cam_metrology.outputs import Output
from cam_metrology.wire.cdr import (decode, encode_joint_state,  # noqa: F401 (re-exported)
                                    encode_joint_state_positions, encode_joint_states,
                                    encode_string, typestore)
from cam_metrology.wire.layouts import (encode_output, encode_statuses,  # noqa: F401
                                        encode_table, msgtype_of, statuses_from_msg,
                                        table_from_msg)
from cam_metrology.wire.topics import (CAMSHAFT_JOINT, JOINT_STATES,  # noqa: F401
                                       LATCHED_TOPICS, PROBE_JOINT, SCENE, TOPIC_TYPES,
                                       default_qos_yaml, qos_yaml)

__all__ = [
    'JOINT_STATES', 'CAMSHAFT_JOINT', 'PROBE_JOINT', 'TOPIC_TYPES', 'BagWriter',
    'BagMessage', 'JointSamples', 'LightJointState', 'typestore', 'qos_yaml',
    'default_qos_yaml', 'encode_joint_state', 'encode_joint_states',
    'encode_joint_state_positions', 'encode_string', 'encode_output', 'encode_table',
    'encode_statuses', 'decode', 'table_from_msg', 'statuses_from_msg', 'iter_messages',
    'read_joint_states', 'decode_joint_states', 'light_joint_states', 'bag_topics',
    'BagTopic', 'bag_connections', 'JointIssue', 'MAX_NAME_BYTES', 'BagScene',
    'bag_scenes', 'require_scenes',
    'topic_qos_yaml', 'copy_bag', 'recover_bag', 'Recovered', 'add_topics_like',
    'topic_definitions', 'iter_joint_states', 'JointSummary', 'STREAM_BLOCK_BYTES',
]

MCAP_MAGIC = b'\x89MCAP0\r\n'


def _dump_qos(profiles: list[Any]) -> str:
    from io import StringIO

    from rosbags.rosbag2.metadata import dump_qos_v9
    from ruamel.yaml import YAML

    stream = StringIO()
    yaml = YAML(typ='safe')
    yaml.default_flow_style = False
    yaml.dump(dump_qos_v9(profiles), stream)
    return stream.getvalue().strip()


def _parse_qos(text: str) -> list[Any]:
    from rosbags.rosbag2.metadata import parse_qos

    try:
        return list(parse_qos(text))
    except Exception as exc:   # rosbags raises several types for malformed YAML
        raise InputError('qos_yaml', text, f'rosbag2 offered_qos_profiles YAML ({exc})') \
            from None


# ------------------------------------------------------------------------- writer

class BagWriter:
    """A new rosbag2 directory (MCAP storage, format version 9) written from CDR bytes.

    ``BagWriter(path, compression=True)``: zstd chunk compression by default (readable
    by rosbags, mcap and ros2 bag; about 3-6x smaller); ``compression=False`` writes
    plain chunks. Use it as a context manager
    or call ``close()``: ``metadata.yaml`` is written on close only (docs/ros.md).
    An existing ``path`` is never overwritten (InputError).
    """

    def __init__(self, path: str | Path, compression: bool = True) -> None:
        from rosbags.rosbag2 import StoragePlugin, Writer

        self.path = Path(path)
        if self.path.exists():
            raise InputError('bag', str(self.path),
                             'a path that does not exist yet (bags are never overwritten)')
        self._writer = Writer(self.path, version=9, storage_plugin=StoragePlugin.MCAP)
        if compression:
            from rosbags.rosbag2 import CompressionFormat, CompressionMode

            self._writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
        self._writer.open()
        self._crc_inline = _crc_chunks_inline(self._writer)
        self._connections: dict[str, Any] = {}
        self.counts: dict[str, int] = {}
        self.closed = False

    def add_topic(self, topic: str, msgtype: str, qos_yaml: str | None = None,
                  msgdef: str | None = None) -> None:
        """Register ``topic`` of ROS type ``msgtype`` ('pkg/msg/Type').

        ``qos_yaml``: rosbag2 ``offered_qos_profiles`` text; default from
        ``default_qos_yaml(topic)``. ``msgdef``: the message definition text (ros2msg)
        of a type ROS 2 Jazzy does not know, as a source bag recorded it (copies and
        recoveries of foreign bags keep such topics). Adding the same topic twice with
        the same type is a no-op; with another type it is an InputError.
        """
        if topic in self._connections:
            if self._connections[topic].msgtype != msgtype:
                raise InputError(f'topic {topic}', msgtype,
                                 f'its registered type {self._connections[topic].msgtype}')
            return
        store = typestore()
        profiles = _parse_qos(qos_yaml if qos_yaml is not None else default_qos_yaml(topic))
        if msgtype in store.types:
            conn = self._writer.add_connection(topic, msgtype, typestore=store,
                                               offered_qos_profiles=profiles)
        elif msgdef is not None:
            conn = self._writer.add_connection(topic, msgtype, msgdef=msgdef,
                                               rihs01=_rihs01_of(msgtype, msgdef),
                                               offered_qos_profiles=profiles)
        else:
            raise InputError(f'topic {topic}', msgtype, 'a ROS 2 Jazzy message type (or '
                             'the definition of this one)')
        self._connections[topic] = conn
        self.counts[topic] = 0

    def has_topic(self, topic: str) -> bool:
        """True if ``topic`` is registered."""
        return topic in self._connections

    def write(self, topic: str, stamp_ns: int, cdr: bytes | memoryview) -> None:
        """Append CDR bytes (as received, not re-encoded) with log time ``stamp_ns``.

        The topic must have been added (``add_topic``), unless it is one of the
        project's topics (TOPIC_TYPES), which is added on first use.
        """
        if not 0 <= stamp_ns < 2**63:
            raise InputError(f'{topic} log time', stamp_ns, 'a time in ns >= 0')
        if self.closed:
            raise InputError('bag', str(self.path), 'an open bag (this one is closed)')
        conn = self._connections.get(topic)
        if conn is None:
            if topic not in TOPIC_TYPES:
                raise InputError('topic', topic, 'a topic registered with add_topic')
            self.add_topic(topic, TOPIC_TYPES[topic])
            conn = self._connections[topic]
        self._writer.write(conn, int(stamp_ns), cdr)
        self.counts[topic] += 1

    def write_output(self, output: Output, stamp_ns: int) -> None:
        """Encode a neutral output (outputs.py) and append it on its topic."""
        if output.topic not in self._connections:
            self.add_topic(output.topic, msgtype_of(output))
        self.write(output.topic, stamp_ns, encode_output(output, stamp_ns))

    def close(self) -> None:
        """Finish the MCAP file and write metadata.yaml (idempotent)."""
        if not self.closed:
            self.closed = True
            self._writer.close()
            if not self._crc_inline:   # another rosbags: fill the CRCs after the fact
                from cam_metrology.bagcheck import fill_chunk_crcs, mcap_files

                for path in mcap_files(self.path):
                    fill_chunk_crcs(path)

    def __enter__(self) -> BagWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _crc_chunks_inline(writer: Any) -> bool:
    """Make rosbags' MCAP storage writer store the CRC-32 of every chunk it closes
    (it writes 0: no CRC). The CRC of the uncompressed records is computed when the
    chunk closes and written into the Chunk record's ``uncompressed_crc`` field (byte
    33 of the record: opcode, length, start, end, size). False when the storage
    object is not the expected one (BagWriter.close then fills the CRCs in a pass)."""
    import zlib

    storage = getattr(writer, 'storage', None)
    if not all(hasattr(storage, a) for a in ('close_chunk', 'chunk', 'bio', 'compression')):
        return False
    close_chunk = storage.close_chunk

    def close_chunk_with_crc() -> None:
        crc = zlib.crc32(storage.chunk.bio.getbuffer())
        start = storage.bio.tell()
        close_chunk()
        end = storage.bio.tell()
        storage.bio.seek(start + 9 + 24)
        storage.bio.write(_U32.pack(crc))
        storage.bio.seek(end)

    storage.close_chunk = close_chunk_with_crc
    return True


_U32 = struct.Struct('<I')


# ------------------------------------------------------------------------- readers

class BagMessage(NamedTuple):
    """One decoded message: topic, ROS type, log time [ns], rosbags message object (or
    the CDR bytes with ``raw=True``); a tuple ``(topic, msgtype, stamp_ns, msg)``."""

    topic: str
    msgtype: str
    stamp_ns: int
    msg: Any


def looks_like_bag(path: str | Path) -> bool:
    """True for what the readers here take as a bag: a directory (rosbag2) or a bare
    ``.mcap`` file; anything else is a table or scene file to the CLIs."""
    p = Path(path)
    return p.is_dir() or p.suffix == '.mcap'


def _open_reader(path: str | Path, *, check: bool = True) -> Any:
    """A reader of the bag at ``path`` with ``connections`` (topic, msgtype, msgcount,
    msgdef, ext.offered_qos_profiles), ``messages(connections)`` -> (conn, log time,
    CDR bytes) in log-time order, ``deserialize(data, msgtype)`` and ``close()``.

    rosbag2 directories are opened with ``rosbags.rosbag2.Reader``, which reads no
    message definition on open: a topic whose type cam-bench does not know (a Jazzy
    service-event topic, a vendor message) is listed and its bytes can be copied; its
    definition is parsed only if a caller decodes it (``_Decoder``). ``check``: MCAP
    chunks are verified first (``check_bag``) and a damaged bag is refused naming the
    damaged range (docs/contract.md §4).
    """
    bag = Path(path)
    if not bag.exists():
        raise InputError('bag', str(bag), 'an existing rosbag2 directory')
    if bag.is_dir() and not (bag / 'metadata.yaml').exists():
        raise InputError('bag', str(bag),
                         'a closed rosbag2 directory with metadata.yaml (the recorder '
                         'writes it on close; an interrupted recording has none: '
                         '`cam-bench bag recover SRC DST` saves its complete chunks)')
    if bag.is_file() and bag.suffix not in ('.bag', '.mcap'):
        raise InputError('bag', str(bag), 'a rosbag2 directory or .mcap file')
    if check:
        require_intact(bag)
    if bag.is_file() and bag.suffix == '.mcap':
        return _BareMcapReader(bag)
    try:
        if bag.is_dir():
            from rosbags.rosbag2 import Reader

            reader = Reader(bag)
        else:   # a ROS 1 .bag: AnyReader converts the types
            from rosbags.highlevel import AnyReader

            reader = AnyReader([bag], default_typestore=typestore())
        reader.open()
    except Exception as exc:   # rosbags raises its own error types
        raise InputError('bag', str(bag), f'a readable rosbag2 bag ({exc})') from None
    return _RosbagsReader(bag, reader)


class _Decoder:
    """CDR decoding by ROS type name: the ROS 2 Jazzy typestore for the types it knows;
    other types from the definition recorded in the bag, parsed on first use (a type
    whose definition cannot be parsed is an InputError naming the topic, only when that
    topic is decoded)."""

    def __init__(self, bag: Path, connections: Sequence[Any]) -> None:
        self.bag = bag
        self._defs = {c.msgtype: (c.topic, c.msgdef) for c in connections}
        self._own: Any = None

    def __call__(self, data: bytes | memoryview, msgtype: str) -> Any:
        store = typestore()
        if msgtype not in store.types:
            store = self._store_for(msgtype)
        try:
            return store.deserialize_cdr(data, msgtype)
        except Exception as exc:   # noqa: BLE001 - rosbags raises several types
            raise InputError('message', f'{len(data)} bytes',
                             f'a complete {msgtype} CDR message ({type(exc).__name__}: '
                             f'{exc})') from None

    def _store_for(self, msgtype: str) -> Any:
        if self._own is not None and msgtype in self._own.types:
            return self._own
        from rosbags.typesys import (Stores, get_types_from_idl, get_types_from_msg,
                                     get_typestore)

        topic, msgdef = self._defs.get(msgtype, ('?', None))
        fmt = getattr(getattr(msgdef, 'format', None), 'name', '')
        text = getattr(msgdef, 'data', '') or ''
        try:
            if fmt == 'MSG' and text:
                types = get_types_from_msg(text, msgtype)
            elif fmt == 'IDL' and text:
                sep = '=' * 80 + '\n'
                types = {}
                for part in (text.split(sep)[1:] if text.startswith(sep + 'IDL: ')
                             else [text]):
                    types.update(get_types_from_idl(part.split('\n', 1)[1]
                                                    if part.startswith('IDL: ') else part))
            else:
                raise ValueError('no message definition recorded')
            if self._own is None:
                self._own = get_typestore(Stores.ROS2_JAZZY)
            self._own.register({k: v for k, v in types.items()
                                if k not in self._own.types})
        except Exception as exc:   # noqa: BLE001 - rosbags raises several types
            first = str(exc).strip().splitlines()[0][:120] if str(exc).strip() else ''
            raise InputError(f'topic {topic}', msgtype,
                             'a ROS 2 Jazzy message type or one whose definition in the '
                             f'bag can be parsed ({type(exc).__name__}: {first}); '
                             'cam-bench needs only the topics of docs/contract.md') from None
        if msgtype not in self._own.types:
            raise InputError(f'topic {topic}', msgtype, 'a type defined in the bag')
        return self._own


class _RosbagsReader:
    """A rosbags reader (rosbag2 ``Reader`` or ROS 1 ``AnyReader``) with errors turned
    into InputError and lazy decoding of types cam-bench does not know."""

    def __init__(self, bag: Path, reader: Any) -> None:
        self.bag = bag
        self._reader = reader
        self.connections = list(reader.connections)
        self._decode = (reader.deserialize if hasattr(reader, 'typestore')
                        else _Decoder(bag, self.connections))

    def messages(self, connections: Sequence[Any] = ()) -> Iterator[tuple[Any, int, bytes]]:
        try:
            yield from self._reader.messages(connections=connections)
        except Exception as exc:   # noqa: BLE001 - a damaged file: name the range
            raise InputError('bag', str(self.bag), f'a readable bag ({exc}); '
                             '`cam-bench bag check` names the damaged range, '
                             '`cam-bench bag recover SRC DST` keeps what is intact') from None

    def deserialize(self, data: bytes, msgtype: str) -> Any:
        return self._decode(data, msgtype)

    def close(self) -> None:
        self._reader.close()


class _BareMcapReader:
    """The subset of AnyReader used here, for a single ``.mcap`` file with ROS 2 CDR
    channels but no rosbag2 directory (written by other MCAP tools). Messages come in
    log-time order; types are decoded as by ``_Decoder``. Channels in another encoding
    are listed (their type is the schema name, or the encoding) but not decoded."""

    def __init__(self, path: Path) -> None:
        from types import SimpleNamespace

        from mcap.reader import make_reader

        self.path = path
        self._file = open(path, 'rb')
        try:
            self._reader = make_reader(self._file)
            summary = self._reader.get_summary()
        except Exception as exc:   # noqa: BLE001 - any mcap error is a bad file
            self._file.close()
            raise InputError('bag', str(path), f'a readable MCAP file ({exc}); an '
                             'interrupted recording: cam-bench bag recover') from None
        if summary is None:
            self._file.close()
            raise InputError('bag', str(path), 'an MCAP file with a summary (indexed); '
                             'an interrupted recording: cam-bench bag recover')
        counts = summary.statistics.channel_message_counts if summary.statistics else {}
        self.connections = []
        self._by_channel: dict[int, Any] = {}
        for cid, ch in sorted(summary.channels.items()):
            schema = summary.schemas.get(ch.schema_id)
            qos = ch.metadata.get('offered_qos_profiles')
            try:
                profiles = _parse_qos(qos) if qos else []
            except InputError:
                profiles = []
            msgdef = _schema_msgdef(schema)
            name = schema.name if schema is not None else f'({ch.message_encoding})'
            conn = SimpleNamespace(id=cid, topic=ch.topic, msgtype=name,
                                   msgcount=int(counts.get(cid, 0)), msgdef=msgdef,
                                   cdr=ch.message_encoding == 'cdr',
                                   ext=SimpleNamespace(offered_qos_profiles=profiles))
            self.connections.append(conn)
            self._by_channel[cid] = conn
        self._decode = _Decoder(path, [c for c in self.connections if c.cdr])

    def messages(self, connections: Sequence[Any] = ()) -> Iterator[tuple[Any, int, bytes]]:
        topics = sorted({c.topic for c in connections}) if connections else None
        try:
            for _, channel, message in self._reader.iter_messages(topics=topics,
                                                                  log_time_order=True):
                conn = self._by_channel.get(channel.id)
                if conn is not None:
                    yield conn, message.log_time, message.data
        except InputError:
            raise
        except Exception as exc:   # noqa: BLE001 - a damaged file: name the range
            raise InputError('bag', str(self.path), f'a readable MCAP file ({exc}); '
                             '`cam-bench bag check` names the damaged range') from None

    def deserialize(self, data: bytes, msgtype: str) -> Any:
        conn = next((c for c in self.connections if c.msgtype == msgtype), None)
        if conn is not None and not conn.cdr:
            raise InputError(f'topic {conn.topic}', msgtype, 'a CDR-encoded ROS 2 topic')
        return self._decode(data, msgtype)

    def close(self) -> None:
        self._file.close()


def _schema_msgdef(schema: Any) -> Any:
    """The rosbags MessageDefinition of an mcap Schema (NONE when there is none)."""
    from rosbags.interfaces import MessageDefinition, MessageDefinitionFormat

    fmt = {'ros2msg': MessageDefinitionFormat.MSG, 'ros2idl': MessageDefinitionFormat.IDL,
           'omgidl': MessageDefinitionFormat.IDL}.get(getattr(schema, 'encoding', ''))
    if schema is None or fmt is None:
        return MessageDefinition(MessageDefinitionFormat.NONE, '')
    return MessageDefinition(fmt, bytes(schema.data).decode('utf-8', errors='replace'))


def bag_topics(path: str | Path) -> dict[str, tuple[str, int]]:
    """topic -> (ROS type, message count) of a bag."""
    reader = _open_reader(path)
    try:
        out: dict[str, tuple[str, int]] = {}
        for conn in reader.connections:
            _, count = out.get(conn.topic, (conn.msgtype, 0))
            out[conn.topic] = (conn.msgtype, count + conn.msgcount)
        return out
    finally:
        reader.close()


def iter_messages(path: str | Path, topics: Iterable[str] | None = None,
                  *, raw: bool = False) -> Iterator[BagMessage]:
    """Yield ``BagMessage(topic, msgtype, stamp_ns, msg)`` in log-time order.

    ``topics``: only these (None: all). ``stamp_ns`` is the bag's log time [ns].
    ``raw=True`` yields the CDR bytes instead of decoded objects (for copying).
    Topics whose type is unknown to ROS 2 Jazzy are decoded from the bag's own
    message definitions (AnyReader registers them).
    """
    reader = _open_reader(path)
    try:
        wanted = None if topics is None else set(topics)
        conns = [c for c in reader.connections if wanted is None or c.topic in wanted]
        if not conns:
            return
        direct = _iter_mcap_raw(Path(path), {c.topic for c in conns})
        if direct is not None:
            conn_of = {c.topic: c for c in conns}
            found = ((conn_of[topic], stamp, data) for topic, stamp, data in direct)
        for conn, stamp, data in (found if direct is not None
                                  else reader.messages(connections=conns)):
            try:
                msg = data if raw else reader.deserialize(data, conn.msgtype)
            except InputError as exc:   # name the topic and the message's log time
                if exc.key.startswith('topic '):
                    raise
                raise InputError(f'{conn.topic} message at log time {stamp / 1e9:.6f} s',
                                 exc.value, exc.expected) from None
            yield BagMessage(conn.topic, conn.msgtype, int(stamp), msg)
    finally:
        reader.close()


SCENE_TOPIC = SCENE


class BagScene(NamedTuple):
    """One ``/bench/scene`` message of a bag: log time [ns], the YAML text, and the
    parsed ``Scene`` or the InputError that the scene parser raised (key prefixed with
    the topic, the log time in ``expected``)."""

    stamp_ns: int
    text: str
    scene: Any
    error: InputError | None


def bag_scenes(path: str | Path) -> list[BagScene]:
    """Every scene message of a bag in log-time order, parsed (the one place where a
    bag's scene is read: ``bag info`` and ``analyze`` use it)."""
    from cam_metrology.scene_parse import parse_scene

    out = []
    for m in iter_messages(path, [SCENE_TOPIC]):
        text = str(getattr(m.msg, 'data', ''))
        try:
            out.append(BagScene(m.stamp_ns, text, parse_scene(text, source=SCENE_TOPIC),
                                None))
        except InputError as exc:
            key = exc.key if exc.key not in ('scene', SCENE_TOPIC) else ''
            err = InputError(f'{SCENE_TOPIC}.{key}' if key else SCENE_TOPIC, exc.value,
                             f'{exc.expected} (the scene recorded at log time '
                             f'{m.stamp_ns / 1e9:.6f} s)')
            out.append(BagScene(m.stamp_ns, text, None, err))
    return out


def require_scenes(path: str | Path) -> list[BagScene]:
    """The distinct scenes of a bag in the order they came into force (a repeated text
    is not a change). InputError when the bag has no scene message, or for the first
    invalid one (naming its bad key)."""
    scenes = bag_scenes(path)
    if not scenes:
        raise InputError('bag', str(path), f'a {SCENE_TOPIC} message with the scene YAML '
                         f'(docs/contract.md §2): the bag has no {SCENE_TOPIC} message, '
                         'nothing to analyse')
    for sc in scenes:
        if sc.error is not None:
            raise sc.error
    out = [scenes[0]]
    for sc in scenes[1:]:
        if sc.text != out[-1].text:
            out.append(sc)
    return out


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

    def __len__(self) -> int:
        return int(self.theta.size)


class JointIssue(NamedTuple):
    """Messages of a JointState topic that cannot give a sample: ``key`` names the
    field of the first such message (``/bench/joint_states[i].name`` or
    ``.position``), ``value`` what it held, ``expected`` what would work, ``count``
    how many messages have the problem (their samples are NaN: dropped and counted)."""

    key: str
    value: Any
    expected: str
    count: int

    def error(self, total: int) -> InputError:
        """The InputError of this issue (``total``: messages on the topic)."""
        return InputError(self.key, self.value,
                          f'{self.expected} ({self.count} of {total} messages)')

    def text(self, total: int) -> str:
        """One line: the error text of ``error(total)``."""
        return str(self.error(total))


def read_joint_states(path: str | Path, topic: str = JOINT_STATES, *,
                      direct: bool = True) -> JointSamples:
    """Fast decode of every ``sensor_msgs/JointState`` on ``topic`` (numpy, no objects).

    Messages are taken in log-time order (ties in recorded order, as AnyReader).
    Joints are looked up by name ('camshaft', 'probe') per message, so other joint
    orders and extra joints are fine. CDR in either byte order is accepted.
    ``direct``: read the MCAP chunks directly (no per-message Python objects); bags it
    cannot read that way (SQLite storage, file compression, unindexed MCAP) go through
    AnyReader's raw iteration. Both give identical results.
    """
    reader = _open_reader(path)
    try:
        conns = [c for c in reader.connections if c.topic == topic]
        for conn in conns:
            if conn.msgtype != 'sensor_msgs/msg/JointState':
                raise InputError(f'topic {topic}', conn.msgtype, 'sensor_msgs/msg/JointState')
        if not conns:
            return decode_joint_states([])
        raw = _read_mcap_direct(Path(path), topic) if direct else None
        if raw is not None:
            return _decode_joint_buffer(*raw)
        chunks: list[bytes] = []
        logs: list[int] = []
        for _, stamp, data in reader.messages(connections=conns):
            chunks.append(data)
            logs.append(stamp)
    finally:
        reader.close()
    return decode_joint_states(chunks, np.asarray(logs, dtype=np.int64))


_MSG_HEAD = struct.Struct('<BQHIQ')   # opcode, record length, channel, sequence, log_time


def _read_mcap_direct(bag: Path, topic: str,
                      ) -> tuple[bytes, NDArray[np.int64], NDArray[np.int64],
                                 NDArray[np.int64]] | None:
    """(buffer, message starts, lengths, log times) of ``topic`` in log-time order, read
    straight from the MCAP chunks of a rosbag2 directory; None if the bag is not an
    indexed, chunked MCAP bag without file compression (the caller falls back)."""
    from mcap.reader import make_reader

    found_files = _direct_mcap_files(bag)
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
            try:
                summary = make_reader(f).get_summary()
            except Exception:   # noqa: BLE001 - any mcap error: let AnyReader decide
                return None
            if summary is None or not summary.chunk_indexes:
                if summary is not None and not summary.channels:
                    continue
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
                records = _chunk_records(f.read(index.chunk_length))
                if records is None:
                    return None
                found = _indexed_messages(f, index, wanted, records) if wanted else None
                if found is None:
                    found = _walk_messages(records, chans)
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


def _direct_mcap_files(bag: Path) -> tuple[Path, list[str]] | None:
    """(directory, MCAP file names) of a bag the direct readers can take: a bare
    ``.mcap`` file, or a rosbag2 directory with MCAP storage and no file compression;
    None otherwise (the caller goes through the rosbags reader)."""
    import yaml

    if bag.is_file():
        return bag.parent, [bag.name]
    try:
        from cam_metrology.yaml_input import load_yaml
        info = load_yaml((bag / 'metadata.yaml').read_text(), 'metadata.yaml')[
            'rosbag2_bagfile_information']
    except (OSError, KeyError, TypeError, yaml.YAMLError, InputError):
        return None
    if info.get('storage_identifier') != 'mcap' or info.get('compression_mode') not in (
            '', None, 'none', 'NONE'):
        return None
    return bag, list(info.get('relative_file_paths') or [f.get('path')
                                                         for f in info.get('files', [])])


def _indexed_messages(f: Any, index: Any, chans: list[int], records: bytes,
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


def _walk_messages(records: bytes, chans: set[int]) -> tuple[NDArray[np.int64], ...]:
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


def _chunk_records(raw: bytes) -> bytes | None:
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
                        first: int = 0) -> JointSamples:
    """Vectorised CDR decode of JointState messages (see ``read_joint_states``);
    ``first``: index on the topic of the first message (named in errors)."""
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
    return _decode_joint_buffer(b''.join(chunks), start, lengths,
                                np.asarray(log_ns, dtype=np.int64), first)


def _decode_joint_buffer(data: bytes | bytearray, start: NDArray[np.int64],
                         lengths: NDArray[np.int64],
                         log_ns: NDArray[np.int64], first: int = 0) -> JointSamples:
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
        for target, idx in ((CAMSHAFT_JOINT, cam_idx), (PROBE_JOINT, probe_idx)):
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
    issues = _joint_issues(cam_idx, probe_idx, count, pcount, name_codes, name_texts, first)
    return JointSamples(frame_id=frame_ids, stamp_ns=stamp.astype(np.int64),
                        log_ns=np.asarray(log_ns, dtype=np.int64),
                        theta=pick(cam_idx), s=pick(probe_idx), names=names,
                        features=features, issues=issues)


def _joint_issues(cam_idx: NDArray[np.int64], probe_idx: NDArray[np.int64],
                  count: NDArray[np.int64], pcount: NDArray[np.int64],
                  codes: list[NDArray[np.int64]], texts: list[NDArray[np.str_]],
                  first: int = 0) -> tuple[JointIssue, ...]:
    """What makes messages unusable: a missing ``camshaft`` or ``probe`` joint, fewer
    positions than names (docs/contract.md §2), naming the first message of each."""
    def names_of(i: int) -> list[str]:
        return [str(texts[j][c[i]]) for j, c in enumerate(codes) if c[i] >= 0]

    out = []
    for joint, idx in ((CAMSHAFT_JOINT, cam_idx), (PROBE_JOINT, probe_idx)):
        bad = idx < 0
        if np.any(bad):
            i = int(np.argmax(bad))
            out.append(JointIssue(f'{JOINT_STATES}[{first + i}].name', names_of(i),
                                  f'a joint named {joint!r} (joints are looked up by name)',
                                  int(bad.sum())))
    short = pcount < count
    if np.any(short):
        i = int(np.argmax(short))
        out.append(JointIssue(f'{JOINT_STATES}[{first + i}].position',
                              f'{int(pcount[i])} values for {int(count[i])} names '
                              f'{names_of(i)}', 'one position per name', int(short.sum())))
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


# ------------------------------------------------------------------ streamed reads

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
    reader = _open_reader(path)
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
    from mcap.reader import make_reader

    found = _direct_mcap_files(bag)
    if found is None:
        return None
    folder, files = found
    plan: list[_PlannedChunk] = []
    for k, name in enumerate(files):
        try:
            with open(folder / name, 'rb') as f:
                summary = make_reader(f).get_summary()
        except Exception:   # noqa: BLE001 - any mcap error: let AnyReader decide
            return None
        if summary is None or not summary.chunk_indexes:
            if summary is not None and not summary.channels:
                continue
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
        samples = _decode_joint_buffer(data, starts, lengths, logs, first)
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
        records = _chunk_records(f.read(c.index.chunk_length))
        if records is None:
            raise InputError('bag', str(folder / files[c.file]),
                             f'a readable MCAP chunk at byte {c.index.chunk_start_offset} '
                             '(`cam-bench bag check` names the damaged range)')
        found = _indexed_messages(f, c.index, c.wanted, records) if c.wanted else None
        if found is None:
            found = _walk_messages(records, c.chans)
        found_all.append((found[0] + base, found[1], found[2]))
        data += records
        base += len(records)
        del records
    starts = np.concatenate([s for s, _, _ in found_all])
    logs = np.concatenate([g for _, _, g in found_all])
    order = np.lexsort((starts, logs))   # log time, then recorded order
    lengths = np.concatenate([n for _, n, _ in found_all])[order]
    return data, starts[order], lengths, logs[order]


def _iter_mcap_raw(bag: Path, topics: Iterable[str],
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


# -------------------------------------------------------------------------- copying

class BagTopic(NamedTuple):
    """One topic of a bag: ROS type, message count, offered QoS YAML ('' if none
    recorded) and whether it was offered transient local (latched)."""

    msgtype: str
    count: int
    qos_yaml: str
    latched: bool


def bag_connections(path: str | Path) -> dict[str, BagTopic]:
    """topic -> BagTopic(msgtype, count, qos_yaml, latched) of a bag (rosbag2 directory
    or bare .mcap); counts and latching summed over the topic's connections."""
    reader = _open_reader(path)
    try:
        out: dict[str, BagTopic] = {}
        for conn in reader.connections:
            profiles = list(getattr(conn.ext, 'offered_qos_profiles', None) or [])
            latched = any(getattr(p.durability, 'name', '') == 'TRANSIENT_LOCAL'
                          for p in profiles)
            prev = out.get(conn.topic)
            out[conn.topic] = BagTopic(
                conn.msgtype, conn.msgcount + (prev.count if prev else 0),
                prev.qos_yaml if prev and prev.qos_yaml else
                (_dump_qos(profiles) if profiles else ''),
                latched or bool(prev and prev.latched))
        return out
    finally:
        reader.close()


def topic_qos_yaml(path: str | Path) -> dict[str, str]:
    """topic -> offered QoS YAML recorded in a bag (topics without QoS are absent)."""
    reader = _open_reader(path)
    try:
        out: dict[str, str] = {}
        for conn in reader.connections:
            profiles = getattr(conn.ext, 'offered_qos_profiles', None)
            if profiles and conn.topic not in out:
                out[conn.topic] = _dump_qos(list(profiles))
        return out
    finally:
        reader.close()


def _rihs01_of(msgtype: str, msgdef: str) -> str:
    """The RIHS01 hash of a foreign type from its ros2msg definition; a zero hash when
    the definition does not parse (a Jazzy service-event schema holds the raw .srv)."""
    try:
        from rosbags.typesys import Stores, get_types_from_msg, get_typestore

        store = get_typestore(Stores.ROS2_JAZZY)
        types = get_types_from_msg(msgdef, msgtype)
        store.register({k: v for k, v in types.items() if k not in store.types})
        return str(store.hash_rihs01(msgtype))
    except Exception:   # noqa: BLE001 - rosbags raises several types
        return 'RIHS01_' + '0' * 64


def topic_definitions(path: str | Path) -> dict[str, str]:
    """topic -> message definition text recorded in a bag, for the topics whose type
    ROS 2 Jazzy does not know (what ``BagWriter.add_topic(msgdef=...)`` needs)."""
    reader = _open_reader(path)
    try:
        store = typestore()
        return {c.topic: getattr(c.msgdef, 'data', '') or '' for c in reader.connections
                if c.msgtype not in store.types}
    finally:
        reader.close()


def add_topics_like(dst: BagWriter, src: str | Path, topics: Iterable[str] | None = None,
                    ) -> list[str]:
    """Register in ``dst`` the topics of bag ``src`` (all, or only ``topics``) with
    their type, QoS and, for foreign types, their recorded definition; returns them."""
    qos = topic_qos_yaml(src)
    defs = topic_definitions(src)
    wanted = None if topics is None else set(topics)
    added = []
    for topic, (msgtype, _) in bag_topics(src).items():
        if wanted is None or topic in wanted:
            dst.add_topic(topic, msgtype, qos.get(topic), defs.get(topic))
            added.append(topic)
    return added


def copy_bag(src: str | Path, dst: BagWriter, topics: Iterable[str] | None = None) -> int:
    """Copy every message of ``src`` (optionally only ``topics``) into an open writer,
    bytes unchanged, keeping types, QoS and foreign definitions; returns the number of
    messages copied."""
    copied = 0
    wanted = add_topics_like(dst, src, topics)
    for m in iter_messages(src, wanted, raw=True):
        dst.write(m.topic, m.stamp_ns, m.msg)
        copied += 1
    return copied


class Recovered(dict):  # type: ignore[type-arg]
    """Messages kept per topic (a dict) by ``recover_bag``, with ``damaged``: the
    ranges that were dropped (``bagcheck.Damage``; a torn tail included)."""

    damaged: list[Any]


def recover_bag(src: str | Path, dst: str | Path, *, compression: bool = False,
                ) -> Recovered:
    """Copy what is intact of a damaged or interrupted recording into a new, closed bag.

    ``src``: a rosbag2 directory (or a single ``.mcap`` file): one whose writer never
    closed (no metadata.yaml, no MCAP footer: docs/ros.md) or one with damaged chunks.
    Every record that passes the checks of ``bagcheck`` (chunk size, CRC-32 where the
    file has one, record framing) is kept, bytes unchanged, with its topic, type
    (foreign types with their recorded definition) and QoS; damaged chunks and the
    torn tail are dropped and listed in the result's ``damaged``. Returns messages
    kept per topic.
    """
    from cam_metrology.bagcheck import (iter_records, mcap_files, parse_channel,
                                        parse_message, parse_schema, walk)

    source = Path(src)
    files = [source] if source.is_file() else mcap_files(source) if source.exists() else []
    if not files or not all(f.is_file() for f in files):
        raise InputError('bag', str(source), 'a rosbag2 directory with .mcap files')
    for path in files:   # nothing is written for a file that is not MCAP at all
        with open(path, 'rb') as f:
            if f.read(len(MCAP_MAGIC)) != MCAP_MAGIC:
                raise InputError('bag', str(path), 'an MCAP recording (the file does not '
                                 'start with the MCAP magic bytes)')
    counts = Recovered()
    counts.damaged = []
    readable = False
    with BagWriter(dst, compression=compression) as writer:
        for path in files:
            schemas: dict[int, tuple[str, str, bytes]] = {}
            channels: dict[int, str] = {}

            def channel(rec: tuple[int, int, str, str, dict[str, str]]) -> None:
                cid, sid, topic, _, meta = rec
                if cid in channels:
                    return
                name, encoding, data = schemas.get(sid, ('', '', b''))
                msgdef = data.decode('utf-8', errors='replace') \
                    if encoding in ('ros2msg', 'ros2idl') else None
                writer.add_topic(topic, name, meta.get('offered_qos_profiles') or None,
                                 msgdef)
                channels[cid] = topic

            def message(cid: int, log: int, data: bytes) -> None:
                topic = channels.get(cid)
                if topic is not None:
                    writer.write(topic, log, data)
                    counts[topic] = counts.get(topic, 0) + 1

            for kind, item in walk(path):
                if kind == 'schema':
                    schemas[item[0]] = item[1:]
                elif kind == 'channel':
                    channel(item)
                elif kind == 'message':
                    message(*item)
                elif kind == 'damage':
                    counts.damaged.append(item)   # (an empty range: only the end missing)
                elif item.damage is not None:
                    counts.damaged.append(item.damage)
                else:
                    for op, body in iter_records(item.records):
                        if op == 5:
                            message(*parse_message(body))
                        elif op == 3:
                            rec = parse_schema(body)
                            schemas.setdefault(rec[0], rec[1:])
                        elif op == 4:
                            channel(parse_channel(body))
            readable = readable or bool(channels)
    if not readable:   # not even a channel: do not leave an empty "recovered" bag
        import shutil
        shutil.rmtree(dst, ignore_errors=True)
        raise InputError('bag', str(source), 'an MCAP recording with at least one '
                         'readable channel (nothing recoverable found)')
    return counts


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
