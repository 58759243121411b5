"""Opening and reading bags: ``looks_like_bag``, ``bag_topics``, ``iter_messages``
(every message decoded, log-time order; the few non-sample messages of a single-file
MCAP straight from the chunks that hold them) and the scenes a bag carries. No rclpy."""
from __future__ import annotations

from pathlib import Path
from typing import Any, Iterable, Iterator, NamedTuple

from cam_design.errors import InputError
from cam_metrology.bagio.opening import BagMessage, _open_reader
from cam_metrology.bagio.stream import _iter_mcap_raw
from cam_metrology.wire.topics import SCENE


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
    from cam_metrology.scene.parse import parse_scene

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
