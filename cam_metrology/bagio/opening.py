"""Opening a bag for reading: a rosbag2 folder or a single ``.mcap`` file, checked for
damage first (``bagcheck``), through rosbags or, for MCAP files rosbags cannot take, a
bare MCAP reader; ``BagMessage`` is what readers yield. No rclpy."""
from __future__ import annotations

from pathlib import Path
from typing import Any, Iterator, NamedTuple, Sequence

from cam_design.errors import InputError
from cam_metrology.bagio.check import require_intact
from cam_metrology.bagio.writer import qos_from_yaml
from cam_metrology.wire.cdr import typestore


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


def open_reader(path: str | Path, *, check: bool = True) -> Any:
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
    reader: Any
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
                profiles = qos_from_yaml(qos) if qos else []
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
