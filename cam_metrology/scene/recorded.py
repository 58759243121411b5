"""The scenes a bag carries: every ``/bench/scene`` message read with ``bagio`` and
parsed once (``bag info`` and ``analyze`` use it: one place where a bag's scene is read).
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


def bag_scenes(path: str | Path) -> list[BagScene]:
    """Every scene message of a bag in log-time order, parsed."""
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
