"""Opening and reading bags: ``looks_like_bag``, ``bag_topics``, ``iter_messages``
(every message decoded, log-time order; the few non-sample messages of a single-file
MCAP straight from the chunks that hold them). No rclpy; the scenes a bag carries are
parsed by ``cam_metrology.scene.recorded`` (bagio knows no scene)."""
from __future__ import annotations

from pathlib import Path
from typing import Iterable, Iterator

from cam_design.errors import InputError
from cam_metrology.bagio.opening import BagMessage, open_reader
from cam_metrology.bagio.stream import iter_mcap_raw


def bag_topics(path: str | Path) -> dict[str, tuple[str, int]]:
    """topic -> (ROS type, message count) of a bag."""
    reader = open_reader(path)
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
    reader = open_reader(path)
    try:
        wanted = None if topics is None else set(topics)
        conns = [c for c in reader.connections if wanted is None or c.topic in wanted]
        if not conns:
            return
        direct = iter_mcap_raw(Path(path), {c.topic for c in conns})
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
