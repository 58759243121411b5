"""The scenes a bag carries: every ``/bench/scene`` message read with ``bagio`` and
parsed once (``bag info`` and ``analyze`` use it: one place where a bag's scene is read;
the scenes of the last bag are kept, so that the check before a replay and the replay's
joint names read the bag once).
"""
from __future__ import annotations

from pathlib import Path
from typing import Any, NamedTuple

from cam_design.errors import InputError
from cam_metrology.bagio.reader import iter_messages
from cam_metrology.scene.parse import parse_scene
from cam_metrology.wire.topics import SCENE

SCENE_TOPIC = SCENE


class BagScene(NamedTuple):
    """One ``/bench/scene`` message of a bag: log time [ns], the YAML text, and the
    parsed ``Scene`` or the InputError that the scene parser raised (key prefixed with
    the topic, the log time in ``expected``)."""

    stamp_ns: int
    text: str
    scene: Any
    error: InputError | None


#: the scenes of the last bag read, by its identity (``_bag_identity``): ``analyze``
#: checks them before the replay and the replay takes the joint names from them; the
#: bag is read and its scenes parsed once
_LAST: dict[str, Any] = {}


def _bag_identity(path: str | Path) -> tuple[Any, ...]:
    """The bag's resolved path with the size and modification time of its files (a
    rosbag2 directory: each file in it; a bare MCAP file: itself)."""
    p = Path(path).resolve()
    files = sorted(f for f in p.iterdir() if f.is_file()) if p.is_dir() else [p]
    stats = [(f.name, f.stat()) for f in files]
    return (str(p), *((name, st.st_size, st.st_mtime_ns) for name, st in stats))


def bag_scenes(path: str | Path) -> list[BagScene]:
    """Every scene message of a bag in log-time order, parsed (once: a second call for
    the same unchanged bag gives the same scenes without reading it again)."""
    try:
        key = _bag_identity(path)
    except OSError:   # not there: the reader names it
        key = None
    if key is not None and _LAST.get('key') == key:
        return list(_LAST['scenes'])
    out = _read_scenes(path)
    if key is not None:
        _LAST.update(key=key, scenes=tuple(out))
    return out


def _read_scenes(path: str | Path) -> list[BagScene]:
    """``bag_scenes`` read from the bag."""
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
