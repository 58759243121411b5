"""Writing rosbag2 (MCAP) bags from pre-serialized CDR: ``BagWriter`` (QoS metadata per
topic, zstd chunks by default, a CRC-32 on every chunk). No rclpy."""
from __future__ import annotations

import struct
from pathlib import Path
from typing import Any

from cam_design.errors import InputError
from cam_metrology.cores.outputs import Output
from cam_metrology.wire.cdr import typestore
from cam_metrology.wire.layouts import encode_output, msgtype_of
from cam_metrology.wire.topics import TOPIC_TYPES, default_qos_yaml


MCAP_MAGIC = b'\x89MCAP0\r\n'


def qos_to_yaml(profiles: list[Any]) -> str:
    """rosbag2 ``offered_qos_profiles`` YAML (metadata version 9) of QoS profiles."""
    from io import StringIO

    from rosbags.rosbag2.metadata import dump_qos_v9
    from ruamel.yaml import YAML

    stream = StringIO()
    yaml = YAML(typ='safe')
    yaml.default_flow_style = False
    yaml.dump(dump_qos_v9(profiles), stream)
    return stream.getvalue().strip()


def qos_from_yaml(text: str) -> list[Any]:
    """QoS profiles of a rosbag2 ``offered_qos_profiles`` YAML; malformed: ``InputError``."""
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
        profiles = qos_from_yaml(qos_yaml if qos_yaml is not None else default_qos_yaml(topic))
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
                from cam_metrology.bagio.check import fill_chunk_crcs, mcap_files

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
