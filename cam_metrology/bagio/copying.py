"""Copying and recovering bags: topic connections and QoS of a bag, ``copy_bag``,
``add_topics_like``, and ``recover_bag`` (every intact chunk of a damaged bag)."""
from __future__ import annotations

from pathlib import Path
from typing import Any, Iterable, NamedTuple

from cam_design.errors import InputError
from cam_metrology.bagio.opening import open_reader
from cam_metrology.bagio.reader import bag_topics, iter_messages
from cam_metrology.bagio.writer import BagWriter, MCAP_MAGIC, qos_to_yaml
from cam_metrology.wire.cdr import typestore


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
    reader = open_reader(path)
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
                (qos_to_yaml(profiles) if profiles else ''),
                latched or bool(prev and prev.latched))
        return out
    finally:
        reader.close()


def topic_qos_yaml(path: str | Path) -> dict[str, str]:
    """topic -> offered QoS YAML recorded in a bag (topics without QoS are absent)."""
    reader = open_reader(path)
    try:
        out: dict[str, str] = {}
        for conn in reader.connections:
            profiles = getattr(conn.ext, 'offered_qos_profiles', None)
            if profiles and conn.topic not in out:
                out[conn.topic] = qos_to_yaml(list(profiles))
        return out
    finally:
        reader.close()


def topic_definitions(path: str | Path) -> dict[str, str]:
    """topic -> message definition text recorded in a bag, for the topics whose type
    ROS 2 Jazzy does not know (what ``BagWriter.add_topic(msgdef=...)`` needs)."""
    reader = open_reader(path)
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
    from cam_metrology.bagio.check import (iter_records, mcap_files, parse_channel,
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
